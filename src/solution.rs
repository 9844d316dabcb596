//! What a solve hands to the store and to playback: the scene's patches and the leaves
//! of the solved hierarchy, each leaf a parametric sub-domain of one patch over a time
//! range, with radiosity at its corners.
//!
//! This is the contract between [`crate::solver`], [`crate::store`] and
//! [`crate::playback`], and it sits below all three: the store persists exactly these
//! records, and probing a [`Solution`] in memory or read back from a `.rhier` file
//! runs the same code. It also holds how a point finds its leaf ([`leaf_at`]) and the
//! error measures every report uses ([`relative_rms`], and [`PointError`] off the
//! emitters). It knows nothing of how a
//! solution is computed, stored or drawn.
//!
//! ## Patch parameterisation
//! A patch is one input polygon. A quad `v0 v1 v2 v3` is parameterised bilinearly,
//! `P(u,v) = (1-u)(1-v) v0 + u(1-v) v1 + u v v2 + (1-u) v v3`, `(u,v)` in `[0,1]^2`; a
//! triangle `v0 v1 v2` affinely, `P(u,v) = v0 + u (v1-v0) + v (v2-v0)`, `u,v >= 0`,
//! `u+v <= 1`. Since patches are planar, the image of a parametric rectangle of a quad is
//! a planar quad, and the image of a parametric triangle is a triangle.

use bytemuck::{Pod, Zeroable};

pub use crate::geometry::{PatchGeometry, param_point};

/// Leaves handled at a time by whoever pages a column of them: the store checks,
/// compresses and hands back a chunk's leaves in blocks of this many, and a
/// space-time window sorts its leaves into file order releasing pages as often
/// (8192 leaves, 768 KiB).
pub const LEAF_BLOCK: usize = 8192;

/// Shape of a patch or leaf domain.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Three corners, affine parameterisation.
    Triangle = 3,
    /// Four corners, bilinear parameterisation.
    Quad = 4,
}

/// One leaf of the hierarchy as playback needs it. `repr(C)`, Pod, 96 bytes.
///
/// Corners `uv[0..n]` are in the patch's parameter space, counter-clockwise like the
/// patch (`n` = 3 for triangle patches, 4 for quad patches: `(u0,v0) (u1,v0) (u1,v1)
/// (u0,v1)`); `b[i]` is the radiosity at corner `i`. Inside the leaf, `B` is the
/// bilinear (quad) or linear (triangle) interpolation of the corner values.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Leaf {
    /// Patch index (position in [`Solution::patches`]).
    pub patch: u32,
    /// Number of valid corners: 3 or 4 (the patch's shape).
    pub corners: u32,
    /// Time range `[t0, t1]` over which this leaf holds.
    pub time: [f32; 2],
    /// Corners in the patch's parameter space.
    pub uv: [[f32; 2]; 4],
    /// Radiosity (RGB) at each corner.
    pub b: [[f32; 3]; 4],
}

const _: () = assert!(std::mem::size_of::<Leaf>() == 96);

impl Leaf {
    /// True if every corner parameter and radiosity is finite: what the store's
    /// writer and reader demand of a leaf.
    pub fn values_finite(&self) -> bool {
        self.uv.iter().flatten().all(|x| x.is_finite())
            && self.b.iter().flatten().all(|x| x.is_finite())
    }

    /// Radiosity at parameter point `(u, v)` of the patch, assumed inside this leaf.
    pub fn eval(&self, u: f64, v: f64) -> [f64; 3] {
        let w = self.weights(u, v);
        let mut out = [0.0; 3];
        for (c, wc) in w.iter().enumerate().take(self.corners as usize) {
            for (k, o) in out.iter_mut().enumerate() {
                *o += wc * self.b[c][k] as f64;
            }
        }
        out
    }

    /// Interpolation weights of the corners at `(u, v)` (clamped into the leaf).
    pub fn weights(&self, u: f64, v: f64) -> [f64; 4] {
        let p = |i: usize| (self.uv[i][0] as f64, self.uv[i][1] as f64);
        if self.corners == 3 {
            // Barycentric coordinates in the parametric triangle.
            let (a, b, c) = (p(0), p(1), p(2));
            let det = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
            if det.abs() < 1e-300 {
                return [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0];
            }
            let l1 = ((u - a.0) * (c.1 - a.1) - (c.0 - a.0) * (v - a.1)) / det;
            let l2 = ((b.0 - a.0) * (v - a.1) - (u - a.0) * (b.1 - a.1)) / det;
            let (l1, l2) = (l1.clamp(0.0, 1.0), l2.clamp(0.0, 1.0));
            let s = (l1 + l2).max(1.0);
            let (l1, l2) = (l1 / s, l2 / s);
            [1.0 - l1 - l2, l1, l2, 0.0]
        } else {
            let (u0, v0) = p(0);
            let (u1, v1) = p(2);
            let s = if u1 > u0 {
                ((u - u0) / (u1 - u0)).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let t = if v1 > v0 {
                ((v - v0) / (v1 - v0)).clamp(0.0, 1.0)
            } else {
                0.5
            };
            [(1.0 - s) * (1.0 - t), s * (1.0 - t), s * t, (1.0 - s) * t]
        }
    }

    /// True if parameter point `(u, v)` lies in this leaf's domain (with slack `eps`).
    pub fn contains(&self, u: f64, v: f64, eps: f64) -> bool {
        let p = |i: usize| (self.uv[i][0] as f64, self.uv[i][1] as f64);
        if self.corners == 3 {
            let (a, b, c) = (p(0), p(1), p(2));
            let edge = |p0: (f64, f64), p1: (f64, f64)| {
                (p1.0 - p0.0) * (v - p0.1) - (p1.1 - p0.1) * (u - p0.0)
            };
            let (e0, e1, e2) = (edge(a, b), edge(b, c), edge(c, a));
            let sign = if (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            sign * e0 >= -eps && sign * e1 >= -eps && sign * e2 >= -eps
        } else {
            let (u0, v0) = p(0);
            let (u1, v1) = p(2);
            u >= u0 - eps && u <= u1 + eps && v >= v0 - eps && v <= v1 + eps
        }
    }

    /// True if this leaf holds at time `t` in a scene whose time domain ends at
    /// `t_end`: `t0 <= t < t1`, or `t0 <= t <= t1` when `t1` is the domain's end (so
    /// that exactly one leaf of a domain holds at a chunk boundary, and static leaves
    /// `[t, t]` hold at `t`). Compared in `f32`, the precision leaf times are kept in.
    pub fn is_live(&self, t: f64, t_end: f64) -> bool {
        let (t, t_end) = (t as f32, t_end as f32);
        let [t0, t1] = self.time;
        t0 <= t && (t < t1 || (t <= t1 && t1 >= t_end))
    }

    /// Area-weighted mean radiosity of the leaf (exact for the interpolant).
    pub fn mean(&self) -> [f64; 3] {
        let n = self.corners as usize;
        let mut out = [0.0; 3];
        for c in 0..n {
            for (k, o) in out.iter_mut().enumerate() {
                *o += self.b[c][k] as f64 / n as f64;
            }
        }
        out
    }
}

/// Statistics of the solve that produced a solution (also printed by `solve`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Wall-clock seconds of the solve.
    pub seconds: f64,
    /// Iterations run.
    pub iterations: u32,
    /// Elements in the hierarchy (all levels).
    pub elements: u64,
    /// Active links.
    pub links_active: u64,
    /// Passive (refined) links.
    pub links_passive: u64,
    /// Estimated relative error of the stored answer: the change of the final gather
    /// between refinement levels combined with the reconstruction's interpolation
    /// error ([`crate::solver::Solver::run`]); `NaN` when no two
    /// levels were compared (no error samples, a scene with motion, a solve that
    /// stopped in its first level).
    pub estimated_error: f64,
    /// Last iteration's relative residual.
    pub residual: f64,
}

/// A solved scene: its patches and the leaves of the hierarchy.
#[derive(Clone, Debug, Default)]
pub struct Solution {
    /// The scene the solution is for (materials, objects, motion, camera).
    pub scene: crate::scene::Scene,
    /// Patches in scene order (objects in order, polygons in order, zero-area dropped).
    pub patches: Vec<PatchGeometry>,
    /// Leaves, sorted by `(time[0], patch)`.
    pub leaves: Vec<Leaf>,
    /// Statistics of the solve.
    pub stats: SolveStats,
}

impl Solution {
    /// The answer for a scene with no emitter, known without solving: one leaf of
    /// radiosity zero per patch, over the scene's time domain.
    pub fn zero(scene: &crate::scene::Scene) -> Solution {
        let patches = crate::geometry::Patches::at_time(scene, scene.time.start).geometry;
        let time = [scene.time.start as f32, scene.time.end as f32];
        let leaves = patches
            .iter()
            .enumerate()
            .map(|(i, p)| Leaf {
                patch: i as u32,
                corners: p.corners,
                time,
                uv: if p.corners == 4 {
                    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
                } else {
                    [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]
                },
                b: [[0.0; 3]; 4],
            })
            .collect();
        Solution {
            scene: scene.clone(),
            patches,
            leaves,
            stats: SolveStats {
                estimated_error: 0.0,
                ..SolveStats::default()
            },
        }
    }
}

/// How far outside a leaf's domain, in the patch's parameters, [`leaf_at`] still
/// takes a point as in it: far above the round-off of a point's parameters
/// (`1e-16` relative, in any unit), far below any leaf. A point on the edge of two
/// leaves (a probe at the middle of a patch, on its first split) is in both; taken
/// exactly, its parameters' round-off chose one leaf in metres and the other in
/// millimetres, and the reconstruction's values jump there by up to 1% (issue 45,
/// part 3).
pub const LEAF_EDGE_TOLERANCE: f64 = 1e-9;

/// The leaf of `leaves` (one patch's) holding `(u, v)`: the first whose domain
/// contains it within [`LEAF_EDGE_TOLERANCE`], else the first within `1e-6` (a
/// point in a crack between f32 domains), else the one whose domain centre is
/// nearest.
pub fn leaf_at(leaves: &[Leaf], u: f64, v: f64) -> Option<&Leaf> {
    let found = leaves
        .iter()
        .find(|l| l.contains(u, v, LEAF_EDGE_TOLERANCE));
    found
        .or_else(|| leaves.iter().find(|l| l.contains(u, v, 1e-6)))
        .or_else(|| {
            leaves
                .iter()
                .min_by(|a, b| domain_distance(a, u, v).total_cmp(&domain_distance(b, u, v)))
        })
}

fn domain_distance(l: &Leaf, u: f64, v: f64) -> f64 {
    let n = l.corners as usize;
    let (mut cu, mut cv) = (0.0, 0.0);
    for c in &l.uv[..n] {
        cu += c[0] as f64 / n as f64;
        cv += c[1] as f64 / n as f64;
    }
    (cu - u).powi(2) + (cv - v).powi(2)
}

/// The true error of a solution at reference points, as every report gives it
/// (issue 45, "report errors off the emitters"): relative RMS over the points off
/// the emitters (the headline: on an emitter `B ≈ E` is known in advance and says
/// nothing of the light the solver computes), over all points beside it, and the
/// worst point off the emitters. 40 bytes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PointError {
    /// [`relative_rms`] over the points not on an emitting patch (`NaN` if none).
    pub off_emitters: f64,
    /// [`relative_rms`] over all points.
    pub all: f64,
    /// Index of the worst point off the emitters (`usize::MAX` if none): the
    /// largest per-point [`relative_rms`].
    pub worst: usize,
    /// That point's relative RMS error (`NaN` if none).
    pub worst_error: f64,
    /// Points off the emitters.
    pub points_off: usize,
}

impl PointError {
    /// The error of `b` against `reference`, point by point; `on_emitter[i]` says
    /// whether point `i` lies on an emitting patch (a shorter mask leaves the rest
    /// off the emitters).
    pub fn measure(b: &[[f64; 3]], reference: &[[f64; 3]], on_emitter: &[bool]) -> PointError {
        let off = |i: &usize| !on_emitter.get(*i).copied().unwrap_or(false);
        let idx: Vec<usize> = (0..b.len().min(reference.len())).filter(off).collect();
        let (mut worst, mut worst_error) = (usize::MAX, f64::NAN);
        for &i in &idx {
            let e = relative_rms(&b[i..=i], &reference[i..=i]);
            if worst == usize::MAX || e > worst_error {
                (worst, worst_error) = (i, e);
            }
        }
        let pick = |v: &[[f64; 3]]| idx.iter().map(|&i| v[i]).collect::<Vec<_>>();
        PointError {
            off_emitters: if idx.is_empty() {
                f64::NAN
            } else {
                relative_rms(&pick(b), &pick(reference))
            },
            all: relative_rms(b, reference),
            worst,
            worst_error,
            points_off: idx.len(),
        }
    }

    /// One line for people: `7.1e-2 off the emitters (31 points; worst point 4: 1.2e-1),
    /// 3.0e-2 over all points`.
    pub fn text(&self) -> String {
        let worst = if self.worst == usize::MAX {
            String::new()
        } else {
            format!("; worst point {}: {:.3e}", self.worst, self.worst_error)
        };
        format!(
            "{:.3e} off the emitters ({} points{worst}), {:.3e} over all points",
            self.off_emitters, self.points_off, self.all
        )
    }
}

/// Relative RMS error `sqrt(Σ(B − B_ref)² / Σ B_ref²)` over points and channels: the
/// measure DESIGN.md fixes for every error report (absolute RMS if the reference is 0).
pub fn relative_rms(b: &[[f64; 3]], reference: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in b.iter().zip(reference) {
        for c in 0..3 {
            num += (x[c] - y[c]).powi(2);
            den += y[c] * y[c];
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        num.sqrt()
    }
}
