//! Scene loaders on every format: native JSON (the issue's minimum file, motion,
//! round trip), the embedded Cornell box and its committed JSON copies, the animated
//! glTF sample (.gltf embedded, .gltf + external .bin, .glb) and the OBJ + MTL sample.
//!
//! Expected values come from the sample files' definitions (see
//! `tools/make_moving_cube_gltf.py`, `formats/examples/room.obj`) and from the
//! published Cornell box data, not from the loaders' output.
//!
//! `RHIER_REGENERATE_EXAMPLES=1 cargo test --release --test it scene::loaders`
//! rewrites `formats/examples/cornell*.json` from the embedded scene.

use std::f64::consts::{FRAC_PI_4, PI};
use std::path::Path;

use glam::{DAffine3, DQuat, DVec3};
use rhier::scene::{
    self, Camera, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, cornell_box,
    validate::NO_EMITTER_WARNING,
};

use crate::common::example;

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).abs().max_element() <= tol
}

fn material<'a>(s: &'a Scene, name: &str) -> &'a scene::Material {
    s.materials
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name} in {:?}", s.materials))
}

fn object<'a>(s: &'a Scene, name: &str) -> &'a Object {
    s.objects
        .iter()
        .find(|o| o.name == name)
        .unwrap_or_else(|| panic!("no object {name}"))
}

#[test]
fn minimal_native_json_from_the_issue_loads_as_written() {
    let path = example("minimal.json");
    let s = scene::load(&path).unwrap();
    assert_eq!((s.time.start, s.time.end), (0.0, 3.0));
    // Materials come back sorted by name.
    assert_eq!(s.materials.len(), 2);
    assert_eq!(s.materials[0].name, "lamp");
    assert_eq!(s.materials[0].rho, [0.78, 0.78, 0.78]);
    assert_eq!(s.materials[0].emission, [17.0, 12.0, 4.0]);
    assert_eq!(s.materials[1].name, "white");
    assert_eq!(s.materials[1].rho, [0.73, 0.71, 0.68]);
    assert_eq!(s.materials[1].emission, [0.0; 3]);
    assert_eq!(s.objects.len(), 1);
    let room = &s.objects[0];
    assert_eq!(room.name, "room");
    assert_eq!(room.polygons.len(), 1);
    assert_eq!(room.polygons[0].material, MaterialId(1));
    assert_eq!(
        room.polygons[0].vertices,
        vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 0.0, 1.0), DVec3::Z]
    );
    assert_eq!(
        room.motion.as_ref().unwrap().keys,
        vec![MotionKey::identity(0.0)]
    );
    // The lamp material exists but no polygon uses it.
    assert_eq!(s.warnings, vec![NO_EMITTER_WARNING.to_string()]);
    // Same text through load_json_str.
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(scene::load_json_str(&text, &path).unwrap(), s);
}

const MOVING: &str = r#"{"rhier_scene": 1,
 "future_key": {"ignored": true},
 "camera": {"eye": [0, 1, 5], "target": [0, 1, 0], "fov_y_degrees": 45},
 "materials": {"lamp": {"reflectance": [0.5, 0.5, 0.5], "emission": [1, 2, 3]}},
 "objects": [
  {"name": "floor", "polygons": [{"vertices": [[0,0,0],[0,0,1],[1,0,0]], "material": "lamp"}]},
  {"name": "spinner",
   "polygons": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "material": "lamp"}],
   "motion": [{"t": 1.0},
              {"t": 3.0, "translation": [2, 0, 0], "rotation": [0, 0, 0.7071067811865476, 0.7071067811865476], "scale": [2, 2, 2]}]}]}"#;

#[test]
fn native_motion_defaults_and_interpolation() {
    let s = scene::load_json_str(MOVING, Path::new("moving.json")).unwrap();
    // No "time": the domain spans the motion keys.
    assert_eq!((s.time.start, s.time.end), (1.0, 3.0));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let cam = s.camera.unwrap();
    assert_eq!(cam.up, DVec3::Y);
    assert!((cam.fov_y - FRAC_PI_4).abs() < 1e-15);
    let floor = object(&s, "floor");
    assert!(floor.motion.is_none());
    assert_eq!(floor.to_world(2.0), DAffine3::IDENTITY);
    let spinner = object(&s, "spinner");
    assert!(spinner.is_moving());
    // Halfway: translation (1,0,0), rotation 45 degrees about z, scale 1.5.
    let m = spinner.to_world(2.0);
    let expected = DAffine3::from_scale_rotation_translation(
        DVec3::splat(1.5),
        DQuat::from_rotation_z(FRAC_PI_4),
        DVec3::X,
    );
    for p in [DVec3::X, DVec3::Y, DVec3::new(1.0, 2.0, 3.0)] {
        assert!(close(
            m.transform_point3(p),
            expected.transform_point3(p),
            1e-12
        ));
    }
    // Held before the first key and after the last.
    assert_eq!(spinner.to_world(0.0), DAffine3::IDENTITY);
    assert!(close(
        spinner.to_world(9.0).transform_point3(DVec3::X),
        DVec3::new(2.0, 2.0, 0.0),
        1e-12
    ));
}

#[test]
fn native_json_round_trips_through_the_writer() {
    let s = scene::load_json_str(MOVING, Path::new("moving.json")).unwrap();
    let text = scene::to_json_string(&s);
    let back = scene::load_json_str(&text, Path::new("written.json")).unwrap();
    assert_eq!(back.objects, s.objects);
    assert_eq!(back.materials, s.materials);
    assert_eq!(back.time, s.time);
    let (a, b) = (back.camera.unwrap(), s.camera.unwrap());
    assert_eq!((a.eye, a.target, a.up), (b.eye, b.target, b.up));
    assert!((a.fov_y - b.fov_y).abs() < 1e-15);
}

/// Box centre of the published room (x 0..556, y 0..548.8, z 0..559.2).
const ROOM_CENTRE: DVec3 = DVec3::new(278.0, 274.4, 279.6);

#[test]
fn cornell_box_is_the_published_geometry_lit_from_inside() {
    for blocks in [false, true] {
        let s = cornell_box(blocks);
        assert_eq!(s.polygon_count(), if blocks { 20 } else { 10 });
        assert!(s.has_emitter() && !s.has_motion());
        // Validation accepts it unchanged, without warnings.
        let v = scene::validate::validate(s.clone(), Path::new("<cornell>")).unwrap();
        assert_eq!(v, s);
        for o in &s.objects {
            let block = o.name.ends_with("_block");
            let centre = if block {
                // The block's own centre: mean of its vertices.
                let all: Vec<DVec3> = o.polygons.iter().flat_map(|p| p.vertices.clone()).collect();
                all.iter().sum::<DVec3>() / all.len() as f64
            } else {
                ROOM_CENTRE
            };
            for (i, p) in o.polygons.iter().enumerate() {
                let towards_centre = p.normal().dot(centre - p.centroid());
                if block {
                    assert!(towards_centre < 0.0, "{} polygon {i} faces inward", o.name);
                } else {
                    assert!(towards_centre > 0.0, "{} polygon {i} faces away", o.name);
                }
            }
        }
        // The ceiling frame plus the light tile the published ceiling exactly.
        let ceiling: f64 = object(&s, "ceiling")
            .polygons
            .iter()
            .map(Polygon::area)
            .sum();
        let light = &object(&s, "light").polygons[0];
        assert!((ceiling + light.area() - 556.0 * 559.2).abs() < 1e-6);
        assert!((light.area() - 130.0 * 105.0).abs() < 1e-9);
        assert_eq!(light.normal(), DVec3::NEG_Y);
        assert!(light.vertices.iter().all(|v| v.y == 548.8));
        let lamp = &s.materials[light.material.0 as usize];
        assert_eq!(lamp.emission, [17.0, 12.0, 4.0]);
        assert_eq!(lamp.rho, [0.78; 3]);
        assert_eq!(material(&s, "white").rho, [0.73, 0.71, 0.68]);
        assert_eq!(material(&s, "red").rho, [0.63, 0.065, 0.05]);
        assert_eq!(material(&s, "green").rho, [0.14, 0.45, 0.091]);
        // Red on the left (x ~ 556), green on the right (x = 0) seen from the camera.
        let red = material_id(&s, "red");
        let green = material_id(&s, "green");
        assert!(
            object(&s, "left_wall")
                .polygons
                .iter()
                .all(|p| p.material == red)
        );
        assert!(
            object(&s, "right_wall")
                .polygons
                .iter()
                .all(|p| p.material == green)
        );
        let Camera {
            eye,
            target,
            up,
            fov_y,
        } = s.camera.unwrap();
        assert_eq!(
            (eye, target, up),
            (
                DVec3::new(278.0, 273.0, -800.0),
                DVec3::new(278.0, 273.0, 0.0),
                DVec3::Y
            )
        );
        assert!((fov_y.to_degrees() - 39.3077).abs() < 1e-3);
    }
}

fn material_id(s: &Scene, name: &str) -> MaterialId {
    MaterialId(s.materials.iter().position(|m| m.name == name).unwrap() as u32)
}

#[test]
fn cornell_examples_equal_the_embedded_scenes() {
    for (file, blocks) in [("cornell.json", false), ("cornell_blocks.json", true)] {
        let path = example(file);
        let embedded = cornell_box(blocks);
        if std::env::var_os("RHIER_REGENERATE_EXAMPLES").is_some() {
            std::fs::write(&path, scene::to_json_string(&embedded)).unwrap();
        }
        let loaded = scene::load(&path).unwrap();
        assert_eq!(loaded.objects, embedded.objects, "{file}");
        assert_eq!(loaded.materials, embedded.materials, "{file}");
        assert_eq!(loaded.time, embedded.time, "{file}");
        assert!(loaded.warnings.is_empty(), "{file}: {:?}", loaded.warnings);
        // The file holds the field of view in degrees: radians -> degrees -> radians
        // may differ by one ulp, everything else is exact.
        let (a, b) = (loaded.camera.unwrap(), embedded.camera.unwrap());
        assert_eq!((a.eye, a.target, a.up), (b.eye, b.target, b.up));
        assert!((a.fov_y - b.fov_y).abs() <= 2.0 * f64::EPSILON * b.fov_y);
    }
}

/// The Cornell box with blocks whose short block slides 60 mm towards the green wall
/// (-x) over 2 s: `formats/examples/cornell_moving.json`.
fn cornell_moving() -> Scene {
    let mut s = cornell_box(true);
    s.time = scene::TimeDomain {
        start: 0.0,
        end: 2.0,
    };
    let short = s
        .objects
        .iter_mut()
        .find(|o| o.name == "short_block")
        .unwrap();
    short.motion = Some(MotionTrack {
        keys: vec![
            MotionKey::identity(0.0),
            MotionKey {
                translation: DVec3::new(-60.0, 0.0, 0.0),
                ..MotionKey::identity(2.0)
            },
        ],
    });
    s
}

#[test]
fn moving_cornell_example_loads_with_its_motion() {
    let path = example("cornell_moving.json");
    let expected = cornell_moving();
    if std::env::var_os("RHIER_REGENERATE_EXAMPLES").is_some() {
        std::fs::write(&path, scene::to_json_string(&expected)).unwrap();
    }
    let s = scene::load(&path).unwrap();
    assert_eq!(s.objects, expected.objects);
    assert_eq!((s.time.start, s.time.end), (0.0, 2.0));
    assert!(s.has_motion() && s.warnings.is_empty());
    let short = object(&s, "short_block");
    assert_eq!(
        short
            .to_world(1.0)
            .transform_point3(DVec3::new(130.0, 0.0, 65.0)),
        DVec3::new(100.0, 0.0, 65.0)
    );
    // Slides clear of the room and of the tall block: x stays in [22, 290].
    let xs = short.polygons.iter().flat_map(|p| &p.vertices).map(|v| v.x);
    let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    assert_eq!((lo - 60.0, hi), (22.0, 290.0));
}

/// World transform of the sample's cube at `t`, from the sample's definition:
/// mover translation (LINEAR through (-1,.5,0), (0,.5,.5), (1,.5,0) at t = 0, 1, 2),
/// cube rotation about +y at 45 degrees per second, cube scale 0.5.
fn expected_cube(t: f64) -> DAffine3 {
    let (a, b, s) = if t <= 1.0 {
        (DVec3::new(-1.0, 0.5, 0.0), DVec3::new(0.0, 0.5, 0.5), t)
    } else {
        (
            DVec3::new(0.0, 0.5, 0.5),
            DVec3::new(1.0, 0.5, 0.0),
            t - 1.0,
        )
    };
    DAffine3::from_translation(a.lerp(b, s))
        * DAffine3::from_rotation_y(FRAC_PI_4 * t)
        * DAffine3::from_scale(DVec3::splat(0.5))
}

fn check_moving_cube(s: &Scene) {
    assert_eq!((s.time.start, s.time.end), (0.0, 2.0));
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["room", "lamp", "cube"]);
    // Room: 6 quads written as 12 triangles, merged back; static, node translation
    // baked in.
    let room = object(s, "room");
    assert_eq!(room.polygons.len(), 6);
    assert!(room.polygons.iter().all(|p| p.vertices.len() == 4));
    assert!(room.motion.is_none());
    let xs = room
        .polygons
        .iter()
        .flat_map(|p| p.vertices.iter().map(|v| v.x));
    let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    assert_eq!((lo, hi), (-2.0, 2.0));
    let room_centre = DVec3::new(0.0, 1.5, 0.0);
    for p in &room.polygons {
        assert!(p.normal().dot(room_centre - p.centroid()) > 0.0);
    }
    // Lamp: white 1.0 clamped, E = pi * emissiveFactor * strength 5, facing down.
    let lamp_obj = object(s, "lamp");
    assert_eq!(lamp_obj.polygons.len(), 1);
    assert!((lamp_obj.polygons[0].area() - 1.0).abs() < 1e-12);
    assert!(
        lamp_obj
            .polygons
            .iter()
            .all(|p| close(p.normal(), DVec3::NEG_Y, 1e-12))
    );
    let lamp = material(s, "lamp");
    assert_eq!(lamp.rho, [0.999; 3]);
    for (e, l) in lamp.emission.iter().zip([1.0, 0.9, 0.8]) {
        assert!((e - PI * 5.0 * l).abs() < 1e-6, "{:?}", lamp.emission);
    }
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("material \"lamp\"") && w.contains("clamped to 0.999")),
        "{:?}",
        s.warnings
    );
    assert!((material(s, "red").rho[0] - 0.7).abs() < 1e-6);
    // Cube: mesh space kept (half-size 1), keys at the union {0, 1, 2}.
    let cube = object(s, "cube");
    assert_eq!(cube.polygons.len(), 6);
    let area: f64 = cube.polygons.iter().map(Polygon::area).sum();
    assert!((area - 24.0).abs() < 1e-12);
    let track: &MotionTrack = cube.motion.as_ref().unwrap();
    let times: Vec<f64> = track.keys.iter().map(|k| k.t).collect();
    assert_eq!(times, [0.0, 1.0, 2.0]);
    for t in [0.0, 0.25, 0.5, 1.0, 1.5, 1.75, 2.0, 3.0] {
        let got = cube.to_world(t);
        let want = expected_cube(t.min(2.0));
        for p in [
            DVec3::ONE,
            DVec3::new(1.0, -1.0, 1.0),
            DVec3::new(-1.0, 1.0, -1.0),
        ] {
            let (g, w) = (got.transform_point3(p), want.transform_point3(p));
            assert!(close(g, w, 1e-6), "t = {t}: {g} != {w}");
        }
    }
    // Cube faces point away from its centre at every time.
    let m = cube.to_world(1.3);
    let c = m.transform_point3(DVec3::ZERO);
    for p in &cube.polygons {
        let w: Vec<DVec3> = p.vertices.iter().map(|v| m.transform_point3(*v)).collect();
        let n = (w[1] - w[0]).cross(w[2] - w[0]);
        assert!(n.dot(w[0] - c) > 0.0);
    }
    let cam = s.camera.unwrap();
    assert!(close(cam.eye, DVec3::new(0.0, 1.5, 1.9), 1e-6));
    assert!(close(cam.target, DVec3::new(0.0, 1.5, 0.9), 1e-6));
    assert!(close(cam.up, DVec3::Y, 1e-12));
    assert!((cam.fov_y - 0.8).abs() < 1e-6);
}

#[test]
fn animated_gltf_loads_the_cube_motion_the_sample_defines() {
    check_moving_cube(&scene::load(&example("moving_cube.gltf")).unwrap());
}

#[test]
fn glb_and_external_buffer_equal_embedded_gltf() {
    let gltf = scene::load(&example("moving_cube.gltf")).unwrap();
    let glb = scene::load(&example("moving_cube.glb")).unwrap();
    let external = scene::load(&example("moving_cube_external.gltf")).unwrap();
    check_moving_cube(&glb);
    assert_eq!(glb, gltf);
    assert_eq!(external, gltf);
}

#[test]
fn obj_with_mtl_loads_the_materials_and_polygons_the_sample_defines() {
    let s = scene::load(&example("room.obj")).unwrap();
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["white", "lamp", "blue"]);
    assert_eq!(s.materials[1].emission, [10.0, 8.0, 6.0]);
    assert_eq!(s.materials[1].rho, [0.999; 3]);
    assert!((s.materials[2].rho[2] - 0.7).abs() < 1e-6);
    assert_eq!(s.time, scene::TimeDomain::default());
    let counts: Vec<(&str, usize)> = s
        .objects
        .iter()
        .map(|o| (o.name.as_str(), o.polygons.len()))
        .collect();
    // Room 6 quads; hexagon lamp fanned into 4 triangles; box 5 quads + 2 triangles.
    assert_eq!(counts, [("room", 6), ("lamp", 4), ("box", 7)]);
    assert!(s.objects.iter().all(|o| o.motion.is_none()));
    let room = object(&s, "room");
    assert!(room.polygons.iter().all(|p| p.vertices.len() == 4));
    for p in &room.polygons {
        assert!(p.normal().dot(DVec3::ONE - p.centroid()) > 0.0);
    }
    let lamp = object(&s, "lamp");
    let area: f64 = lamp.polygons.iter().map(Polygon::area).sum();
    // Regular hexagon of radius 0.3: 3 sqrt(3) / 2 r^2 (vertices rounded to 1e-6).
    assert!((area - 1.5 * 3f64.sqrt() * 0.09).abs() < 1e-5);
    assert!(
        lamp.polygons
            .iter()
            .all(|p| close(p.normal(), DVec3::NEG_Y, 1e-9))
    );
    let b = object(&s, "box");
    let centre = DVec3::new(0.75, 0.25, 0.75);
    for p in &b.polygons {
        assert!(p.normal().dot(p.centroid() - centre) > 0.0);
    }
    assert_eq!(
        s.warnings,
        vec![
            "material \"lamp\": reflectance 1.0 clamped to 0.999 (radiosity needs rho < 1)"
                .to_string(),
            format!(
                "room.obj:{}: split 1 face(s) into triangles: 0 non-planar quad(s) (a vertex off the plane by more than 0.0001 x diameter), 0 concave quad(s), 1 face(s) of 5 or more vertices (the first here)",
                hexagon_line()
            )
        ]
    );
}

/// The line of `room.obj`'s one face of more than 4 vertices (the lamp's hexagon).
fn hexagon_line() -> usize {
    let text = std::fs::read_to_string(example("room.obj")).unwrap();
    let lines: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.starts_with("f ") && l.split_whitespace().count() > 5)
        .map(|(k, _)| k + 1)
        .collect();
    assert_eq!(lines.len(), 1);
    lines[0]
}

#[test]
fn unsupported_extension_names_file_and_formats() {
    let e = scene::load(Path::new("dir/scene.fbx"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("dir/scene.fbx: file name: expected"), "{e}");
    assert!(e.contains(".json") && e.contains(".gltf") && e.contains(".glb") && e.contains(".obj"));
    assert!(e.ends_with("found extension .fbx"), "{e}");
    let e = scene::load(Path::new("noext")).unwrap_err().to_string();
    assert!(e.ends_with("found no extension"), "{e}");
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let e = scene::load(Path::new("/nonexistent/x.json"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/x.json: "), "{e}");
    let e = scene::load(Path::new("/nonexistent/x.glb"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/x.glb: "), "{e}");
}

#[test]
fn mirrored_static_node_keeps_the_front_face_lit() {
    // The sample with the room node mirrored in x: glTF then treats clockwise as front,
    // so after the loader reverses the triangles every room face still faces inward.
    let text = std::fs::read_to_string(example("moving_cube.gltf")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["nodes"][0]["scale"] = serde_json::json!([-1.0, 1.0, 1.0]);
    let bytes = serde_json::to_vec(&v).unwrap();
    let s = scene::load_gltf_slice(&bytes, None, Path::new("mirrored.gltf")).unwrap();
    let room = object(&s, "room");
    let xs: Vec<f64> = room
        .polygons
        .iter()
        .flat_map(|p| p.vertices.iter().map(|v| v.x))
        .collect();
    let (lo, hi) = xs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    assert_eq!((lo, hi), (-6.0, -2.0));
    // Mesh x in [0, 4] -> scale -1 -> [-4, 0] -> translation -2 -> [-6, -2].
    let centre = DVec3::new(-4.0, 1.5, 0.0);
    for p in &room.polygons {
        assert!(p.normal().dot(centre - p.centroid()) > 0.0);
    }
}

#[test]
fn readme_scene_example_loads_with_the_stated_orientation() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let section = &readme[readme.find("## Scene and file formats").unwrap()..];
    let start = section.find("```json\n").unwrap() + "```json\n".len();
    let text = &section[start..start + section[start..].find("```").unwrap()];
    let s = scene::load_json_str(text, Path::new("README.md")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(object(&s, "floor").polygons[0].normal(), DVec3::Y);
    assert_eq!(object(&s, "lamp").polygons[0].normal(), DVec3::NEG_Y);
}

/// Asserts `got` is `want` up to f32 rounding of coordinates and material values
/// (OBJ and glTF store `f32`; millimetre coordinates below 1000 round by < 1e-4).
fn assert_same_up_to_f32(got: &Scene, want: &Scene, what: &str) {
    assert_eq!(got.objects.len(), want.objects.len(), "{what}");
    for (g, w) in got.objects.iter().zip(&want.objects) {
        assert_eq!(g.name, w.name, "{what}");
        assert_eq!(g.polygons.len(), w.polygons.len(), "{what}: {}", w.name);
        assert_eq!(g.motion, w.motion, "{what}: {}", w.name);
        for (gp, wp) in g.polygons.iter().zip(&w.polygons) {
            assert_eq!(gp.material, wp.material, "{what}: {}", w.name);
            assert_eq!(gp.vertices.len(), wp.vertices.len(), "{what}: {}", w.name);
            for (a, b) in gp.vertices.iter().zip(&wp.vertices) {
                assert!(close(*a, *b, 1e-4), "{what}: {}: {a} != {b}", w.name);
            }
        }
    }
    assert_eq!(got.materials.len(), want.materials.len(), "{what}");
    for (g, w) in got.materials.iter().zip(&want.materials) {
        assert_eq!(g.name, w.name, "{what}");
        for c in 0..3 {
            assert!((g.rho[c] - w.rho[c]).abs() < 1e-7, "{what}: {g:?} vs {w:?}");
            assert!(
                (g.emission[c] - w.emission[c]).abs() < 1e-5 * w.emission[c].max(1.0),
                "{what}: {g:?} vs {w:?}"
            );
        }
    }
    assert_eq!(got.time, want.time, "{what}");
}

#[test]
fn cornell_box_as_obj_and_gltf_loads_to_the_embedded_scene() {
    // Written by tools/make_cornell_samples.py from cornell_blocks.json.
    let want = cornell_box(true);
    let obj = scene::load(&example("cornell_blocks.obj")).unwrap();
    assert!(obj.warnings.is_empty(), "{:?}", obj.warnings);
    assert_same_up_to_f32(&obj, &want, "OBJ");
    let gltf = scene::load(&example("cornell_blocks.gltf")).unwrap();
    assert!(gltf.warnings.is_empty(), "{:?}", gltf.warnings);
    // Quads written as triangle pairs come back as the same quads; the bent left
    // wall stays two triangles.
    assert_same_up_to_f32(&gltf, &want, "glTF");
    let (a, b) = (gltf.camera.unwrap(), want.camera.unwrap());
    // A glTF camera has a direction, not a target: compare the view directions.
    let (da, db) = (
        (a.target - a.eye).normalize(),
        (b.target - b.eye).normalize(),
    );
    assert!(close(a.eye, b.eye, 1e-4) && close(da, db, 1e-7), "{a:?}");
    assert!(
        close(a.up, b.up, 1e-7) && (a.fov_y - b.fov_y).abs() < 1e-7,
        "{a:?}"
    );
}
