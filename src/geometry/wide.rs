//! [`Bvh4`]: the occlusion rays' BVH of a [`super::SceneBvh`] part, a 4-wide BVH with
//! plain (not quantised) `f32` child boxes in SIMD-friendly rows, collapsed from the
//! binary BVH that obvhs' PLOC builder makes (Meister & Bittner, "Parallel
//! locally-ordered clustering for bounding volume hierarchy construction", 2018), and
//! traversed any-hit, nearest child first (the layout of Embree's BVH4, Wald et al.
//! 2014, §4).
//!
//! Why: obvhs' compressed wide BVH (Ylitie et al. 2017) stores its child boxes as bytes
//! on a per-node grid, and decoding them (eight byte-to-float conversions per axis and
//! side at every node) took most of a solve's occlusion rays on the CPU (issue 48,
//! BENCHMARKS.md "Occlusion rays"). Here a node's four boxes are read as they are.
//!
//! It only finds candidates, like the CWBVH it replaces for occlusion: a leaf's
//! triangles are handed to the caller, which decides each in `f64`. It is built on the
//! same padded triangle boxes as the CWBVH (`visibility::padded_boxes`), so every
//! triangle the `f64` test hits is a candidate of both, and the answers are the same.
//!
//! Beside its box, a child whose triangles form a thin curved sheet (a piece of an
//! icosphere's or a cylinder's wall) has an oriented slab: the two planes, normal to
//! the mean normal of its triangles, that hold them all. Axis-aligned boxes are
//! loose round such a piece (a piece of a sphere's wall is as deep as it is wide in
//! its box's corners); a segment whose both ends lie beyond one face of the slab
//! cannot meet the piece, and the child is skipped though the segment crosses its
//! box (the oriented boxes of Gottschalk et al., "OBBTree", 1996, reduced to their
//! one thin axis; the slab test of Kay & Kajiya, 1986). A child has a slab only where
//! it is thinner than half its box along the slab's normal, so that flat walls,
//! which their boxes bound tightly, cost no more.
//!
//! What it does not do: closest hits and box queries (the CWBVH's).

use glam::{DVec3, Vec3A};
use obvhs::{BvhBuildParams, aabb::Aabb, bvh2::builder::build_bvh2};
use std::time::Duration;

/// Marks a child reference as a leaf (the rest of the bits index [`Bvh4::leaves`]).
const LEAF: u32 = 1 << 31;
/// An empty child slot (its box is inverted, so no ray enters it).
const EMPTY: u32 = u32::MAX;
/// Marks a child reference whose child has a slab in [`Bvh4::slabs`] (bit 30:
/// node and leaf indices stay below it).
const SLAB: u32 = 1 << 30;

/// How much thinner than its box along the slab's normal a child's slab must be to
/// be kept: a slab that prunes little costs a test at every visit of its node.
const SLAB_KEEP: f64 = 0.5;

/// One node: the boxes of its 4 children, coordinate by coordinate (`b[axis][child]`
/// the low sides for axes 0–2, `b[3 + axis][child]` the high), and what each child is.
/// 112 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Node4 {
    b: [[f32; 4]; 6],
    /// Node index, or [`LEAF`] `|` leaf index, or [`EMPTY`]; `|` [`SLAB`] where
    /// the child has a slab.
    child: [u32; 4],
}

/// The oriented slabs of one node's 4 children, coordinate by coordinate: child
/// `c`'s is the points `p` with `lo[c] ≤ n[·][c] · p ≤ hi[c]` (`n` of length ~1);
/// a child without one holds `n = 0` and `[−∞, ∞]`. 80 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Slab4 {
    n: [[f32; 4]; 3],
    lo: [f32; 4],
    hi: [f32; 4],
}

/// A node's slabs where none of its children has one.
const NO_SLABS: Slab4 = Slab4 {
    n: [[0.0; 4]; 3],
    lo: [f32::NEG_INFINITY; 4],
    hi: [f32::INFINITY; 4],
};

/// A 4-wide BVH over a part's triangles (module docs).
pub struct Bvh4 {
    nodes: Vec<Node4>,
    /// Node `i`'s children's slabs (module docs), read where a child reference
    /// has [`SLAB`].
    slabs: Vec<Slab4>,
    /// Each leaf's range in `prims`.
    leaves: Vec<(u32, u32)>,
    /// Triangle ids (the part's order), leaf by leaf.
    prims: Vec<u32>,
    /// The root: a node, a leaf, or [`EMPTY`].
    root: u32,
}

impl Bvh4 {
    /// A 4-wide BVH over the boxes `boxes` of the triangles `tris` (triangle `i`'s
    /// is `boxes[i]`, f64 corners in part space), a triangle a leaf; its slabs are
    /// widened by `pad` (what the boxes are padded by).
    pub fn build(boxes: &[Aabb], tris: &[[DVec3; 3]], pad: f64) -> Bvh4 {
        Self::build_slabs(boxes, tris, pad, true)
    }

    /// [`Bvh4::build`], with slabs or without.
    fn build_slabs(boxes: &[Aabb], tris: &[[DVec3; 3]], pad: f64, slabs: bool) -> Bvh4 {
        let mut out = Bvh4 {
            nodes: Vec::new(),
            slabs: Vec::new(),
            leaves: Vec::new(),
            prims: Vec::new(),
            root: EMPTY,
        };
        if boxes.is_empty() {
            return out;
        }
        let params = BvhBuildParams {
            // One triangle a leaf: each is culled by its own box before the f64
            // test, which costs more than a node's 4 boxes.
            max_prims_per_leaf: 1,
            ..BvhBuildParams::medium_build()
        };
        let bvh2 = build_bvh2(boxes, params, &mut Duration::default());
        if bvh2.nodes.is_empty() {
            return out;
        }
        let slabs = slabs.then_some((tris, pad));
        out.root = out.collapse(&bvh2, 0, slabs);
        out
    }

    /// Adds the subtree of `bvh2`'s node `n` and returns its reference.
    /// Children get slabs from `slabs`' triangles and pad where they are thin.
    fn collapse(
        &mut self,
        bvh2: &obvhs::bvh2::Bvh2,
        n: usize,
        slabs: Option<(&[[DVec3; 3]], f64)>,
    ) -> u32 {
        let node = &bvh2.nodes[n];
        if node.prim_count > 0 {
            let start = self.prims.len() as u32;
            let first = node.first_index as usize;
            self.prims.extend_from_slice(
                &bvh2.primitive_indices[first..first + node.prim_count as usize],
            );
            self.leaves.push((start, node.prim_count));
            return LEAF | (self.leaves.len() - 1) as u32;
        }
        // Open the inner child of largest area until there are 4.
        let mut kids: Vec<usize> = vec![node.first_index as usize, node.first_index as usize + 1];
        while kids.len() < 4 {
            let best = kids
                .iter()
                .enumerate()
                .filter(|&(_, &k)| bvh2.nodes[k].prim_count == 0)
                .max_by(|a, b| {
                    let area = |k: usize| bvh2.nodes[k].aabb.half_area();
                    area(*a.1).total_cmp(&area(*b.1))
                })
                .map(|(i, _)| i);
            let Some(i) = best else { break };
            let k = kids.swap_remove(i);
            let f = bvh2.nodes[k].first_index as usize;
            kids.push(f);
            kids.push(f + 1);
        }
        let ix = self.nodes.len();
        self.nodes.push(Node4 {
            b: [
                [f32::INFINITY; 4],
                [f32::INFINITY; 4],
                [f32::INFINITY; 4],
                [f32::NEG_INFINITY; 4],
                [f32::NEG_INFINITY; 4],
                [f32::NEG_INFINITY; 4],
            ],
            child: [EMPTY; 4],
        });
        self.slabs.push(NO_SLABS);
        for (slot, &k) in kids.iter().enumerate() {
            let b = bvh2.nodes[k].aabb;
            // A subtree's triangles are contiguous in `prims` (depth first).
            let first = self.prims.len();
            let mut r = self.collapse(bvh2, k, slabs);
            let slab = slabs.and_then(|(tris, pad)| slab_of(tris, &self.prims[first..], pad, &b));
            if let Some((n, lo, hi)) = slab {
                let s = &mut self.slabs[ix];
                for (row, x) in s.n.iter_mut().zip(n) {
                    row[slot] = x;
                }
                (s.lo[slot], s.hi[slot]) = (lo, hi);
                r |= SLAB;
            }
            let node = &mut self.nodes[ix];
            for a in 0..3 {
                node.b[a][slot] = b.min[a];
                node.b[3 + a][slot] = b.max[a];
            }
            node.child[slot] = r;
        }
        ix as u32
    }

    /// Number of children with a slab.
    #[cfg(test)]
    fn slab_count(&self) -> usize {
        self.nodes
            .iter()
            .flat_map(|n| n.child)
            .filter(|&c| c != EMPTY && c & SLAB != 0)
            .count()
    }

    /// Calls `f(triangle)` for the triangles of every leaf whose box the ray `o +
    /// t·d`, `t ∈ [tmin, tmax]`, meets (f32, part space), nearest child first, until
    /// `f` returns true; returns whether it did. A box is met where the ray's slab
    /// interval meets `[tmin, tmax]`; a direction component of 0 is taken as a tiny
    /// one of the same sign, which keeps every box the ray runs inside of.
    pub fn any_hit(
        &self,
        o: DVec3,
        d: DVec3,
        tmin: f64,
        tmax: f64,
        mut f: impl FnMut(u32) -> bool,
    ) -> bool {
        if self.root == EMPTY {
            return false;
        }
        let o = Vec3A::new(o.x as f32, o.y as f32, o.z as f32);
        let d32 = Vec3A::new(d.x as f32, d.y as f32, d.z as f32);
        let inv = Vec3A::new(inv(d.x), inv(d.y), inv(d.z));
        // Per axis: which row is the near side.
        let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        let (tmin, tmax) = (tmin as f32, tmax as f32);
        let ray = Ray4 {
            o: o.to_array(),
            d: d32.to_array(),
            inv: inv.to_array(),
            near: [0, 1, 2].map(|a| a + 3 * usize::from(neg[a])),
            far: [0, 1, 2].map(|a| a + 3 * usize::from(!neg[a])),
            tmin,
            tmax,
            slab_tol: SLAB_ULPS
                * f32::EPSILON
                * (o.abs().element_sum() + tmin.abs().max(tmax.abs()) * d32.abs().element_sum()),
        };
        let mut stack = [0u32; 64];
        let mut top = 0usize;
        let mut cur = self.root;
        loop {
            if cur & LEAF != 0 {
                let (start, count) = self.leaves[(cur & !(LEAF | SLAB)) as usize];
                for &id in &self.prims[start as usize..(start + count) as usize] {
                    if f(id) {
                        return true;
                    }
                }
            } else {
                let (near, hit) = self.visit(cur, &ray);
                let node = &self.nodes[(cur & !SLAB) as usize];
                // Hit children, nearest first: sort the (≤ 4) hits by entry.
                let mut hits = [(0f32, 0u32); 4];
                let mut k = 0;
                for (c, &t) in near.iter().enumerate() {
                    if hit & (1 << c) != 0 {
                        let mut j = k;
                        while j > 0 && hits[j - 1].0 > t {
                            hits[j] = hits[j - 1];
                            j -= 1;
                        }
                        hits[j] = (t, node.child[c]);
                        k += 1;
                    }
                }
                if k > 0 {
                    // Push the farther ones (farthest first), go on with the nearest.
                    for j in (1..k).rev() {
                        if top < stack.len() {
                            stack[top] = hits[j].1;
                            top += 1;
                        } else {
                            // Deeper than any PLOC tree of a real scene; go on in
                            // place rather than lose a candidate.
                            if self.any_hit_from(hits[j].1, &ray, &mut f) {
                                return true;
                            }
                        }
                    }
                    cur = hits[0].1;
                    continue;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            cur = stack[top];
        }
    }

    /// Calls `f(triangle)` for the triangles under every child whose box (part
    /// space) lies outside none of the half-spaces of `cull`, depth first, until
    /// `f` returns true; returns whether it did. A leaf's box is one triangle's
    /// padded box, so with the half-spaces of a convex volume (a shaft's
    /// [`crate::shafts::Shaft::box_tests`]) `f` gets every triangle that meets
    /// the volume (and some more). The slabs are not used.
    pub fn any_in(&self, cull: &Cull4, mut f: impl FnMut(u32) -> bool) -> bool {
        if self.root == EMPTY {
            return false;
        }
        self.any_in_from(self.root, cull, &mut f)
    }

    /// [`Bvh4::any_in`] under the reference `start` (a stack of its own; a
    /// child that would overflow it is walked by a nested call).
    fn any_in_from(&self, start: u32, cull: &Cull4, f: &mut impl FnMut(u32) -> bool) -> bool {
        let mut stack = [0u32; 64];
        let mut top = 0usize;
        let mut cur = start;
        loop {
            if cur & LEAF != 0 {
                let (first, count) = self.leaves[(cur & !(LEAF | SLAB)) as usize];
                for &id in &self.prims[first as usize..(first + count) as usize] {
                    if f(id) {
                        return true;
                    }
                }
            } else {
                let node = &self.nodes[(cur & !SLAB) as usize];
                let out = cull.outside(node);
                for c in 0..4 {
                    let child = node.child[c];
                    if child == EMPTY || out[c] {
                        continue;
                    }
                    if top < stack.len() {
                        stack[top] = child;
                        top += 1;
                    } else if self.any_in_from(child, cull, f) {
                        return true;
                    }
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            cur = stack[top];
        }
    }

    /// [`Bvh4::any_hit`] from the node or leaf `start` (recursive; the stack's
    /// overflow only).
    fn any_hit_from(&self, start: u32, ray: &Ray4, f: &mut dyn FnMut(u32) -> bool) -> bool {
        if start & LEAF != 0 {
            let (s, count) = self.leaves[(start & !(LEAF | SLAB)) as usize];
            return self.prims[s as usize..(s + count) as usize]
                .iter()
                .any(|&id| f(id));
        }
        let (_, hit) = self.visit(start, ray);
        let node = &self.nodes[(start & !SLAB) as usize];
        (0..4).any(|c| hit & (1 << c) != 0 && self.any_hit_from(node.child[c], ray, f))
    }

    /// The entries of `ray` into the children of the node `node` (a reference
    /// that is no leaf) and the mask of the children it meets: within their box,
    /// and within their slab where they have one.
    #[inline(always)]
    fn visit(&self, node: u32, ray: &Ray4) -> ([f32; 4], u32) {
        let ix = (node & !SLAB) as usize;
        let n = &self.nodes[ix];
        let (near, mut hit) = slabs(n, ray);
        let flagged = (0..4).fold(0, |m, c| m | (((n.child[c] & SLAB) >> 30) << c));
        if hit & flagged != 0 {
            hit &= !(flagged & slabs_missed(&self.slabs[ix], ray));
        }
        (near, hit)
    }

    /// Bytes held.
    pub fn resident_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.slabs.as_slice())
            + std::mem::size_of_val(self.leaves.as_slice())
            + std::mem::size_of_val(self.prims.as_slice())
    }
}

/// Most half-spaces a [`Cull4`] holds (a shaft's: 6 for its box, 2 ends, 16 hull
/// planes).
const CULL_PLANES: usize = 24;

/// Half-spaces that [`Bvh4::any_in`] tests a node's four child boxes against at
/// once, in `f32`: a box is out where `m · c ≥ t` at its corner `c` lowest along
/// `m` for one of them. Made from `f64` tests by [`Cull4::push`], each `t` raised
/// by a bound on the `f32` round-off, so a box out here is out of the `f64` test
/// too. 392 bytes.
#[derive(Clone, Copy, Debug)]
pub struct Cull4 {
    /// Per half-space: `m` and `t`.
    m: [[f32; 3]; CULL_PLANES],
    t: [f32; CULL_PLANES],
    /// Per half-space: per axis, the row of a node's boxes holding the lowest
    /// side along `m` (`axis`, or `3 + axis` where `m` is negative there).
    rows: [[u8; 3]; CULL_PLANES],
    count: usize,
    /// Bound on the absolute coordinates of the boxes tested.
    extent: f64,
}

impl Cull4 {
    /// No half-space yet, for boxes of coordinates up to `extent` in absolute value.
    pub fn new(extent: f64) -> Cull4 {
        Cull4 {
            m: [[0.0; 3]; CULL_PLANES],
            t: [0.0; CULL_PLANES],
            rows: [[0; 3]; CULL_PLANES],
            count: 0,
            extent,
        }
    }

    /// Adds the `f64` test "out where `m · c ≥ t`" (ignored when full or not
    /// finite: fewer tests only cull less). `f32` rounding of `m`, of the box
    /// sides (stored rounded outwards by their padding, read as they are) and of
    /// the dot product is at most a few `1e-7` of `|m|₁ · extent + |t|`; `t` is
    /// raised by `1e-5` of it.
    pub fn push(&mut self, m: DVec3, t: f64) {
        if self.count == CULL_PLANES || !m.is_finite() || !t.is_finite() {
            return;
        }
        let slack = 1e-5 * (m.abs().element_sum() * self.extent + t.abs());
        let k = self.count;
        self.m[k] = [m.x as f32, m.y as f32, m.z as f32];
        self.t[k] = (t + slack) as f32;
        self.rows[k] = [0, 1, 2].map(|a| if m[a] >= 0.0 { a as u8 } else { 3 + a as u8 });
        self.count += 1;
    }

    /// Which of the node's four children lie out of one of the half-spaces.
    #[inline]
    fn outside(&self, node: &Node4) -> [bool; 4] {
        let mut out = [false; 4];
        for k in 0..self.count {
            let (m, r) = (self.m[k], self.rows[k]);
            let (bx, by, bz) = (
                &node.b[r[0] as usize],
                &node.b[r[1] as usize],
                &node.b[r[2] as usize],
            );
            for c in 0..4 {
                out[c] |= m[0] * bx[c] + m[1] * by[c] + m[2] * bz[c] >= self.t[k];
            }
            if out == [true; 4] {
                break;
            }
        }
        out
    }
}

/// `1 / x` in f32, with 0 (and anything under `1e-30`) taken as `±1e-30`, so that a
/// ray along a slab gets an interval of ±∞-like extent rather than NaN.
fn inv(x: f64) -> f32 {
    let x = x as f32;
    let x = if x.abs() < 1e-30 {
        if x.is_sign_negative() { -1e-30 } else { 1e-30 }
    } else {
        x
    };
    1.0 / x
}

/// The oriented slab (`n`, `[lo, hi]`, widened by `pad`) of the triangles `ids` of
/// `tris`, their area-weighted mean normal rounded to f32, if it is under
/// [`SLAB_KEEP`] of the f32 box `b`'s width along that normal.
fn slab_of(tris: &[[DVec3; 3]], ids: &[u32], pad: f64, b: &Aabb) -> Option<([f32; 3], f32, f32)> {
    let tri = |id: u32| tris.get(id as usize);
    let sum: DVec3 = ids
        .iter()
        .filter_map(|&id| tri(id))
        .map(|&[a, b, c]| (b - a).cross(c - a))
        .sum();
    let n = sum.normalize_or_zero();
    if n == DVec3::ZERO {
        return None;
    }
    // The slab of the normal as traversal reads it.
    let n32 = [n.x as f32, n.y as f32, n.z as f32];
    let n = DVec3::new(n32[0] as f64, n32[1] as f64, n32[2] as f64);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for t in ids.iter().filter_map(|&id| tri(id)) {
        for v in t {
            let x = n.dot(*v);
            lo = lo.min(x);
            hi = hi.max(x);
        }
    }
    let width: f64 = (0..3)
        .map(|a| n[a].abs() * (b.max[a] as f64 - b.min[a] as f64))
        .sum();
    // Widened by the boxes' pad, and by an f32 ulp of the bounds for their
    // rounding to f32.
    let ulp = (f32::EPSILON as f64) * lo.abs().max(hi.abs());
    let (lo, hi) = (lo - pad - ulp, hi + pad + ulp);
    // (A NaN keeps no slab.)
    let thin = hi - lo < SLAB_KEEP * width;
    if !thin {
        return None;
    }
    Some((n32, lo as f32, hi as f32))
}

/// How many f32 ulps of a ray's `|o|₁ + max(|tmin|, |tmax|) |d|₁` widen the slabs
/// it is tested against ([`slabs_missed`]): the ray's rounding to f32 moves its
/// points by one, and the f32 products `n · o + t n · d` round off by a few more;
/// 16 leaves a margin. The slabs themselves are widened by the boxes' pad for the
/// f64 test's own round-off at the triangles.
const SLAB_ULPS: f32 = 16.0;

/// A ray as [`slabs`] reads it (f32, part space).
struct Ray4 {
    o: [f32; 3],
    d: [f32; 3],
    inv: [f32; 3],
    /// Per axis, the row of [`Node4::b`] the ray enters a box by, and leaves by.
    near: [usize; 3],
    far: [usize; 3],
    tmin: f32,
    tmax: f32,
    /// How much wider than they are the slabs are read ([`SLAB_ULPS`]).
    slab_tol: f32,
}

/// The mask of the 4 slabs of `s` that the segment of `ray` (`[tmin, tmax]`) does
/// not meet: both its ends beyond the slab's low face, or both beyond its high one
/// (a slab `[−∞, ∞]`, a child's without one, is always met).
#[inline(always)]
fn slabs_missed(s: &Slab4, ray: &Ray4) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of x86_64's baseline; the loads read 4 f32 of a
        // 16-byte aligned row (`Slab4` is `align(16)`, rows are 16 bytes).
        unsafe {
            let row = |r: &[f32; 4]| _mm_load_ps(r.as_ptr());
            let dot = |v: &[f32; 3]| {
                _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(row(&s.n[0]), _mm_set1_ps(v[0])),
                        _mm_mul_ps(row(&s.n[1]), _mm_set1_ps(v[1])),
                    ),
                    _mm_mul_ps(row(&s.n[2]), _mm_set1_ps(v[2])),
                )
            };
            let (no, nd) = (dot(&ray.o), dot(&ray.d));
            let e0 = _mm_add_ps(no, _mm_mul_ps(nd, _mm_set1_ps(ray.tmin)));
            let e1 = _mm_add_ps(no, _mm_mul_ps(nd, _mm_set1_ps(ray.tmax)));
            let tol = _mm_set1_ps(ray.slab_tol);
            let below = _mm_cmplt_ps(_mm_max_ps(e0, e1), _mm_sub_ps(row(&s.lo), tol));
            let above = _mm_cmpgt_ps(_mm_min_ps(e0, e1), _mm_add_ps(row(&s.hi), tol));
            _mm_movemask_ps(_mm_or_ps(below, above)) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut missed = 0;
        for c in 0..4 {
            let dot = |v: &[f32; 3]| s.n[0][c] * v[0] + s.n[1][c] * v[1] + s.n[2][c] * v[2];
            let (no, nd) = (dot(&ray.o), dot(&ray.d));
            let (e0, e1) = (no + nd * ray.tmin, no + nd * ray.tmax);
            let below = e0.max(e1) < s.lo[c] - ray.slab_tol;
            let above = e0.min(e1) > s.hi[c] + ray.slab_tol;
            missed |= u32::from(below || above) << c;
        }
        missed
    }
}

/// The entry parameters of `ray` into `node`'s 4 child boxes and the mask of those it
/// meets within `[tmin, tmax]` (Kay & Kajiya's slabs, 1986). An empty slot's inverted
/// box is never met.
#[inline(always)]
fn slabs(node: &Node4, ray: &Ray4) -> ([f32; 4], u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of x86_64's baseline; the loads read 4 f32 of a
        // 16-byte aligned row (`Node4` is `align(16)`, rows are 16 bytes), and the
        // store writes the 4 of `near`.
        unsafe {
            let row = |r: usize| _mm_load_ps(node.b[r].as_ptr());
            let t = |r: usize, a: usize| {
                _mm_mul_ps(
                    _mm_sub_ps(row(r), _mm_set1_ps(ray.o[a])),
                    _mm_set1_ps(ray.inv[a]),
                )
            };
            let n = _mm_max_ps(
                _mm_max_ps(t(ray.near[0], 0), t(ray.near[1], 1)),
                _mm_max_ps(t(ray.near[2], 2), _mm_set1_ps(ray.tmin)),
            );
            let f = _mm_min_ps(
                _mm_min_ps(t(ray.far[0], 0), t(ray.far[1], 1)),
                _mm_min_ps(t(ray.far[2], 2), _mm_set1_ps(ray.tmax)),
            );
            let mut near = [0f32; 4];
            _mm_storeu_ps(near.as_mut_ptr(), n);
            (near, _mm_movemask_ps(_mm_cmple_ps(n, f)) as u32)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut near = [ray.tmin; 4];
        let mut far = [ray.tmax; 4];
        for a in 0..3 {
            for c in 0..4 {
                let t0 = (node.b[ray.near[a]][c] - ray.o[a]) * ray.inv[a];
                let t1 = (node.b[ray.far[a]][c] - ray.o[a]) * ray.inv[a];
                near[c] = if t0 > near[c] { t0 } else { near[c] };
                far[c] = if t1 < far[c] { t1 } else { far[c] };
            }
        }
        let hit = (0..4).fold(0, |m, c| m | (u32::from(near[c] <= far[c]) << c));
        (near, hit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::icosphere;
    use crate::geometry::visibility::{BOX_PAD, padded_boxes, part_reach};
    use crate::oracle::xorshift;

    /// A closed cylinder about the `y` axis through `c`: `k` quads around (two
    /// triangles each), `rings` along the height, and two caps of `k` triangles.
    fn cylinder(c: DVec3, r: f64, h: f64, k: usize, rings: usize) -> Vec<[DVec3; 3]> {
        let at = |i: usize, y: f64| {
            let a = std::f64::consts::TAU * i as f64 / k as f64;
            c + DVec3::new(r * a.cos(), y, -r * a.sin())
        };
        let mut tris = Vec::new();
        for i in 0..k {
            for j in 0..rings {
                let (y0, y1) = (
                    h * j as f64 / rings as f64,
                    h * (j + 1) as f64 / rings as f64,
                );
                let (a, b, p, q) = (at(i, y0), at(i + 1, y0), at(i + 1, y1), at(i, y1));
                tris.push([a, b, p]);
                tris.push([a, p, q]);
            }
            tris.push([c, at(i + 1, 0.0), at(i, 0.0)]);
            tris.push([c + DVec3::Y * h, at(i, h), at(i + 1, h)]);
        }
        tris
    }

    /// Möller & Trumbore in f64, edges included (as `visibility::Part::hit64`).
    fn hits(tri: &[DVec3; 3], o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        let [v0, v1, v2] = *tri;
        let (e1, e2) = (v1 - v0, v2 - v0);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return false;
        }
        let inv = 1.0 / det;
        let c = o - v0;
        let u = c.dot(p) * inv;
        let q = c.cross(e1);
        let v = d.dot(q) * inv;
        let t = e2.dot(q) * inv;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= tmin && t <= tmax
    }

    /// On an icosphere's and a cylinder's walls (where the slabs are), every
    /// triangle that a random segment's f64 test hits is a candidate of the
    /// traversal with slabs and of the one without, and the occlusion answers are
    /// those of a loop over every triangle; and the slabs prune: the traversal
    /// with them hands out at most 80% of the candidates of the one without on
    /// the icospheres, 95% on the cylinder.
    /// Segments run between points of the surface (as the solver's rays do: their
    /// ends on the wall, trimmed by 10⁻⁹), from the surface to anywhere, anywhere,
    /// and grazing a triangle's plane.
    #[test]
    fn wide_bvh_with_slabs_finds_every_hit() {
        let mut rnd = xorshift(0x51ab_5eed_u64);
        let mut r = move || rnd();
        let meshes = [
            // Measured: 0.67 and 0.71 of the candidates without slabs on the
            // icospheres, 0.92 on the cylinder (its wall is curved one way only).
            (
                "icosphere 3",
                icosphere(DVec3::new(0.2, -0.1, 0.3), 0.5, 3),
                0.8,
            ),
            (
                "icosphere 4",
                icosphere(DVec3::new(-0.3, 0.4, 0.1), 0.7, 4),
                0.8,
            ),
            (
                "cylinder",
                cylinder(DVec3::new(0.1, -0.4, 0.2), 0.5, 0.9, 48, 6),
                0.95,
            ),
        ];
        for (name, tris, prune) in meshes {
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &v in tris.iter().flatten() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
            // The boxes and pad `visibility::Part` builds with.
            let pad = part_reach(&tris) * BOX_PAD;
            let boxes = padded_boxes(&tris, pad);
            let with = Bvh4::build_slabs(&boxes, &tris, pad, true);
            let without = Bvh4::build_slabs(&boxes, &tris, pad, false);
            assert_eq!(without.slab_count(), 0);
            assert!(
                with.slab_count() > tris.len() / 4,
                "{name}: {} slabs for {} triangles",
                with.slab_count(),
                tris.len()
            );
            let on_surface = |r: &mut dyn FnMut() -> f64| {
                let [a, b, c] = tris[(r() * tris.len() as f64) as usize % tris.len()];
                let (u, v) = (r(), r());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                a + (b - a) * u + (c - a) * v
            };
            let (mut blocked, mut n_with, mut n_without) = (0, 0usize, 0usize);
            let segments = 3000;
            for k in 0..segments {
                let anywhere = |r: &mut dyn FnMut() -> f64| {
                    lo - 0.2 * (hi - lo) + (hi - lo) * 1.4 * DVec3::new(r(), r(), r())
                };
                let (a, b, trim) = match k % 4 {
                    0 | 1 => (on_surface(&mut r), on_surface(&mut r), 1e-9),
                    2 => (on_surface(&mut r), anywhere(&mut r), 1e-9),
                    _ => {
                        // Grazing a triangle's plane through a point of it.
                        let t = tris[k % tris.len()];
                        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
                        let (u, v) = (r(), r());
                        let (u, v) = if u + v > 1.0 {
                            (1.0 - u, 1.0 - v)
                        } else {
                            (u, v)
                        };
                        let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                        let (e1, _) = n.any_orthonormal_pair();
                        let h = n * (r() - 0.5) * 1e-5;
                        (p - e1 * r() + h, p + e1 * r() - h * r(), 1e-4)
                    }
                };
                let d = b - a;
                // Cast as `SceneBvh::occluded_trimmed` does: from behind `a`, the
                // f32 range wider by `WIDE_SLACK`.
                let back = 2e-4;
                let o = a - d * back;
                let (t0, t1) = (trim + back, 1.0 - trim + back);
                let brute: Vec<u32> = (0..tris.len() as u32)
                    .filter(|&i| hits(&tris[i as usize], o, d, t0, t1))
                    .collect();
                let (w0, w1) = (t0 - 1e-6, t1 + 1e-6);
                for (bvh, count) in [(&with, &mut n_with), (&without, &mut n_without)] {
                    let mut candidates = Vec::new();
                    bvh.any_hit(o, d, w0, w1, |id| {
                        candidates.push(id);
                        false
                    });
                    *count += candidates.len();
                    for id in &brute {
                        assert!(
                            candidates.contains(id),
                            "{name}: triangle {id} hit by {a} -> {b} is no candidate"
                        );
                    }
                    let occluded =
                        bvh.any_hit(o, d, w0, w1, |id| hits(&tris[id as usize], o, d, t0, t1));
                    assert_eq!(occluded, !brute.is_empty(), "{name}: {a} -> {b}");
                }
                blocked += usize::from(!brute.is_empty());
            }
            eprintln!(
                "{name}: {} triangles, {} slabs, {blocked} of {segments} segments blocked, \
                 candidates {n_with} with slabs, {n_without} without",
                tris.len(),
                with.slab_count()
            );
            assert!(blocked > segments / 10, "{name}: {blocked} blocked");
            assert!(
                (n_with as f64) < prune * n_without as f64,
                "{name}: {n_with} candidates with slabs, {n_without} without"
            );
        }
    }
}
