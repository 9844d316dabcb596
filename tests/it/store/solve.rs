//! Round trip with the real solver: solve the Cornell box, write the `.rhier` file,
//! and check that probing the file gives the solve's own probe answers bit for bit,
//! that the file holds the solution's leaves, and that `rhier probe` prints them.

use glam::DVec3;
use rhier::playback::{ProbePoint, probe};
use rhier::scene::cornell_box;
use rhier::solver::{SolveOptions, solve};
use rhier::store::{Reader, WriteOptions, write_solution};

use crate::common::{rhier, succeed};

#[test]
fn solve_file_probe_equals_the_solves_probe() {
    let scene = cornell_box(true);
    let opts = SolveOptions {
        max_rounds: 2,
        ..SolveOptions::default()
    };
    let (sol, _) = solve(&scene, opts).unwrap();
    assert!(!sol.leaves.is_empty());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.rhier");
    write_solution(&path, &sol, WriteOptions::default()).unwrap();
    let r = Reader::open(&path).unwrap();
    let back = r.to_solution().unwrap();
    assert_eq!(back.leaves, sol.leaves);
    assert_eq!(back.patches, sol.patches);
    // Bit for bit, NaN included (an estimated error the solve did not estimate).
    assert_eq!(format!("{:?}", back.stats), format!("{:?}", sol.stats));
    assert_eq!(r.camera(), scene.camera);

    // Random points in the box, normals along the six axes: each finds the nearest
    // surface facing it. (Random, not on a grid: a grid point can sit exactly on a
    // leaf boundary, where the 1-ulp change JSON parsing may make to a coordinate
    // would pick the neighbouring leaf in the CLI check below.)
    let (lo, hi) = sol
        .patches
        .iter()
        .flat_map(|p| p.vertices[..p.corners as usize].to_vec())
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let axes = [
        DVec3::X,
        DVec3::NEG_X,
        DVec3::Y,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ];
    let mut s = 12345u64;
    let mut rnd = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        rhier::oracle::unit(s)
    };
    let points: Vec<ProbePoint> = (0..150)
        .map(|k| ProbePoint {
            p: lo + (hi - lo) * DVec3::new(rnd(), rnd(), rnd()),
            n: axes[k % 6],
        })
        .collect();
    let t = scene.time.start;
    let from_solve = probe(&sol, &points, t).unwrap();
    let from_file = probe(&r, &points, t).unwrap();
    assert_eq!(from_solve, from_file);
    assert!(from_file.iter().any(|b| b.iter().any(|&x| x > 0.0)));

    // The CLI prints the same numbers.
    let pts = dir.path().join("p.json");
    let json: Vec<serde_json::Value> = points
        .iter()
        .map(|p| serde_json::json!({"p": p.p.to_array(), "n": p.n.to_array()}))
        .collect();
    std::fs::write(&pts, serde_json::to_string(&json).unwrap()).unwrap();
    let out = succeed(rhier().arg("probe").arg(&path).arg("--points").arg(&pts));
    let v: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    for (got, want) in v.iter().zip(&from_solve) {
        let got: Vec<f64> = got["B"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        // Points and values cross JSON as shortest decimals, which serde_json
        // (without its float_roundtrip feature) parses back within an ulp or so: the
        // point moves by ~1e-16 and B, linear in it, by as little; 1e-12 relative.
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() <= w.abs() * 1e-12, "{g} vs {w}");
        }
    }
}

/// A static object placed by a single motion key (its file coordinates in its own
/// space, as a glTF node's or an exported scene's are) is stored with that key:
/// probing the file gives the solve's answer at the placed surfaces bit for bit, and
/// the answer is the one of the same scene with the block's coordinates written in
/// world space. Before the fix the writer kept only tracks that move, so a file
/// drew and probed the block at its file coordinates (a furnished room's people
/// stood half outside the room, lit, while their footprints stayed on the floor).
#[test]
fn a_static_object_placed_by_one_key_is_stored_where_it_was_solved() {
    use rhier::scene::{MotionKey, MotionTrack};
    let world = cornell_box(true);
    let mut placed = world.clone();
    let shift = DVec3::new(-200.0, 0.0, -150.0);
    let block = placed
        .objects
        .iter_mut()
        .find(|o| o.name == "tall_block")
        .unwrap();
    for p in &mut block.polygons {
        for v in &mut p.vertices {
            *v += shift;
        }
    }
    let mut key = MotionKey::identity(0.0);
    key.translation = -shift;
    block.motion = Some(MotionTrack { keys: vec![key] });
    assert!(!placed.has_motion(), "a placement alone is not motion");

    let opts = SolveOptions {
        max_rounds: 2,
        ..SolveOptions::default()
    };
    let (sol_world, _) = solve(&world, opts.clone()).unwrap();
    let (sol, _) = solve(&placed, opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("placed.rhier");
    write_solution(&path, &sol, WriteOptions::default()).unwrap();
    let r = Reader::open(&path).unwrap();
    let stored = r.objects().iter().find(|o| o.name == "tall_block").unwrap();
    assert_eq!(stored.to_world(0.0).translation, -shift);
    assert!(!stored.is_moving());
    assert!(
        r.objects()
            .iter()
            .filter(|o| o.name != "tall_block")
            .all(|o| o.motion.is_none())
    );

    // A point off the middle of each of the tall block's faces (where it stands in
    // the world), and points on the floor and two walls.
    let mut points: Vec<ProbePoint> = world
        .objects
        .iter()
        .find(|o| o.name == "tall_block")
        .unwrap()
        .polygons
        .iter()
        .map(|p| {
            let n = p.area_vector().normalize();
            let mid = p.vertices.iter().sum::<DVec3>() / p.vertices.len() as f64;
            ProbePoint {
                p: mid + n * 1e-3,
                n,
            }
        })
        .collect();
    points.extend([
        ProbePoint {
            p: DVec3::new(150.0, 1e-3, 150.0),
            n: DVec3::Y,
        },
        ProbePoint {
            p: DVec3::new(400.0, 300.0, 559.2 - 1e-3),
            n: DVec3::NEG_Z,
        },
        ProbePoint {
            p: DVec3::new(1e-3, 300.0, 300.0),
            n: DVec3::X,
        },
    ]);
    let from_solve = probe(&sol, &points, 0.0).unwrap();
    let from_file = probe(&r, &points, 0.0).unwrap();
    assert_eq!(from_file, from_solve);
    let from_world = probe(&sol_world, &points, 0.0).unwrap();
    for (i, (a, b)) in from_file.iter().zip(&from_world).enumerate() {
        for c in 0..3 {
            // The same surfaces up to the rounding of (v - shift) + shift.
            assert!(
                (a[c] - b[c]).abs() <= 1e-3 * b[c].abs().max(1e-3),
                "point {i} channel {c}: placed {} against world {}",
                a[c],
                b[c]
            );
        }
    }
}
