//! The data of the viewer benchmark (BENCHMARKS.md, "Viewer"): writes two solutions of
//! 99 846 polygons, one leaf each, built without the solver
//! ([`rhier::store::samples::tiled_box`]: a unit box seen from inside, each wall cut
//! into 129 × 129 tiles, radiosity linear in the position), as `tiled129.rhier`
//! (static) and `tiled129_turning.rhier` (the same box turning a quarter turn about
//! its centre over 2 s, [`rhier::store::samples::turning_tiled_box`]), and times the server's answers (`/api/frame`, `/api/mesh`:
//! what the page waits for) frame after frame at 25 fps, in process, for each of
//! them and of any other `.rhier` file named. The page's side is measured by
//! `node tools/view_test/test.mjs --bench FILE`.
//!
//! Run: `cargo bench --bench view -- DIR [FILE.rhier ...]` (default DIR: the system's
//! temp directory).

use std::path::PathBuf;
use std::time::Instant;

use rhier::store::samples::{tiled_box, turning_tiled_box};
use rhier::store::{Reader, WriteOptions, write_solution};
use rhier::view::Viewer;

fn main() {
    let dir = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-') && !a.ends_with(".rhier"))
        .map_or_else(std::env::temp_dir, PathBuf::from);
    std::fs::create_dir_all(&dir).unwrap();
    let still = tiled_box(129, 1);
    let turning = turning_tiled_box(129);
    let mut files = Vec::new();
    for (name, sol) in [
        ("tiled129.rhier", &still),
        ("tiled129_turning.rhier", &turning),
    ] {
        let path = dir.join(name);
        write_solution(&path, sol, WriteOptions::default()).unwrap();
        files.push(path);
    }
    files.extend(
        std::env::args()
            .skip(1)
            .filter(|a| a.ends_with(".rhier"))
            .map(PathBuf::from),
    );
    for path in files {
        let t0 = Instant::now();
        let viewer = Viewer::new(Reader::open(&path).unwrap(), serde_json::Value::Null).unwrap();
        let open = t0.elapsed().as_secs_f64();
        let reader = viewer.reader();
        println!(
            "{}: {} polygons, {} bytes; open + start camera {open:.3} s",
            path.display(),
            reader.patches().len(),
            std::fs::metadata(&path).unwrap().len(),
        );
        play(&viewer);
    }
}

/// Milliseconds of `f`.
fn ms<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t0 = Instant::now();
    let out = f();
    (t0.elapsed().as_secs_f64() * 1e3, out)
}

/// Plays up to 50 frames at 25 fps as the page asks for them, one request at a time:
/// each frame with its colours (kept or built), again with `have=` its colour id
/// (the answer while colours hold), and its mesh; prints the median and the largest
/// of each.
fn play(viewer: &Viewer) {
    let td = viewer.reader().time_domain();
    let n = (((td.end - td.start) * 25.0 + 1e-9).floor() as usize + 1).min(50);
    let (mut full, mut kept, mut mesh) = (Vec::new(), Vec::new(), Vec::new());
    let mut bytes = [0; 3];
    for k in 0..n {
        let t = (td.start + k as f64 / 25.0).min(td.end);
        let (a, f) = ms(|| viewer.handle("GET", &format!("/api/frame?t={t}")));
        let id = u32::from_le_bytes(f.body[44..48].try_into().unwrap());
        let (b, h) = ms(|| viewer.handle("GET", &format!("/api/frame?t={t}&have={id}")));
        let (c, m) = ms(|| viewer.handle("GET", &format!("/api/mesh?t={t}")));
        assert!(f.status == 200 && h.status == 200 && m.status == 200);
        full.push(a);
        kept.push(b);
        mesh.push(c);
        bytes = [f.body.len(), h.body.len(), m.body.len()];
    }
    let stat = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        format!("{:.3} ms (max {:.1})", v[v.len() / 2], v[v.len() - 1])
    };
    println!(
        "  {n} frames at 25 fps, median: frame {} ({} bytes); frame, colours kept {} ({} bytes); mesh {} ({} bytes)",
        stat(&mut full),
        bytes[0],
        stat(&mut kept),
        bytes[1],
        stat(&mut mesh),
        bytes[2],
    );
}
