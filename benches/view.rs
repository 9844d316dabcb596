//! The data of the viewer benchmark (BENCHMARKS.md, "Viewer"): writes two solutions of
//! 99 846 polygons, one leaf each, built without the solver
//! ([`rhier::store::samples::tiled_box`]: a unit box seen from inside, each wall cut
//! into 129 × 129 tiles, radiosity linear in the position), as `tiled129.rhier`
//! (static) and `tiled129_turning.rhier` (the same box turning a quarter turn about
//! its centre over 2 s), and times the server's answers for one frame of each
//! (`/api/mesh`, `/api/frame`: what the page waits for). The page's side is measured
//! by `node tools/view_test/test.mjs --bench FILE`.
//!
//! Run: `cargo bench --bench view -- DIR` (default: the system's temp directory).

use std::path::PathBuf;
use std::time::Instant;

use glam::{DQuat, DVec3};
use rhier::scene::{MotionKey, MotionTrack, TimeDomain};
use rhier::store::samples::tiled_box;
use rhier::store::{Reader, WriteOptions, write_solution};
use rhier::view::Viewer;

fn main() {
    let dir = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .map_or_else(std::env::temp_dir, PathBuf::from);
    std::fs::create_dir_all(&dir).unwrap();
    let still = tiled_box(129, 1);
    let mut turning = still.clone();
    turning.scene.time = TimeDomain {
        start: 0.0,
        end: 2.0,
    };
    let c = DVec3::splat(0.5);
    let key = |t: f64| {
        let rotation = DQuat::from_rotation_y(t * std::f64::consts::FRAC_PI_4);
        MotionKey {
            t,
            translation: c - rotation * c,
            rotation,
            scale: DVec3::ONE,
        }
    };
    turning.scene.objects[0].motion = Some(MotionTrack {
        keys: (0..=4).map(|k| key(k as f64 * 0.5)).collect(),
    });
    for l in &mut turning.leaves {
        l.time = [0.0, 2.0];
    }
    for (name, sol) in [
        ("tiled129.rhier", &still),
        ("tiled129_turning.rhier", &turning),
    ] {
        let path = dir.join(name);
        write_solution(&path, sol, WriteOptions::default()).unwrap();
        let t0 = Instant::now();
        let viewer = Viewer::new(Reader::open(&path).unwrap(), serde_json::Value::Null).unwrap();
        let open = t0.elapsed().as_secs_f64();
        let t = sol.scene.time.end;
        let t1 = Instant::now();
        let mesh = viewer.handle("GET", &format!("/api/mesh?t={t}"));
        let t2 = Instant::now();
        let frame = viewer.handle("GET", &format!("/api/frame?t={t}"));
        let t3 = Instant::now();
        // A time not asked for yet: the frame is built, not taken from the kept ones.
        let again = viewer.handle("GET", &format!("/api/frame?t={}", 0.5 * t));
        let t4 = Instant::now();
        assert!(mesh.status == 200 && frame.status == 200 && again.status == 200);
        println!(
            "{}: {} polygons, {} leaves, {} bytes; open + start camera {open:.3} s; mesh {:.3} s ({} bytes); frame {:.3} s kept, {:.3} s built ({} bytes)",
            path.display(),
            sol.patches.len(),
            sol.leaves.len(),
            std::fs::metadata(&path).unwrap().len(),
            (t2 - t1).as_secs_f64(),
            mesh.body.len(),
            (t3 - t2).as_secs_f64(),
            (t4 - t3).as_secs_f64(),
            frame.body.len(),
        );
    }
}
