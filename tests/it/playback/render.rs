//! Playback: pictures and exports of known scenes, and the real `rhier` binary on
//! sample files (probe, play, inspect, exit codes).

use std::path::Path;

use glam::DVec3;
use rhier::playback::Frame;
use rhier::playback::export::gltf_document;
use rhier::playback::raster::{
    FrameMesh, Shading, auto_camera, auto_exposure, render, srgb_oetf, tone_map,
};
use rhier::scene::{Camera, Material, MaterialId, Object, Polygon, Scene};
use rhier::solution::{PatchGeometry, Solution, SolveStats};
use rhier::store::samples::{box_solution, uniform_leaves};
use rhier::store::{WriteOptions, write_solution};

use crate::common::{rhier, succeed};

/// A 2 × 2 white wall in the plane z = 0 facing +z, radiosity `b` everywhere, seen
/// head-on from (0, 0, 3).
fn wall(b: f64, n: u32) -> (Solution, Camera) {
    let v = [
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 0.0),
    ];
    let scene = Scene {
        materials: vec![Material::diffuse("white", [0.8; 3])],
        objects: vec![Object::still(
            "wall",
            vec![Polygon {
                vertices: v.to_vec(),
                material: MaterialId(0),
            }],
        )],
        ..Scene::default()
    };
    let patch = PatchGeometry {
        object: 0,
        material: 0,
        corners: 4,
        vertices: v,
    };
    let leaves = uniform_leaves(0, &patch, n, [0.0, 0.0], |_| [b, b, b]);
    let camera = Camera {
        eye: DVec3::new(0.0, 0.0, 3.0),
        target: DVec3::ZERO,
        up: DVec3::Y,
        fov_y: 60f64.to_radians(),
    };
    (
        Solution {
            scene,
            patches: vec![patch],
            leaves,
            stats: SolveStats::default(),
        },
        camera,
    )
}

#[test]
fn lit_white_wall_has_the_expected_pixel_value() {
    let (sol, cam) = wall(0.5, 3);
    let frame = Frame::build(&sol, 0.0).unwrap();
    for shading in [Shading::Smooth, Shading::Flat] {
        let mesh = FrameMesh::build(&frame, shading);
        let pic = render(&mesh, &cam, 64, 48);
        let img = tone_map(&pic, 1.0, [0, 0, 0]);
        assert_eq!(img.dimensions(), (64, 48));
        // sRGB of linear 0.5 is 0.7354 -> 188.
        let want = (srgb_oetf(0.5) * 255.0).round() as u8;
        assert_eq!(want, 188);
        assert_eq!(img.get_pixel(32, 24).0, [want; 3]);
        // The wall's half-width 1 at distance 3 with a 60° vertical field of view is
        // 1 / (3 tan 30°) = 0.577 of the half-height (24 px), i.e. 13.9 px, and the
        // same 13.9 px horizontally (0.433 of the half-width, 32 px, at aspect 4:3).
        assert_eq!(img.get_pixel(32 + 12, 24).0, [want; 3]);
        assert_eq!(img.get_pixel(32 + 16, 24).0, [0; 3]);
        assert_eq!(img.get_pixel(32, 24 - 12).0, [want; 3]);
        assert_eq!(img.get_pixel(32, 24 - 16).0, [0; 3]);
        // Auto exposure maps the wall (every drawn pixel at 0.5) to 1.
        assert!((auto_exposure(&pic) - 2.0).abs() < 1e-12);
    }
    // Seen from behind, the wall is culled.
    let back = Camera {
        eye: DVec3::new(0.0, 0.0, -3.0),
        ..cam
    };
    let mesh = FrameMesh::build(&frame, Shading::Smooth);
    assert!(
        render(&mesh, &back, 16, 16)
            .pixels
            .iter()
            .all(Option::is_none)
    );
}

#[test]
fn smooth_shading_interpolates_vertex_radiosity() {
    // B = 1 + x on the wall: smooth shading reproduces the linear ramp per pixel.
    let (mut sol, cam) = wall(0.0, 4);
    let p = sol.patches[0];
    sol.leaves = uniform_leaves(0, &p, 4, [0.0, 0.0], |q| [1.0 + q.x; 3]);
    let frame = Frame::build(&sol, 0.0).unwrap();
    let pic = render(&FrameMesh::build(&frame, Shading::Smooth), &cam, 64, 48);
    let (w, h) = (64.0, 48.0);
    let f = 1.0 / (30f64.to_radians()).tan();
    for px in [22u32, 28, 32, 36, 41] {
        let c = pic.pixels[(24 * 64 + px) as usize].expect("on the wall");
        // Invert the projection at the pixel centre: x_ndc = x f / (aspect * 3).
        let ndc = (px as f64 + 0.5) / w * 2.0 - 1.0;
        let x = ndc * (w / h) * 3.0 / f;
        assert!(
            (c[0] - (1.0 + x)).abs() < 1e-9,
            "pixel {px}: {} vs {}",
            c[0],
            1.0 + x
        );
    }
}

#[test]
fn auto_camera_sees_the_inside_of_the_box() {
    let sol = box_solution(2);
    let frame = Frame::build(&sol, 0.0).unwrap();
    let cam = auto_camera(&frame);
    let pic = render(&FrameMesh::build(&frame, Shading::Smooth), &cam, 40, 30);
    // The back wall z = 0 is seen through the culled front wall at the centre:
    // B = wall_radiosity(0.5, 0.5, 0) = (1.5, 2, 0.5); the pixel centre is half a
    // pixel (~0.02 in x and y on the wall) off the box centre, and only the back wall
    // has B.z = 0.5 (the front wall has 3.5).
    let c = pic.pixels[15 * 40 + 20].expect("centre drawn");
    assert!(
        (c[0] - 1.5).abs() < 0.06 && (c[1] - 2.0).abs() < 0.12 && (c[2] - 0.5).abs() < 1e-6,
        "{c:?}"
    );
}

#[test]
fn gltf_export_parses_back_with_expected_counts() {
    let sol = box_solution(2);
    let frame = Frame::build(&sol, 0.0).unwrap();
    let mesh = FrameMesh::build(&frame, Shading::Flat);
    // 5 quad walls * 4 leaves * 2 triangles + 2 triangle walls * 4 leaves.
    assert_eq!(mesh.triangles.len(), 5 * 4 * 2 + 2 * 4);
    let text = serde_json::to_vec(&gltf_document(&mesh, 0.25)).unwrap();
    let g = gltf::Gltf::from_slice(&text).unwrap();
    let buffers = gltf::import_buffers(&g.document, None, None).unwrap();
    let prim = g
        .document
        .meshes()
        .next()
        .unwrap()
        .primitives()
        .next()
        .unwrap();
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    let colors: Vec<[f32; 3]> = reader.read_colors(0).unwrap().into_rgb_f32().collect();
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    assert_eq!(positions.len(), mesh.positions.len());
    assert_eq!(indices.len(), mesh.triangles.len() * 3);
    for (c, m) in colors.iter().zip(&mesh.colors) {
        for k in 0..3 {
            assert!((c[k] as f64 - (m[k] * 0.25).clamp(0.0, 1.0)).abs() < 1e-6);
        }
    }
}

#[test]
fn cli_probe_play_and_inspect_read_back_the_written_box() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("box.rhier");
    let sol = box_solution(2);
    write_solution(&file, &sol, WriteOptions::default()).unwrap();
    let pts = dir.path().join("p.json");
    std::fs::write(
        &pts,
        r#"[{"p":[0.5,0.5,0.02],"n":[0,0,1]},{"p":[0.25,0.001,0.5],"n":[0,1,0]}]"#,
    )
    .unwrap();

    let out = succeed(rhier().arg("probe").arg(&file).arg("--points").arg(&pts));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let b0: Vec<f64> = v[0]["B"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let b1: Vec<f64> = v[1]["B"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let w0 = rhier::store::samples::wall_radiosity(DVec3::new(0.5, 0.5, 0.0));
    let w1 = rhier::store::samples::wall_radiosity(DVec3::new(0.25, 0.0, 0.5));
    for k in 0..3 {
        assert!(
            (b0[k] - w0[k]).abs() < 1e-5 && (b1[k] - w1[k]).abs() < 1e-5,
            "{b0:?} {b1:?}"
        );
    }

    let frames = dir.path().join("frames");
    succeed(
        rhier()
            .arg("play")
            .arg(&file)
            .args(["--time", "0", "--width", "80", "--height", "60", "-o"])
            .arg(&frames),
    );
    let img = image::open(frames.join("frame_00000.png")).unwrap();
    assert_eq!((img.width(), img.height()), (80, 60));

    succeed(
        rhier()
            .arg("play")
            .arg(&file)
            .args(["--time", "0", "--export", "gltf", "-o"])
            .arg(&frames),
    );
    let exported = frames.join("frame_00000.gltf");
    if let Err(e) = gltf::Gltf::open(&exported) {
        panic!("{} does not parse: {e}", exported.display());
    }

    let out = succeed(rhier().arg("inspect").arg(&file).arg("--json"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Format version 2 (issue 50); without a provenance section a version-1
    // reader reads the file.
    assert_eq!(v["header"]["version"], 2);
    assert_eq!(v["header"]["min_reader_version"], 1);
    assert_eq!(v["scene"]["patches"], 7);
    assert_eq!(v["verified_leaves"], 5 * 4 + 2 * 4);
    assert_eq!(v["memory"]["chunks"][0]["leaves"], 5 * 4 + 2 * 4);
}

#[test]
fn cli_bad_files_and_times_exit_1_and_bad_usage_exits_2() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    // Corrupt file: exit 1 with a message naming it.
    for name in [
        "bitflip_chunk.rhier",
        "wrong_magic.rhier",
        "huge_raw_length.rhier",
    ] {
        let out = rhier()
            .arg("inspect")
            .arg(data.join(name))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{name}");
        assert!(String::from_utf8_lossy(&out.stderr).contains(name));
    }
    // Time outside the domain: exit 1.
    let pts = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(pts.path(), r#"[{"p":[0,0,0],"n":[0,0,1]}]"#).unwrap();
    let out = rhier()
        .arg("probe")
        .arg(data.join("v1_animated.rhier"))
        .arg("--points")
        .arg(pts.path())
        .args(["--time", "7"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    // Usage errors: exit 2.
    let out = rhier()
        .arg("play")
        .arg(data.join("v1_animated.rhier"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn smooth_shading_averages_only_within_a_material() {
    // Two coplanar unit quads sharing the edge x = 1, B = 1 on the left, 5 on the
    // right: with one material the shared corners average to 3; with two (a light
    // beside a ceiling) they keep 1 and 5.
    for (right_material, want_left, want_right) in [(0u32, 3.0, 3.0), (1, 1.0, 5.0)] {
        let quad = |x0: f64| {
            [
                DVec3::new(x0, 0.0, 0.0),
                DVec3::new(x0 + 1.0, 0.0, 0.0),
                DVec3::new(x0 + 1.0, 1.0, 0.0),
                DVec3::new(x0, 1.0, 0.0),
            ]
        };
        let patches = vec![
            PatchGeometry {
                object: 0,
                material: 0,
                corners: 4,
                vertices: quad(0.0),
            },
            PatchGeometry {
                object: 0,
                material: right_material,
                corners: 4,
                vertices: quad(1.0),
            },
        ];
        let mut leaves = uniform_leaves(0, &patches[0], 1, [0.0, 0.0], |_| [1.0; 3]);
        leaves.extend(uniform_leaves(1, &patches[1], 1, [0.0, 0.0], |_| [5.0; 3]));
        let m = Material::diffuse("m", [0.5; 3]);
        let scene = Scene {
            materials: vec![m.clone(), m],
            objects: vec![Object::still("o", Vec::new())],
            ..Scene::default()
        };
        let sol = Solution {
            scene,
            patches,
            leaves,
            stats: SolveStats::default(),
        };
        let frame = Frame::build(&sol, 0.0).unwrap();
        let mesh = FrameMesh::build(&frame, Shading::Smooth);
        // Colour of the vertex at (1, 0, 0) as used by each patch's first triangle.
        let at = |tri: &[u32; 3]| {
            tri.iter()
                .find(|&&i| mesh.positions[i as usize].distance(DVec3::X) < 1e-12)
                .map(|&i| mesh.colors[i as usize][0])
        };
        assert_eq!(at(&mesh.triangles[0]), Some(want_left));
        assert_eq!(at(&mesh.triangles[2]), Some(want_right));
    }
}

#[test]
fn cli_play_frame_range_writes_one_picture_per_frame() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let dir = tempfile::tempdir().unwrap();
    succeed(
        rhier()
            .arg("play")
            .arg(data.join("v1_animated.rhier"))
            .args([
                "--frames", "0..1", "--fps", "4", "--width", "32", "--height", "24", "-o",
            ])
            .arg(dir.path())
            // Seen from beyond +z (the front wall culled): the plate faces +z. The
            // automatic camera of this interior looks at its brightest wall instead.
            .args(["--eye", "0.5,0.5,3", "--target", "0.5,0.5,0.5"]),
    );
    // Frames at 0, 0.25, 0.5, 0.75, 1.
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want: Vec<String> = (0..5).map(|k| format!("frame_{k:05}.png")).collect();
    assert_eq!(names, want);
    // The plate moves: the first and last frames differ.
    let a = image::open(dir.path().join("frame_00000.png"))
        .unwrap()
        .to_rgb8();
    let b = image::open(dir.path().join("frame_00004.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(a.dimensions(), (32, 24));
    assert_ne!(a, b);
    // A bad range is a usage error of the job: exit 1 with the flag named.
    let out = rhier()
        .arg("play")
        .arg(data.join("v1_animated.rhier"))
        .args(["--frames", "1..0", "--fps", "4", "-o"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--frames"));
}

/// `rhier inspect big.rhier | head` must not panic when the pipe closes (regression:
/// `println!` panicked with "failed printing to stdout: Broken pipe").
#[test]
fn cli_inspect_into_a_closed_pipe_does_not_panic() {
    use rhier::store::samples::animated_box;
    use rhier::store::{SolutionHeader, Writer};
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("long.rhier");
    // 3000 chunks: the chunk table alone is ~250 KB of text, beyond a pipe's buffer.
    let s = animated_box(1, 3000);
    let mut w = Writer::create(
        &file,
        &SolutionHeader::of(&s.solution),
        WriteOptions::default(),
    )
    .unwrap();
    for (t0, t1, leaves) in &s.chunks {
        w.write_chunk(*t0, *t1, leaves).unwrap();
    }
    w.finish(&s.solution.stats).unwrap();
    let mut child = rhier()
        .arg("inspect")
        .arg(&file)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}
