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
                    assert!((a - b).abs() < 1e-12, "{mesh:?} t {t}: F({i},{j}) {a} vs {b}");
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
                created += now.difference(p).count();
                destroyed += p.difference(&now).count();
            }
            prev = Some(now);
            assert_eq!(rep.ff_total, full.nonzeros());
            if rep.ff_recomputed < rep.ff_total {
                partial += 1;
            }
        }
        assert!(created > 0 && destroyed > 0, "{mesh:?}: no visibility event on the path");
        assert!(partial >= 15, "{mesh:?}: only {partial} steps were partial updates");
    }
}

#[test]
fn static_steps_recompute_nothing() {
    let scene = load(scene_path()).unwrap();
    let (mut dynamic, _) = Dynamic::new(&scene, Mesh::None, 1.0);
    let rep = dynamic.step(2.0); // after the last key: nothing moves
    assert_eq!(rep.ff_recomputed, 0);
    assert_eq!(rep.cells_visited, 0);
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
