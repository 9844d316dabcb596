//! Property tests of the native JSON writer and of validation: a random valid scene
//! written with `to_json_string` reads back with the same structure and every number
//! within 1 ulp, and validating a validated scene changes nothing.

use std::path::Path;

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;
use rhier::scene::{
    self, Material, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, TimeDomain,
};

fn vec3(range: f64) -> impl Strategy<Value = DVec3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn material(i: usize) -> impl Strategy<Value = Material> {
    (
        prop::array::uniform3(0.0..0.999f64),
        prop::array::uniform3(prop_oneof![Just(0.0), 0.0..50.0f64]),
    )
        .prop_map(move |(rho, emission)| Material {
            // Names in sorted order, as the reader returns them.
            name: format!("m{i}"),
            rho,
            emission,
        })
}

fn track() -> impl Strategy<Value = Option<MotionTrack>> {
    prop::option::of(
        prop::collection::vec(
            (
                0.01..2.0f64,
                vec3(10.0),
                vec3(1.0),
                (0.1..3.0f64, 0.1..3.0f64, 0.1..3.0f64),
            ),
            1..4,
        )
        .prop_map(|raw| {
            let mut t = 0.0;
            let keys = raw
                .into_iter()
                .map(|(dt, translation, axis, (sx, sy, sz))| {
                    t += dt;
                    let axis = axis.try_normalize().unwrap_or(DVec3::Z);
                    MotionKey {
                        t,
                        translation,
                        rotation: DQuat::from_axis_angle(axis, 3.0 * dt),
                        scale: DVec3::new(sx, sy, sz),
                    }
                })
                .collect();
            MotionTrack { keys }
        }),
    )
}

fn scene_strategy() -> impl Strategy<Value = Scene> {
    let materials = (1..4usize).prop_flat_map(|n| (0..n).map(material).collect::<Vec<_>>());
    materials.prop_flat_map(|materials| {
        let m = materials.len() as u32;
        let polygon =
            (vec3(100.0), vec3(100.0), vec3(100.0), 0..m).prop_map(|(a, b, c, k)| Polygon {
                vertices: vec![a, b, c],
                material: MaterialId(k),
            });
        let object = (prop::collection::vec(polygon, 1..5), track());
        (Just(materials), prop::collection::vec(object, 1..4)).prop_map(|(materials, objects)| {
            let objects: Vec<Object> = objects
                .into_iter()
                .enumerate()
                .map(|(i, (polygons, motion))| Object {
                    name: format!("object {i}"),
                    polygons,
                    motion,
                })
                .collect();
            let end = objects
                .iter()
                .filter_map(|o| o.motion.as_ref())
                .flat_map(|m| m.keys.iter().map(|k| k.t))
                .fold(0.0, f64::max);
            Scene {
                time: TimeDomain { start: 0.0, end },
                materials,
                objects,
                camera: None,
                warnings: Vec::new(),
            }
        })
    })
}

/// Names, counts and material ids of a scene.
fn shape(s: &Scene) -> Vec<String> {
    let mut out: Vec<String> = s.materials.iter().map(|m| m.name.clone()).collect();
    for o in &s.objects {
        out.push(format!(
            "{} {:?}",
            o.name,
            o.motion.as_ref().map(|m| m.keys.len())
        ));
        out.extend(
            o.polygons
                .iter()
                .map(|p| format!("{} {}", p.vertices.len(), p.material.0)),
        );
    }
    out
}

/// Every number of a scene, in a fixed order.
fn numbers(s: &Scene) -> Vec<f64> {
    let mut out = vec![s.time.start, s.time.end];
    for m in &s.materials {
        out.extend(m.rho);
        out.extend(m.emission);
    }
    for o in &s.objects {
        for p in &o.polygons {
            out.extend(p.vertices.iter().flat_map(|v| v.to_array()));
        }
        for k in o.motion.iter().flat_map(|m| &m.keys) {
            out.push(k.t);
            out.extend(k.translation.to_array());
            out.extend(k.rotation.to_array());
            out.extend(k.scale.to_array());
        }
    }
    out
}

proptest! {
    // Failing cases are kept next to this file, in `<file>.proptest-regressions`
    // (proptest's default would put them under a `proptest-regressions/` directory
    // beside the nearest folder holding a `main.rs`).
    #![proptest_config(ProptestConfig {
        cases: 128,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn json_round_trip_and_validation_is_idempotent(s in scene_strategy()) {
        let path = Path::new("random.json");
        let v = scene::validate::validate(s, path).unwrap();
        let mut again = scene::validate::validate(Scene { warnings: Vec::new(), ..v.clone() }, path).unwrap();
        // Warnings are recomputed, not accumulated.
        again.warnings.clone_from(&v.warnings);
        prop_assert_eq!(&again, &v);
        let text = scene::to_json_string(&v);
        let back = scene::load_json_str(&text, path).unwrap();
        // Same structure; every number within 1 ulp (serde_json's default float
        // parser is not correctly rounded: see formats/scene.md).
        prop_assert_eq!(shape(&back), shape(&v));
        let (a, b) = (numbers(&back), numbers(&v));
        prop_assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            prop_assert!((x - y).abs() <= f64::EPSILON * y.abs(), "{} vs {}", x, y);
        }
    }
}
