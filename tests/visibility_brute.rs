//! Accelerated visibility against brute force: the BVH box query and occlusion rays
//! against a loop over every triangle, and shaft culling against casting rays.

use glam::DVec3;
use rhier::geometry::{Patches, SceneBvh};
use rhier::oracle::hash3;
use rhier::shafts::Shaft;

fn u(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

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
