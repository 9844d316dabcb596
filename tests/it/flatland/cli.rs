//! `rhier flatland` end to end: the real binary in a temporary directory.

use std::path::Path;

use serde_json::Value;

use crate::common::{example, rhier};

fn read(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A closed room where every segment emits E = 1 with rho = 0.5, with a box inside:
/// closure makes B = E / (1 - rho) = 2 everywhere, whatever the mesh.
const UNIFORM_ROOM: &str = r#"{"rhier_flatland": 1, "objects": [
  {"name": "room", "segments": [
    {"a": [0, 0], "b": [3, 0], "reflectance": 0.5, "emission": 1},
    {"a": [3, 0], "b": [3, 2], "reflectance": 0.5, "emission": 1},
    {"a": [3, 2], "b": [0, 2], "reflectance": 0.5, "emission": 1},
    {"a": [0, 2], "b": [0, 0], "reflectance": 0.5, "emission": 1}]},
  {"name": "box", "segments": [
    {"a": [1, 0.5], "b": [1, 1], "reflectance": 0.5, "emission": 1},
    {"a": [1, 1], "b": [1.7, 1], "reflectance": 0.5, "emission": 1},
    {"a": [1.7, 1], "b": [1.7, 0.5], "reflectance": 0.5, "emission": 1},
    {"a": [1.7, 0.5], "b": [1, 0.5], "reflectance": 0.5, "emission": 1}]}]}"#;

#[test]
fn uniform_room_has_the_known_radiosity_with_every_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("uniform.json");
    std::fs::write(&scene, UNIFORM_ROOM).unwrap();
    for mesh in ["none", "uniform:3", "discontinuity"] {
        let out = dir.path().join("r.json");
        let st = rhier()
            .args(["flatland"])
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .args(["--mesh", mesh])
            .status()
            .unwrap();
        assert!(st.success());
        let r = read(&out);
        assert_eq!(r["rhier_flatland_result"], 1);
        let segs = r["segments"].as_array().unwrap();
        assert_eq!(segs.len(), 8);
        assert_eq!(segs[5]["object"], "box");
        assert_eq!(segs[5]["index"], 1);
        for s in segs {
            assert!(
                (s["B"].as_f64().unwrap() - 2.0).abs() < 1e-12,
                "{mesh}: {s}"
            );
            for e in s["elements"].as_array().unwrap() {
                assert!((e["B"].as_f64().unwrap() - 2.0).abs() < 1e-12);
            }
        }
        if mesh == "uniform:3" {
            assert_eq!(segs[0]["elements"].as_array().unwrap().len(), 3);
        }
    }
}

#[test]
fn room_example_matches_the_library_and_draws_svg() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.json");
    let svg = dir.path().join("room.svg");
    let st = rhier()
        .arg("flatland")
        .arg(example("flatland_room.json"))
        .arg("--out")
        .arg(&out)
        .arg("--svg")
        .arg(&svg)
        .arg("--dual")
        .status()
        .unwrap();
    assert!(st.success());
    let r = read(&out);
    let scene = rhier::flatland::scene::load(&example("flatland_room.json")).unwrap();
    let sol = rhier::flatland::solve(&scene, 0.0, rhier::flatland::mesh::Mesh::None);
    let segs = r["segments"].as_array().unwrap();
    assert_eq!(segs.len(), 10);
    for (s, b) in segs.iter().zip(&sol.segment_b) {
        // The scene has RGB values: B is a triple.
        let got: Vec<f64> = s["B"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        for c in 0..3 {
            assert!((got[c] - b[c]).abs() < 1e-12);
        }
    }
    // The light is brighter than the floor under the occluder.
    assert!(segs[3]["B"][1].as_f64().unwrap() > segs[0]["B"][1].as_f64().unwrap());
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("<polygon"));
    // The same picture as PNG: scene (600 px) + dual plane (600 px) side by side.
    let png = dir.path().join("room.png");
    let st = rhier()
        .arg("flatland")
        .arg(example("flatland_room.json"))
        .arg("--out")
        .arg(&out)
        .arg("--svg")
        .arg(&png)
        .arg("--dual")
        .status()
        .unwrap();
    assert!(st.success());
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (1220, 600));
    // The light (ceiling x in [1.5, 2.5]) is drawn (nearly) white, the floor darker.
    let light = img.get_pixel(20 + (2.0 * 140.0) as u32, 20 + 3);
    assert!(light.0.iter().all(|&c| c >= 250), "{light:?}");
    let floor = img.get_pixel(20 + (2.0 * 140.0) as u32, 20 + 420 - 3);
    assert!(
        floor.0.iter().all(|&c| c < 250) && floor.0.iter().any(|&c| c > 40),
        "{floor:?}"
    );
}

#[test]
fn times_report_updates_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.json");
    let st = rhier()
        .arg("flatland")
        .arg(example("flatland_moving.json"))
        .arg("--out")
        .arg(&out)
        .args(["--times", "0,0.25,0.5,0.75,1", "--verify"])
        .status()
        .unwrap();
    assert!(st.success());
    let r = read(&out);
    let frames = r["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 5);
    assert_eq!(frames[0]["update"]["full"], true);
    for f in &frames[1..] {
        let u = &f["update"];
        assert_eq!(u["full"], false);
        let (re, tot) = (
            u["form_factors_recomputed"].as_u64().unwrap(),
            u["form_factors_total"].as_u64().unwrap(),
        );
        assert!(re > 0 && tot > 0);
        assert!(u["faces_visited"].as_u64().unwrap() > 0);
        assert!(u["verify"]["max_abs_dF"].as_f64().unwrap() < 1e-12);
        assert!(u["verify"]["max_abs_dB"].as_f64().unwrap() < 1e-10);
        assert_eq!(f["segments"].as_array().unwrap().len(), 14);
    }
}

#[test]
fn bad_scene_exits_1_naming_file_and_place() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.json");
    std::fs::write(
        &scene,
        r#"{"rhier_flatland": 1, "objects": [{"name": "room", "segments": [
            {"a": [0, 0], "b": [1, 0], "reflectance": 1.5}]}]}"#,
    )
    .unwrap();
    let o = rhier()
        .arg("flatland")
        .arg(&scene)
        .arg("--out")
        .arg(dir.path().join("r.json"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.json"), "{err}");
    assert!(err.contains("object \"room\", segment 0"), "{err}");
    assert!(err.contains("[0, 1)") && err.contains("1.5"), "{err}");
    let o = rhier()
        .arg("flatland")
        .arg(dir.path().join("missing.json"))
        .arg("--out")
        .arg(dir.path().join("r.json"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.json"));
    // Too many elements for the dense solve: refused before any work.
    let o = rhier()
        .arg("flatland")
        .arg(example("flatland_room.json"))
        .arg("--out")
        .arg(dir.path().join("r.json"))
        .args(["--mesh", "uniform:1000"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("flatland_room.json") && err.contains("10000"),
        "{err}"
    );
    let o = rhier()
        .arg("flatland")
        .arg(&scene)
        .args(["--out", "r.json", "--mesh", "fine"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn crossing_at_a_solve_time_between_keys_exits_1() {
    // The bar passes through the wall between its two (valid) keyframes.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("through.json");
    std::fs::write(
        &scene,
        r#"{"rhier_flatland": 1, "objects": [
          {"name": "wall", "segments": [{"a": [0, 0], "b": [0, 2]}]},
          {"name": "bar", "segments": [{"a": [-2, 1], "b": [-1, 1]}],
           "motion": [{"t": 0, "translation": [0, 0]}, {"t": 1, "translation": [3, 0]}]}]}"#,
    )
    .unwrap();
    let o = rhier()
        .arg("flatland")
        .arg(&scene)
        .arg("--out")
        .arg(dir.path().join("r.json"))
        .args(["--times", "0,0.5,1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("through.json") && err.contains("t = 0.5"),
        "{err}"
    );
    assert!(err.contains("object \"wall\", segment 0") && err.contains("object \"bar\""));
}
