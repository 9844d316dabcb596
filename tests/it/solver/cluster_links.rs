//! Links with a cluster end (issue 2): visibility by rays between the ends' surfaces,
//! and the directional emission of a flat emitter cluster.

use glam::DVec3;
use rhier::geometry::{Poly, point_to_polygon};
use rhier::oracle::{self, EvalSettings};
use rhier::pools::{ElementId, ElementKind};
use rhier::scene::{Material, MaterialId, Object, Polygon, Scene};
use rhier::solver::{SolveOptions, Solver};

fn white() -> Material {
    Material::diffuse("white", [0.7, 0.7, 0.7])
}

fn lamp() -> Material {
    Material {
        name: "lamp".into(),
        rho: [0.5, 0.5, 0.5],
        emission: [10.0, 10.0, 10.0],
    }
}

/// Quad from corners listed clockwise seen from its front (reversed here).
fn quad(v: [DVec3; 4], m: u32) -> Polygon {
    Polygon {
        vertices: v.iter().rev().copied().collect(),
        material: MaterialId(m),
    }
}

/// Inward-facing box `[lo, hi]` (side `skip` left out: 0 = −x, 1 = +x), with a lamp
/// under its ceiling if `lit`.
fn room(name: &str, lo: DVec3, hi: DVec3, lit: bool, skip: Option<usize>) -> Object {
    let c = |x: usize, y: usize, z: usize| {
        DVec3::new(
            if x == 0 { lo.x } else { hi.x },
            if y == 0 { lo.y } else { hi.y },
            if z == 0 { lo.z } else { hi.z },
        )
    };
    let mut polygons = vec![
        quad([c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], 0),
        quad([c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)], 0),
        quad([c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], 0),
        quad([c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)], 0),
        quad([c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)], 0),
        quad([c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], 0),
    ];
    if let Some(k) = skip {
        polygons.remove(2 + k);
    }
    if lit {
        let mid = (lo + hi) * 0.5;
        polygons.push(quad(
            [
                DVec3::new(mid.x - 0.3, hi.y - 1e-3, mid.z - 0.3),
                DVec3::new(mid.x - 0.3, hi.y - 1e-3, mid.z + 0.3),
                DVec3::new(mid.x + 0.3, hi.y - 1e-3, mid.z + 0.3),
                DVec3::new(mid.x + 0.3, hi.y - 1e-3, mid.z - 0.3),
            ],
            1,
        ));
    }
    Object::still(name, polygons)
}

/// Room A (lit) and room B, 6 apart along x; `walls`: closed, else the facing walls
/// are left out (A's +x, B's −x) and light passes between the openings.
fn two_rooms(walls: bool) -> Scene {
    let a = room(
        "room_a",
        DVec3::ZERO,
        DVec3::splat(2.0),
        true,
        (!walls).then_some(1),
    );
    let b = room(
        "room_b",
        DVec3::new(8.0, 0.0, 0.0),
        DVec3::new(10.0, 2.0, 2.0),
        false,
        (!walls).then_some(0),
    );
    Scene {
        materials: vec![white(), lamp()],
        objects: vec![a, b],
        ..Scene::default()
    }
}

fn coarse() -> SolveOptions {
    SolveOptions {
        eps: 1.0,
        contact_meshing: false,
        ..SolveOptions::default()
    }
}

/// Box `(lo, hi)` of an element.
fn element_box(s: &Solver, e: u32) -> (DVec3, DVec3) {
    let g = &s.elems.geoms.as_slice()[e as usize];
    let k = if g.patch == u32::MAX { 2 } else { g.n as usize };
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in &g.corners[..k] {
        lo = lo.min(DVec3::from_array(*p));
        hi = hi.max(DVec3::from_array(*p));
    }
    (lo, hi)
}

/// Cluster links between the rooms (one end wholly in A, x < 5, the other wholly in
/// B) and their largest coefficient; and the area-weighted mean radiosity of room
/// B's leaves. `sealed`: [`SolveOptions::sealed_regions`] (off, the links between
/// the rooms are made and their rays must find the walls; on, the closed dark room
/// is left out whole and no link reaches it).
fn solve_rooms(walls: bool, sealed: bool) -> (usize, f64, f64) {
    let scene = two_rooms(walls);
    let opts = SolveOptions {
        sealed_regions: sealed,
        ..coarse()
    };
    let mut s = Solver::new(&scene, opts).unwrap();
    s.run(|_, _| {}).unwrap();
    let mut between = 0;
    let mut fmax: f64 = 0.0;
    let ends = s.links.ends.as_slice();
    let tr = s.links.transports.as_slice();
    for (e, t) in ends.iter().zip(tr) {
        let cluster = s.elems.kind(ElementId(e.receiver)) == ElementKind::Cluster
            || s.elems.kind(ElementId(e.source)) == ElementKind::Cluster;
        let (r, src) = (element_box(&s, e.receiver), element_box(&s, e.source));
        let apart = (r.1.x < 5.0 && src.0.x > 5.0) || (src.1.x < 5.0 && r.0.x > 5.0);
        if cluster && apart {
            between += 1;
            fmax = fmax.max(t.f as f64);
        }
    }
    let (mut sum, mut area) = (0.0, 0.0);
    let sol = s.solution();
    for l in &sol.leaves {
        if s.patches.objects[l.patch as usize] != 1 {
            continue;
        }
        let a = s.patches.areas[l.patch as usize];
        for c in 0..l.corners as usize {
            sum += a * l.b[c][0] as f64 / l.corners as f64;
        }
        area += a;
    }
    // And the leaf radiosities of the hierarchy itself.
    for (p, _, b) in s.leaf_radiosities() {
        if s.patches.objects[p as usize] == 1 && walls {
            assert_eq!(b, [0.0; 3], "a leaf of the closed dark room is lit");
        }
    }
    (between, fmax, sum / area)
}

#[test]
fn a_closed_dark_room_gets_no_light_through_cluster_links() {
    let (between, fmax, b_dark) = solve_rooms(true, false);
    assert!(
        between > 0,
        "no cluster link between the rooms was evaluated"
    );
    assert_eq!(fmax, 0.0, "a cluster link leaks through the walls");
    assert_eq!(b_dark, 0.0, "the closed dark room is lit: {b_dark}");
    // With the facing walls open, the same links carry light, whether the solve
    // looks for sealed regions or not (there is none).
    for sealed in [false, true] {
        let (between, fmax, b_open) = solve_rooms(false, sealed);
        assert!(between > 0);
        assert!(fmax > 0.0);
        assert!(b_open > 1e-3, "the open dark room gets no light: {b_open}");
    }
    // Closed and left out as sealed: no link between the rooms at all, and black.
    let (between, _, b_dark) = solve_rooms(true, true);
    assert_eq!(between, 0);
    assert_eq!(b_dark, 0.0);
}

/// A flat lamp of 2×2 emitting quads in the plane z = 0 facing +z (side 0.4), and
/// two small receivers 6 away: one on the lamp's axis facing it (head-on), one in
/// the lamp's plane facing it (edge-on).
fn flat_lamp() -> Scene {
    let h = 0.2;
    let mut lamp_quads = Vec::new();
    for (x0, y0) in [(-h, -h), (0.0, -h), (-h, 0.0), (0.0, 0.0)] {
        // Counter-clockwise seen from +z: listed clockwise for `quad`.
        lamp_quads.push(quad(
            [
                DVec3::new(x0, y0, 0.0),
                DVec3::new(x0, y0 + h, 0.0),
                DVec3::new(x0 + h, y0 + h, 0.0),
                DVec3::new(x0 + h, y0, 0.0),
            ],
            1,
        ));
    }
    let r = 0.02;
    // Facing −z at (dx, 0, z).
    let facing_down_z = |dx: f64, z: f64| {
        quad(
            [
                DVec3::new(dx - r, -r, z),
                DVec3::new(dx + r, -r, z),
                DVec3::new(dx + r, r, z),
                DVec3::new(dx - r, r, z),
            ],
            0,
        )
    };
    let head = facing_down_z(0.0, 6.0);
    // Facing −y at y = 3, in the lamp's plane.
    let edge = quad(
        [
            DVec3::new(-r, 3.0, -r),
            DVec3::new(-r, 3.0, r),
            DVec3::new(r, 3.0, r),
            DVec3::new(r, 3.0, -r),
        ],
        0,
    );
    // Two far patches, so that the median split of the cluster tree (along z, the
    // longest axis) puts the lamp's four quads in one cluster.
    let far = vec![facing_down_z(1.0, 7.0), facing_down_z(-1.0, 8.0)];
    Scene {
        materials: vec![white(), lamp()],
        objects: vec![
            Object::still("lamp", lamp_quads),
            Object::still("head", vec![head]),
            Object::still("edge", vec![edge]),
            Object::still("far", far),
        ],
        ..Scene::default()
    }
}

#[test]
fn a_flat_emitter_cluster_radiates_like_its_surface() {
    let scene = flat_lamp();
    let s = Solver::new(&scene, SolveOptions::default()).unwrap();
    let geoms = s.elems.geoms.as_slice();
    let lamp_area = 0.16;
    // The cluster holding exactly the lamp's four quads.
    let lamp = (0..s.elems.len() as u32)
        .find(|&e| {
            let g = &geoms[e as usize];
            g.patch == u32::MAX
                && (g.area - lamp_area).abs() < 1e-9
                && g.corners[1][2] < 0.1
                && g.corners[0][2] > -0.1
        })
        .map(ElementId)
        .expect("a cluster of the lamp's quads");
    let root_of = |object: u32| {
        (0..s.elems.len() as u32)
            .find(|&e| {
                let g = &geoms[e as usize];
                g.patch != u32::MAX && s.patches.objects[g.patch as usize] == object
            })
            .map(ElementId)
            .unwrap()
    };
    let set = EvalSettings {
        rays_per_point: 4,
        cluster_rays: 8,
        seed: 7,
        sources_by_power: true,
    };
    let whole = Poly::new(&[
        DVec3::new(-0.2, -0.2, 0.0),
        DVec3::new(0.2, -0.2, 0.0),
        DVec3::new(0.2, 0.2, 0.0),
        DVec3::new(-0.2, 0.2, 0.0),
    ]);
    for (object, x, n) in [
        (1, DVec3::new(0.0, 0.0, 6.0), DVec3::NEG_Z),
        (2, DVec3::new(0.0, 3.0, 0.0), DVec3::NEG_Y),
    ] {
        let r = root_of(object);
        let ev = oracle::evaluate(
            &s.elems,
            &s.bvh,
            r,
            lamp,
            [r.0 as u64, lamp.0 as u64],
            &set,
            1e-9,
        );
        assert!(!ev.empty);
        let exact = point_to_polygon(x, n, &whole);
        let (f, spread) = (ev.transport.f as f64, ev.transport.spread as f64);
        // Within the error bound, and (nothing in the way) fully visible.
        assert!(
            (f - exact).abs() <= spread,
            "object {object}: {f} vs {exact} ± {spread}"
        );
        assert_eq!(ev.transport.visibility, 1.0);
        if object == 1 {
            // Head-on: cos θ = 1, not the isotropic 1/4.
            assert!(exact > 1e-3);
            assert!((f - exact).abs() <= 0.02 * exact, "{f} vs {exact}");
        } else {
            assert!(exact.abs() < 1e-12);
            assert!(f <= 1e-6, "edge-on: {f}");
        }
    }
}

/// Writes LIGHT at t = 0 with its motion removed (a static scene file both `rhier
/// solve` and `rhier reference` read) to `$LIGHT_T0_OUT`: the input of
/// `tools/light_left_wall.py`, which measures the left wall's error against the path
/// tracer for BENCHMARKS.md "## Cluster links". Run with
/// `LIGHT_T0_OUT=light_t0.json cargo test --release --test it solver::cluster_links::write_light_at_t0 -- --ignored`.
#[test]
#[ignore = "writes $LIGHT_T0_OUT for tools/light_left_wall.py"]
fn write_light_at_t0() {
    let out = std::env::var_os("LIGHT_T0_OUT").expect("LIGHT_T0_OUT names the file to write");
    let mut scene = rhier::scene::light_scene(75);
    for o in &mut scene.objects {
        if let Some(m) = o.motion.take() {
            let world = m.at(scene.time.start);
            for p in &mut o.polygons {
                for v in &mut p.vertices {
                    *v = world.transform_point3(*v);
                }
            }
        }
    }
    scene.time.end = scene.time.start;
    std::fs::write(out, rhier::scene::to_json_string(&scene)).unwrap();
}

/// Two coplanar quads side by side at z = 0 facing +z, `bright` (index 0) on the
/// left and `dark` (index 1) on the right, a black blocker at z = 1 over the dark
/// one, and a black receiver at z = 6 over the middle, facing down; two far patches
/// so the cluster tree puts the two quads and the blocker in one cluster (the
/// blocker turns its back on the receiver: its samples weigh nothing).
fn half_hidden() -> Scene {
    let black = Material::diffuse("black", [0.0; 3]);
    let at = |x0: f64, x1: f64, h: f64, z: f64, m: u32| {
        quad(
            [
                DVec3::new(x0, -h, z),
                DVec3::new(x0, h, z),
                DVec3::new(x1, h, z),
                DVec3::new(x1, -h, z),
            ],
            m,
        )
    };
    let down = |x0: f64, x1: f64, h: f64, z: f64| {
        quad(
            [
                DVec3::new(x0, -h, z),
                DVec3::new(x1, -h, z),
                DVec3::new(x1, h, z),
                DVec3::new(x0, h, z),
            ],
            2,
        )
    };
    Scene {
        materials: vec![white(), lamp(), black],
        objects: vec![
            Object::still(
                "pair",
                vec![at(-0.4, -0.2, 0.1, 0.0, 1), at(0.2, 0.4, 0.1, 0.0, 0)],
            ),
            Object::still("blocker", vec![down(0.1, 0.5, 0.2, 1.0)]),
            Object::still("receiver", vec![down(-0.02, 0.02, 0.02, 6.0)]),
            Object::still(
                "far",
                vec![down(1.0, 1.2, 0.1, 7.0), down(-1.2, -1.0, 0.1, 8.0)],
            ),
        ],
        ..Scene::default()
    }
}

/// A cluster's visibility is that of the light it hands on: its sample points are
/// drawn by power. Of two quads, one bright and seen from the receiver, one hidden
/// behind a blocker, the receiver sees all of the cluster's light when the hidden
/// one is dark, and half when both are as bright (by area it would be half both
/// times: the ceiling over a floor of black boxes was 7.2% too bright).
#[test]
fn a_cluster_is_seen_by_the_light_it_hands_on() {
    let scene = half_hidden();
    let mut s = Solver::new(&scene, SolveOptions::default()).unwrap();
    let n = s.elems.len();
    // The cluster of the two quads and the blocker.
    let pair = (0..n as u32)
        .find(|&e| {
            let g = &s.elems.geoms.as_slice()[e as usize];
            g.patch == u32::MAX
                && (g.area - 0.24).abs() < 1e-9
                && g.corners[0][2] > -0.01
                && g.corners[1][2] < 1.01
        })
        .map(ElementId)
        .expect("a cluster of the two quads and the blocker");
    let patch_of = |object: u32, s: &Solver| {
        (0..s.patches.objects.len() as u32)
            .find(|&p| s.patches.objects[p as usize] == object)
            .unwrap()
    };
    let (bright, receiver) = (patch_of(0, &s), patch_of(2, &s));
    let dark = bright + 1;
    assert_eq!(s.patches.objects[dark as usize], 0);
    let x = DVec3::new(0.0, 0.0, 6.0);
    // By area (a space-time window's choice) half the rays are blocked either way.
    for (dark_b, by_power, expected) in [(0.0, true, 1.0), (1.0, true, 0.5), (0.0, false, 0.5)] {
        // Radiosity by patch, clusters the area-weighted mean of their children
        // (children come after their parent).
        let mut b = vec![0.0f64; n];
        for e in (0..n).rev() {
            let g = s.elems.geoms.as_slice()[e];
            let node = s.elems.nodes.as_slice()[e];
            b[e] = if g.patch != u32::MAX {
                match g.patch {
                    p if p == bright => 1.0,
                    p if p == dark => dark_b,
                    _ => 0.0,
                }
            } else {
                let kids =
                    node.first_child as usize..(node.first_child + node.child_count) as usize;
                let a: f64 = kids.clone().map(|c| s.elems.geoms.as_slice()[c].area).sum();
                kids.map(|c| s.elems.geoms.as_slice()[c].area * b[c])
                    .sum::<f64>()
                    / a
            };
        }
        for (out, v) in s.elems.radiosities.as_mut_slice().iter_mut().zip(&b) {
            *out = [*v as f32; 3];
        }
        let (vis, rays) = oracle::point_cluster_visibility(
            &s.elems,
            &s.bvh,
            x,
            DVec3::NEG_Z,
            receiver,
            pair,
            64,
            11,
            by_power,
        );
        // By area, two thirds of the points fall on the blocker's back and cast nothing.
        let cast = if by_power { 64..=64 } else { 10..=40 };
        assert!(cast.contains(&rays), "{rays} rays");
        assert!(
            (vis - expected).abs() < 0.15,
            "hidden quad's radiosity {dark_b}, by power {by_power}: visibility {vis}, expected {expected}"
        );
    }
    assert!(s.elems.kind(pair) == ElementKind::Cluster);
}
