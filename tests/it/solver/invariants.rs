//! Solver invariants: dense solve equals the hierarchical one when nothing may split,
//! RAM and mmap pools give identical results, answers are invariant to the scene's
//! scale and scale linearly with emission, and degenerate geometry gives no NaN,
//! infinity or negative radiosity.

#![expect(
    clippy::needless_range_loop,
    reason = "dense matrix code reads best with indices"
)]

use glam::DVec3;
use rhier::geometry::{Patches, point_to_polygon};
use rhier::oracle::samples;
use rhier::pools::Storage;
use rhier::scene::{Material, MaterialId, Object, Polygon, Scene};
use rhier::solver::{SolveOptions, Solver, solve};

use crate::common;

/// A unit box, 2×2 quads per face, a lamp on the ceiling quads of one corner.
fn lit_box() -> Scene {
    let polys = common::closed_box(DVec3::ZERO, DVec3::ONE, 2, |f| if f == 1 { 1 } else { 0 });
    let mut scene = Scene {
        materials: vec![
            Material::diffuse("white", [0.7, 0.5, 0.3]),
            Material::diffuse("ceiling", [0.6; 3]),
            Material {
                name: "lamp".into(),
                rho: [0.2; 3],
                emission: [10.0, 8.0, 6.0],
            },
        ],
        objects: vec![Object::still("box", polys)],
        ..Default::default()
    };
    // One ceiling quad emits.
    let ceiling = scene.objects[0]
        .polygons
        .iter_mut()
        .filter(|p| p.material == MaterialId(1))
        .nth(1)
        .unwrap();
    ceiling.material = MaterialId(2);
    scene
}

/// Gaussian elimination with partial pivoting.
fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap();
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..n {
            let m = a[r][c] / a[c][c];
            for k in c..n {
                a[r][k] -= m * a[c][k];
            }
            b[r] -= m * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

#[test]
fn hierarchical_equals_dense_when_nothing_splits() {
    let scene = lit_box();
    // min_size 1: no element may split, and eps ~0 forces every cluster link down
    // to patch pairs, so the hierarchy holds exactly the dense system.
    let opts = SolveOptions {
        eps: 1e-12,
        min_size: 1.0,
        ..Default::default()
    };
    let mut s = Solver::new(&scene, opts).unwrap();
    s.run(|_, _| {}).unwrap();
    let patches = Patches::at_time(&scene, 0.0);
    let n = patches.len();
    // Independent dense matrix: same quadrature, exact inner factor, empty box.
    let mut f = vec![vec![0.0; n]; n];
    for i in 0..n {
        let g = rhier::pools::elements::Geom {
            corners: std::array::from_fn(|k| patches.polys[i].v[k].to_array()),
            normal: patches.normals[i].to_array(),
            area: patches.areas[i],
            uv: [[0.0; 2]; 4],
            patch: i as u32,
            n: patches.polys[i].n as u32,
        };
        let q = samples(&g);
        for j in 0..n {
            if i != j {
                f[i][j] = (0..q.count)
                    .map(|k| {
                        q.weights[k]
                            * point_to_polygon(q.points[k], patches.normals[i], &patches.polys[j])
                    })
                    .sum();
            }
        }
    }
    let hier = s.leaf_radiosities();
    assert_eq!(hier.len(), n);
    for c in 0..3 {
        let a: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| if i == j { 1.0 } else { 0.0 } - patches.rhos[i][c] * f[i][j])
                    .collect()
            })
            .collect();
        let b: Vec<f64> = (0..n).map(|i| patches.emissions[i][c]).collect();
        let x = dense_solve(a, b);
        for (p, _, bh) in &hier {
            let d = x[*p as usize];
            assert!(
                (bh[c] as f64 - d).abs() <= 2e-4 * d.abs().max(1e-3),
                "patch {p} channel {c}: hierarchical {} dense {d}",
                bh[c]
            );
        }
    }
}

#[test]
fn ram_and_mmap_pools_give_identical_solutions() {
    let scene = rhier::scene::cornell_box(true);
    let (a, _) = solve(
        &scene,
        SolveOptions {
            storage: Storage::Ram,
            ..Default::default()
        },
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (b, _) = solve(
        &scene,
        SolveOptions {
            storage: Storage::Mmap(dir.path().to_owned()),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(a.leaves, b.leaves);
    assert!(!a.leaves.is_empty());
    // And the files they write are the same bytes (once the wall-clock time, which
    // the file records, is set equal).
    let (mut a, mut b) = (a, b);
    a.stats.seconds = 0.0;
    b.stats.seconds = 0.0;
    let name = std::path::Path::new("x.rhier");
    let opts = rhier::store::WriteOptions::default();
    let (fa, fb) = (
        rhier::store::encode_solution(name, &a, opts).unwrap(),
        rhier::store::encode_solution(name, &b, opts).unwrap(),
    );
    assert_eq!(fa, fb);
}

fn scaled(scene: &Scene, s: f64, e: f64) -> Scene {
    let mut out = scene.clone();
    for o in &mut out.objects {
        for p in &mut o.polygons {
            for v in &mut p.vertices {
                *v *= s;
            }
        }
    }
    for m in &mut out.materials {
        for x in &mut m.emission {
            *x *= e;
        }
    }
    out
}

/// Refinement decisions compare floating-point values against thresholds, so a
/// rescaled scene may flip a borderline split; what must not change is the answer:
/// probes at the same (scaled) points agree within 0.5% RMS.
#[test]
fn invariant_to_scene_scale_and_linear_in_emission() {
    let base = rhier::scene::cornell_box(true);
    let patches = Patches::at_time(&base, 0.0);
    let pts = common::probe::grid_points(&patches, 3);
    let (a, _) = solve(&base, SolveOptions::default()).unwrap();
    let va: Vec<[f64; 3]> = probe_all(&a, &pts, 1.0);
    for (s, e) in [(1e-3, 1.0), (1e3, 1.0), (1.0, 1e4), (1e-6, 1e-3)] {
        let (b, _) = solve(&scaled(&base, s, e), SolveOptions::default()).unwrap();
        let scaled_pts: Vec<_> = pts.iter().map(|&(p, n)| (p * s, n)).collect();
        let vb: Vec<[f64; 3]> = probe_all(&b, &scaled_pts, 1.0 / e);
        let rel = rhier::solution::relative_rms(&vb, &va);
        assert!(
            rel < 5e-3,
            "scale {s} emission {e}: relative RMS difference {rel}"
        );
    }
}

fn probe_all(
    sol: &rhier::solution::Solution,
    pts: &[(DVec3, DVec3)],
    factor: f64,
) -> Vec<[f64; 3]> {
    let points: Vec<rhier::playback::ProbePoint> = pts
        .iter()
        .map(|&(p, n)| rhier::playback::ProbePoint { p, n })
        .collect();
    rhier::playback::probe(sol, &points, 0.0)
        .unwrap()
        .iter()
        .map(|b| [b[0] * factor, b[1] * factor, b[2] * factor])
        .collect()
}

#[test]
fn slivers_touching_and_coplanar_polygons_stay_finite() {
    let mut scene = lit_box();
    let polys = &mut scene.objects[0].polygons;
    // A sliver triangle standing on the floor, a quad touching it, and two coplanar
    // quads sharing an edge, floating mid-room; a tiny quad.
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    polys.push(Polygon {
        vertices: vec![v(0.2, 0.2, 0.0), v(0.8, 0.2, 0.0), v(0.5, 0.2 + 1e-7, 0.6)],
        material: MaterialId(0),
    });
    polys.push(Polygon {
        vertices: vec![
            v(0.3, 0.5, 0.5),
            v(0.5, 0.5, 0.5),
            v(0.5, 0.7, 0.5),
            v(0.3, 0.7, 0.5),
        ],
        material: MaterialId(0),
    });
    polys.push(Polygon {
        vertices: vec![
            v(0.5, 0.5, 0.5),
            v(0.7, 0.5, 0.5),
            v(0.7, 0.7, 0.5),
            v(0.5, 0.7, 0.5),
        ],
        material: MaterialId(0),
    });
    polys.push(Polygon {
        vertices: vec![
            v(0.1, 0.9, 0.2),
            v(0.1 + 1e-6, 0.9, 0.2),
            v(0.1 + 1e-6, 0.9, 0.2 + 1e-6),
            v(0.1, 0.9, 0.2 + 1e-6),
        ],
        material: MaterialId(0),
    });
    let (sol, recs) = solve(&scene, SolveOptions::default()).unwrap();
    assert!(recs.last().unwrap().residual < 1e-4);
    for l in &sol.leaves {
        for c in 0..l.corners as usize {
            for k in 0..3 {
                let b = l.b[c][k];
                assert!(
                    b.is_finite() && b >= 0.0,
                    "patch {} corner {c}: {b}",
                    l.patch
                );
            }
        }
    }
}

/// The library refuses settings outside their domain when a solver is made, with
/// an error naming the setting, instead of refining without end (`eps <= 0`,
/// `min_size = 0`) or returning an unsolved hierarchy (`max_rounds = 0`).
#[test]
fn settings_outside_their_domain_are_refused_by_the_solver() {
    let scene = lit_box();
    let base = SolveOptions::default();
    if let Err(e) = base.validate() {
        panic!("the default settings are refused: {e}");
    }
    let cases: [(&str, SolveOptions); 7] = [
        (
            "--eps",
            SolveOptions {
                eps: -0.5,
                ..base.clone()
            },
        ),
        (
            "--min-size",
            SolveOptions {
                min_size: 0.0,
                ..base.clone()
            },
        ),
        (
            "--recon-tol",
            SolveOptions {
                recon_tol: f64::NAN,
                ..base.clone()
            },
        ),
        (
            "--recon-tol-moving",
            SolveOptions {
                recon_tol_moving: Some(0.0),
                ..base.clone()
            },
        ),
        (
            "--power-size",
            SolveOptions {
                power_size: f64::INFINITY,
                ..base.clone()
            },
        ),
        (
            "--max-rounds",
            SolveOptions {
                max_rounds: 0,
                ..base.clone()
            },
        ),
        (
            "rays_per_point",
            SolveOptions {
                rays_per_point: 0,
                ..base.clone()
            },
        ),
    ];
    for (name, opts) in cases {
        let err = match Solver::new(&scene, opts) {
            Ok(_) => panic!("{name}: a solver was made"),
            Err(e) => e.to_string(),
        };
        assert!(err.starts_with(&format!("{name}: expected ")), "{err}");
    }
    // The time settings of a space-time solve, checked by the same rule
    // (`SpaceTime::new` calls this before any work; `fps = 0` made one frame at a
    // NaN time).
    use rhier::solver::spacetime::SpaceTimeOptions;
    let st = SpaceTimeOptions::default();
    if let Err(e) = st.validate() {
        panic!("the default space-time settings are refused: {e}");
    }
    // 0 turns `--interp-motion` off, and makes `--moving-power-tol` skip only
    // where nothing changes; neither is refused.
    let off = SpaceTimeOptions {
        interp_motion: 0.0,
        moving_power_tol: 0.0,
        ..st
    };
    if let Err(e) = off.validate() {
        panic!("interp_motion = moving_power_tol = 0 is refused: {e}");
    }
    for (name, bad) in [
        ("--fps", SpaceTimeOptions { fps: 0.0, ..st }),
        (
            "--window",
            SpaceTimeOptions {
                window: Some(f64::NAN),
                ..st
            },
        ),
        (
            "--key-stride",
            SpaceTimeOptions {
                key_stride: Some(0),
                ..st
            },
        ),
        (
            "--key-motion",
            SpaceTimeOptions {
                key_motion: -0.1,
                ..st
            },
        ),
        (
            "--interp-motion",
            SpaceTimeOptions {
                interp_motion: f64::INFINITY,
                ..st
            },
        ),
        (
            "--interp-motion",
            SpaceTimeOptions {
                interp_motion: -0.01,
                ..st
            },
        ),
        (
            "--moving-power-tol",
            SpaceTimeOptions {
                moving_power_tol: f64::NAN,
                ..st
            },
        ),
        (
            "--moving-power-tol",
            SpaceTimeOptions {
                moving_power_tol: -0.01,
                ..st
            },
        ),
    ] {
        let err = bad.validate().expect_err(name).to_string();
        assert!(err.starts_with(&format!("{name}: expected ")), "{err}");
    }
}
