//! "Never a panic on any input": random and mutated scene files go through every
//! loader and must come back as `Ok` or `Err`, never as a panic (proptest reports a
//! panic as a failure). Mutations start from the committed samples so that most cases
//! get past the first parser into the mapping and validation code.

use std::path::Path;

use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;
use rhier::scene;

use crate::common;

fn example(name: &str) -> Vec<u8> {
    std::fs::read(common::example(name)).unwrap()
}

/// Replaces the numbers of a JSON value at the chosen positions by `values`.
fn mutate_numbers(v: &mut serde_json::Value, picks: &[(usize, f64)], counter: &mut usize) {
    match v {
        serde_json::Value::Number(_) => {
            for &(at, x) in picks {
                if at == *counter {
                    *v =
                        serde_json::Number::from_f64(x).map_or(serde_json::Value::Null, Into::into);
                }
            }
            *counter += 1;
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| mutate_numbers(x, picks, counter)),
        serde_json::Value::Object(m) => m
            .values_mut()
            .for_each(|x| mutate_numbers(x, picks, counter)),
        _ => {}
    }
}

/// Replaces the values (of any kind, counted in pre-order) at the chosen positions by
/// one of a few replacements of other kinds and shapes.
fn mutate_values(v: &mut serde_json::Value, picks: &[(usize, usize)], counter: &mut usize) {
    let here = *counter;
    *counter += 1;
    if let Some(&(_, k)) = picks.iter().find(|(at, _)| *at == here) {
        let replacements = [
            serde_json::json!(null),
            serde_json::json!(0),
            serde_json::json!(-1),
            serde_json::json!(3),
            serde_json::json!(1e9),
            serde_json::json!("x"),
            serde_json::json!("rotation"),
            serde_json::json!([]),
            serde_json::json!({}),
            serde_json::json!([0, 0, 0]),
            serde_json::json!([1, 2, 3, 4]),
        ];
        *v = replacements[k % replacements.len()].clone();
        return;
    }
    match v {
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| mutate_values(x, picks, counter)),
        serde_json::Value::Object(m) => m
            .values_mut()
            .for_each(|x| mutate_values(x, picks, counter)),
        _ => {}
    }
}

fn interesting_number() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(-1.0),
        Just(0.0),
        Just(1.0),
        Just(2.0),
        Just(3.0),
        Just(4.0),
        Just(5.0),
        Just(7.0),
        Just(1e9),
        Just(4294967295.0),
        Just(-1e-300),
        -10.0..10.0f64,
    ]
}

proptest! {
    // Failing cases are kept next to this file, in `<file>.proptest-regressions`
    // (proptest's default would put them under a `proptest-regressions/` directory
    // beside the nearest folder holding a `main.rs`).
    #![proptest_config(ProptestConfig {
        cases: 256,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        let _ = scene::load_gltf_slice(&bytes, None, Path::new("r.glb"));
        let text = String::from_utf8_lossy(&bytes);
        let _ = scene::load_json_str(&text, Path::new("r.json"));
    }

    #[test]
    fn mutated_glb_never_panics(flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8)) {
        let mut bytes = example("moving_cube.glb");
        for (i, b) in flips {
            let i = i.index(bytes.len());
            bytes[i] = b;
        }
        let _ = scene::load_gltf_slice(&bytes, None, Path::new("m.glb"));
    }

    #[test]
    fn mutated_gltf_numbers_never_panic(picks in proptest::collection::vec((0usize..400, interesting_number()), 1..6)) {
        let mut v: serde_json::Value = serde_json::from_slice(&example("moving_cube.gltf")).unwrap();
        mutate_numbers(&mut v, &picks, &mut 0);
        let bytes = serde_json::to_vec(&v).unwrap();
        let _ = scene::load_gltf_slice(&bytes, None, Path::new("m.gltf"));
    }

    #[test]
    fn mutated_gltf_structure_never_panics(picks in proptest::collection::vec((0usize..700, 0usize..11), 1..4)) {
        let mut v: serde_json::Value = serde_json::from_slice(&example("moving_cube.gltf")).unwrap();
        mutate_values(&mut v, &picks, &mut 0);
        let bytes = serde_json::to_vec(&v).unwrap();
        let _ = scene::load_gltf_slice(&bytes, None, Path::new("m.gltf"));
    }

    #[test]
    fn mutated_native_json_structure_never_panics(picks in proptest::collection::vec((0usize..500, 0usize..11), 1..4)) {
        let mut v: serde_json::Value = serde_json::from_slice(&example("cornell_blocks.json")).unwrap();
        mutate_values(&mut v, &picks, &mut 0);
        let _ = scene::load_json_str(&v.to_string(), Path::new("m.json"));
    }

    #[test]
    fn mutated_native_json_numbers_never_panic(picks in proptest::collection::vec((0usize..300, interesting_number()), 1..6)) {
        let mut v: serde_json::Value = serde_json::from_slice(&example("cornell_blocks.json")).unwrap();
        mutate_numbers(&mut v, &picks, &mut 0);
        let _ = scene::load_json_str(&v.to_string(), Path::new("m.json"));
    }

    #[test]
    fn random_obj_lines_never_panic(lines in proptest::collection::vec(
        prop_oneof![
            "v -?[0-9]{1,2}(\\.[0-9])? -?[0-9]{1,2} [0-9]",
            "v nan 0 0",
            "f( -?[0-9]{1,2}(/[0-9]?(/[0-9])?)?){0,7}",
            "(o|g|usemtl)( [a-z]{0,3})?",
            "[a-z ]{0,8}",
        ],
        0..30,
    )) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("t.mtl"), "newmtl a\nKd 0.5 0.5 0.5\nKe 1 1 1\n").unwrap();
        let path = dir.path().join("t.obj");
        std::fs::write(&path, format!("mtllib t.mtl\n{}\n", lines.join("\n"))).unwrap();
        let _ = scene::load(&path);
    }
}
