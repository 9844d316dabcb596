//! Accelerated visibility against brute force: the BVH box query and occlusion rays
//! against a loop over every triangle, and shaft culling against casting rays.

use glam::DVec3;
use rhier::geometry::{Patches, SceneBvh};
use rhier::oracle::{hash3, unit as u};
use rhier::shafts::Shaft;

fn tri_box_overlap_aabb(t: &[DVec3; 3], lo: DVec3, hi: DVec3) -> bool {
    let tl = t[0].min(t[1]).min(t[2]);
    let th = t[0].max(t[1]).max(t[2]);
    tl.x <= hi.x && tl.y <= hi.y && tl.z <= hi.z && th.x >= lo.x && th.y >= lo.y && th.z >= lo.z
}

#[test]
fn box_query_finds_every_overlapping_triangle() {
    let scene = rhier::scene::cornell_box(true);
    let patches = Patches::at_time(&scene, 0.0);
    let bvh = SceneBvh::build(&scene, &patches, 0.0);
    for k in 0..500u64 {
        let a = DVec3::new(u(hash3(k, 1, 0)), u(hash3(k, 2, 0)), u(hash3(k, 3, 0))) * 560.0;
        let b = a + DVec3::new(u(hash3(k, 4, 0)), u(hash3(k, 5, 0)), u(hash3(k, 6, 0))) * 200.0;
        let mut found = std::collections::BTreeSet::new();
        bvh.for_each_triangle_in_box(a, b, |p, _| {
            found.insert(p);
            true
        });
        for (i, poly) in patches.polys.iter().enumerate() {
            let c = poly.corners();
            for j in 1..c.len() - 1 {
                if tri_box_overlap_aabb(&[c[0], c[j], c[j + 1]], a, b) {
                    assert!(
                        found.contains(&(i as u32)),
                        "box {a:?}..{b:?}: patch {i} missed"
                    );
                }
            }
        }
    }
}

#[test]
fn clear_shafts_are_never_crossed_by_rays() {
    let scene = rhier::scene::cornell_box(true);
    let patches = Patches::at_time(&scene, 0.0);
    let bvh = SceneBvh::build(&scene, &patches, 0.0);
    let n = patches.len();
    let (mut clear, mut checked) = (0, 0);
    for i in 0..n {
        for j in 0..n {
            if i == j {
                continue;
            }
            let (a, b) = (&patches.polys[i], &patches.polys[j]);
            let s = Shaft::new(
                a.corners(),
                patches.normals[i],
                b.corners(),
                patches.normals[j],
            );
            if !s.is_clear(&bvh, [i as u32, j as u32]) {
                continue;
            }
            clear += 1;
            // Brute force: 64 segments between random points of the two patches.
            for k in 0..64u64 {
                let x = patches.point(
                    i,
                    u(hash3(i as u64, j as u64, k)),
                    u(hash3(j as u64, i as u64, k)),
                );
                let y = patches.point(j, u(hash3(i as u64, k, 9)), u(hash3(j as u64, k, 9)));
                let (x, y) = if patches.polys[i].n == 3 || patches.polys[j].n == 3 {
                    (patches.polys[i].centroid(), patches.polys[j].centroid())
                } else {
                    (x, y)
                };
                let len = (y - x).length();
                if patches.normals[i].dot(y - x) <= 1e-3 * len
                    || patches.normals[j].dot(x - y) <= 1e-3 * len
                {
                    continue;
                }
                checked += 1;
                assert!(
                    !bvh.occluded(x, y),
                    "patches {i} -> {j}: shaft clear but segment {x:?} {y:?} blocked"
                );
            }
        }
    }
    assert!(
        clear > 50 && checked > 300,
        "clear {clear} checked {checked}"
    );
}

/// Closest hit of `o + s·d`, `s ∈ (smin, 1]`, over every triangle (f64 Möller &
/// Trumbore): `(patch, s)`.
fn brute_closest(patches: &Patches, o: DVec3, d: DVec3, smin: f64) -> Option<(u32, f64)> {
    let mut best: Option<(u32, f64)> = None;
    for i in 0..patches.len() {
        let c = patches.polys[i].corners();
        for k in 1..c.len() - 1 {
            let (v0, v1, v2) = (c[0], c[k], c[k + 1]);
            let (e1, e2) = (v1 - v0, v2 - v0);
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-300 {
                continue;
            }
            let tv = o - v0;
            let a = tv.dot(p) / det;
            let q = tv.cross(e1);
            let b = d.dot(q) / det;
            let s = e2.dot(q) / det;
            if a >= 0.0
                && b >= 0.0
                && a + b <= 1.0
                && s > smin
                && s <= 1.0
                && best.is_none_or(|h| s < h.1)
            {
                best = Some((i as u32, s));
            }
        }
    }
    best
}

/// `SceneBvh::intersect` from points within a few 10⁻⁵ of the box's diameter of an
/// edge, into the face across it: obvhs' traversal drops nodes the ray leaves before
/// `t = 10⁻⁴`, and before the fix 147 of the 261 rays that hit that close went
/// through the face they were heading into (the path tracer's bounces leaked out of
/// closed rooms).
#[test]
fn closest_hits_near_the_rays_origin_are_found() {
    let scene = rhier::scene::cornell_box(false);
    let patches = Patches::at_time(&scene, 0.0);
    let bvh = SceneBvh::build(&scene, &patches, 0.0);
    let diam = patches.diameter;
    let (mut near, mut wrong) = (0, 0);
    for k in 0..2000u64 {
        let i = (hash3(k, 7, 0) % patches.len() as u64) as usize;
        // A point a hair from one of the patch's edges, a direction into its
        // hemisphere.
        let edge = u(hash3(k, 8, 0)) * 4e-5;
        let along = u(hash3(k, 9, 0));
        let (s, t) = match hash3(k, 10, 0) % 4 {
            0 => (edge, along),
            1 => (1.0 - edge, along),
            2 => (along, edge),
            _ => (along, 1.0 - edge),
        };
        let o = patches.point(i, s, t);
        let n = patches.normals[i];
        let r = DVec3::new(
            u(hash3(k, 11, 0)) - 0.5,
            u(hash3(k, 12, 0)) - 0.5,
            u(hash3(k, 13, 0)) - 0.5,
        );
        let dir = (r.normalize() + n * 0.3).normalize();
        if dir.dot(n) <= 0.05 {
            continue;
        }
        let d = dir * diam * 2.0;
        let want = brute_closest(&patches, o, d, 1e-6);
        let got = bvh.intersect(o, d, 1e-6, 1.0);
        if want.is_some_and(|w| w.1 < 1e-4) {
            near += 1;
        }
        let agree = match (want, got) {
            (None, None) => true,
            (Some(w), Some(g)) => w.0 == g.patch || (w.1 - g.t).abs() < 1e-6,
            _ => false,
        };
        if !agree {
            wrong += 1;
            eprintln!("ray {k}: brute force {want:?}, BVH {got:?}");
        }
    }
    eprintln!("{near} rays hit within 1e-4 of their origin");
    assert!(near > 100, "too few rays test the near range: {near}");
    assert_eq!(wrong, 0);
}

/// The shadow cache ([`rhier::geometry::LastHit`]) changes which triangle a
/// segment is tested against first, never the answer: bundles of 8 segments from a
/// point of one patch to points of another (the solver's rays), on ACTOR at a time
/// its actors are in the room, each answer taken with one cache carried through
/// every bundle and every part asked (static, moving, all) against the same query
/// without a cache. Every second bundle starts on the patch that blocked the last
/// blocked segment, so the cache offers it a triangle of a patch it skips (a
/// segment leaving a patch seldom meets that patch's own triangles, so this guards
/// the skip rule at grazing angles only; dropping the test of which parts a query
/// asks fails it).
#[test]
fn the_shadow_cache_never_changes_an_answer() {
    use rhier::geometry::{LastHit, Parts};
    let t = 1.2;
    let scene = rhier::scene::actor_scene(75);
    let patches = Patches::at_time(&scene, t);
    let bvh = SceneBvh::build(&scene, &patches, t);
    let n = patches.len() as u64;
    let mut last = LastHit::default();
    let (mut rays, mut blocked, mut full, mut skipped) = (0, 0, 0, 0);
    let mut blocker: Option<u32> = None;
    for k in 0..4000u64 {
        let i = match blocker.take() {
            Some(p) if k % 2 == 1 => {
                skipped += 1;
                p as usize
            }
            _ => (hash3(k, 1, 7) % n) as usize,
        };
        let j = (hash3(k, 2, 7) % n) as usize;
        if i == j {
            continue;
        }
        let x = patches.point(i, u(hash3(k, 3, 7)), u(hash3(k, 4, 7)));
        for which in [Parts::All, Parts::Static, Parts::Moving] {
            let mut hidden = 0;
            for r in 0..8u64 {
                let y = patches.point(j, u(hash3(k, r, 8)), u(hash3(k, r, 9)));
                let skip = [i as u32, j as u32];
                let plain = bvh.occluded_by(x, y, skip, which);
                let cached = bvh.occluded_cached(x, y, skip, which, &mut last);
                assert_eq!(
                    plain, cached,
                    "bundle {k}, ray {r}, {which:?}: {x:?} -> {y:?} skipping {skip:?}"
                );
                rays += 1;
                if plain {
                    hidden += 1;
                    blocked += 1;
                    if which == Parts::All {
                        blocker = bvh
                            .intersect(x, y - x, rhier::geometry::SEGMENT_TRIM, 1.0)
                            .map(|h| h.patch)
                            .filter(|&p| p != i as u32 && p != j as u32);
                    }
                }
            }
            full += usize::from(hidden == 8);
        }
    }
    // The cache is offered bundles it can serve and bundles it must not.
    assert!(rays > 80_000, "{rays} rays");
    assert!(
        blocked > rays / 10 && full > 500,
        "{blocked} of {rays} blocked, {full} bundles whole"
    );
    assert!(skipped > 300, "{skipped} bundles from the last blocker");
}

/// Occlusion answers of `bvh` for random segments between points of random patch
/// pairs (`n` pairs, 8 segments each), in every form the solver asks: between
/// surfaces (`occluded_between`, twins skipped) and with the plain trim
/// (`occluded_by`), over each set of parts; segments within 1° of their end
/// patches' planes left out when `all` is false. Also the number blocked.
fn occlusion_answers(bvh: &SceneBvh, patches: &Patches, n: u64, all: bool) -> (Vec<bool>, usize) {
    use rhier::geometry::{LastHit, Parts};
    let np = patches.len() as u64;
    let mut out = Vec::new();
    let mut last = LastHit::default();
    for k in 0..n {
        let (i, j) = (
            (hash3(k, 1, 5) % np) as usize,
            (hash3(k, 2, 5) % np) as usize,
        );
        if i == j {
            continue;
        }
        let x = patches.point(i, u(hash3(k, 3, 5)), u(hash3(k, 4, 5)));
        let skip = [i as u32, j as u32];
        for which in [Parts::All, Parts::Static, Parts::Moving] {
            for r in 0..8u64 {
                let y = patches.point(j, u(hash3(k, r, 6)), u(hash3(k, r, 7)));
                // Under 1° to its end patches: the segment may lie in their
                // plane, along coplanar neighbours that only round-off makes it
                // cross (between two points of the Cornell box's ceiling, obvhs
                // found the lamp in the way, Embree did not); the kernel weighs
                // such a ray by the cosine it makes, under sin 1°.
                let e = y - x;
                let sin = (patches.normals[i].dot(e).abs()).min(patches.normals[j].dot(e).abs());
                if !all && sin < 1f64.to_radians().sin() * e.length() {
                    continue;
                }
                out.push(bvh.occluded_between(x, y, skip, which, &mut last));
                out.push(bvh.occluded_by(x, y, skip, which));
            }
        }
    }
    let blocked = out.iter().filter(|&&b| b).count();
    (out, blocked)
}

/// The Embree backend (`RHIER_RAYS=embree`, its library opened at run time)
/// answers every occlusion query as obvhs does: both decide the candidates by the
/// same f64 test, and Embree's dilated triangles hold every candidate obvhs' padded
/// boxes do but for rays grazing an edge at under 1° (and segments lying in the
/// plane of their ends' patches, left out). On the Cornell box with its blocks,
/// ACTOR mid-motion (moving parts in object space), the touching boxes of
/// `solver::scale_free` (triangles of unequal sizes, T-junctions, faces in
/// contact) and a room with a pillar in 6×6 quads per face. Also: `RHIER_RAYS`
/// chooses what `SceneBvh::build` casts with, so that CI's pass with
/// `RHIER_RAYS=embree` runs the suite on Embree.
///
/// Where Embree cannot be loaded (and `RHIER_RAYS` does not ask for it, which
/// fails at `Rays::from_env`), asking for it is an error naming the library and
/// how to install it, which leaves the backend casting the rays as it was.
#[test]
fn embree_answers_every_occlusion_query_as_obvhs() {
    use rhier::geometry::Rays;
    let t = 1.2;
    use crate::common::shapes::{self, Tiling};
    let m = rhier::scene::MaterialId(0);
    let scenes = [
        ("cornell", rhier::scene::cornell_box(true)),
        ("actor", rhier::scene::actor_scene(75)),
        ("touching boxes", shapes::touching_boxes()),
        (
            "pillar room, 6x6 quads",
            shapes::uniform_scene(
                shapes::room_with_pillar_and_box(Tiling::Quads(6), m),
                0.5,
                1.0,
            ),
        ),
    ];
    for (name, scene) in &scenes {
        let patches = Patches::at_time(scene, t);
        let mut bvh = SceneBvh::build(scene, &patches, t);
        assert_eq!(bvh.rays(), Rays::from_env().unwrap(), "{name}");
        bvh.set_rays(Rays::Obvhs).unwrap();
        if let Err(e) = bvh.set_rays(Rays::Embree) {
            let e = e.to_string();
            assert!(
                e.contains("libembree3.so.3: ") && e.contains("apt-get install libembree3-3"),
                "{e}"
            );
            assert_eq!(bvh.rays(), Rays::Obvhs);
            continue;
        }
        bvh.set_rays(Rays::Obvhs).unwrap();
        let (obvhs, blocked) = occlusion_answers(&bvh, &patches, 3000, false);
        bvh.set_rays(Rays::Embree).unwrap();
        assert_eq!(bvh.rays(), Rays::Embree);
        let (embree, _) = occlusion_answers(&bvh, &patches, 3000, false);
        let differ = obvhs.iter().zip(&embree).filter(|(a, b)| a != b).count();
        assert!(
            blocked > obvhs.len() / 20,
            "{name}: {blocked} of {} blocked",
            obvhs.len()
        );
        assert_eq!(
            differ,
            0,
            "{name}: {differ} of {} answers differ",
            obvhs.len()
        );
    }
}

/// Segments made to graze: between corners of two patches (through vertices, along
/// shared edges), between points on their edges, and between points of patches in
/// one plane (along coplanar neighbours, which only round-off can make a segment
/// cross); each cast as between surfaces (twins skipped), with the plain trim, and
/// the patches' skips dropped (so that the segments' own end patches and their
/// neighbours are candidates at the trim); over every set of parts. Also the number
/// blocked.
fn grazing_answers(bvh: &SceneBvh, patches: &Patches, n: u64) -> (Vec<bool>, usize) {
    use rhier::geometry::{LastHit, Parts};
    let np = patches.len() as u64;
    let mut out = Vec::new();
    let mut last = LastHit::default();
    // A point on the boundary of patch `i`: corner `c`, or along the edge from it.
    let edge = |i: usize, c: usize, s: f64| {
        let v = patches.polys[i].corners();
        v[c % v.len()].lerp(v[(c + 1) % v.len()], s)
    };
    for k in 0..n {
        let (i, j) = (
            (hash3(k, 1, 15) % np) as usize,
            (hash3(k, 2, 15) % np) as usize,
        );
        let coplanar = (patches.normals[i].dot(patches.normals[j]) - 1.0).abs() < 1e-12
            && patches.normals[i]
                .dot(patches.polys[j].corners()[0] - patches.polys[i].corners()[0])
                .abs()
                < 1e-12;
        let mut segs = Vec::new();
        for r in 0..4u64 {
            let (ci, cj) = (
                (hash3(k, r, 16) % 8) as usize,
                (hash3(k, r, 17) % 8) as usize,
            );
            segs.push((edge(i, ci, 0.0), edge(j, cj, 0.0)));
            let (si, sj) = (u(hash3(k, r, 18)), u(hash3(k, r, 19)));
            segs.push((edge(i, ci, si), edge(j, cj, sj)));
            segs.push((edge(i, ci, 0.5), edge(j, cj, 0.5)));
            if coplanar || r == 0 {
                let x = patches.point(i, u(hash3(k, r, 20)), u(hash3(k, r, 21)));
                let y = patches.point(j, u(hash3(k, r, 22)), u(hash3(k, r, 23)));
                segs.push((x, y));
            }
        }
        for (x, y) in segs {
            if (y - x).length() == 0.0 {
                continue;
            }
            for which in [Parts::All, Parts::Static, Parts::Moving] {
                let skip = [i as u32, j as u32];
                out.push(bvh.occluded_between(x, y, skip, which, &mut last));
                out.push(bvh.occluded_by(x, y, skip, which));
                out.push(bvh.occluded_by(x, y, [u32::MAX; 2], which));
            }
        }
    }
    let blocked = out.iter().filter(|&&b| b).count();
    (out, blocked)
}

/// The default occlusion traversal (`Rays::Obvhs`, rhier's 4-wide BVH over obvhs'
/// PLOC tree, `geometry::wide`) answers every query as obvhs' CWBVH traversal
/// (`Rays::Cwbvh`, the default before): both are built on the same padded triangle
/// boxes and decide each candidate by the same f64 test, so an answer could differ
/// only if one of them lost a candidate the f64 test hits. Random segments between
/// patches, with no angle left out, and the grazing ones of [`grazing_answers`]
/// (through corners, along edges, in the plane of coplanar neighbours, ends' patches
/// not skipped), on the Cornell box with its blocks, ACTOR mid-motion (moving parts
/// in object space), the touching boxes of `solver::scale_free` (T-junctions, faces
/// in contact), a room with a pillar in 6×6 quads per face (coplanar tiles), and
/// the same in millimetres and kilometres (scale-free f32).
#[test]
fn the_4_wide_traversal_answers_every_occlusion_query_as_the_cwbvh() {
    type Answers = fn(&SceneBvh, &Patches, u64) -> (Vec<bool>, usize);
    use crate::common::shapes::{self, Tiling};
    use rhier::geometry::Rays;
    let t = 1.2;
    let m = rhier::scene::MaterialId(0);
    let pillar = || {
        shapes::uniform_scene(
            shapes::room_with_pillar_and_box(Tiling::Quads(6), m),
            0.5,
            1.0,
        )
    };
    let scaled = |mut s: rhier::scene::Scene, k: f64| {
        for o in &mut s.objects {
            for p in &mut o.polygons {
                for v in &mut p.vertices {
                    *v *= k;
                }
            }
        }
        s
    };
    let scenes = [
        ("cornell", rhier::scene::cornell_box(true)),
        ("actor", rhier::scene::actor_scene(75)),
        ("touching boxes", shapes::touching_boxes()),
        ("pillar room, 6x6 quads", pillar()),
        ("pillar room in mm", scaled(pillar(), 1e3)),
        ("pillar room in km", scaled(pillar(), 1e-3)),
    ];
    for (name, scene) in &scenes {
        let patches = Patches::at_time(scene, t);
        let mut bvh = SceneBvh::build(scene, &patches, t);
        for (kind, answers) in [
            (
                "random",
                (|b, p, n| occlusion_answers(b, p, n, true)) as Answers,
            ),
            ("grazing", grazing_answers),
        ] {
            bvh.set_rays(Rays::Obvhs).unwrap();
            let (wide, blocked) = answers(&bvh, &patches, 1500);
            bvh.set_rays(Rays::Cwbvh).unwrap();
            let (cwbvh, _) = answers(&bvh, &patches, 1500);
            let differ = wide.iter().zip(&cwbvh).filter(|(a, b)| a != b).count();
            assert!(
                blocked > wide.len() / 20 && blocked < wide.len() * 19 / 20,
                "{name}, {kind}: {blocked} of {} blocked",
                wide.len()
            );
            assert_eq!(
                differ,
                0,
                "{name}, {kind}: {differ} of {} answers differ",
                wide.len()
            );
        }
    }
}

/// A surface's back side cut into other pieces than its front, a hair in front of
/// it, as contact meshing leaves a two-sided slab's two sides (issue 45, part 4:
/// on Blender's Cornell box the ceiling's back side, 3·10⁻⁸ m off the room side's
/// plane and no twin of it bit for bit, blocked every ray from the final gather's
/// points by the ceiling's corner to the green wall, the floor and the red wall):
/// a segment from the front to the floor facing it is not blocked by it; a real
/// occluder 1 mm under the front still blocks. Before (`SURFACE_TRIM` only): all
/// 64 segments blocked.
#[test]
fn a_surfaces_own_back_side_cut_otherwise_does_not_block_it() {
    use rhier::geometry::{LastHit, Parts};
    use rhier::scene::{MaterialId, Polygon};
    let quad = |v: [DVec3; 4]| Polygon {
        vertices: v.to_vec(),
        material: MaterialId(0),
    };
    let (lo, hi) = (0.0, 2.0);
    // The ceiling at y = 2, facing down.
    let ceiling = quad([
        DVec3::new(lo, 2.0, lo),
        DVec3::new(hi, 2.0, lo),
        DVec3::new(hi, 2.0, hi),
        DVec3::new(lo, 2.0, hi),
    ]);
    // Its back side, facing up, in two halves 3e-8 under it.
    let y = 2.0 - 3e-8;
    let back = |x0: f64, x1: f64| {
        quad([
            DVec3::new(x0, y, lo),
            DVec3::new(x0, y, hi),
            DVec3::new(x1, y, hi),
            DVec3::new(x1, y, lo),
        ])
    };
    // The floor at y = 0, facing up.
    let floor = quad([
        DVec3::new(lo, 0.0, lo),
        DVec3::new(lo, 0.0, hi),
        DVec3::new(hi, 0.0, hi),
        DVec3::new(hi, 0.0, lo),
    ]);
    let scene = crate::common::shapes::uniform_scene(
        vec![ceiling, back(lo, 1.0), back(1.0, hi), floor],
        0.5,
        0.0,
    );
    let patches = Patches::at_time(&scene, 0.0);
    let bvh = SceneBvh::build(&scene, &patches, 0.0);
    assert_eq!(rhier::geometry::twin_patches(&patches)[0], u32::MAX);
    let mut last = LastHit::default();
    let mut blocked = 0;
    for k in 0..64u64 {
        let x = patches.point(0, u(hash3(k, 1, 31)), u(hash3(k, 2, 31)));
        let f = patches.point(3, u(hash3(k, 3, 31)), u(hash3(k, 4, 31)));
        blocked += usize::from(bvh.occluded_between(x, f, [0, 3], Parts::All, &mut last));
    }
    assert_eq!(
        blocked, 0,
        "{blocked} of 64 segments blocked by the back side"
    );
    // A real occluder 1 mm under the ceiling blocks: a small plate under the point.
    let plate = quad([
        DVec3::new(0.9, 2.0 - 1e-3, 0.9),
        DVec3::new(1.1, 2.0 - 1e-3, 0.9),
        DVec3::new(1.1, 2.0 - 1e-3, 1.1),
        DVec3::new(0.9, 2.0 - 1e-3, 1.1),
    ]);
    let scene = crate::common::shapes::uniform_scene(
        vec![
            patches_poly(&scene, 0),
            patches_poly(&scene, 1),
            patches_poly(&scene, 2),
            patches_poly(&scene, 3),
            plate,
        ],
        0.5,
        0.0,
    );
    let patches = Patches::at_time(&scene, 0.0);
    let bvh = SceneBvh::build(&scene, &patches, 0.0);
    let x = DVec3::new(1.0, 2.0, 1.0);
    let f = DVec3::new(1.0, 0.0, 1.0);
    assert!(bvh.occluded_between(x, f, [0, 3], Parts::All, &mut LastHit::default()));
}

/// Polygon `i` of `scene`'s only object.
fn patches_poly(scene: &rhier::scene::Scene, i: usize) -> rhier::scene::Polygon {
    scene.objects[0].polygons[i].clone()
}
