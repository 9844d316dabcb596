//! Views (rotational sweeps around each point) against the dual-plane sweep and brute
//! force: the same exact measures, the visibility graph = brute-force `sees`.

use std::path::Path;

use rhier::flatland::complex::sweep;
use rhier::flatland::geometry::PairMap;
use rhier::flatland::mesh::Mesh;
use rhier::flatland::scene::load;
use rhier::flatland::views::{Topology, all_views, form_factors_mu, visibility_graph};

use crate::common::random_flat_geometry;

fn assert_same_mu(a: &PairMap, b: &PairMap, tol: f64, what: &str) {
    for (k, x) in a {
        let y = b.get(k).copied().unwrap_or(0.0);
        assert!((x - y).abs() < tol, "{what} {k:?}: views {x} vs sweep {y}");
    }
    for (k, y) in b {
        let x = a.get(k).copied().unwrap_or(0.0);
        assert!((x - y).abs() < tol, "{what} {k:?}: views {x} vs sweep {y}");
    }
}

#[test]
fn views_give_the_dual_sweep_measures_on_random_scenes() {
    for seed in 1..25u64 {
        for splits in [1usize, 3] {
            let g = random_flat_geometry(seed, 4 + (seed as usize % 9), splits);
            let (mu, stats) = form_factors_mu(&g);
            let old = sweep(&g, None, false).mu;
            assert!(!old.is_empty());
            assert_same_mu(&mu, &old, 1e-12, &format!("seed {seed} splits {splits}"));
            assert_eq!(stats.points, g.points.len());
        }
    }
}

#[test]
fn views_give_the_dual_sweep_measures_in_degenerate_rooms() {
    // Axis-aligned boxes in a room: many collinear points, shared corners.
    let p = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/formats/examples/flatland_moving.json"
    ));
    let scene = load(p).unwrap();
    for mesh in [Mesh::None, Mesh::Uniform(3), Mesh::Discontinuity] {
        for t in [0.0, 0.3, 1.0] {
            let g = rhier::flatland::geometry_at(&scene, t, mesh);
            let (mu, _) = form_factors_mu(&g);
            let old = sweep(&g, None, false).mu;
            assert_same_mu(&mu, &old, 1e-12, &format!("{mesh:?} t {t}"));
        }
    }
}

#[test]
fn visibility_graph_from_views_equals_brute_force() {
    for seed in 1..20u64 {
        // Unsplit segments: brute-force `sees` is not robust for split points.
        let g = random_flat_geometry(seed, 3 + (seed as usize % 8), 1);
        let topo = Topology::new(&g);
        let (views, _) = all_views(&g, &topo);
        let graph = visibility_graph(&topo, &views);
        let mut brute = Vec::new();
        for u in 0..g.points.len() {
            for w in u + 1..g.points.len() {
                if g.sees(g.points[u], g.points[w]) {
                    brute.push((u as u32, w as u32));
                }
            }
        }
        assert_eq!(graph, brute, "seed {seed}");
        // Symmetry: u sees w in u's view iff w sees u in w's view.
        for (u, view) in views.iter().enumerate() {
            for b in view.boundaries.iter().filter(|b| b.visible) {
                assert!(
                    views[b.point as usize]
                        .boundaries
                        .iter()
                        .any(|c| c.point == u as u32 && c.visible),
                    "seed {seed}: {u} sees {} but not back",
                    b.point
                );
            }
        }
    }
}
