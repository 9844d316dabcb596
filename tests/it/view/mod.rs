//! `rhier view`: the server's answers to good, bad and hostile requests through the
//! real binary and a raw socket, and its frames and probes against playback's own
//! evaluation of the same file (the browser side is tools/view_test/test.mjs).

mod frames;
mod server;

use std::path::{Path, PathBuf};

use crate::common::{example, rhier};

/// Solves the embedded Cornell box into `dir`.
pub fn cornell(dir: &Path) -> PathBuf {
    let out = dir.join("cornell.rhier");
    let s = rhier()
        .args(["solve", "-q", "-o"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(s.success());
    out
}

/// Solves formats/examples/cornell_moving.json coarsely (5 fps) into `dir`.
pub fn moving(dir: &Path) -> PathBuf {
    let out = dir.join("moving.rhier");
    let s = rhier()
        .arg("solve")
        .arg(example("cornell_moving.json"))
        .args(["--fps", "5", "--eps", "2", "-q", "-o"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(s.success());
    out
}
