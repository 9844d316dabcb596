//! One test per validation rule of `formats/scene.md`: each asserts that the error
//! names the file, the place (object and polygon, material, motion key, line), what
//! was expected and what was found; and that repairs (zero-area polygons, white 1.0
//! in glTF/OBJ) and the no-emitter case give the documented warnings.

use std::path::{Path, PathBuf};

use glam::DVec3;
use rhier::Error;
use rhier::scene::{
    self, Material, MaterialId, Object, Polygon, Scene, validate::NO_EMITTER_WARNING,
};

/// Asserts `err` is an `Error::Invalid` on `file` whose place, expected and found
/// contain the given fragments.
fn assert_invalid(err: Error, file: &str, place: &str, expected: &str, found: &str) {
    let text = err.to_string();
    match err {
        Error::Invalid {
            path,
            place: p,
            expected: e,
            found: f,
        } => {
            // OBJ messages name the line: `t.obj:12`.
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            let name = name.unwrap_or_default();
            assert!(
                name == file || name.starts_with(&format!("{file}:")),
                "path {path:?} in: {text}"
            );
            assert!(p.contains(place), "place {p:?} lacks {place:?} in: {text}");
            assert!(
                e.contains(expected),
                "expected {e:?} lacks {expected:?} in: {text}"
            );
            assert!(f.contains(found), "found {f:?} lacks {found:?} in: {text}");
        }
        other => panic!("not Invalid: {other}"),
    }
}

/// A native scene with one emitting material "m" (reflectance `rho`) and one object
/// "obj" holding the given polygons (vertex lists) and optional motion JSON.
fn native(rho: &str, emission: &str, polygons: &[&str], motion: Option<&str>) -> String {
    let polys: Vec<String> = polygons
        .iter()
        .map(|v| format!(r#"{{"vertices": {v}, "material": "m"}}"#))
        .collect();
    let motion = motion.map_or(String::new(), |m| format!(r#", "motion": {m}"#));
    format!(
        r#"{{"rhier_scene": 1,
 "materials": {{"m": {{"reflectance": {rho}, "emission": {emission}}}}},
 "objects": [{{"name": "obj", "polygons": [{}]{motion}}}]}}"#,
        polys.join(", ")
    )
}

const TRI: &str = "[[0,0,0],[1,0,0],[0,1,0]]";
const QUAD: &str = "[[0,0,0],[1,0,0],[1,1,0],[0,1,0]]";

fn load_native(text: &str) -> rhier::Result<Scene> {
    scene::load_json_str(text, Path::new("scenes/bad.json"))
}

#[test]
fn valid_native_baseline_loads() {
    let s = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI, QUAD], None)).unwrap();
    assert_eq!(s.polygon_count(), 2);
    assert!(s.warnings.is_empty());
}

#[test]
fn wrong_json_type_reports_line_and_column() {
    let text = "{\"rhier_scene\": 1,\n \"objects\": [{\"name\": \"a\", \"polygons\": \"none\"}]}";
    let err = load_native(text).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "line 2 column",
        "native rhier scene",
        "invalid type",
    );
}

#[test]
fn missing_or_wrong_version_is_refused() {
    let err = load_native(r#"{"objects": []}"#).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "top level",
        "\"rhier_scene\": 1",
        "no \"rhier_scene\"",
    );
    let err = load_native(r#"{"rhier_scene": 7}"#).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "rhier_scene",
        "format version 1",
        "version 7",
    );
}

#[test]
fn unknown_material_names_object_polygon_and_name() {
    let text = native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], None).replace(
        r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "material": "m"}"#,
        r#"{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "material": "m"}, {"vertices": [[0,0,0],[1,0,0],[0,1,0]], "material": "blue"}"#,
    );
    let err = load_native(&text).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", polygon 1",
        "a material defined in \"materials\" (defined: m)",
        "material \"blue\"",
    );
}

#[test]
fn vertex_count_other_than_3_or_4_is_refused() {
    let penta = "[[0,0,0],[1,0,0],[1,1,0],[0.5,1.5,0],[0,1,0]]";
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI, penta], None)).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", polygon 1",
        "3 or 4 vertices",
        "5 vertices",
    );
    let err = load_native(&native(
        "[0.5,0.5,0.5]",
        "[1,1,1]",
        &["[[0,0,0],[1,0,0]]"],
        None,
    ))
    .unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "polygon 0",
        "3 or 4 vertices",
        "2 vertices",
    );
}

#[test]
fn non_planar_quad_is_refused_beyond_tolerance() {
    // Diameter sqrt(2); a corner lifted by 0.01 puts every vertex 0.0025 off the mean
    // plane, 1.8e-3 of the diameter > 1e-4.
    let bent = "[[0,0,0],[1,0,0],[1,1,0.01],[0,1,0]]";
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI, bent], None)).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", polygon 1",
        "a planar quad (every vertex within 0.0001 x diameter",
        "off the plane",
    );
    // Within tolerance (1e-5 lift: 1.8e-6 of the diameter): accepted.
    let slight = "[[0,0,0],[1,0,0],[1,1,0.00001],[0,1,0]]";
    if let Err(e) = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[slight], None)) {
        panic!("a quad within tolerance is refused: {e}");
    }
}

#[test]
fn concave_quad_is_refused() {
    let dart = "[[0,0,0],[2,0,0],[0.5,0.5,0],[0,2,0]]";
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[dart], None)).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "polygon 0",
        "a convex quad",
        "reflex corner at vertex 2",
    );
}

#[test]
fn native_reflectance_outside_0_1_is_refused() {
    for (rho, found) in [
        ("[1.0,0.5,0.5]", "[1, 0.5, 0.5]"),
        ("[0.5,-0.1,0.5]", "[0.5, -0.1, 0.5]"),
        ("[0.5,0.5,2]", "[0.5, 0.5, 2]"),
    ] {
        let err = load_native(&native(rho, "[1,1,1]", &[TRI], None)).unwrap_err();
        assert_invalid(
            err,
            "bad.json",
            "material \"m\"",
            "reflectance in [0, 1) per channel",
            found,
        );
    }
}

#[test]
fn emission_whose_radiosity_overflows_32_bit_floats_is_refused() {
    // 1e33 / (1 - 0.5) fits under 1e36; with a reflectance of 0.9999 it would not.
    if let Err(e) = load_native(&native("[0.5,0.5,0.5]", "[1e33,0,0]", &[TRI], None)) {
        panic!("an emission whose radiosity fits is refused: {e}");
    }
    let err = load_native(&native("[0.5,0.9999,0.5]", "[1e33,0,0]", &[TRI], None)).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "material \"m\"",
        "emission / (1 - largest reflectance, 0.9999) <= 1e36",
        "[1e33, 0, 0]",
    );
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1e39,1]", &[TRI], None)).unwrap_err();
    assert_invalid(err, "bad.json", "material \"m\"", "32-bit floats", "1e39");
}

#[test]
fn vanishing_emission_loads_with_a_warning() {
    let s = load_native(&native("[0.5,0.5,0.5]", "[1e-42,0,0]", &[TRI], None)).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("largest emission") && w.contains("is below 1e-30")),
        "{:?}",
        s.warnings
    );
    let s = load_native(&native("[0.5,0.5,0.5]", "[1e-20,0,0]", &[TRI], None)).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn repeated_polygons_are_dropped_with_a_warning() {
    // The same quad twice, the second from another corner (same cycle, same facing),
    // then reversed (a thin panel's back face, kept).
    let again = "[[1,1,0],[0,1,0],[0,0,0],[1,0,0]]";
    let back = "[[0,0,0],[0,1,0],[1,1,0],[1,0,0]]";
    let s = load_native(&native(
        "[0.5,0.5,0.5]",
        "[1,1,1]",
        &[QUAD, again, back],
        None,
    ))
    .unwrap();
    assert_eq!(s.objects[0].polygons.len(), 2);
    assert_eq!(
        s.objects[0].polygons[1].vertices[1],
        DVec3::new(0.0, 1.0, 0.0)
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("dropped 1 polygon(s) repeating")
                && w.contains("object \"obj\" polygon 1")),
        "{:?}",
        s.warnings
    );
}

/// The solve's side: the Cornell box with its floor given twice solves as the box
/// (the copy came out 22–73% too bright off the floor before it was dropped).
#[test]
fn a_repeated_floor_does_not_double_its_light() {
    let mut twice = scene::cornell_box(false);
    let floor = twice.objects[0].polygons[0].clone();
    twice
        .objects
        .push(Object::still("floor again", vec![floor]));
    let twice = rhier::scene::validate::validate(twice, Path::new("twice.json")).unwrap();
    assert_eq!(twice, {
        let mut once = scene::cornell_box(false);
        once.warnings = twice.warnings.clone();
        once
    });
}

#[test]
fn negative_emission_is_refused() {
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,-2,1]", &[TRI], None)).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "material \"m\"",
        "finite emission >= 0",
        "[1, -2, 1]",
    );
}

#[test]
fn unsorted_motion_keys_are_refused() {
    let motion = r#"[{"t": 0.0}, {"t": 2.0}, {"t": 1.0}]"#;
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], Some(motion))).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", motion key 2",
        "t greater than the previous key's t = 2",
        "t = 1",
    );
    // Equal times are not strictly increasing either.
    let motion = r#"[{"t": 0.0}, {"t": 0.0}]"#;
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], Some(motion))).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "motion key 1",
        "strictly increasing",
        "t = 0",
    );
}

#[test]
fn non_unit_quaternion_is_refused() {
    let motion = r#"[{"t": 0.0, "rotation": [0, 0, 0, 1.01]}]"#;
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], Some(motion))).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", motion key 0",
        "unit rotation quaternion (length 1 +- 0.001)",
        "of length 1.01",
    );
}

#[test]
fn zero_scale_and_empty_track_are_refused() {
    let motion = r#"[{"t": 0.0, "scale": [1, 0, 1]}]"#;
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], Some(motion))).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "motion key 0",
        "non-zero scale",
        "[1, 0, 1]",
    );
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], Some("[]"))).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", motion",
        "at least one motion key",
        "empty",
    );
}

#[test]
fn bad_time_domain_is_refused() {
    let text = native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI], None).replace(
        "\"rhier_scene\": 1,",
        "\"rhier_scene\": 1, \"time\": {\"start\": 2, \"end\": 1},",
    );
    let err = load_native(&text).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "time",
        "end >= start",
        "start = 2, end = 1",
    );
}

#[test]
fn zero_area_polygons_are_dropped_and_counted() {
    let sliver = "[[0,0,0],[1,0,0],[2,0,0]]";
    let point = "[[5,5,5],[5,5,5],[5,5,5],[5,5,5]]";
    let s = load_native(&native(
        "[0.5,0.5,0.5]",
        "[1,1,1]",
        &[sliver, TRI, point],
        None,
    ))
    .unwrap();
    assert_eq!(s.polygon_count(), 1);
    assert_eq!(s.objects[0].polygons[0].vertices[2], DVec3::Y);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].starts_with("dropped 2 zero-area polygon(s)")
            && s.warnings[0].contains("object \"obj\" polygon 0")
            && s.warnings[0].contains("object \"obj\" polygon 2"),
        "{}",
        s.warnings[0]
    );
}

#[test]
fn scene_without_emitter_warns() {
    let s = load_native(&native("[0.5,0.5,0.5]", "[0,0,0]", &[TRI], None)).unwrap();
    assert_eq!(s.warnings, vec![NO_EMITTER_WARNING.to_string()]);
    assert_eq!(
        NO_EMITTER_WARNING,
        "scene has no emitter: the solution is zero"
    );
}

#[test]
fn nan_and_inf_in_a_built_scene_are_refused() {
    for bad in [f64::NAN, f64::INFINITY] {
        let s = Scene {
            materials: vec![Material {
                name: "m".into(),
                rho: [0.5; 3],
                emission: [1.0; 3],
            }],
            objects: vec![Object::still(
                "o",
                vec![Polygon {
                    vertices: vec![DVec3::ZERO, DVec3::X, DVec3::new(0.0, bad, 0.0)],
                    material: MaterialId(0),
                }],
            )],
            ..Scene::default()
        };
        let err = scene::validate::validate(s, Path::new("built")).unwrap_err();
        assert_invalid(
            err,
            "built",
            "object \"o\", polygon 0",
            "finite vertex coordinates",
            &format!("vertex 2 = [0, {bad}, 0]"),
        );
    }
}

#[test]
fn material_index_out_of_range_is_refused() {
    let s = Scene {
        objects: vec![Object::still(
            "o",
            vec![Polygon {
                vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
                material: MaterialId(3),
            }],
        )],
        ..Scene::default()
    };
    let err = scene::validate::validate(s, Path::new("built")).unwrap_err();
    assert_invalid(
        err,
        "built",
        "polygon 0",
        "a material index < 0",
        "material index 3",
    );
}

// ---- OBJ ----

fn write_obj(dir: &Path, obj: &str, mtl: &str) -> PathBuf {
    std::fs::write(dir.join("t.mtl"), mtl).unwrap();
    let path = dir.join("t.obj");
    std::fs::write(&path, format!("mtllib t.mtl\n{obj}")).unwrap();
    path
}

const OBJ_VERTS: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn obj_nan_vertex_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv nan 1 0\no thing\nusemtl m\nf 1 2 3\n";
    let path = write_obj(dir.path(), obj, "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    let err = scene::load(&path).unwrap_err();
    assert_invalid(
        err,
        "t.obj",
        "object \"thing\", polygon 0",
        "finite vertex",
        "vertex 2 = [NaN, 1, 0]",
    );
    let obj = "v 0 0 0\nv 1 0 0\nv inf 1 0\no thing\nusemtl m\nf 1 2 3\n";
    let path = write_obj(dir.path(), obj, "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    let err = scene::load(&path).unwrap_err();
    assert_invalid(err, "t.obj", "polygon 0", "finite vertex", "[inf, 1, 0]");
}

#[test]
fn obj_unknown_usemtl_is_refused_with_line() {
    let dir = tempfile::tempdir().unwrap();
    let obj = format!("{OBJ_VERTS}o a\nusemtl m\nf 1 2 3\nf 1 3 4\nusemtl nosuch\nf 1 2 4\n");
    let path = write_obj(dir.path(), &obj, "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    let err = scene::load(&path).unwrap_err();
    assert_invalid(
        err,
        "t.obj",
        "object \"a\", polygon 2 (line 10)",
        "defined: m",
        "usemtl \"nosuch\"",
    );
}

#[test]
fn obj_reflectance_above_one_and_nan_emission_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let obj = format!("{OBJ_VERTS}o a\nusemtl m\nf 1 2 3\n");
    let path = write_obj(dir.path(), &obj, "newmtl m\nKd 0.5 1.5 0.5\n");
    let err = scene::load(&path).unwrap_err();
    assert_invalid(err, "t.obj", "material \"m\"", "[0, 1)", "[0.5, 1.5, 0.5]");
    let path = write_obj(dir.path(), &obj, "newmtl m\nKd 0.5 0.5 0.5\nKe 1 nan 1\n");
    let err = scene::load(&path).unwrap_err();
    assert_invalid(
        err,
        "t.obj",
        "material \"m\"",
        "finite emission >= 0",
        "[1, NaN, 1]",
    );
}

#[test]
fn obj_concave_and_convex_ngons_are_triangulated() {
    let dir = tempfile::tempdir().unwrap();
    // A pentagon with a notch (vertex 4 pushed inward): area 4 - 1.5 = 2.5.
    let obj = "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\no star\nusemtl m\nf 1 2 3 4 5\n";
    let path = write_obj(dir.path(), obj, "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    let s = scene::load(&path).unwrap();
    assert_eq!(s.objects[0].polygons.len(), 3);
    let area: f64 = s.objects[0].polygons.iter().map(Polygon::area).sum();
    assert!((area - 2.5).abs() < 1e-12, "{area}");
    assert!(s.objects[0].polygons.iter().all(|p| p.normal().z > 0.99));
    let obj = "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 3 0\nv 0 2 0\no house\nusemtl m\nf 1 2 3 4 5\n";
    let path = write_obj(dir.path(), obj, "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
    let s = scene::load(&path).unwrap();
    assert_eq!(s.objects[0].polygons.len(), 3);
    let area: f64 = s.objects[0].polygons.iter().map(Polygon::area).sum();
    assert!((area - 5.0).abs() < 1e-12);
}

#[test]
fn obj_missing_mtl_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.obj");
    std::fs::write(&path, format!("mtllib gone.mtl\n{OBJ_VERTS}f 1 2 3\n")).unwrap();
    let err = scene::load(&path).unwrap_err();
    assert_invalid(err, "t.obj", "mtllib", "readable MTL", "gone.mtl");
}

// ---- glTF ----

fn sample_gltf() -> serde_json::Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("formats/examples/moving_cube.gltf");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn load_gltf(v: &serde_json::Value) -> rhier::Result<Scene> {
    scene::load_gltf_slice(&serde_json::to_vec(v).unwrap(), None, Path::new("bad.gltf"))
}

#[test]
fn gltf_non_triangle_primitive_is_refused() {
    let mut v = sample_gltf();
    v["meshes"][2]["primitives"][0]["mode"] = 1.into(); // LINES
    let err = load_gltf(&v).unwrap_err();
    assert_invalid(
        err,
        "bad.gltf",
        "mesh \"cube\", primitive 0",
        "mode TRIANGLES",
        "Lines",
    );
}

#[test]
fn gltf_reflectance_above_one_is_refused_exact_one_clamped() {
    let mut v = sample_gltf();
    v["materials"][2]["pbrMetallicRoughness"]["baseColorFactor"] =
        serde_json::json!([1.5, 0.1, 0.1, 1.0]);
    let err = load_gltf(&v).unwrap_err();
    assert_invalid(err, "bad.gltf", "material \"red\"", "[0, 1)", "[1.5, ");
    // Exactly 1.0 in one channel: clamped, warned, other channels untouched.
    v["materials"][2]["pbrMetallicRoughness"]["baseColorFactor"] =
        serde_json::json!([1.0, 0.5, 0.25, 1.0]);
    let s = load_gltf(&v).unwrap();
    let red = s.materials.iter().find(|m| m.name == "red").unwrap();
    assert_eq!(red.rho, [0.999, 0.5, 0.25]);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("material \"red\": reflectance 1.0 clamped"))
    );
}

#[test]
fn gltf_negative_emission_is_refused() {
    let mut v = sample_gltf();
    v["materials"][1]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] =
        (-1.0).into();
    let err = load_gltf(&v).unwrap_err();
    // E = pi * [1, 0.9, 0.8] * (-1).
    assert_invalid(
        err,
        "bad.gltf",
        "material \"lamp\"",
        "finite emission >= 0 per channel",
        "[-3.14159",
    );
}

#[test]
fn gltf_animation_count_mismatch_is_refused() {
    let mut v = sample_gltf();
    // Swap the rotation sampler's input to the 3-key accessor with 2 outputs: count
    // mismatch.
    v["animations"][0]["samplers"][1]["input"] = v["animations"][0]["samplers"][0]["input"].clone();
    let err = load_gltf(&v).unwrap_err();
    assert_invalid(
        err,
        "bad.gltf",
        "animation 0, channel 1",
        "1 output value(s) per input time",
        "3 inputs, 2 outputs",
    );
}

#[test]
fn gltf_accessor_outside_its_buffer_is_refused_not_panicking() {
    let mut v = sample_gltf();
    let acc = v["meshes"][2]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    v["accessors"][acc]["count"] = 100000.into();
    let err = load_gltf(&v).unwrap_err();
    assert_invalid(
        err,
        "bad.gltf",
        &format!("accessor {acc}"),
        "inside buffer view",
        "does not fit",
    );
    // Wrong type for POSITION.
    let mut v = sample_gltf();
    v["accessors"][acc]["type"] = "VEC2".into();
    let err = load_gltf(&v).unwrap_err();
    assert!(err.to_string().starts_with("bad.gltf: "), "{err}");
}

#[test]
fn gltf_garbage_is_refused() {
    let err = scene::load_gltf_slice(b"not gltf", None, Path::new("x.glb")).unwrap_err();
    assert_invalid(err, "x.glb", "glTF document", "a valid glTF 2.0 file", "");
    let err = scene::load_gltf_slice(b"glTF\x02\0\0\0\x10\0\0\0garbage", None, Path::new("x.glb"))
        .unwrap_err();
    assert_invalid(err, "x.glb", "glTF document", "a valid glTF 2.0 file", "");
}

#[test]
fn gltf_unsorted_animation_input_is_refused() {
    // The external-buffer sample copied to a temp dir, with the mover's key times
    // [0, 1, 2] rewritten as [0, 2, 1] in the .bin file.
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("formats/examples");
    let text = std::fs::read_to_string(examples.join("moving_cube_external.gltf")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let acc =
        &v["accessors"][v["animations"][0]["samplers"][0]["input"].as_u64().unwrap() as usize];
    let view = &v["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let offset = view["byteOffset"].as_u64().unwrap() as usize;
    let mut bin = std::fs::read(examples.join("moving_cube.bin")).unwrap();
    assert_eq!(
        bin[offset + 4..offset + 12],
        [1f32.to_le_bytes(), 2f32.to_le_bytes()].concat()
    );
    bin[offset + 4..offset + 12]
        .copy_from_slice(&[2f32.to_le_bytes(), 1f32.to_le_bytes()].concat());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("moving_cube.bin"), bin).unwrap();
    let path = dir.path().join("unsorted.gltf");
    std::fs::write(&path, text).unwrap();
    let err = scene::load(&path).unwrap_err();
    assert_invalid(
        err,
        "unsorted.gltf",
        "animation 0, channel 0, key 2",
        "strictly increasing",
        "t = 1 after t = 2",
    );
}

#[test]
fn huge_coordinates_are_refused() {
    let huge = "[[0,0,0],[1e200,0,0],[0,1,0]]";
    let err = load_native(&native("[0.5,0.5,0.5]", "[1,1,1]", &[TRI, huge], None)).unwrap_err();
    assert_invalid(
        err,
        "bad.json",
        "object \"obj\", polygon 1",
        "magnitude <= 1e100",
        "vertex 1 = [1e200, 0, 0]",
    );
}

#[test]
fn gltf_node_cycle_and_missing_scene_are_refused() {
    let mut v = sample_gltf();
    v["nodes"][3]["children"] = serde_json::json!([2]); // cube -> mover -> cube
    let err = load_gltf(&v).unwrap_err();
    assert_invalid(
        err,
        "bad.gltf",
        "node 2",
        "a node tree",
        "two parents or a cycle",
    );
    let mut v = sample_gltf();
    v.as_object_mut().unwrap().remove("scene");
    v["scenes"] = serde_json::json!([]);
    let err = load_gltf(&v).unwrap_err();
    assert_invalid(err, "bad.gltf", "glTF document", "a scene", "no scene");
}

#[test]
fn gltf_missing_texture_is_warned_and_the_factor_kept() {
    let mut v = sample_gltf();
    v["images"] = serde_json::json!([{"uri": "missing.png"}]);
    v["textures"] = serde_json::json!([{"source": 0}]);
    v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = serde_json::json!({"index": 0});
    let s = load_gltf(&v).unwrap();
    let before = load_gltf(&sample_gltf()).unwrap();
    assert_eq!(s.materials[0].rho, before.materials[0].rho);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("material \"white\": baseColorTexture missing.png not read (")),
        "{:?}",
        s.warnings
    );
}
