//! Nearest-patch queries: a bounding-volume hierarchy over patch bounds, and exact
//! point-to-polygon distances.
//!
//! The tree is built top-down (median split of the centroids along the widest axis,
//! up to [`LEAF_SIZE`] patches per leaf node) and queried depth-first, nearer child
//! first, pruning nodes whose box is farther than the best distance found. Ties are
//! broken by the smaller patch index, so the answer equals the brute-force scan's
//! ([`nearest_brute_force`], used by the tests). Distances are exact
//! ([`closest_point_triangle`], Ericson, *Real-Time Collision Detection* §5.1.5); a quad
//! is the union of the triangles `v0 v1 v2` and `v0 v2 v3`. It does not handle moving
//! geometry: build one per frame.

use glam::DVec3;

use super::frame::WorldPatch;

/// Most patches per leaf node.
pub const LEAF_SIZE: usize = 4;

/// One node, 56 bytes: bounds, then either children (`count == 0`: `first` is the
/// left child, `first + 1` the right) or `count` items from `first`.
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    first: u32,
    count: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 56);

/// A BVH over a subset of patches.
#[derive(Clone, Debug, Default)]
pub struct NearestIndex {
    nodes: Vec<Node>,
    items: Vec<u32>,
}

/// Closest point to `p` on triangle `a b c` (Ericson §5.1.5).
pub fn closest_point_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-300 {
        // Degenerate triangle: nearest of its corners.
        return [a, b, c]
            .into_iter()
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

/// Closest point to `p` on a patch.
pub fn closest_point_patch(p: DVec3, patch: &WorldPatch) -> DVec3 {
    let v = &patch.v;
    let q0 = closest_point_triangle(p, v[0], v[1], v[2]);
    if patch.corners == 3 {
        return q0;
    }
    let q1 = closest_point_triangle(p, v[0], v[2], v[3]);
    if q1.distance_squared(p) < q0.distance_squared(p) {
        q1
    } else {
        q0
    }
}

fn box_distance_squared(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
}

impl NearestIndex {
    /// Builds the tree over `ids`, patches of `patches`.
    pub fn build(patches: &[WorldPatch], ids: Vec<u32>) -> NearestIndex {
        let mut idx = NearestIndex {
            nodes: Vec::with_capacity(2 * ids.len() / LEAF_SIZE + 1),
            items: ids,
        };
        if idx.items.is_empty() {
            return idx;
        }
        let bounds: Vec<(DVec3, DVec3)> = patches.iter().map(WorldPatch::bounds).collect();
        idx.nodes.push(Node {
            lo: DVec3::ZERO,
            hi: DVec3::ZERO,
            first: 0,
            count: 0,
        });
        // Explicit stack of (node, item range) still to split.
        let mut stack = vec![(0usize, 0usize, idx.items.len())];
        while let Some((node, start, end)) = stack.pop() {
            let items = &mut idx.items[start..end];
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            let (mut clo, mut chi) = (lo, hi);
            for &i in items.iter() {
                let (a, b) = bounds[i as usize];
                lo = lo.min(a);
                hi = hi.max(b);
                let c = 0.5 * (a + b);
                clo = clo.min(c);
                chi = chi.max(c);
            }
            idx.nodes[node].lo = lo;
            idx.nodes[node].hi = hi;
            if items.len() <= LEAF_SIZE {
                idx.nodes[node].first = start as u32;
                idx.nodes[node].count = items.len() as u32;
                continue;
            }
            let ext = chi - clo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = items.len() / 2;
            items.select_nth_unstable_by(mid, |&a, &b| {
                let ca = bounds[a as usize].0[axis] + bounds[a as usize].1[axis];
                let cb = bounds[b as usize].0[axis] + bounds[b as usize].1[axis];
                ca.total_cmp(&cb)
            });
            let left = idx.nodes.len();
            let blank = Node {
                lo: DVec3::ZERO,
                hi: DVec3::ZERO,
                first: 0,
                count: 0,
            };
            idx.nodes.push(blank);
            idx.nodes.push(blank);
            idx.nodes[node].first = left as u32;
            idx.nodes[node].count = 0;
            stack.push((left, start, start + mid));
            stack.push((left + 1, start + mid, end));
        }
        idx
    }

    /// The patch nearest `p` among the indexed ones that `accept` lets through (ties:
    /// smaller index), with the closest point and its squared distance.
    pub fn nearest(
        &self,
        patches: &[WorldPatch],
        p: DVec3,
        accept: impl Fn(u32) -> bool,
    ) -> Option<(u32, DVec3, f64)> {
        let root = self.nodes.first()?;
        let mut best: Option<(u32, DVec3, f64)> = None;
        let mut stack = vec![(0usize, box_distance_squared(p, root.lo, root.hi))];
        while let Some((n, d_box)) = stack.pop() {
            if best.is_some_and(|b| d_box > b.2) {
                continue;
            }
            let node = self.nodes[n];
            if node.count > 0 {
                for &i in &self.items[node.first as usize..(node.first + node.count) as usize] {
                    if !accept(i) {
                        continue;
                    }
                    let q = closest_point_patch(p, &patches[i as usize]);
                    let d = q.distance_squared(p);
                    let better = match best {
                        None => true,
                        Some((bi, _, bd)) => d < bd || (d == bd && i < bi),
                    };
                    if better {
                        best = Some((i, q, d));
                    }
                }
                continue;
            }
            let (l, r) = (node.first as usize, node.first as usize + 1);
            let dl = box_distance_squared(p, self.nodes[l].lo, self.nodes[l].hi);
            let dr = box_distance_squared(p, self.nodes[r].lo, self.nodes[r].hi);
            // Push the farther child first so the nearer one is visited first.
            if dl <= dr {
                stack.push((r, dr));
                stack.push((l, dl));
            } else {
                stack.push((l, dl));
                stack.push((r, dr));
            }
        }
        best
    }
}

/// The plain scan [`NearestIndex::nearest`] must agree with.
pub fn nearest_brute_force(
    patches: &[WorldPatch],
    ids: &[u32],
    p: DVec3,
    accept: impl Fn(u32) -> bool,
) -> Option<(u32, DVec3, f64)> {
    let mut best: Option<(u32, DVec3, f64)> = None;
    for &i in ids.iter().filter(|&&i| accept(i)) {
        let q = closest_point_patch(p, &patches[i as usize]);
        let d = q.distance_squared(p);
        if best.is_none_or(|(bi, _, bd)| d < bd || (d == bd && i < bi)) {
            best = Some((i, q, d));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        crate::oracle::unit(*s)
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut s = 7u64;
        let mut patches = Vec::new();
        for k in 0..500 {
            let o = DVec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 10.0;
            let a = DVec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let b = DVec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let corners = if k % 3 == 0 { 3 } else { 4 };
            patches.push(WorldPatch {
                corners,
                material: 0,
                v: [o, o + a, o + a + b, o + b],
                normal: a.cross(b).normalize(),
            });
        }
        let ids: Vec<u32> = (0..patches.len() as u32).filter(|i| i % 5 != 0).collect();
        let idx = NearestIndex::build(&patches, ids.clone());
        for _ in 0..300 {
            let p = DVec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 12.0 - 1.0;
            let n = DVec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let facing = |i: u32| patches[i as usize].normal.dot(n) > 0.0;
            let a = idx.nearest(&patches, p, facing).map(|x| (x.0, x.2));
            let b = nearest_brute_force(&patches, &ids, p, facing).map(|x| (x.0, x.2));
            assert!(a.is_some());
            assert_eq!(a, b);
        }
    }

    #[test]
    fn closest_point_on_unit_square() {
        let sq = WorldPatch {
            corners: 4,
            material: 0,
            v: [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            normal: DVec3::Z,
        };
        let q = closest_point_patch(DVec3::new(0.25, 0.75, 3.0), &sq);
        assert!((q - DVec3::new(0.25, 0.75, 0.0)).length() < 1e-12);
        let q = closest_point_patch(DVec3::new(2.0, 0.5, -1.0), &sq);
        assert!((q - DVec3::new(1.0, 0.5, 0.0)).length() < 1e-12);
        let q = closest_point_patch(DVec3::new(-1.0, -1.0, 0.0), &sq);
        assert!(q.length() < 1e-12);
    }
}
