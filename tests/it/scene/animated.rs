//! The embedded animated scenes ACTOR and LIGHT (`src/scene/animated.rs`): they pass
//! validation unchanged, their moving objects stay clear of everything else at 200
//! times (separating-axis test, at least 5 mm), the JSON examples in
//! `formats/examples/` load equal to them, longer shots repeat the same motion back
//! and forth, and LIGHT's board really hides its wall lamp mid-shot.
//!
//! `RHIER_REGENERATE_EXAMPLES=1 cargo test --release --test it scene::animated`
//! rewrites the JSON examples from the embedded scenes.

use std::path::Path;

use glam::DVec3;
use rhier::scene::{self, Object, Scene, actor_scene, light_scene, validate};

use crate::common::example;

/// (file name, builtin name, scene) of every embedded animated scene.
fn all_scenes() -> Vec<(&'static str, &'static str, Scene)> {
    vec![
        ("actor.json", "actor", actor_scene(75)),
        ("actor150.json", "actor150", actor_scene(150)),
        ("actor750.json", "actor750", actor_scene(750)),
        ("light.json", "light", light_scene(75)),
        ("light150.json", "light150", light_scene(150)),
        ("light750.json", "light750", light_scene(750)),
    ]
}

#[test]
fn scenes_pass_validation_unchanged() {
    let mut scenes = all_scenes();
    // A length that is not a multiple of the 1.5 s key step (last key interpolated).
    scenes.push(("-", "-", actor_scene(100)));
    scenes.push(("-", "-", light_scene(10)));
    for (file, _, s) in scenes {
        let checked = validate::validate(s.clone(), Path::new(file)).unwrap();
        assert_eq!(checked, s, "{file}: validation changed the scene");
        assert!(s.has_motion() && s.has_emitter(), "{file}");
        for o in s.objects.iter().filter(|o| o.is_moving()) {
            let keys = &o.motion.as_ref().unwrap().keys;
            assert_eq!(keys.first().unwrap().t, 0.0, "{file} {}", o.name);
            assert_eq!(keys.last().unwrap().t, s.time.end, "{file} {}", o.name);
        }
    }
}

#[test]
fn lengths_are_frames_at_25_fps() {
    for (frames, seconds) in [(75, 3.0), (150, 6.0), (750, 30.0), (100, 4.0)] {
        for s in [actor_scene(frames), light_scene(frames)] {
            assert_eq!((s.time.start, s.time.end), (0.0, seconds), "{frames}");
        }
    }
    // Polygon counts: the shared room is floor 1, ceiling 4, lamp 1, left/front 2,
    // desk 6 + 4 legs x 4 = 30. ACTOR: 30 + right 1, back 4, window 1, shelf 4, two
    // actors 6 each = 52. LIGHT: 30 + back 1 + right 4 + wall lamp 1 + board 6 = 42.
    assert_eq!(actor_scene(75).polygon_count(), 52);
    assert_eq!(light_scene(75).polygon_count(), 42);
}

#[test]
fn builtin_names_resolve() {
    for name in scene::BUILTIN_NAMES {
        assert!(scene::builtin(name).is_some(), "{name}");
    }
    assert_eq!(scene::builtin("actor750"), Some(actor_scene(750)));
    assert_eq!(
        scene::builtin("cornell-blocks"),
        Some(scene::cornell_box(true))
    );
    assert_eq!(scene::builtin("light").map(|s| s.time.end), Some(3.0));
    assert!(scene::builtin("actor75").is_none() && scene::builtin("").is_none());
}

#[test]
fn json_examples_equal_the_embedded_scenes() {
    for (file, _, embedded) in all_scenes() {
        let path = example(file);
        if std::env::var_os("RHIER_REGENERATE_EXAMPLES").is_some() {
            std::fs::write(&path, scene::to_json_string(&embedded)).unwrap();
        }
        let loaded = scene::load(&path).unwrap();
        assert_eq!(loaded.objects, embedded.objects, "{file}");
        assert_eq!(loaded.materials, embedded.materials, "{file}");
        assert_eq!(loaded.time, embedded.time, "{file}");
        assert!(loaded.warnings.is_empty(), "{file}: {:?}", loaded.warnings);
        // The field of view is stored in degrees: one ulp may move (as for Cornell).
        let (a, b) = (loaded.camera.unwrap(), embedded.camera.unwrap());
        assert_eq!((a.eye, a.target, a.up), (b.eye, b.target, b.up), "{file}");
        assert!(
            (a.fov_y - b.fov_y).abs() <= 2.0 * f64::EPSILON * b.fov_y,
            "{file}"
        );
    }
}

/// World-space vertices of `o` at `t`, per polygon.
fn world_polygons(o: &Object, t: f64) -> Vec<Vec<DVec3>> {
    let m = o.to_world(t);
    o.polygons
        .iter()
        .map(|p| p.vertices.iter().map(|&v| m.transform_point3(v)).collect())
        .collect()
}

fn normal(p: &[DVec3]) -> DVec3 {
    let mut s = DVec3::ZERO;
    for i in 1..p.len() - 1 {
        s += (p[i] - p[0]).cross(p[i + 1] - p[0]);
    }
    s.normalize()
}

fn edges(p: &[DVec3]) -> impl Iterator<Item = DVec3> + '_ {
    (0..p.len()).map(move |i| p[(i + 1) % p.len()] - p[i])
}

/// Largest separation, over the separating-axis candidates, between the convex hull
/// of `a` (a convex solid given by its faces) and the convex hull of `b` (a convex
/// solid's faces, or a single flat polygon): face normals of both, in-plane edge
/// normals of `b`'s faces (which make a flat polygon a complete convex body), and
/// every cross product of an edge of `a` with an edge of `b`. Positive: the hulls are
/// at least that far apart; negative or zero: they touch or overlap.
fn separation(a: &[Vec<DVec3>], b: &[Vec<DVec3>]) -> f64 {
    let pa: Vec<DVec3> = a.iter().flatten().copied().collect();
    let pb: Vec<DVec3> = b.iter().flatten().copied().collect();
    let mut axes: Vec<DVec3> = Vec::new();
    for f in a {
        axes.push(normal(f));
    }
    for f in b {
        let n = normal(f);
        axes.push(n);
        axes.extend(edges(f).map(|e| n.cross(e)));
    }
    for ea in a.iter().flat_map(|f| edges(f)) {
        for eb in b.iter().flat_map(|f| edges(f)) {
            axes.push(ea.cross(eb));
        }
    }
    let span = |pts: &[DVec3], d: DVec3| {
        pts.iter()
            .map(|p| p.dot(d))
            .fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)))
    };
    axes.into_iter()
        .filter_map(|d| d.try_normalize())
        .map(|d| {
            let ((a0, a1), (b0, b1)) = (span(&pa, d), span(&pb, d));
            (b0 - a1).max(a0 - b1)
        })
        .fold(f64::MIN, f64::max)
}

/// Smallest separation between any moving object and any static polygon or other
/// moving object of `s`, over `n` times spread evenly over the shot (ends included),
/// with where it happens.
fn min_clearance(s: &Scene, n: usize) -> (f64, String) {
    let mut worst = (f64::MAX, String::new());
    for i in 0..n {
        let t = s.time.start + (s.time.end - s.time.start) * i as f64 / (n - 1) as f64;
        let moving: Vec<(&Object, Vec<Vec<DVec3>>)> = s
            .objects
            .iter()
            .filter(|o| o.is_moving())
            .map(|o| (o, world_polygons(o, t)))
            .collect();
        for (k, (o, faces)) in moving.iter().enumerate() {
            for st in s.objects.iter().filter(|o| !o.is_moving()) {
                for (pi, poly) in world_polygons(st, t).into_iter().enumerate() {
                    let d = separation(faces, &[poly]);
                    if d < worst.0 {
                        worst = (
                            d,
                            format!("{} vs {} polygon {pi} at t = {t}", o.name, st.name),
                        );
                    }
                }
            }
            for (o2, faces2) in &moving[k + 1..] {
                let d = separation(faces, faces2);
                if d < worst.0 {
                    worst = (d, format!("{} vs {} at t = {t}", o.name, o2.name));
                }
            }
        }
    }
    worst
}

#[test]
fn moving_objects_stay_clear_at_200_times() {
    for s in [
        actor_scene(75),
        light_scene(75),
        actor_scene(150),
        light_scene(150),
    ] {
        let (d, place) = min_clearance(&s, 200);
        assert!(d >= 0.005, "clearance {d} m at {place}");
    }
    // ACTOR's actors hover 1 cm over the floor: the smallest gap in the scene.
    let (d, place) = min_clearance(&actor_scene(75), 200);
    assert!((d - 0.01).abs() < 1e-9, "{d} at {place}");
}

#[test]
fn clearance_test_detects_an_overlap() {
    // Guard of the test above: put actor A's path through the desk (x 0.6..2, z
    // 2.9..3.6) and the separation test must see it.
    let mut s = actor_scene(75);
    let a = s.objects.iter_mut().find(|o| o.name == "actor_a").unwrap();
    for k in &mut a.motion.as_mut().unwrap().keys {
        k.translation.z = 3.2;
    }
    let (d, place) = min_clearance(&s, 200);
    assert!(d < 0.0 && place.contains("desk"), "{d} at {place}");
    // And two boxes 2 cm apart are found 2 cm apart.
    let cube = |x0: f64| {
        let o = &actor_scene(75).objects;
        let body = &o.iter().find(|o| o.name == "actor_a").unwrap().polygons;
        body.iter()
            .map(|p| {
                p.vertices
                    .iter()
                    .map(|v| *v + DVec3::new(x0, 0.0, 0.0))
                    .collect()
            })
            .collect::<Vec<Vec<DVec3>>>()
    };
    assert!((separation(&cube(0.0), &cube(0.52)) - 0.02).abs() < 1e-12);
}

/// World position of the first vertex of object `name` at `t`.
fn position(s: &Scene, name: &str, t: f64) -> DVec3 {
    let o = s.objects.iter().find(|o| o.name == name).unwrap();
    o.to_world(t).transform_point3(o.polygons[0].vertices[1])
}

#[test]
fn longer_shots_walk_the_same_paths_back_and_forth() {
    for (short, long, names) in [
        (actor_scene(75), actor_scene(150), ["actor_a", "actor_b"]),
        (light_scene(75), light_scene(750), ["panel", "panel"]),
    ] {
        let end = long.time.end;
        for i in 0..=300 {
            let t = end * i as f64 / 300.0;
            // Phase in the back-and-forth walk: forward on even legs, back on odd.
            let leg = (t / 3.0).floor();
            let local = t - 3.0 * leg;
            let same = if leg as u64 % 2 == 0 {
                local
            } else {
                3.0 - local
            };
            for name in names {
                let (a, b) = (position(&long, name, t), position(&short, name, same));
                assert!(a.distance(b) < 1e-9, "{name} t = {t}: {a} vs {b}");
            }
        }
        // Same speed: the short shot covers its path once.
        for name in names {
            let d = position(&short, name, 0.0).distance(position(&short, name, 3.0));
            assert!(d > 1.5, "{name} moves {d} m");
        }
    }
}

/// True if the segment `a → b` crosses the axis-aligned box around `pts`.
fn segment_hits_box(a: DVec3, b: DVec3, pts: &[DVec3]) -> bool {
    let lo = pts.iter().copied().fold(DVec3::MAX, DVec3::min);
    let hi = pts.iter().copied().fold(DVec3::MIN, DVec3::max);
    let (mut s0, mut s1) = (0.0f64, 1.0f64);
    let d = b - a;
    for k in 0..3 {
        if d[k].abs() < 1e-300 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return false;
            }
            continue;
        }
        let (u, w) = ((lo[k] - a[k]) / d[k], (hi[k] - a[k]) / d[k]);
        s0 = s0.max(u.min(w));
        s1 = s1.min(u.max(w));
    }
    s0 <= s1
}

#[test]
fn light_board_hides_the_wall_lamp_mid_shot() {
    let s = light_scene(75);
    let board = s.objects.iter().find(|o| o.name == "panel").unwrap();
    let lamp = s.objects.iter().find(|o| o.name == "wall_lamp").unwrap();
    let corners = &lamp.polygons[0].vertices;
    let centre = DVec3::new(2.5, 1.1, 2.0); // middle of the room at the lamp's height
    let hidden = |t: f64| {
        let pts: Vec<DVec3> = world_polygons(board, t).into_iter().flatten().collect();
        corners
            .iter()
            .filter(|&&c| segment_hits_box(c, centre, &pts))
            .count()
    };
    assert_eq!(hidden(0.0), 0, "lamp visible at the start");
    assert_eq!(hidden(1.5), 4, "lamp hidden mid-shot");
    assert_eq!(hidden(3.0), 0, "lamp visible at the end");
}
