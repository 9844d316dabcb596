//! What `rhier view` sends, decoded from its bytes as formats/view.md says, against
//! playback's own evaluation of the same file at the same time: the triangles and
//! colours `rhier play` draws (`FrameMesh`, smooth and flat), and the answer of
//! `rhier probe` with the patch and leaf that gave it; a scene turning as one keeps
//! its mesh and colours, which are those computed afresh at each time.

use glam::{DAffine3, DMat3, DVec3};
use rhier::playback::frame::Frame;
use rhier::playback::probe::{ProbePoint, probe};
use rhier::playback::raster::{FrameMesh, Shading};
use rhier::solution::Leaf;
use rhier::store::samples::turning_tiled_box;
use rhier::store::{Reader, WriteOptions, write_solution};
use rhier::view::Viewer;

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// A triangle in world space with its corners' radiosity.
type Tri = [(DVec3, [f64; 3]); 3];

/// Decodes a mesh and a frame message into world triangles with colours: those of
/// the mesh's leaves live at the frame's time (`Leaf::is_live`, in a domain ending
/// at `t_end`), with the frame's colours in the mesh's order.
fn decode(mesh: &[u8], frame: &[u8], t_end: f64) -> Vec<Tri> {
    assert_eq!(&mesh[..4], b"RHVM");
    assert_eq!(&frame[..4], b"RHVF");
    assert_eq!(mesh[8..16], frame[8..16], "mesh and frame keys");
    let groups = u32_at(mesh, 16) as usize;
    let vertices = u32_at(mesh, 20) as usize;
    let leaves = u32_at(mesh, 24) as usize;
    let pos = 32 + 20 * groups;
    let times = pos + 12 * vertices;
    let counts = times + 8 * leaves;
    assert_eq!(mesh.len(), (counts + leaves).next_multiple_of(4));
    let t = f64::from_le_bytes(frame[24..32].try_into().unwrap());
    let objects = u32_at(frame, 32) as usize;
    let scale = f32_at(frame, 40) as f64;
    let col = 48 + 48 * objects;
    let transform = |o: usize| {
        let a: Vec<f64> = (0..12)
            .map(|k| f32_at(frame, 48 + 48 * o + 4 * k) as f64)
            .collect();
        DAffine3::from_mat3_translation(
            DMat3::from_cols_slice(&a[..9]),
            DVec3::new(a[9], a[10], a[11]),
        )
    };
    let mut out = Vec::new();
    // The next colour (corner) of the frame.
    let mut next = 0usize;
    for g in 0..groups {
        let r = |k: usize| u32_at(mesh, 32 + 20 * g + 4 * k) as usize;
        let (object, first, count, first_leaf, n) = (r(0), r(1), r(2), r(3), r(4));
        let m = transform(object);
        let mut v = first;
        for k in first_leaf..first_leaf + n {
            let corners = mesh[counts + k] as u32;
            let leaf = Leaf {
                patch: 0,
                corners,
                time: [f32_at(mesh, times + 8 * k), f32_at(mesh, times + 8 * k + 4)],
                uv: [[0.0; 2]; 4],
                b: [[0.0; 3]; 4],
            };
            if leaf.is_live(t, t_end) {
                let corner = |i: u32| {
                    let c = next + i as usize;
                    let v = v + i as usize;
                    assert!(v < first + count);
                    let p = DVec3::from_array(
                        [0, 1, 2].map(|k| f32_at(mesh, pos + 12 * v + 4 * k) as f64),
                    );
                    let c = [0, 1, 2].map(|k| {
                        let at = col + 6 * c + 2 * k;
                        half::f16::from_bits(u16::from_le_bytes([frame[at], frame[at + 1]]))
                            .to_f64()
                            * scale
                    });
                    (m.transform_point3(p), c)
                };
                for tri in [[0, 1, 2], [0, 2, 3]].iter().take(corners as usize - 2) {
                    out.push(tri.map(corner));
                }
                next += corners as usize;
            }
            v += corners as usize;
        }
    }
    assert_eq!(
        next,
        u32_at(frame, 36) as usize,
        "colours for the live corners"
    );
    out
}

/// Every sent triangle is one of play's, at the same place with the same colours
/// (to f32 positions and half-float colours), and they are as many.
fn assert_same_triangles(sent: &[Tri], play: &FrameMesh, what: &str) {
    let diag = play
        .positions
        .iter()
        .fold((DVec3::MAX, DVec3::MIN), |(a, b), &p| (a.min(p), b.max(p)));
    let diag = (diag.1 - diag.0).length();
    let mut left: Vec<Tri> = play
        .triangles
        .iter()
        .map(|t| t.map(|i| (play.positions[i as usize], play.colors[i as usize])))
        .collect();
    assert_eq!(sent.len(), left.len(), "{what}: triangle count");
    let top = play.colors.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
    let mut worst = 0.0f64;
    for s in sent {
        let dist = |t: &Tri| (0..3).map(|k| (t[k].0 - s[k].0).length()).sum::<f64>();
        let (j, d) = left
            .iter()
            .enumerate()
            .map(|(j, t)| (j, dist(t)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!(
            d < 1e-5 * diag,
            "{what}: no triangle of play's at {s:?} ({d})"
        );
        for k in 0..3 {
            for c in 0..3 {
                let (a, b) = (s[k].1[c], left[j][k].1[c]);
                // Half floats: 11 significant bits, subnormal below 6e-5 of the top.
                let err = (a - b).abs();
                worst = worst.max(err / (b.abs() + 1e-4 * top));
                assert!(
                    err <= 5e-4 * b.abs() + 1e-7 * top,
                    "{what}: {a} against {b}"
                );
            }
        }
        left.swap_remove(j);
    }
    assert!(worst > 0.0 || top == 0.0, "{what}: colours not compared");
}

#[test]
fn frames_are_what_play_draws_at_the_same_time() {
    let dir = tempfile::tempdir().unwrap();
    let file = super::moving(dir.path());
    let reader = Reader::open(&file).unwrap();
    let viewer = Viewer::new(Reader::open(&file).unwrap(), serde_json::Value::Null).unwrap();
    let mut moved = 0;
    for t in [0.0, 0.7, 1.3, 2.0] {
        let mesh = viewer.handle("GET", &format!("/api/mesh?t={t}"));
        assert_eq!(mesh.status, 200);
        let frame = Frame::build(&reader, t).unwrap();
        for (shading, name) in [(Shading::Smooth, "smooth"), (Shading::Flat, "flat")] {
            let sent = viewer.handle("GET", &format!("/api/frame?t={t}&shading={name}"));
            assert_eq!(sent.status, 200);
            let tris = decode(&mesh.body, &sent.body, reader.time_domain().end);
            assert_same_triangles(
                &tris,
                &FrameMesh::build(&frame, shading),
                &format!("t = {t}, {name}"),
            );
        }
        // The moving block's corners are sent once, in object space: its transform moves it.
        let start = viewer.handle("GET", "/api/frame?t=0").body;
        let now = viewer.handle("GET", &format!("/api/frame?t={t}")).body;
        moved += usize::from(
            start[48..48 + 48 * reader.objects().len()]
                != now[48..48 + 48 * reader.objects().len()],
        );
    }
    assert_eq!(moved, 3, "the transforms of t > 0 differ from t = 0's");
    // Asked again with its colour id, a frame comes without its colours; the block
    // moving against the room, another time has other colours, under another id.
    let id = |m: &[u8]| u32_at(m, 44);
    let full = viewer.handle("GET", "/api/frame?t=1.3").body;
    let short = viewer
        .handle("GET", &format!("/api/frame?t=1.3&have={}", id(&full)))
        .body;
    let objects = reader.objects().len();
    assert_eq!((id(&short), u32_at(&short, 36)), (id(&full), 0));
    assert_eq!(
        short[..],
        full[..48 + 48 * objects]
            .iter()
            .enumerate()
            .map(|(i, &b)| if (36..40).contains(&i) { 0 } else { b })
            .collect::<Vec<u8>>()[..]
    );
    let other = viewer
        .handle("GET", &format!("/api/frame?t=1.5&have={}", id(&full)))
        .body;
    let corners = u32_at(&other, 36) as usize;
    assert!(id(&other) != id(&full) && corners > 0);
    assert!(other.len() >= 48 + 48 * objects + 6 * corners);
}

#[test]
fn frames_of_one_span_draw_their_own_live_leaves_from_one_mesh() {
    // A space-time solve: its live leaves change from frame to frame, its mesh only
    // from span to span. Two times of one span with different live leaves each
    // draw play's triangles and colours at their own time.
    let dir = tempfile::tempdir().unwrap();
    let file = super::moving(dir.path());
    let reader = Reader::open(&file).unwrap();
    let t_end = reader.time_domain().end;
    let viewer = Viewer::new(Reader::open(&file).unwrap(), serde_json::Value::Null).unwrap();
    let frames: Vec<(f64, Vec<u8>)> = (0..=50)
        .map(|k| k as f64 / 25.0)
        .map(|t| (t, viewer.handle("GET", &format!("/api/frame?t={t}")).body))
        .collect();
    let keys: std::collections::BTreeSet<&[u8]> = frames.iter().map(|f| &f.1[8..16]).collect();
    let lives: std::collections::BTreeSet<&[u8]> = frames.iter().map(|f| &f.1[16..24]).collect();
    assert!(
        keys.len() < lives.len() / 2,
        "{} meshes for {} live sets",
        keys.len(),
        lives.len()
    );
    let (a, b) = frames
        .iter()
        .zip(&frames[1..])
        .find(|(a, b)| a.1[8..16] == b.1[8..16] && a.1[16..24] != b.1[16..24])
        .expect("two frames of one span with different live leaves");
    let mesh = viewer.handle("GET", &format!("/api/mesh?t={}", a.0)).body;
    assert_eq!(
        mesh,
        viewer.handle("GET", &format!("/api/mesh?t={}", b.0)).body
    );
    for (t, sent) in [a, b] {
        let frame = Frame::build(&reader, *t).unwrap();
        assert!((u32_at(&mesh, 24) as usize) > frame.leaves.len(), "t = {t}");
        let tris = decode(&mesh, sent, t_end);
        assert_same_triangles(
            &tris,
            &FrameMesh::build(&frame, Shading::Smooth),
            &format!("t = {t}"),
        );
    }
}

#[test]
fn a_click_is_the_probe_answer_with_its_patch_and_leaf() {
    let dir = tempfile::tempdir().unwrap();
    let file = super::moving(dir.path());
    let reader = Reader::open(&file).unwrap();
    let viewer = Viewer::new(Reader::open(&file).unwrap(), serde_json::Value::Null).unwrap();
    let points = [
        (DVec3::new(278.0, 0.0, 200.0), DVec3::Y),
        (DVec3::new(100.0, 300.0, 559.2), DVec3::NEG_Z),
        (DVec3::new(556.0, 200.0, 300.0), DVec3::NEG_X),
        (DVec3::new(0.5, 400.0, 100.0), DVec3::X),
        (DVec3::new(278.0, 548.8, 280.0), DVec3::NEG_Y),
    ];
    for t in [0.0, 1.1, 2.0] {
        let frame = Frame::build(&reader, t).unwrap();
        for (p, n) in points {
            let url = format!(
                "/api/probe?t={t}&p={},{},{}&n={},{},{}",
                p.x, p.y, p.z, n.x, n.y, n.z
            );
            let r = viewer.handle("GET", &url);
            assert_eq!(r.status, 200, "{url}");
            let v: serde_json::Value = serde_json::from_slice(&r.body).unwrap();
            let expected = probe(&reader, &[ProbePoint { p, n }], t).unwrap()[0];
            let b: Vec<f64> = v["B"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            // serde_json's default float parsing may be one ulp off: not a difference.
            let close = |a: &[f64], b: &[f64]| {
                a.iter()
                    .zip(b)
                    .all(|(x, y)| (x - y).abs() <= 1e-14 * y.abs().max(1e-300))
            };
            assert!(
                close(&b, &expected),
                "{url}: {b:?} against probe's {expected:?}"
            );
            // The leaf named is the frame's leaf on that patch, and gives that value.
            let patch = v["patch"].as_u64().unwrap() as u32;
            let k = v["leaf"]["index"].as_u64().unwrap() as usize;
            let leaf = frame.leaves[k];
            assert_eq!(leaf.patch, patch, "{url}");
            let uv: Vec<f64> = v["uv"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            assert!(close(&leaf.eval(uv[0], uv[1]), &b), "{url}: leaf {k}");
            let facing = frame.patches[patch as usize].normal.dot(n);
            assert!(facing > 0.0, "{url}: patch {patch} faces away");
        }
    }
}

#[test]
fn a_scene_turning_as_one_keeps_its_mesh_and_colours() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("turning.rhier");
    write_solution(&file, &turning_tiled_box(6), WriteOptions::default()).unwrap();
    let viewer = Viewer::new(Reader::open(&file).unwrap(), serde_json::Value::Null).unwrap();
    let first = viewer.handle("GET", "/api/frame?t=0").body;
    let (key, id) = (&first[8..16], u32_at(&first, 44));
    let colors = &first[48 + 48..];
    assert!(u32_at(&first, 36) as usize >= 4 * 6 * 36 && colors.iter().any(|&b| b != 0));
    for k in 1..=50 {
        let t = k as f64 / 25.0;
        // Kept: the same live leaves (key), the same colour id, no colours sent.
        let kept = viewer
            .handle("GET", &format!("/api/frame?t={t}&have={id}"))
            .body;
        assert_eq!(
            (&kept[8..16], u32_at(&kept, 44), u32_at(&kept, 36)),
            (key, id, 0),
            "t = {t}"
        );
        // And they are the colours computed afresh at that time.
        // (A fresh viewer holds the smooth colours of t = 0: flat ones come in between.)
        let fresh = Viewer::new(Reader::open(&file).unwrap(), serde_json::Value::Null).unwrap();
        fresh.handle("GET", &format!("/api/frame?t={t}&shading=flat"));
        let own = fresh.handle("GET", &format!("/api/frame?t={t}")).body;
        assert_eq!(&own[48 + 48..], colors, "t = {t}");
    }
}
