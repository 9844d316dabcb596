//! Reconstruction: the stored answer of a solve, meshed where `B(x)` bends.
//!
//! Each leaf of the hierarchy is a root cell. A cell's corners and centre are
//! final-gathered ([`Solver::gather_point`], in parallel batches of
//! [`GATHER_BATCH`] points, each point once however many cells share it:
//! [`VertexCache`]); a cell whose centre differs from the mean of its corners by more
//! than the reconstruction tolerance (on a root cell a source is partly hidden from,
//! or an edge's midpoint from the mean of its ends) splits along the directions in which it is
//! long enough ([`Cell::split_dirs`]), and the cells that stop are stored with
//! their corner values (bilinear within the cell), each corner raised by the
//! share of its cells' centre offsets their interpolant misses ([`MEAN_SHIFT`]).
//! With [`super::SolveOptions::source_field`] a static solve reconstructs twice: the second final gather sees each leaf source by the
//! first one's field, cell by cell where the source looks large from the point, by
//! quadrants elsewhere ([`Solver::field_shapes`]), not by its constant radiosity.
//!
//! # Near field
//!
//! A point's final gather takes each source at its constant radiosity (the leaf
//! system's), which is right where the point's kernel is nearly constant across the
//! source. Where the source looks large (the floor by a block sees the block's side,
//! a ceiling point by a wall the wall), the point sees most the strip of it nearest,
//! which the mean misses (the dark foot of a block, the dark top of a wall at a
//! concave edge). With [`super::SolveOptions::near_field`] the gathers of a static
//! solve note those terms ([`super::gather::NearTerms`]); once the cells have
//! stopped, each is taken again at the kernel-weighted mean of the reconstruction's
//! own field over its source, cell by cell with exact factors and a ray to each cell
//! ([`Solver::mend_near_terms`]), where that can move the point by a share of the
//! tolerance, and the cells whose mended values now bend split on (a point by a
//! concave edge moves more than one a cell further: unsplit, the cell would
//! interpolate between them). One pass, from the first field (a Jacobi step), in
//! the manner of a final gather from a first solution (Lischinski et al. 1993
//! §3).
//!
//! In a space-time window the
//! points a frame between two solved frames may take on the line between theirs
//! are not gathered ([`super::FrameBetween`]), and every point's value comes back for
//! later frames to interpolate ([`super::FrameValues`]), with the direct light of the
//! points on moving surfaces apart (`Solver::direct_light`).

use glam::DVec3;
use rayon::prelude::*;

use super::gather::NearTerms;
use super::spacetime::interpolate::point_coord;
use super::{
    ANY_LEAF, CORNER_INSET, ElementId, FastMap, FrameBetween, FrameValues, KeptKey, Leaf, Patches,
    PointKey, Solution, SolveStats, Solver, hierarchy,
};

/// Points gathered in parallel at a time by the reconstruction: enough to keep the
/// threads busy, few enough that the terms they return to keep stay small and, out
/// of core, that the kept terms' pages a batch reads stay few (each point touches
/// up to three pages). ACTOR out of core peaked at 40.9 MB with 512 and 37.7 MB
/// with 256; with its leaves out of core too, 128 takes another 0.6–1.8 MiB off
/// both scenes at the same time (BENCHMARKS.md).
const GATHER_BATCH: usize = 128;

/// What [`Solver::reconstruct_between`] did.
#[derive(Clone, Debug, Default)]
pub struct Reconstruction {
    /// The cells, as [`Solver::reconstruct`] returns them.
    pub leaves: Vec<Leaf>,
    /// The value at every point, gathered or interpolated, for later frames of a
    /// space-time window to interpolate (empty outside a window).
    pub values: FrameValues,
    /// Points gathered by a final gather.
    pub gathered: u64,
    /// Points interpolated between keyframes.
    pub interpolated: u64,
    /// Estimated relative RMS error of the bilinear interpolation between gathered
    /// corners: `0.53 ·` the area-weighted RMS, over the cells, of the gather at a
    /// cell's centre minus its corners' mean, relative to the RMS reflected
    /// radiosity at the centres (0.53 = RMS over a cell of the bubble
    /// `16 u(1−u) v(1−v)` whose peak is that difference).
    pub interpolation_error: f64,
}

/// A point to gather: the leaf whose links gather, the patch, the parameter point,
/// the parameter point it is inset towards, and its key (place and, gathered per
/// leaf, that leaf).
type GatherPoint = (ElementId, u32, [f32; 2], [f32; 2], KeptKey);

/// RMS over the unit square of the bubble `16 u(1−u) v(1−v)` (peak 1): `16/30`.
const BUBBLE_RMS: f64 = 16.0 / 30.0;

/// A reconstruction cell: a parameter sub-domain of a leaf's patch.
#[derive(Clone, Copy, Debug)]
struct Cell {
    leaf: ElementId,
    patch: u32,
    n: u32,
    uv: [[f32; 2]; 4],
    area: f64,
}

impl Cell {
    fn centre_uv(&self) -> [f32; 2] {
        let n = self.n as usize;
        let (mut u, mut v) = (0.0, 0.0);
        for c in &self.uv[..n] {
            u += c[0] / n as f32;
            v += c[1] / n as f32;
        }
        [u, v]
    }

    fn split(&self) -> [Cell; 4] {
        let kids = hierarchy::child_domains(self.n as usize, &self.uv);
        kids.map(|uv| Cell {
            uv,
            area: self.area / 4.0,
            ..*self
        })
    }

    /// Corner `i` of the cell in world space.
    fn corner(&self, i: usize, patches: &Patches) -> DVec3 {
        let [u, v] = self.uv[i];
        patches.point(self.patch as usize, u as f64, v as f64)
    }

    /// Which parameter directions `(u, v)` the cell may split along: a direction
    /// whose world edge is at least twice `min_len` (so no child is thinner than
    /// the reconstruction's smallest size), both for a triangle above four times
    /// the smallest area. A thin quad (a strip between two contact lines) keeps
    /// halving along its length; an area bound stopped it while it was long, or
    /// cut it thinner than the smallest size while it was short.
    fn split_dirs(&self, min_len: f64, patches: &Patches) -> (bool, bool) {
        if self.n == 3 {
            let ok = self.area >= 4.0 * min_len * min_len;
            return (ok, ok);
        }
        let p = |i: usize| self.corner(i, patches);
        let len_u = p(0).distance(p(1)).max(p(3).distance(p(2)));
        let len_v = p(0).distance(p(3)).max(p(1).distance(p(2)));
        (len_u >= 2.0 * min_len, len_v >= 2.0 * min_len)
    }

    /// Whether a split along `dirs` (see [`Cell::split_dirs`]) cuts edge `i`
    /// (from corner `i` to the next) at its midpoint: every edge of a triangle
    /// split at all; a quad's edges along `u` (0 and 2) when it splits along `u`,
    /// along `v` (1 and 3) when along `v`.
    fn cuts_edge(&self, i: usize, (su, sv): (bool, bool)) -> bool {
        if self.n == 3 {
            su || sv
        } else if i % 2 == 0 {
            su
        } else {
            sv
        }
    }

    /// The children of a split along `(u, v)`: four ([`Cell::split`]) along both,
    /// two halves of a quad along one.
    fn split_along(&self, (su, sv): (bool, bool)) -> Vec<Cell> {
        if su && sv {
            return self.split().to_vec();
        }
        let (u0, v0, u1, v1) = (self.uv[0][0], self.uv[0][1], self.uv[2][0], self.uv[2][1]);
        let r = |a: f32, b: f32, c: f32, d: f32| [[a, b], [c, b], [c, d], [a, d]];
        let kids = if su {
            let um = (u0 + u1) * 0.5;
            [r(u0, v0, um, v1), r(um, v0, u1, v1)]
        } else {
            let vm = (v0 + v1) * 0.5;
            [r(u0, v0, u1, vm), r(u0, vm, u1, v1)]
        };
        kids.iter()
            .map(|&uv| Cell {
                uv,
                area: self.area / 2.0,
                ..*self
            })
            .collect()
    }
}

/// Final-gather values at distinct parameter points of each patch (of each leaf,
/// with [`VertexCache::per_leaf`]).
#[derive(Default)]
struct VertexCache {
    /// The gather point of each place and leaf (the leaf [`ANY_LEAF`] unless
    /// [`VertexCache::per_leaf`]).
    index: FastMap<KeptKey, usize>,
    /// The first gather point of each place: the frame's value there, for the
    /// frames between to interpolate (after [`Solver::weld`], the same as the
    /// place's other points).
    first: FastMap<PointKey, usize>,
    /// Gather a point once per leaf whose cells have it, from inside that leaf
    /// ([`Solver::weld`] then averages them): a static solve, and a space-time
    /// window of one instant (solved as the static solve is).
    per_leaf: bool,
    /// (leaf whose links gather, patch, parameter point, point inset towards this
    /// uv, the point's key).
    points: Vec<GatherPoint>,
    values: Vec<([f64; 3], bool)>,
    /// The direct light of the points on moving surfaces, in a space-time window
    /// ([`Solver::direct_light`]).
    direct: Vec<(PointKey, [f32; 3])>,
    /// The gathered points with near terms, and those terms
    /// ([`super::gather::NearTerms`], [`Solver::mend_near_terms`]).
    near: Vec<(usize, NearTerms)>,
}

/// What the reconstruction makes of one point: its value, whether it lies outside
/// every solid, the terms to keep, its direct light if it is on a moving surface,
/// and its near terms ([`super::gather::NearTerms`]).
type Evaluated<T> = ([f64; 3], bool, Option<T>, Option<[f64; 3]>, NearTerms);

impl VertexCache {
    fn register(&mut self, c: &Cell, uv: [f32; 2], toward: [f32; 2]) -> usize {
        let pk = (c.patch, point_coord(uv[0]), point_coord(uv[1]));
        let key = (pk, if self.per_leaf { c.leaf.0 } else { ANY_LEAF });
        let points = &mut self.points;
        let i = *self.index.entry(key).or_insert_with(|| {
            points.push((c.leaf, c.patch, uv, toward, key));
            points.len() - 1
        });
        self.first.entry(pk).or_insert(i);
        i
    }

    /// Gathers up to `batch` of the points registered and not gathered yet; returns
    /// what `gather` made of the terms to keep (see [`Solver::gather_point`]).
    fn evaluate<T: Send>(
        &mut self,
        batch: usize,
        gather: impl Fn(ElementId, DVec3, KeptKey) -> Evaluated<T> + Sync,
        patches: &Patches,
    ) -> Vec<T> {
        let from = self.values.len();
        let to = self.points.len().min(from + batch);
        let new: Vec<_> = self.points[from..to]
            .par_iter()
            .map(|&(leaf, patch, uv, toward, key)| {
                let x = patches.point(patch as usize, uv[0] as f64, uv[1] as f64);
                let c = patches.point(patch as usize, toward[0] as f64, toward[1] as f64);
                // Evaluate a hair inside the cell: on an edge shared with a
                // perpendicular wall the factor jumps (the wall is seen edge-on), and
                // the interpolant wants the limit from inside.
                (key.0, gather(leaf, x + CORNER_INSET * (c - x), key))
            })
            .collect();
        let mut keep = Vec::new();
        for (pk, (b, valid, k, d, near)) in new {
            if valid && !near.is_empty() {
                self.near.push((self.values.len(), near));
            }
            self.values.push((b, valid));
            keep.extend(k);
            if let Some(d) = d {
                self.direct.push((pk, d.map(|x| x as f32)));
            }
        }
        keep
    }
}

fn mean3(v: &[[f64; 3]]) -> [f64; 3] {
    let mut m = [0.0; 3];
    for x in v {
        for k in 0..3 {
            m[k] += x[k] / v.len().max(1) as f64;
        }
    }
    m
}

/// Corner values of a cell; a corner inside a solid takes the mean of the valid ones
/// (or the leaf's element average when none is valid).
fn corner_values(
    cache: &VertexCache,
    corners: &[usize; 4],
    n: usize,
    element_b: [f32; 3],
) -> [[f64; 3]; 4] {
    let valid: Vec<[f64; 3]> = corners[..n]
        .iter()
        .filter(|&&v| cache.values[v].1)
        .map(|&v| cache.values[v].0)
        .collect();
    let fallback = if valid.is_empty() {
        [
            element_b[0] as f64,
            element_b[1] as f64,
            element_b[2] as f64,
        ]
    } else {
        mean3(&valid)
    };
    let mut out = [[0.0; 3]; 4];
    for i in 0..n {
        let (v, ok) = cache.values[corners[i]];
        out[i] = if ok { v } else { fallback };
    }
    out
}

impl Solver<'_> {
    /// The solution: reconstruction cells with corner radiosity from the final gather.
    ///
    /// Cells start as the hierarchy's leaves and split (in parameter space, like
    /// elements) while the gather at a cell's centre differs from the interpolant of
    /// its corners by more than `recon_tol · B_ref` (`recon_tol_moving` on a moving
    /// object's surface), or, on a root cell (a leaf) a shadow edge may cross
    /// (`Solver::shadow_may_cross`), the gather at the midpoint of
    /// an edge the split would cut differs from the mean of its ends by as much (a
    /// shadow edge crossing a big leaf away from its centre: a 0.19 m² floor
    /// triangle read 66% off a solve at `eps / 2`, `tests/it/solver/shadow_edge.rs`),
    /// across each direction in which
    /// it is at least twice the reconstruction's smallest size (both: four children;
    /// one: two halves, see `Cell::split_dirs`); a split cell keeps the links of its
    /// leaf. This meshes the stored answer to where `B(x)` bends (room edges, contact
    /// lines, shadow boundaries) without refining the link hierarchy there. Cells
    /// straddling the plane of a static emitter near them split across it too
    /// (`Solver::straddled_planes`).
    ///
    /// Its estimated error combines the last round's (the hierarchy's) with the
    /// reconstruction's interpolation error, `sqrt(e_h² + e_i²)` (`NaN` if the
    /// rounds gave none).
    pub fn solution(&self) -> Solution {
        let recon = if self.opts.source_field && !self.has_motion() {
            let (first, cell_leaves) = self.reconstruct_with(None, FieldShapes::new());
            let shapes = self.field_shapes(&first.leaves, &cell_leaves);
            self.reconstruct_with(None, shapes).0
        } else {
            self.reconstruct_between(None)
        };
        let leaves = recon.leaves;
        let (active, passive) = self.links.counts();
        Solution {
            scene: self.scene.clone(),
            patches: self.patches.geometry.clone(),
            leaves,
            stats: SolveStats {
                seconds: 0.0,
                iterations: 0,
                elements: self.elems.len() as u64,
                links_active: active,
                links_passive: passive,
                estimated_error: self.estimate.hypot(recon.interpolation_error),
                residual: 0.0,
            },
        }
    }

    /// The reconstruction cells of [`Solver::solution`] as stored leaves (time range
    /// the solver's), sorted by patch and parameters.
    pub fn reconstruct(&self) -> Vec<Leaf> {
        self.reconstruct_between(None).leaves
    }

    /// [`Solver::reconstruct`], with the points of a frame between two solved
    /// frames interpolated where those agree (see [`FrameBetween`]); `None` gathers
    /// every point (a keyframe). In a space-time window the values of every point
    /// come back too.
    pub fn reconstruct_between(&self, between: Option<&FrameBetween>) -> Reconstruction {
        self.reconstruct_with(between, FieldShapes::new()).0
    }

    /// [`Solver::reconstruct_between`] whose final gathers see the sources in
    /// `shapes` by their quadrants ([`Solver::field_shapes`]); with the leaf of
    /// every stored cell, in the order of the cells.
    fn reconstruct_with(
        &self,
        between: Option<&FrameBetween>,
        shapes: FieldShapes,
    ) -> (Reconstruction, Vec<u32>) {
        let geoms = self.elems.geoms.as_slice();
        let interpolated = std::sync::atomic::AtomicU64::new(0);
        // The window's kept terms, locked for the whole reconstruction: the
        // parallel gathers read them, the batches' fresh terms are added between.
        let mut guard = self
            .st
            .window
            .as_ref()
            .map(|w| w.points.lock().unwrap_or_else(|e| e.into_inner()));
        let mut known = guard.as_mut().and_then(|g| g.as_mut());
        // A window's frames share one scale (see `Window::b_ref`).
        let b_ref = match self.st.window.as_ref().and_then(|w| w.b_ref) {
            Some(b) => b,
            None => self.rms_radiosity(),
        };
        let tol = self.opts.recon_tol * b_ref;
        let tol_moving = self.opts.recon_tol_moving.map_or(tol, |t| t * b_ref);
        let mut limits = self.gather_limits(b_ref, true);
        // The near field: static solves and windows of one instant (solved as
        // the static solve is), not the second gather of `source_field` (which
        // sees every leaf by the first one's field).
        if self.opts.near_field
            && between.is_none()
            && (self.st.window.is_none() || !self.window_spans_time())
            && !self.has_motion()
            && shapes.cells.is_empty()
            && shapes.quadrants.is_empty()
        {
            limits.near_field = NEAR_FIELD_RATIO;
        }
        limits.shapes = shapes;
        let min_len = self.opts.recon_min_size * self.patches.diameter;
        let mut cache = VertexCache {
            // A window of one instant welds as the static solve does, its kept
            // terms apart per leaf (`KeptKey`); a window spanning time gathers
            // each point once, for its frames between to interpolate.
            per_leaf: !self.window_spans_time(),
            ..Default::default()
        };
        // In a space-time window the points on moving surfaces keep their direct
        // light apart, for the frames between to interpolate the rest only.
        let emitters = (self.st.direct_apart
            && self.st.window.is_some()
            && self.motion.moving_patch.contains(&true))
        .then(|| self.emitters_now())
        .flatten();
        let root_cell = |l: ElementId| {
            let g = &geoms[l.ix()];
            Cell {
                leaf: l,
                patch: g.patch,
                n: g.n,
                uv: g.uv,
                area: g.area,
            }
        };
        // A dark leaf ([`Solver::is_dark`]) is one black cell: nothing gathered,
        // nothing welded (a two-sided slab's inner face shares its corners with
        // the lit room side, whose values the weld would hand it).
        let (lit, dark): (Vec<ElementId>, Vec<ElementId>) =
            self.sys.leaves.iter().partition(|&&l| !self.is_dark(l));
        let mut cells: Vec<Cell> = lit.into_iter().map(root_cell).collect();
        let planes = self.emitter_planes();
        let mut done: Vec<(Cell, [usize; 4], usize)> = Vec::with_capacity(cells.len());
        // The root cells (the leaves) test their edges' midpoints too, see below.
        let mut test_mids = true;
        // The first field, once the cells have stopped, to mend the near terms
        // from ([`Solver::near_field`]).
        let mut field: Option<NearField> = None;
        loop {
            while !cells.is_empty() {
                // Register every corner and centre, gather the new ones in parallel.
                let mut ids = Vec::with_capacity(cells.len());
                for c in &cells {
                    let centre = c.centre_uv();
                    let mut corners = [usize::MAX; 4];
                    for (i, slot) in corners.iter_mut().enumerate().take(c.n as usize) {
                        *slot = cache.register(c, c.uv[i], centre);
                    }
                    // The midpoints of the edges a split would cut (the corners its
                    // children would have, gathered whether it splits or not), on the
                    // root cells only: a shadow edge crossing a big leaf where its
                    // centre does not see it. Every cell testing them stored 32% more
                    // cells on `gen_cubes 12` for 50% more CPU, the roots 5% and 9%.
                    // Only where a source is partly hidden (`shadow_may_cross`).
                    let dirs = c.split_dirs(min_len, &self.patches);
                    let mut mids = [usize::MAX; 4];
                    let n = c.n as usize;
                    let edges = test_mids && self.shadow_may_cross(c.leaf);
                    for (i, slot) in mids.iter_mut().enumerate().take(n) {
                        if edges && c.cuts_edge(i, dirs) {
                            let (a, b) = (c.uv[i], c.uv[(i + 1) % n]);
                            let m = [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5];
                            *slot = cache.register(c, m, centre);
                        }
                    }
                    ids.push((corners, cache.register(c, centre, centre), mids, dirs));
                }
                // In batches, so that the terms to keep are merged as they come (and
                // not computed at all for new points once the budget is spent).
                while cache.values.len() < cache.points.len() {
                    let admit = known.as_ref().is_some_and(|c| c.admits());
                    let view = known.as_deref();
                    // Whether a point of the batch was gathered (read the kept terms);
                    // a batch of interpolated points touches no page of them.
                    let gathered = std::sync::atomic::AtomicBool::new(false);
                    let fresh = cache.evaluate(
                        GATHER_BATCH,
                        |leaf, x, key| {
                            let pk = key.0;
                            let n = DVec3::from_array(geoms[leaf.ix()].normal);
                            let outside = || self.outside_solids(x, n);
                            let direct = emitters
                                .as_ref()
                                .filter(|_| self.motion.moving_patch[pk.0 as usize])
                                .map(|em| self.direct_light(x, n, pk.0, &pk, em));
                            if let Some((b, valid)) =
                                between.and_then(|bw| bw.value(&pk, outside, direct))
                            {
                                interpolated.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                                return (b, valid, None, direct.filter(|_| valid), Vec::new());
                            }
                            gathered.store(true, std::sync::atomic::Ordering::Relaxed);
                            let (b, valid, fresh, near) =
                                self.gather_point(leaf, x, view, key, admit, &limits);
                            // The records to keep are laid out here, in parallel.
                            let keep = view
                                .filter(|_| !fresh.is_empty())
                                .and_then(|v| v.prepare(key, fresh));
                            (b, valid, keep, direct.filter(|_| valid), near)
                        },
                        &self.patches,
                    );
                    if let Some(m) = known.as_mut().filter(|_| gathered.into_inner()) {
                        for p in fresh {
                            m.commit(p);
                        }
                        // Out of core: the pages the batch read and wrote go back to the
                        // scratch file. A batch interpolated whole touched none and has
                        // nothing to commit (most of a frame between: 6k of LIGHT's 12k
                        // `madvise` calls).
                        m.release_resident();
                    }
                }
                if let Some(f) = field.as_mut() {
                    self.mend_near_terms(&mut cache, f, tol);
                }
                let mut next = Vec::new();
                for (c, (corners, centre, mids, dirs)) in cells.into_iter().zip(ids) {
                    let n = c.n as usize;
                    let vals = corner_values(
                        &cache,
                        &corners,
                        n,
                        self.elems.radiosities.as_slice()[c.leaf.ix()],
                    );
                    let interp = mean3(&vals[..n]);
                    let (cv, ok) = cache.values[centre];
                    let mut off = max_dev(cv, interp);
                    // An edge's midpoint off its ends' mean: a shadow edge crossing the
                    // cell where its centre does not see it (a root cell a shadow edge
                    // may cross only).
                    for i in (0..n).filter(|&i| mids[i] != usize::MAX) {
                        let (m, m_ok) = cache.values[mids[i]];
                        if m_ok {
                            off = off.max(max_dev(m, mean3(&[vals[i], vals[(i + 1) % n]])));
                        }
                    }
                    let cell_tol = if self.motion.moving_patch.get(c.patch as usize) == Some(&true)
                    {
                        tol_moving
                    } else {
                        tol
                    };
                    let mut split = if ok && off > cell_tol {
                        dirs
                    } else {
                        (false, false)
                    };
                    if split == (false, false) && !planes.is_empty() {
                        let (su, sv) = self.straddled_planes(&c, &planes);
                        if su || sv {
                            let d = c.split_dirs(min_len, &self.patches);
                            split = (su && d.0, sv && d.1);
                        }
                    }
                    if split != (false, false) {
                        next.extend(c.split_along(split));
                    } else {
                        done.push((c, corners, centre));
                    }
                }
                cells = next;
                test_mids = false;
            }
            // The near field: once, after the cells have stopped. Its points are
            // mended from the field they make, and the cells whose mended values
            // now bend split on, their new points mended as they come.
            if limits.near_field <= 0.0 || field.is_some() || cache.near.is_empty() {
                break;
            }
            let mut f = self.near_field(&mut cache, &done);
            self.mend_near_terms(&mut cache, &mut f, tol);
            field = Some(f);
            let mut kept = Vec::with_capacity(done.len());
            for (c, corners, centre) in done {
                let (cv, ok) = cache.values[centre];
                let off = max_dev(cv, self.corners_mean(&cache, &c, &corners));
                let split = if ok && off > tol {
                    c.split_dirs(min_len, &self.patches)
                } else {
                    (false, false)
                };
                if split != (false, false) {
                    cells.extend(c.split_along(split));
                } else {
                    kept.push((c, corners, centre));
                }
            }
            done = kept;
            if cells.is_empty() {
                break;
            }
        }
        let (mut interp_num, mut interp_den) = (0.0, 0.0);
        for (c, corners, centre) in &done {
            let (cv, ok) = cache.values[*centre];
            if ok {
                let interp = self.corners_mean(&cache, c, corners);
                let e = self.patches.emissions[c.patch as usize];
                for k in 0..3 {
                    interp_num += c.area * (cv[k] - interp[k]).powi(2);
                    interp_den += c.area * (cv[k] - e[k]).powi(2);
                }
            }
        }
        let mut leaves = Vec::with_capacity(done.len());
        let mut cell_leaves = Vec::with_capacity(done.len());
        if cache.per_leaf {
            self.weld(&mut cache);
        }
        let shift = self.mean_shifts(&cache, &done);
        for (c, corners, _) in &done {
            cell_leaves.push(c.leaf.0);
            let mut vals = corner_values(
                &cache,
                corners,
                c.n as usize,
                self.elems.radiosities.as_slice()[c.leaf.ix()],
            );
            for (v, &i) in vals.iter_mut().zip(corners).take(c.n as usize) {
                if let Some(d) = shift.get(i).filter(|_| cache.values[i].1) {
                    for k in 0..3 {
                        v[k] += d[k];
                    }
                }
            }
            let mut b = [[0.0f32; 3]; 4];
            for i in 0..c.n as usize {
                b[i] = [
                    vals[i][0].max(0.0) as f32,
                    vals[i][1].max(0.0) as f32,
                    vals[i][2].max(0.0) as f32,
                ];
            }
            leaves.push(Leaf {
                patch: c.patch,
                corners: c.n,
                time: self.time,
                uv: c.uv,
                b,
            });
        }
        for l in dark {
            let c = root_cell(l);
            cell_leaves.push(c.leaf.0);
            leaves.push(Leaf {
                patch: c.patch,
                corners: c.n,
                time: self.time,
                uv: c.uv,
                b: [[0.0; 3]; 4],
            });
        }
        let mut order: Vec<usize> = (0..leaves.len()).collect();
        order.sort_by(|&i, &j| {
            let (a, b) = (&leaves[i], &leaves[j]);
            a.patch
                .cmp(&b.patch)
                .then(a.uv[0][0].total_cmp(&b.uv[0][0]))
                .then(a.uv[0][1].total_cmp(&b.uv[0][1]))
        });
        let leaves: Vec<Leaf> = order.iter().map(|&i| leaves[i]).collect();
        let cell_leaves: Vec<u32> = order.iter().map(|&i| cell_leaves[i]).collect();
        if let Some(m) = known {
            m.collect(&cache.index);
        }
        drop(guard);
        let interpolated = interpolated.into_inner();
        // Later frames of a window interpolate this one's values; a solve
        // outside a window has no use for them.
        let values = if self.st.window.is_some() {
            FrameValues::from_points(cache.first.iter().map(|(&pk, &i)| {
                let (b, ok) = cache.values[i];
                (pk, b, ok)
            }))
            .with_direct(std::mem::take(&mut cache.direct))
        } else {
            FrameValues::default()
        };
        let recon = Reconstruction {
            leaves,
            values,
            gathered: cache.values.len() as u64 - interpolated,
            interpolated,
            interpolation_error: if interp_den > 0.0 {
                BUBBLE_RMS * (interp_num / interp_den).sqrt()
            } else {
                0.0
            },
        };
        (recon, cell_leaves)
    }

    /// Whether a shadow boundary may cross leaf `leaf`, so that its root cell tests
    /// its edges' midpoints: a source of its chain (its links and its ancestors')
    /// is partly hidden from it, by the link's rays (a link not proved clear by a
    /// shaft, whose visible fraction is strictly between 0 and 1), by the leaf's
    /// own row (its quadrature points' rays, kept in a static solve) or because the
    /// link varies in a time window (a moving object may cross it). A leaf every
    /// source of which is proved clear, or seen whole or hidden whole by every ray
    /// cast for it, has no shadow edge those rays saw.
    ///
    /// Why: the midpoints were a quarter of the empty Cornell box's run time at
    /// eps 0.1 (no occluder in the box, no shadow edge for them to find): CPU
    /// 0.676 → 0.532 s with this test, 0.35% → 0.36% off the lamp; the box with
    /// its blocks tests 900 of its 925 leaves (BENCHMARKS.md, "Static solver:
    /// error against run time (Cornell box)").
    fn shadow_may_cross(&self, leaf: ElementId) -> bool {
        let tr = self.links.transports.as_slice();
        let partial = |v: f32| v > 0.0 && v < 1.0;
        let by_link = self.chain_links(leaf).any(|l| {
            let t = &tr[l as usize];
            t.varying() || (!t.shaft_clear() && partial(t.visibility))
        });
        by_link
            || self
                .sys
                .row_cache
                .get(&leaf.0)
                .is_some_and(|row| row.iter().any(|k| partial(k.vis)))
    }

    /// The planes of the static emitters, for [`Solver::straddled_planes`]: (unit
    /// normal, offset, size as the square root of the area, centroid).
    fn emitter_planes(&self) -> Vec<(DVec3, f64, f64, DVec3)> {
        let p = &self.patches;
        (0..p.len())
            .filter(|&j| p.emits(j) && self.motion.moving_patch.get(j) != Some(&true))
            .map(|j| {
                let poly = &p.polys[j];
                let n = p.normals[j];
                (n, n.dot(poly.v[0]), poly.area().sqrt(), poly.centroid())
            })
            .collect()
    }

    /// Along which parameter directions `(u, v)` cell `c` is split for straddling
    /// the plane of an emitter of `planes` within [`EMITTER_PLANE_REACH`] of its
    /// sizes: while it is more than [`EMITTER_PLANE_CELL`] of them thick across
    /// the plane, along the directions in which its edges cross it (both, on a
    /// triangle).
    ///
    /// Why: a one-sided emitter lights nothing behind its plane, and the direct
    /// light of a surface the plane crosses (a wall beside a lamp hung under the
    /// ceiling) has a kink along the crossing. A cell straddling it interpolates
    /// across the kink, and its centre's gather can agree with its corners' mean
    /// (the wall band under a 1 m lamp hung 20 cm down read 2.4–3.7% over the path
    /// tracer; with a 1 m lamp hung 10 cm down, the one-quad room of
    /// `tests/it/solver/tiled_lamp.rs` differed from the tiled one by 2.15% at
    /// worst, at a wall point 10 cm under the lamp's plane, and by 0.67% at worst
    /// with these splits).
    fn straddled_planes(&self, c: &Cell, planes: &[(DVec3, f64, f64, DVec3)]) -> (bool, bool) {
        let n = c.n as usize;
        let pts: [DVec3; 4] = std::array::from_fn(|i| c.corner(i.min(n - 1), &self.patches));
        let pts = &pts[..n];
        let centre = pts.iter().copied().sum::<DVec3>() / n as f64;
        // A plane through the cell's edge (a lamp set in the ceiling, beside a
        // wall) crosses nothing.
        let tol = 1e-6 * self.patches.diameter;
        let (mut su, mut sv) = (false, false);
        for &(nj, dj, size, cj) in planes {
            if centre.distance(cj) > EMITTER_PLANE_REACH * size {
                continue;
            }
            let sd: [f64; 4] = std::array::from_fn(|i| nj.dot(pts[i.min(n - 1)]) - dj);
            let lo = sd[..n].iter().copied().fold(f64::INFINITY, f64::min);
            let hi = sd[..n].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if lo >= -tol || hi <= tol || hi - lo <= EMITTER_PLANE_CELL * size {
                continue;
            }
            if n == 3 {
                return (true, true);
            }
            let crosses = |a: usize, b: usize| (sd[a] > 0.0) != (sd[b] > 0.0);
            su |= crosses(0, 1) || crosses(3, 2);
            sv |= crosses(0, 3) || crosses(1, 2);
        }
        (su, sv)
    }

    /// Averages the values of the points gathered at one place of one surface
    /// from different leaves ([`VertexCache::per_leaf`]): the same parameter point
    /// gathered inside each leaf that has it, or the same world point on two
    /// coplanar patches of one material (a seam between tiles), unless a surface
    /// stands on the seam between the two sides ([`WELD_PROBE`]).
    ///
    /// Why: a point on the edge of a leaf, gathered from inside it, takes the
    /// sources its leaf's links see (cluster estimates, leaves of the surface
    /// across a corner at their mean, which the point by the corner sees right at
    /// its foot); gathered inside the next leaf it takes that leaf's. The wall of a
    /// 6 × 3 × 6 m room gathered 0.4224 and 0.4342 at either side of one point by
    /// the floor (the floor leaves under it, 0.38 and 0.46). One tiling gathered
    /// the point once, from the first leaf that had it, and another had a seam of
    /// two patches there and gathered each side: the rooms differed by 2.1% at a
    /// probe 0.3 m above the floor. Averaged, the value at a seam is the same
    /// whichever leaves and tiles meet there.
    fn weld(&self, cache: &mut VertexCache) {
        let diam = self.patches.diameter;
        let tol = 1e-6 * diam;
        let probe = WELD_PROBE * diam;
        let n = cache.points.len();
        let world: Vec<(DVec3, DVec3)> = cache
            .points
            .iter()
            .map(|&(_, patch, uv, toward, _)| {
                let p = patch as usize;
                (
                    self.patches.point(p, uv[0] as f64, uv[1] as f64),
                    self.patches.point(p, toward[0] as f64, toward[1] as f64),
                )
            })
            .collect();
        let bin = |x: DVec3| {
            let b = (x / tol).floor();
            (b.x as i64, b.y as i64, b.z as i64)
        };
        let mut bins: FastMap<(i64, i64, i64), Vec<usize>> = FastMap::default();
        for (i, &(x, _)) in world.iter().enumerate() {
            if cache.values[i].1 {
                bins.entry(bin(x)).or_default().push(i);
            }
        }
        let mut root: Vec<usize> = (0..n).collect();
        fn find(root: &mut [usize], mut i: usize) -> usize {
            while root[i] != i {
                root[i] = root[root[i]];
                i = root[i];
            }
            i
        }
        let same_surface = |i: usize, j: usize| {
            let (pi, pj) = (cache.points[i].1 as usize, cache.points[j].1 as usize);
            if pi == pj {
                return true;
            }
            let p = &self.patches;
            p.normals[pi].dot(p.normals[pj]) > 1.0 - 1e-6
                && p.rhos[pi] == p.rhos[pj]
                && p.emissions[pi] == p.emissions[pj]
        };
        for i in 0..n {
            if !cache.values[i].1 {
                continue;
            }
            let (x, ci) = world[i];
            let b = bin(x);
            for d in 0..27i64 {
                let key = (b.0 + d % 3 - 1, b.1 + d / 3 % 3 - 1, b.2 + d / 9 - 1);
                let Some(near) = bins.get(&key) else {
                    continue;
                };
                for &j in near {
                    if j >= i || world[j].0.distance(x) > tol || !same_surface(i, j) {
                        continue;
                    }
                    // A surface standing on the seam between the two sides
                    // (a panel on a wall): the sides differ for real.
                    let nrm = self.patches.normals[cache.points[i].1 as usize];
                    let side = |c: DVec3| x + probe * (nrm + (c - x).normalize_or_zero());
                    if self.bvh.occluded(side(ci), side(world[j].1)) {
                        continue;
                    }
                    let (ri, rj) = (find(&mut root, i), find(&mut root, j));
                    root[ri.max(rj)] = ri.min(rj);
                }
            }
        }
        let mut sum: FastMap<usize, ([f64; 3], f64)> = FastMap::default();
        for i in 0..n {
            if cache.values[i].1 {
                let r = find(&mut root, i);
                let e = sum.entry(r).or_insert(([0.0; 3], 0.0));
                for k in 0..3 {
                    e.0[k] += cache.values[i].0[k];
                }
                e.1 += 1.0;
            }
        }
        for i in 0..n {
            if cache.values[i].1 {
                let (s, w) = sum[&find(&mut root, i)];
                cache.values[i].0 = s.map(|x| x / w);
            }
        }
    }

    /// The mean of the values at the corners of cell `c` (`corners` in `cache`):
    /// the value the cell interpolates at its centre.
    fn corners_mean(&self, cache: &VertexCache, c: &Cell, corners: &[usize; 4]) -> [f64; 3] {
        let n = c.n as usize;
        let b_leaf = self.elems.radiosities.as_slice()[c.leaf.ix()];
        mean3(&corner_values(cache, corners, n, b_leaf)[..n])
    }

    /// The field of the cells `done` as they would be stored (welded, shifted),
    /// for [`Solver::mend_near_terms`]; the cache's values are left as they are.
    fn near_field(&self, cache: &mut VertexCache, done: &[(Cell, [usize; 4], usize)]) -> NearField {
        let b = self.elems.radiosities.as_slice();
        let raw = cache.per_leaf.then(|| cache.values.clone());
        if raw.is_some() {
            self.weld(cache);
        }
        let shift = self.mean_shifts(cache, done);
        let mut cells_of: FastMap<u32, Vec<u32>> = FastMap::default();
        let cells = done
            .iter()
            .enumerate()
            .map(|(j, (c, corners, _))| {
                cells_of.entry(c.leaf.0).or_default().push(j as u32);
                let n = c.n as usize;
                let mut vals = corner_values(cache, corners, n, b[c.leaf.ix()]);
                for (v, &i) in vals.iter_mut().zip(corners).take(n) {
                    if let Some(d) = shift.get(i).filter(|_| cache.values[i].1) {
                        for k in 0..3 {
                            v[k] = (v[k] + d[k]).max(0.0);
                        }
                    }
                }
                FieldCell {
                    n,
                    patch: c.patch,
                    pts: std::array::from_fn(|i| c.corner(i.min(n - 1), &self.patches)),
                    b: vals,
                }
            })
            .collect();
        if let Some(raw) = raw {
            cache.values = raw;
        }
        NearField {
            cells,
            cells_of,
            sources: FastMap::default(),
        }
    }

    /// Mends the near terms of the gathered points (`cache.near`, then emptied)
    /// from the field `f` ([`Solver::near_field`]): each such term took its source
    /// at its constant radiosity `B_s` (the leaf system's), and takes it instead at
    /// the mean of the field over the source weighted by the point's kernel, `Σ F_c
    /// B_c / Σ F_c` over the field's cells `c` of the leaves under the source (`B_c`
    /// a cell's mean), a cell still large seen from the point split further
    /// ([`near_cell`]), each (sub-)cell counted only if a ray from the point
    /// reaches its centre. A point moves by `ρ f v (Σ F_c B_c / Σ F_c − B_s)` per
    /// term; a term whose bound on that (the field's largest distance from `B_s`
    /// over the source) is under [`NEAR_FIELD_SHARE`] of the reconstruction
    /// tolerance `tol` is left alone.
    fn mend_near_terms(&self, cache: &mut VertexCache, f: &mut NearField, tol: f64) {
        let geoms = self.elems.geoms.as_slice();
        let b = self.elems.radiosities.as_slice();
        let near = std::mem::take(&mut cache.near);
        // Each source of a near term: its cells and the field's largest distance
        // from its constant per channel.
        for (_, terms) in &near {
            for &(e, _) in terms {
                if f.sources.contains_key(&e) {
                    continue;
                }
                let mut cells = Vec::new();
                let mut stack = vec![e];
                while let Some(x) = stack.pop() {
                    let kids = self.elems.children(ElementId(x));
                    if kids.is_empty() {
                        cells.extend(f.cells_of.get(&x).into_iter().flatten().copied());
                    } else {
                        stack.extend(kids);
                    }
                }
                let be = b[e as usize];
                let mut dev = [0.0f64; 3];
                for &j in &cells {
                    let fc = &f.cells[j as usize];
                    for k in 0..3 {
                        for v in &fc.b[..fc.n] {
                            dev[k] = dev[k].max((v[k] - be[k] as f64).abs());
                        }
                    }
                }
                f.sources.insert(e, NearSource { cells, dev });
            }
        }
        let patches = &self.patches;
        let f = &*f;
        let moves: Vec<(usize, [f64; 3])> = near
            .par_iter()
            .filter_map(|(i, terms)| {
                let (leaf, patch, uv, toward, _) = cache.points[*i];
                let p = patch as usize;
                let x0 = patches.point(p, uv[0] as f64, uv[1] as f64);
                let c = patches.point(p, toward[0] as f64, toward[1] as f64);
                let x = x0 + CORNER_INSET * (c - x0);
                let n = DVec3::from_array(geoms[leaf.ix()].normal);
                let rho = patches.rhos[p];
                // What the point sees of each cell: one ray to its centre.
                let mut last = crate::geometry::LastHit::default();
                let mut visible = |y: DVec3, q: u32| {
                    !self.bvh.occluded_between(
                        x,
                        y,
                        [patch, q],
                        crate::geometry::Parts::All,
                        &mut last,
                    )
                };
                let mut d = [0.0f64; 3];
                let mut moved = false;
                for &(e, fv) in terms {
                    let src = &f.sources[&e];
                    let bound = (0..3).map(|k| rho[k] * fv * src.dev[k]).fold(0.0, f64::max);
                    if src.cells.is_empty() || bound < NEAR_FIELD_SHARE * tol {
                        continue;
                    }
                    let mut acc = ([0.0f64; 3], 0.0f64);
                    for &j in &src.cells {
                        near_cell(
                            x,
                            n,
                            &f.cells[j as usize],
                            (NEAR_FIELD_RATIO, NEAR_SPLIT_DEPTH),
                            &mut visible,
                            &mut acc,
                        );
                    }
                    if acc.1 <= 0.0 {
                        continue;
                    }
                    let be = b[e as usize];
                    for k in 0..3 {
                        d[k] += rho[k] * fv * (acc.0[k] / acc.1 - be[k] as f64);
                    }
                    moved = true;
                }
                moved.then_some((*i, d))
            })
            .collect();
        for (i, d) in moves {
            for (v, d) in cache.values[i].0.iter_mut().zip(d) {
                *v += d;
            }
        }
    }

    /// Per gathered point: how far its value is raised so that the cells around
    /// it hold the mean their centres' gathers say, [`MEAN_SHIFT`] of each cell's
    /// centre offset averaged over the cells that share the point by area.
    ///
    /// In a space-time window too, every frame: the values a frame hands on to the
    /// frames between ([`FrameValues`]) are the points' own, unshifted, and a frame
    /// between shifts its cells from its own values, gathered or on the line, as a
    /// keyframe does (the shift is linear in the values: a frame between with the
    /// keyframes' cells, every point on the line, stores the line between their
    /// shifted cells; a point no solved frame had takes their stored cells,
    /// shifted already, and a cell of the frame between inside one of those has
    /// its centre on its corners' mean, so no second shift). Why: without it a window's frames read 1.63% off a fine
    /// static solve at t = 0.4 of `tests/it/spacetime.rs`'s sliding block where the
    /// static solve of the frame, shifted, reads 1.40%; shifted 1.37% (1.92% →
    /// 1.68% at t = 0, 1.65% → 1.39% at t = 0.8).
    fn mean_shifts(
        &self,
        cache: &VertexCache,
        done: &[(Cell, [usize; 4], usize)],
    ) -> Vec<[f64; 3]> {
        let f = MEAN_SHIFT;
        let mut sum = vec![[0.0f64; 3]; cache.values.len()];
        let mut weight = vec![0.0f64; cache.values.len()];
        for (c, corners, centre) in done {
            let (cv, ok) = cache.values[*centre];
            if !ok {
                continue;
            }
            let n = c.n as usize;
            let vals = corner_values(
                cache,
                corners,
                n,
                self.elems.radiosities.as_slice()[c.leaf.ix()],
            );
            let interp = mean3(&vals[..n]);
            for &i in &corners[..n] {
                for k in 0..3 {
                    sum[i][k] += c.area * f * (cv[k] - interp[k]);
                }
                weight[i] += c.area;
            }
        }
        sum.iter()
            .zip(&weight)
            .map(|(s, &w)| if w > 0.0 { s.map(|x| x / w) } else { [0.0; 3] })
            .collect()
    }

    /// The quadrant shapes of every quad leaf in the field of a first
    /// reconstruction (`cells`, the leaf of each in `cell_leaves`): the field's
    /// mean over each quadrant of the leaf (cut at its parametric midpoints, in
    /// the order of [`super::shaped_factor`]) over the leaf's radiosity, in the
    /// channel where that is largest. [`SOURCE_SAMPLES`]² points per leaf.
    fn field_shapes(&self, cells: &[Leaf], cell_leaves: &[u32]) -> FieldShapes {
        let geoms = self.elems.geoms.as_slice();
        let b = self.elems.radiosities.as_slice();
        let mut by_leaf: Vec<usize> = (0..cells.len()).collect();
        by_leaf.sort_by_key(|&i| cell_leaves[i]);
        let groups: Vec<&[usize]> = by_leaf
            .chunk_by(|&i, &j| cell_leaves[i] == cell_leaves[j])
            .collect();
        let cells_of: std::collections::HashMap<u32, Vec<(crate::geometry::Poly, f32)>> = groups
            .par_iter()
            .filter_map(|group| {
                let leaf = cell_leaves[group[0]];
                let bl = b[leaf as usize];
                let c = (0..3).max_by(|&x, &y| bl[x].total_cmp(&bl[y]))?;
                if bl[c] <= 0.0 || group.len() < 2 {
                    return None;
                }
                let v = group
                    .iter()
                    .map(|&ci| {
                        let cl = &cells[ci];
                        let k = cl.corners as usize;
                        let pts: Vec<DVec3> = (0..k)
                            .map(|i| {
                                self.patches.point(
                                    cl.patch as usize,
                                    cl.uv[i][0] as f64,
                                    cl.uv[i][1] as f64,
                                )
                            })
                            .collect();
                        let mean = (0..k).map(|i| cl.b[i][c] as f64).sum::<f64>() / k as f64;
                        (
                            crate::geometry::Poly::new(&pts),
                            (mean / bl[c] as f64) as f32,
                        )
                    })
                    .collect();
                Some((leaf, v))
            })
            .collect();
        let quadrants = groups
            .par_iter()
            .filter_map(|group| {
                let leaf = cell_leaves[group[0]];
                let g = &geoms[leaf as usize];
                if g.n != 4 {
                    return None;
                }
                let bl = b[leaf as usize];
                let c = (0..3).max_by(|&x, &y| bl[x].total_cmp(&bl[y]))?;
                if bl[c] <= 0.0 {
                    return None;
                }
                let (u0, v0) = (g.uv[0][0] as f64, g.uv[0][1] as f64);
                let (u1, v1) = (g.uv[2][0] as f64, g.uv[2][1] as f64);
                let k = SOURCE_SAMPLES;
                let mut sum = [0.0f64; 4];
                let mut count = [0u32; 4];
                for i in 0..k {
                    for j in 0..k {
                        let (s, t) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
                        let (u, v) = (u0 + s * (u1 - u0), v0 + t * (v1 - v0));
                        let cell = group
                            .iter()
                            .map(|&ci| &cells[ci])
                            .find(|cl| super::uv_inside(&cl.uv, cl.corners, [u, v]))?;
                        let q = match (s > 0.5, t > 0.5) {
                            (false, false) => 0,
                            (true, false) => 1,
                            (true, true) => 2,
                            (false, true) => 3,
                        };
                        sum[q] += cell.eval(u, v)[c];
                        count[q] += 1;
                    }
                }
                let r = std::array::from_fn(|q| {
                    (sum[q] / count[q].max(1) as f64 / bl[c] as f64) as f32
                });
                Some((leaf, r))
            })
            .collect();
        FieldShapes {
            quadrants,
            cells: cells_of,
        }
    }
}

/// How far from an emitter's centroid, in its sizes (square root of its area), the
/// reconstruction splits the cells its plane crosses ([`Solver::straddled_planes`]):
/// the walls of a 6 m room are 3 m from a 1 m lamp at its middle.
const EMITTER_PLANE_REACH: f64 = 4.0;

/// How thin across an emitter's plane, in the emitter's sizes, the cells that plane
/// crosses are split ([`Solver::straddled_planes`]): 2 cm beside a 1 m lamp.
const EMITTER_PLANE_CELL: f64 = 0.02;

/// How far, in scene diameters, [`Solver::weld`] probes for a surface standing
/// on a seam: a segment this far above the plane, from this far into one side to
/// this far into the other, must be clear.
const WELD_PROBE: f64 = 1e-4;

/// The share of a cell's centre offset (its centre's gather minus its corners'
/// mean) that its corners are raised by ([`Solver::mean_shifts`]): the mean of
/// the bubble `16 u(1−u) v(1−v)` over the cell, `4/9` (on a triangle the cubic
/// bubble's, `27/60`, is close). The bilinear interpolant of the gathered
/// corners misses that share of the cell's mean, one-signed where `B` is
/// concave: the Cornell box's floor and ceiling read 0.5–1% dark at the default
/// `--recon-tol` from it alone. Shifted, the interpolant has the gathered mean
/// and its RMS error over a bubble falls from 0.53 to 0.30 of the offset.
const MEAN_SHIFT: f64 = 4.0 / 9.0;

/// The near field ([`super::SolveOptions::near_field`]): a final-gather term
/// whose source's bounding sphere has a radius above this times its distance from
/// the point is mended from the reconstruction's field ([`Solver::mend_near_terms`]),
/// and a field cell seen so is split further ([`near_cell`]).
const NEAR_FIELD_RATIO: f64 = 0.3;

/// A near term is mended only where it could move its point by more than this
/// share of the reconstruction tolerance ([`Solver::mend_near_terms`]).
const NEAR_FIELD_SHARE: f64 = 0.25;

/// Most times [`near_cell`] halves a field cell.
const NEAR_SPLIT_DEPTH: u32 = 2;

/// A field cell whose bounding radius is under this times its distance from the
/// point, wholly in front of it, takes the point-to-point kernel at its centre
/// times its area ([`near_cell`]), not its exact factor.
const NEAR_KERNEL_RATIO: f64 = 0.2;

/// The largest difference between `a` and `b` over the three channels.
fn max_dev(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max)
}

/// One stored cell of the first field ([`Solver::mend_near_terms`]): its corners
/// in space and their radiosities (bilinear between them; a triangle linear).
struct FieldCell {
    n: usize,
    /// Its patch, for the visibility rays of [`near_cell`].
    patch: u32,
    pts: [DVec3; 4],
    b: [[f64; 3]; 4],
}

/// A source of near terms ([`Solver::mend_near_terms`]): its field cells and the
/// field's largest distance from its constant radiosity per channel.
struct NearSource {
    cells: Vec<u32>,
    dev: [f64; 3],
}

/// The first field of a reconstruction, that its near terms are mended from
/// ([`Solver::near_field`], [`Solver::mend_near_terms`]).
struct NearField {
    /// Every stored cell.
    cells: Vec<FieldCell>,
    /// `leaf →` its cells.
    cells_of: FastMap<u32, Vec<u32>>,
    /// The sources met so far.
    sources: FastMap<u32, NearSource>,
}

/// Adds `(Σ F B̄, Σ F)` of the field cell `c` seen from the point `x` (normal `n`)
/// to `acc`: its exact factor times its mean radiosity, split into four (its
/// parametric midpoints; a triangle's edge midpoints) while its bounding radius
/// exceeds `ratio` times its distance from the point, at most `depth` times; a
/// (sub-)cell whose centre `visible(centre, patch)` says the point does not see
/// adds nothing.
///
/// Why the visibility: the factors are unoccluded, and a source's cells the
/// point cannot see (a slab's face running on inside the slab it crosses, the
/// values of its corners there extrapolated from the room side; a part behind
/// another surface) took weight in the mean. On the Blender box (walls of slabs
/// overlapping at the corners) the floor point by the red wall read 20% bright,
/// 5.4% off the lamp against 2.8% without the near field; one ray per cell,
/// 3.4% and 2.6%.
fn near_cell(
    x: DVec3,
    n: DVec3,
    c: &FieldCell,
    (ratio, depth): (f64, u32),
    visible: &mut dyn FnMut(DVec3, u32) -> bool,
    acc: &mut ([f64; 3], f64),
) {
    let k = c.n;
    let centre = c.pts[..k].iter().copied().sum::<DVec3>() / k as f64;
    let r = c.pts[..k]
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f64::max);
    if depth > 0 && r > ratio * centre.distance(x) {
        let mid = |a: usize, b: usize| {
            let bm: [f64; 3] = std::array::from_fn(|j| 0.5 * (c.b[a][j] + c.b[b][j]));
            (0.5 * (c.pts[a] + c.pts[b]), bm)
        };
        let kids: [[(DVec3, [f64; 3]); 4]; 4] = if k == 3 {
            let (m01, m12, m20) = (mid(0, 1), mid(1, 2), mid(2, 0));
            let p = |i: usize| (c.pts[i], c.b[i]);
            [
                [p(0), m01, m20, m20],
                [m01, p(1), m12, m12],
                [m20, m12, p(2), p(2)],
                [m01, m12, m20, m20],
            ]
        } else {
            let (m01, m12, m23, m30) = (mid(0, 1), mid(1, 2), mid(2, 3), mid(3, 0));
            let cb = mean3(&c.b[..4]);
            let cc = (centre, cb);
            let p = |i: usize| (c.pts[i], c.b[i]);
            [
                [p(0), m01, cc, m30],
                [m01, p(1), m12, cc],
                [cc, m12, p(2), m23],
                [m30, cc, m23, p(3)],
            ]
        };
        for kid in kids {
            let sub = FieldCell {
                n: k,
                patch: c.patch,
                pts: kid.map(|v| v.0),
                b: kid.map(|v| v.1),
            };
            near_cell(x, n, &sub, (ratio, depth - 1), visible, acc);
        }
        return;
    }
    let dist = centre.distance(x);
    let poly = crate::geometry::Poly::new(&c.pts[..k]);
    let f = if r < NEAR_KERNEL_RATIO * dist {
        // Far for its size: the point-to-point kernel at its centre.
        let av = poly.area_vector();
        let w = (centre - x) / dist;
        let (cx, cy) = (n.dot(w), -av.dot(w));
        if cx > r / dist && cy > 0.0 {
            0.5 * cx * cy / (std::f64::consts::PI * dist * dist)
        } else {
            super::point_to_polygon(x, n, &poly)
        }
    } else {
        super::point_to_polygon(x, n, &poly)
    };
    if f > 0.0 && visible(centre, c.patch) {
        let m = mean3(&c.b[..k]);
        for (a, m) in acc.0.iter_mut().zip(m) {
            *a += f * m;
        }
        acc.1 += f;
    }
}

/// Points per side of the grid [`Solver::field_shapes`] samples a leaf at.
const SOURCE_SAMPLES: usize = 8;

/// What a second final gather knows of its sources from the first
/// reconstruction ([`Solver::field_shapes`]).
#[derive(Clone, Debug, Default)]
pub(super) struct FieldShapes {
    /// `leaf → r_q`: the radiosity over quadrant `q` is `r_q B_leaf`.
    pub(super) quadrants: std::collections::HashMap<u32, [f32; 4]>,
    /// `leaf →` its cells: polygon and mean radiosity over `B_leaf`.
    pub(super) cells: std::collections::HashMap<u32, Vec<(crate::geometry::Poly, f32)>>,
}

impl FieldShapes {
    fn new() -> Self {
        FieldShapes::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thin_cell_splits_along_its_length_and_no_thinner_than_the_smallest_size() {
        let scene = crate::scene::cornell_box(false);
        let patches = Patches::at_time(&scene, 0.0);
        let quad = (0..patches.len())
            .find(|&i| patches.polys[i].n == 4)
            .expect("the Cornell box has quads");
        let world = |uv: [f32; 2]| patches.point(quad, uv[0] as f64, uv[1] as f64);
        let cell = |u1: f32, v1: f32| {
            let uv = [[0.0, 0.0], [u1, 0.0], [u1, v1], [0.0, v1]];
            let e = |a: usize, b: usize| world(uv[a]).distance(world(uv[b]));
            Cell {
                leaf: ElementId(0),
                patch: quad as u32,
                n: 4,
                uv,
                area: e(0, 1) * e(0, 3),
            }
        };
        let strip = cell(1.0, 0.02);
        let long = world([0.0, 0.0]).distance(world([1.0, 0.0]));
        let thin = world([0.0, 0.0]).distance(world([0.0, 0.02]));
        assert!(long > 0.3 && thin > 0.005, "{long} {thin}");
        // Thinner than twice the smallest size, far larger than four times its area:
        // halved along its length only.
        let min_len = 0.6 * thin;
        assert!(strip.area >= 4.0 * min_len * min_len);
        assert_eq!(strip.split_dirs(min_len, &patches), (true, false));
        let halves = strip.split_along((true, false));
        assert_eq!(halves.len(), 2);
        assert_eq!(
            halves[0].uv,
            [[0.0, 0.0], [0.5, 0.0], [0.5, 0.02], [0.0, 0.02]]
        );
        assert_eq!(
            halves[1].uv,
            [[0.5, 0.0], [1.0, 0.0], [1.0, 0.02], [0.5, 0.02]]
        );
        assert!((halves[0].area + halves[1].area - strip.area).abs() < 1e-12);
        // Wide enough both ways: the four children of an element split.
        assert_eq!(strip.split_dirs(0.4 * thin, &patches), (true, true));
        let quarters = strip.split_along((true, true));
        assert_eq!(quarters.len(), 4);
        assert_eq!(
            quarters[0].uv,
            [[0.0, 0.0], [0.5, 0.0], [0.5, 0.01], [0.0, 0.01]]
        );
        // Short both ways: not split.
        assert_eq!(
            cell(0.02, 0.02).split_dirs(min_len, &patches),
            (false, false)
        );
        assert_eq!(strip.split_dirs(0.6 * long, &patches), (false, false));
    }
}
