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
