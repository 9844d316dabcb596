//! The page's files, embedded in the binary (`include_bytes!`) so that `rhier view`
//! works with no network and reads nothing from the disk but its one `.rhier` file:
//! the page itself (`web/`) and three.js, vendored from the npm registry with its
//! licence (`web/vendor/`, version in `web/vendor/README.md`).
//!
//! [`asset`] maps a request path to its bytes and media type by exact match against
//! this fixed table; any other path is `None` (the server answers 404).

/// An embedded file: request path, media type, bytes. 40 bytes.
type Asset = (&'static str, &'static str, &'static [u8]);

const JS: &str = "text/javascript; charset=utf-8";

/// Every file the server serves besides its API, by request path.
const ASSETS: &[Asset] = &[
    (
        "/",
        "text/html; charset=utf-8",
        include_bytes!("../../web/index.html"),
    ),
    ("/view.js", JS, include_bytes!("../../web/view.js")),
    ("/wire.js", JS, include_bytes!("../../web/wire.js")),
    (
        "/view.css",
        "text/css; charset=utf-8",
        include_bytes!("../../web/view.css"),
    ),
    (
        "/vendor/three.module.js",
        JS,
        include_bytes!("../../web/vendor/three.module.js"),
    ),
    (
        "/vendor/three.core.js",
        JS,
        include_bytes!("../../web/vendor/three.core.js"),
    ),
    (
        "/vendor/OrbitControls.js",
        JS,
        include_bytes!("../../web/vendor/OrbitControls.js"),
    ),
    (
        "/vendor/LICENSE.three",
        "text/plain; charset=utf-8",
        include_bytes!("../../web/vendor/LICENSE.three"),
    ),
];

/// The media type and bytes of the embedded file at request path `path` (exact
/// match, no decoding: `/index.html`, `/../x` or `/%2e%2e/x` are not in the table).
pub fn asset(path: &str) -> Option<(&'static str, &'static [u8])> {
    ASSETS
        .iter()
        .find(|(p, _, _)| *p == path)
        .map(|&(_, kind, bytes)| (kind, bytes))
}

/// The request paths of every embedded file.
pub fn paths() -> impl Iterator<Item = &'static str> {
    ASSETS.iter().map(|(p, _, _)| *p)
}
