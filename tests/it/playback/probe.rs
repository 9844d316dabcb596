//! The probe contract: nearest surface facing along `n`, the leaf's interpolant there,
//! the same answer whatever order leaves come in, a clear error when nothing faces.

use glam::DVec3;
use rhier::playback::{ProbePoint, probe};
use rhier::scene::{Material, MaterialId, Object, Polygon, Scene};
use rhier::solution::{Leaf, PatchGeometry, Solution, SolveStats};

fn quad(z: f64, facing_up: bool) -> Vec<DVec3> {
    let mut v = vec![
        DVec3::new(0.0, 0.0, z),
        DVec3::new(1.0, 0.0, z),
        DVec3::new(1.0, 1.0, z),
        DVec3::new(0.0, 1.0, z),
    ];
    if !facing_up {
        v.reverse();
    }
    v
}

/// Two parallel unit squares: z = 0 facing +z, z = 0.1 facing -z. The lower one has
/// two leaves split at u = 0.5 with different constant values; the upper one one leaf.
fn two_plates() -> Solution {
    let polys = [quad(0.0, true), quad(0.1, false)];
    let scene = Scene {
        materials: vec![Material::diffuse("m", [0.5; 3])],
        objects: vec![Object::still(
            "plates",
            polys
                .iter()
                .map(|v| Polygon {
                    vertices: v.clone(),
                    material: MaterialId(0),
                })
                .collect(),
        )],
        ..Scene::default()
    };
    let patches: Vec<PatchGeometry> = polys
        .iter()
        .map(|v| PatchGeometry {
            object: 0,
            material: 0,
            corners: 4,
            vertices: [v[0], v[1], v[2], v[3]],
        })
        .collect();
    let leaf = |patch, u0: f32, u1: f32, b: f32| Leaf {
        patch,
        corners: 4,
        time: [0.0, 0.0],
        uv: [[u0, 0.0], [u1, 0.0], [u1, 1.0], [u0, 1.0]],
        b: [[b; 3]; 4],
    };
    Solution {
        scene,
        patches,
        leaves: vec![
            leaf(0, 0.0, 0.5, 1.0),
            leaf(0, 0.5, 1.0, 2.0),
            leaf(1, 0.0, 1.0, 7.0),
        ],
        stats: SolveStats::default(),
    }
}

#[test]
fn normal_selects_the_facing_surface() {
    let sol = two_plates();
    let p = DVec3::new(0.25, 0.5, 0.04);
    let up = probe(&sol, &[ProbePoint { p, n: DVec3::Z }], 0.0).unwrap();
    let down = probe(&sol, &[ProbePoint { p, n: DVec3::NEG_Z }], 0.0).unwrap();
    assert_eq!(up, vec![[1.0; 3]]);
    assert_eq!(down, vec![[7.0; 3]]);
    // Far outside, the nearest facing point is on the edge of the lower plate's right
    // leaf.
    let far = probe(
        &sol,
        &[ProbePoint {
            p: DVec3::new(5.0, 0.5, -3.0),
            n: DVec3::Z,
        }],
        0.0,
    )
    .unwrap();
    assert_eq!(far, vec![[2.0; 3]]);
    // Nothing faces along +x: a clear error naming the point.
    let err = probe(
        &sol,
        &[ProbePoint { p, n: DVec3::Z }, ProbePoint { p, n: DVec3::X }],
        0.0,
    )
    .map(|_| ())
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("probe point 1") && err.contains("none"),
        "{err}"
    );
}

#[test]
fn leaf_order_does_not_change_the_answer_on_a_boundary() {
    let sol = two_plates();
    let mut rev = sol.clone();
    rev.leaves.reverse();
    let pts: Vec<ProbePoint> = [0.5, 0.4999999, 0.5000001]
        .iter()
        .map(|&u| ProbePoint {
            p: DVec3::new(u, 0.3, 0.01),
            n: DVec3::Z,
        })
        .collect();
    let a = probe(&sol, &pts, 0.0).unwrap();
    let b = probe(&rev, &pts, 0.0).unwrap();
    assert_eq!(a, b);
    assert_eq!(a[1], [1.0; 3]);
    assert_eq!(a[2], [2.0; 3]);
}
