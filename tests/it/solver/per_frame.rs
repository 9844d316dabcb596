//! The frame-by-frame baseline (`src/solver/per_frame.rs`, `solve --per-frame`): the
//! file holds one chunk per frame over the frame's interval, probing the file at any
//! time gives the frame whose interval holds it, equal to that frame's own solution
//! and to an independent single-frame solve; a scene without motion gives the same
//! values at every frame; the CLI writes the file and one CSV row per frame.

use std::path::Path;

use glam::DVec3;
use rhier::playback::{ProbePoint, probe};
use rhier::scene::{self, MotionKey, MotionTrack, Scene, TimeDomain};
use rhier::solution::Solution;
use rhier::solver::per_frame::{FrameReport, frame_times, solve_per_frame};
use rhier::solver::{SolveOptions, Solver};
use rhier::store::{FrameWriter, Reader, WriteOptions};

use crate::common::{rhier, shapes, succeeded};

/// Coarse settings: the tests check bookkeeping, not accuracy.
fn coarse() -> SolveOptions {
    SolveOptions {
        eps: 2.0,
        max_rounds: 2,
        recon_tol: 0.5,
        ..SolveOptions::default()
    }
}

/// The Cornell box with blocks, the short block sliding 200 mm towards the green wall
/// and turning a little over [0, 1] s (it stays 5 mm above the floor, clear of the
/// walls and the tall block).
fn moving_cornell() -> Scene {
    let mut s = scene::cornell_box(true);
    s.time = TimeDomain {
        start: 0.0,
        end: 1.0,
    };
    let short = s
        .objects
        .iter_mut()
        .find(|o| o.name == "short_block")
        .unwrap();
    short.motion = Some(MotionTrack {
        keys: vec![
            MotionKey {
                translation: DVec3::new(0.0, 5.0, 0.0),
                ..MotionKey::identity(0.0)
            },
            MotionKey {
                translation: DVec3::new(-60.0, 5.0, 0.0),
                ..MotionKey::identity(1.0)
            },
        ],
    });
    s
}

/// Points on the floor (some in the short block's moving shadow), the back wall and
/// the ceiling of the Cornell box.
fn points() -> Vec<ProbePoint> {
    let mut p = Vec::new();
    for x in [60.0, 150.0, 278.0, 400.0, 500.0] {
        for z in [30.0, 150.0, 300.0, 500.0] {
            p.push(ProbePoint {
                p: DVec3::new(x, 0.0, z),
                n: DVec3::Y,
            });
        }
        p.push(ProbePoint {
            p: DVec3::new(x, 200.0, 559.2),
            n: -DVec3::Z,
        });
        p.push(ProbePoint {
            p: DVec3::new(x, 548.8, 100.0),
            n: -DVec3::Y,
        });
    }
    p
}

/// Writes `scene` per frame at `fps` into `path`, keeping every frame's report and
/// solution.
fn solve_to_file(
    scene: &Scene,
    fps: f64,
    path: &Path,
) -> (Vec<FrameReport>, Vec<Solution>, Reader) {
    let mut frames = Vec::new();
    let mut file = FrameWriter::new(path, WriteOptions::default());
    let stats = solve_per_frame(scene, &coarse(), fps, |r, s| {
        file.push(scene, (r.index, r.t, r.range), s)?;
        frames.push((r.clone(), s.clone()));
        Ok(())
    })
    .unwrap();
    file.finish(&stats.stats).unwrap();
    assert_eq!(stats.frames as usize, frames.len());
    assert_eq!(
        stats.leaves,
        frames
            .iter()
            .map(|(_, s)| s.leaves.len() as u64)
            .sum::<u64>()
    );
    let reader = Reader::open(path).unwrap();
    let (r, s) = frames.into_iter().unzip();
    (r, s, reader)
}

#[test]
fn file_has_one_chunk_per_frame_and_plays_back_each_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pf.rhier");
    let scene = moving_cornell();
    let fps = 4.0;
    let (reports, solutions, reader) = solve_to_file(&scene, fps, &path);
    // Frames at 0, 0.25, ..., 1: five chunks over [0, .125], [.125, .375], ...
    let expected = [0.0, 0.125, 0.375, 0.625, 0.875, 1.0];
    assert_eq!(reports.len(), 5);
    assert_eq!(reader.chunks().len(), 5);
    assert_eq!(reader.time_domain(), scene.time);
    assert_eq!(frame_times(scene.time, fps).unwrap().len(), 5);
    let mut total = 0;
    for (i, (c, r)) in reader.chunks().iter().zip(&reports).enumerate() {
        assert_eq!((c.t0, c.t1), (expected[i], expected[i + 1]), "chunk {i}");
        assert_eq!(r.range, [expected[i], expected[i + 1]], "frame {i}");
        assert_eq!(r.t, i as f64 * 0.25);
        assert_eq!(c.leaves as u64, r.leaves);
        let leaves = reader.chunk_leaves(i).unwrap();
        assert_eq!(
            leaves, solutions[i].leaves,
            "chunk {i} holds frame {i}'s leaves"
        );
        assert!(leaves.iter().all(|l| l.time == [c.t0 as f32, c.t1 as f32]));
        total += leaves.len() as u64;
    }
    assert_eq!(reader.verify().unwrap(), total);

    let pts = points();
    let mut per_frame = Vec::new();
    for (i, (r, sol)) in reports.iter().zip(&solutions).enumerate() {
        let own = probe(sol, &pts, r.t).unwrap();
        // At the frame's time, and anywhere inside its interval.
        assert_eq!(probe(&reader, &pts, r.t).unwrap(), own, "frame {i} at t");
        let inside = 0.5 * (r.range[0] + r.t);
        assert_eq!(
            probe(&reader, &pts, inside).unwrap(),
            own,
            "frame {i} inside"
        );
        per_frame.push(own);
    }
    // The block moves: the floor next to it changes between the first and last frame.
    let changed = per_frame[0]
        .iter()
        .zip(&per_frame[4])
        .filter(|(a, b)| (a[0] - b[0]).abs() > 1e-3 * a[0].abs().max(1e-3))
        .count();
    assert!(changed > 0, "no point changed between frames 0 and 4");

    // An independent single-frame solve of frame 2, frozen as the baseline freezes
    // its frames, gives the same values.
    let (t, range) = (0.5, [0.375f32, 0.625f32]);
    let mut solver = Solver::at_time(&scene, coarse(), t, range).unwrap();
    solver.freeze_motion();
    solver.run(|_, _| {}).unwrap();
    let single = solver.solution();
    assert_eq!(single.leaves, solutions[2].leaves);
    assert_eq!(probe(&single, &pts, t).unwrap(), per_frame[2]);

    // And a frozen frame is the static scene of the objects where they stand at t:
    // the baseline solves each frame as `rhier solve` solves a static scene. (Save
    // for contact meshing, which cuts along static objects only, so that every
    // frame of the file has the same patches: compared without it.)
    let mut still = scene.clone();
    for track in still.objects.iter_mut().filter_map(|o| o.motion.as_mut()) {
        track.keys = vec![track.key_at(t)];
    }
    assert!(!still.has_motion());
    let uncut = SolveOptions {
        contact_meshing: false,
        ..coarse()
    };
    let solve = |scene: &Scene, freeze: bool| {
        let mut solver = Solver::at_time(scene, uncut.clone(), t, range).unwrap();
        if freeze {
            solver.freeze_motion();
        }
        solver.run(|_, _| {}).unwrap();
        solver.solution().leaves
    };
    let frozen = solve(&scene, true);
    assert_eq!(frozen, solve(&still, false));
    assert_ne!(
        frozen,
        solve(&scene, false),
        "freezing changes how a frame is solved"
    );
}

#[test]
fn a_scene_without_motion_gives_the_same_values_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("static.rhier");
    let mut scene = scene::cornell_box(true);
    scene.time = TimeDomain {
        start: 0.0,
        end: 1.0,
    };
    let (reports, solutions, reader) = solve_to_file(&scene, 3.0, &path);
    assert_eq!(reports.len(), 4);
    let strip = |s: &Solution| {
        s.leaves
            .iter()
            .map(|l| (l.patch, l.uv, l.b))
            .collect::<Vec<_>>()
    };
    for s in &solutions[1..] {
        assert_eq!(strip(s), strip(&solutions[0]));
    }
    let pts = points();
    let first = probe(&reader, &pts, 0.0).unwrap();
    for r in &reports {
        assert_eq!(probe(&reader, &pts, r.t).unwrap(), first, "t = {}", r.t);
    }
    // And the same as the plain static solve of the scene.
    let (plain, _) = rhier::solver::solve(&scene, coarse()).unwrap();
    assert_eq!(probe(&plain, &pts, 0.0).unwrap(), first);
}

/// The Cornell box with blocks, its short block resting on the floor and sliding
/// 60 mm towards the red wall over [0, 0.8] s, and every other object's quads fanned
/// into unequal triangles (`shapes::fan_quads`): `h45st4`'s `sb_roomtris.json`. The
/// floor is four triangles meeting under the short block, cut along the tall
/// block's contact lines.
fn block_sliding_on_fanned_floor() -> Scene {
    let mut s = scene::cornell_box(true);
    s.time = TimeDomain {
        start: 0.0,
        end: 0.8,
    };
    for o in &mut s.objects {
        if o.name == "short_block" {
            o.motion = Some(MotionTrack {
                keys: vec![
                    MotionKey::identity(0.0),
                    MotionKey {
                        translation: DVec3::new(-60.0, 0.0, 0.0),
                        ..MotionKey::identity(0.8)
                    },
                ],
            });
        } else {
            o.polygons = shapes::fan_quads(&o.polygons);
        }
    }
    s
}

/// Every frame has the patches of frame 0, the file's: contact meshing hides the
/// floor's pieces under the sliding block where it stands at the start, in every
/// frame. Hidden where it stood at each frame's time, the floor lost two pieces at
/// t = 0.4 and the file refused the frame ("frame 2 at t = 0.4: expected the 73
/// patches of frame 0, found 71").
#[test]
fn a_block_sliding_on_a_fanned_floor_keeps_every_frame_s_patches() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sliding.rhier");
    let scene = block_sliding_on_fanned_floor();
    let (reports, solutions, reader) = solve_to_file(&scene, 5.0, &path);
    assert_eq!(reports.len(), 5);
    for (r, s) in reports.iter().zip(&solutions) {
        assert_eq!(
            s.patches, solutions[0].patches,
            "frame {} at t = {}",
            r.index, r.t
        );
    }
    assert_eq!(reader.patches(), &solutions[0].patches[..]);
}

#[test]
fn a_static_domain_is_one_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one.rhier");
    let (reports, _, reader) = solve_to_file(&scene::cornell_box(false), 25.0, &path);
    assert_eq!(reports.len(), 1);
    assert_eq!((reader.chunks()[0].t0, reader.chunks()[0].t1), (0.0, 0.0));
    assert!(!probe(&reader, &points(), 0.0).unwrap().is_empty());
}

#[test]
fn cli_per_frame_writes_the_file_and_one_report_row_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene_file = dir.path().join("moving.json");
    std::fs::write(&scene_file, scene::to_json_string(&moving_cornell())).unwrap();
    let (out, csv) = (dir.path().join("m.rhier"), dir.path().join("m.csv"));
    let run = |extra: &[&str]| {
        rhier()
            .args(["solve", "--per-frame", "--eps", "2", "--max-rounds", "2"])
            .args(["--recon-tol", "0.5", "--threads", "2"])
            .args(extra)
            .output()
            .unwrap()
    };
    let o = succeeded(run(&[
        scene_file.to_str().unwrap(),
        "--fps",
        "2",
        "-o",
        out.to_str().unwrap(),
        "--report",
        csv.to_str().unwrap(),
    ]));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("frame ")).count(),
        3
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows[0], FrameReport::CSV_HEADER);
    assert_eq!(rows.len(), 4);
    assert!(rows[2].starts_with("1,0.5,0.25,0.75,"), "{}", rows[2]);
    let reader = Reader::open(&out).unwrap();
    assert_eq!(reader.chunks().len(), 3);
    // The same bytes as the library's streamed file with the same settings (the
    // stats section holds wall-clock seconds, so compare the chunks).
    let lib = dir.path().join("lib.rhier");
    let (_, _, lib_reader) = solve_to_file(&moving_cornell(), 2.0, &lib);
    for k in 0..3 {
        assert_eq!(
            reader.chunk_leaves(k).unwrap(),
            lib_reader.chunk_leaves(k).unwrap()
        );
    }
    // --builtin with a static scene: one frame, quiet.
    let one = dir.path().join("c.rhier");
    let o = succeeded(run(&[
        "--builtin",
        "cornell",
        "-q",
        "-o",
        one.to_str().unwrap(),
    ]));
    assert!(o.stderr.is_empty());
    assert_eq!(Reader::open(&one).unwrap().chunks().len(), 1);
    // Bad fps and unsupported flags are refused (exit 1), unknown builtins by clap (2).
    let o = run(&[
        "--builtin",
        "cornell",
        "--fps",
        "0",
        "-o",
        one.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--fps"));
    let o = run(&["--builtin", "cornell", "--keep-links"]);
    assert_eq!(o.status.code(), Some(1));
    let o = run(&["--builtin", "actor75"]);
    assert_eq!(o.status.code(), Some(2));
}

/// A frame whose patches are not frame 0's is refused, naming the frame and the
/// patch, even with as many patches: its leaves would be played back on frame 0's
/// polygons.
#[test]
fn a_frame_with_other_patches_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("other.rhier");
    let mut scene = scene::cornell_box(false);
    scene.time = TimeDomain {
        start: 0.0,
        end: 1.0,
    };
    let (first, _) = rhier::solver::solve(&scene, coarse()).unwrap();
    let mut other = first.clone();
    other.patches[2].vertices[0].x += 1.0;
    let mut file = FrameWriter::new(&path, WriteOptions::default());
    file.push(&scene, (0, 0.0, [0.0, 0.5]), &first).unwrap();
    let e = file
        .push(&scene, (1, 0.5, [0.5, 1.0]), &other)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("other.rhier") && e.contains("frame 1") && e.contains("patch 2"),
        "{e}"
    );
    drop(file);
    assert!(!path.exists(), "a refused per-frame solve leaves no file");
}
