//! Moving polygons (paper §5): the incremental update equals a from-scratch solve at
//! every step of a path whose visibility topology changes, and recomputes fewer form
//! factors than there are.

use std::collections::HashSet;
use std::path::Path;

use rhier::flatland::dynamic::Dynamic;
use rhier::flatland::mesh::Mesh;
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::load;
use rhier::flatland::{geometry_at, solve, solve_with};

use crate::common::random_moving_flat_scene;

fn scene_path() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/formats/examples/flatland_moving.json"
    ))
}

#[test]
fn update_equals_full_recompute_along_the_path() {
    let scene = load(scene_path()).unwrap();
    for mesh in [Mesh::None, Mesh::Uniform(3)] {
        let times: Vec<f64> = (0..=20).map(|k| k as f64 / 20.0).collect();
        let (mut dynamic, _) = Dynamic::new(&scene, mesh, times[0]);
        let mut prev: Option<HashSet<(u32, u32)>> = None;
        let (mut created, mut destroyed, mut partial) = (0, 0, 0);
        for &t in &times[1..] {
            let rep = dynamic.step(t);
            let ff = dynamic.form_factors();
            let full_geom = geometry_at(&scene, t, mesh);
            let (full, _) = form_factors(&full_geom);
            let n = full_geom.elements.len() as u32;
            for i in 0..n {
                for j in 0..n {
                    let (a, b) = (ff.f(i, j), full.f(i, j));
                    assert!(
                        (a - b).abs() < 1e-12,
                        "{mesh:?} t {t}: F({i},{j}) {a} vs {b}"
                    );
                }
            }
            let b_dyn = solve_with(&scene, t, dynamic.geometry().clone(), &ff);
            let b_full = solve(&scene, t, mesh);
            for (x, y) in b_dyn.element_b.iter().zip(&b_full.element_b) {
                for c in 0..3 {
                    assert!((x[c] - y[c]).abs() < 1e-10 * (1.0 + y[c].abs()));
                }
            }
            // Topological changes: pairs that start or stop seeing each other.
            let now: HashSet<(u32, u32)> = full.mu.keys().copied().collect();
            if let Some(p) = &prev {
                let (c, d) = (now.difference(p).count(), p.difference(&now).count());
                assert_eq!((rep.pairs_appeared, rep.pairs_vanished), (c, d), "t {t}");
                created += c;
                destroyed += d;
            }
            prev = Some(now);
            assert_eq!(rep.ff_total, full.nonzeros());
            if rep.ff_recomputed < rep.ff_total {
                partial += 1;
            }
        }
        assert!(
            created > 0 && destroyed > 0,
            "{mesh:?}: no visibility event on the path"
        );
        assert!(
            partial >= 15,
            "{mesh:?}: only {partial} steps were partial updates"
        );
    }
}

#[test]
fn static_steps_recompute_nothing() {
    let scene = load(scene_path()).unwrap();
    let (mut dynamic, _) = Dynamic::new(&scene, Mesh::None, 1.0);
    let rep = dynamic.step(2.0); // after the last key: nothing moves
    assert_eq!(rep.ff_recomputed, 0);
    assert_eq!(rep.points_evaluated, 0);
    assert_eq!(rep.event_candidates, 0);
    assert!(rep.ff_total > 0);
}

#[test]
fn discontinuity_mesh_steps_are_full_and_exact() {
    let scene = load(scene_path()).unwrap();
    let (mut dynamic, _) = Dynamic::new(&scene, Mesh::Discontinuity, 0.0);
    let rep = dynamic.step(0.5);
    assert!(rep.full);
    let full = solve(&scene, 0.5, Mesh::Discontinuity);
    assert_eq!(dynamic.geometry().elements.len(), full.geom.elements.len());
    assert!(full.geom.elements.len() > full.geom.segments.len());
}

#[test]
fn window_sweep_over_the_whole_scene_equals_the_full_sweep() {
    use rhier::flatland::window::window_sweep;
    let scene = load(scene_path()).unwrap();
    for mesh in [Mesh::None, Mesh::Uniform(2)] {
        let g = geometry_at(&scene, 0.3, mesh);
        let (full, _) = form_factors(&g);
        // A region containing every line that meets the scene.
        let big = [[-10.0, -10.0], [14.0, -10.0], [14.0, 13.0], [-10.0, 13.0]];
        let w = window_sweep(&g, &big);
        assert_eq!(w.mu.len(), full.mu.len());
        for (k, v) in &full.mu {
            assert!((w.mu[k] - v).abs() < 1e-12, "{k:?}: {} vs {v}", w.mu[k]);
        }
        // A small region: the window sweep and the full sweep clipped gap by gap
        // (two independent restrictions) agree, up to the window's 1e-9 growth.
        let k = [[1.0, 1.0], [1.6, 1.1], [1.2, 1.7]];
        let w = window_sweep(&g, &k);
        let clip = rhier::flatland::complex::Clip::new(vec![k.to_vec()]);
        let c = rhier::flatland::complex::sweep(&g, Some(&clip), false);
        assert!(!c.mu.is_empty());
        for (key, v) in &c.mu {
            let got = w.mu.get(key).copied().unwrap_or(0.0);
            assert!((got - v).abs() < 1e-7, "{key:?}: window {got}, clipped {v}");
        }
        for key in w.mu.keys() {
            assert!(c.mu.contains_key(key) || w.mu[key] < 1e-7);
        }
    }
}

#[test]
fn update_equals_full_recompute_on_random_scenes_and_motions() {
    let mut tested = 0;
    for seed in 1..40u64 {
        let Some(scene) = random_moving_flat_scene(seed, 6, 0.0) else {
            continue;
        };
        let times: Vec<f64> = (0..=8).map(|k| k as f64 / 8.0).collect();
        tested += 1;
        let (mut dynamic, _) = Dynamic::new(&scene, Mesh::None, 0.0);
        for &t in &times[1..] {
            dynamic.step(t);
            let ff = dynamic.form_factors();
            let (full, _) = form_factors(&geometry_at(&scene, t, Mesh::None));
            for i in 0..9 {
                for j in 0..9 {
                    let (a, b) = (ff.f(i, j), full.f(i, j));
                    assert!(
                        (a - b).abs() < 1e-11,
                        "seed {seed} t {t} F({i},{j}): {a} vs {b}"
                    );
                }
            }
        }
    }
    assert!(tested >= 10, "only {tested} random scenes were valid");
}
