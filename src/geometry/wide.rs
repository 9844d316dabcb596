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
//! What it does not do: closest hits and box queries (the CWBVH's).

use glam::{DVec3, Vec3A};
use obvhs::{BvhBuildParams, aabb::Aabb, bvh2::builder::build_bvh2};
use std::time::Duration;

/// Marks a child reference as a leaf (the rest of the bits index [`Bvh4::leaves`]).
const LEAF: u32 = 1 << 31;
/// An empty child slot (its box is inverted, so no ray enters it).
const EMPTY: u32 = u32::MAX;

/// One node: the boxes of its 4 children, coordinate by coordinate (`b[axis][child]`
/// the low sides for axes 0–2, `b[3 + axis][child]` the high), and what each child is.
/// 112 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Node4 {
    b: [[f32; 4]; 6],
    /// Node index, or [`LEAF`] `|` leaf index, or [`EMPTY`].
    child: [u32; 4],
}

/// A 4-wide BVH over a part's triangles (module docs).
pub struct Bvh4 {
    nodes: Vec<Node4>,
    /// Each leaf's range in `prims`.
    leaves: Vec<(u32, u32)>,
    /// Triangle ids (the part's order), leaf by leaf.
    prims: Vec<u32>,
    /// The root: a node, a leaf, or [`EMPTY`].
    root: u32,
}

impl Bvh4 {
    /// A 4-wide BVH over the boxes `boxes` (triangle `i`'s is `boxes[i]`), a
    /// triangle a leaf.
    pub fn build(boxes: &[Aabb]) -> Bvh4 {
        let mut out = Bvh4 {
            nodes: Vec::new(),
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
        out.root = out.collapse(&bvh2, 0);
        out
    }

    /// Adds the subtree of `bvh2`'s node `n` and returns its reference.
    fn collapse(&mut self, bvh2: &obvhs::bvh2::Bvh2, n: usize) -> u32 {
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
        for (slot, &k) in kids.iter().enumerate() {
            let b = bvh2.nodes[k].aabb;
            let r = self.collapse(bvh2, k);
            let node = &mut self.nodes[ix];
            for a in 0..3 {
                node.b[a][slot] = b.min[a];
                node.b[3 + a][slot] = b.max[a];
            }
            node.child[slot] = r;
        }
        ix as u32
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
        let inv = Vec3A::new(inv(d.x), inv(d.y), inv(d.z));
        // Per axis: which row is the near side.
        let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        let (tmin, tmax) = (tmin as f32, tmax as f32);
        let ray = Ray4 {
            o: o.to_array(),
            inv: inv.to_array(),
            near: [0, 1, 2].map(|a| a + 3 * usize::from(neg[a])),
            far: [0, 1, 2].map(|a| a + 3 * usize::from(!neg[a])),
            tmin,
            tmax,
        };
        let mut stack = [0u32; 64];
        let mut top = 0usize;
        let mut cur = self.root;
        loop {
            if cur & LEAF != 0 {
                let (start, count) = self.leaves[(cur & !LEAF) as usize];
                for &id in &self.prims[start as usize..(start + count) as usize] {
                    if f(id) {
                        return true;
                    }
                }
            } else {
                let node = &self.nodes[cur as usize];
                let (near, hit) = slabs(node, &ray);
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

    /// [`Bvh4::any_hit`] from the node or leaf `start` (recursive; the stack's
    /// overflow only).
    fn any_hit_from(&self, start: u32, ray: &Ray4, f: &mut dyn FnMut(u32) -> bool) -> bool {
        if start & LEAF != 0 {
            let (s, count) = self.leaves[(start & !LEAF) as usize];
            return self.prims[s as usize..(s + count) as usize]
                .iter()
                .any(|&id| f(id));
        }
        let node = &self.nodes[start as usize];
        let (_, hit) = slabs(node, ray);
        (0..4).any(|c| hit & (1 << c) != 0 && self.any_hit_from(node.child[c], ray, f))
    }

    /// Bytes held.
    pub fn resident_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.leaves.as_slice())
            + std::mem::size_of_val(self.prims.as_slice())
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

/// A ray as [`slabs`] reads it (f32, part space).
struct Ray4 {
    o: [f32; 3],
    inv: [f32; 3],
    /// Per axis, the row of [`Node4::b`] the ray enters a box by, and leaves by.
    near: [usize; 3],
    far: [usize; 3],
    tmin: f32,
    tmax: f32,
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
