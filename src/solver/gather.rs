//! The final gather at one reconstruction point: `B(x) = E + ρ Σ_links F(x, s) V(x, s)
//! B_s` over the links of the point's leaf and its ancestors (the chain), each
//! source's factor and visibility evaluated at the point ([`Solver::point_terms`]),
//! a source whose radiosity varies opened into its children.
//!
//! In a space-time window a static point keeps what holds of its terms from static
//! sources ([`super::spacetime::kept_terms`]; paper 001 §5.2's shortcut applied to the final
//! gather): terms no moving object can come between are kept with their
//! visibility, the others with the static part of each ray as a mask, cast again at
//! the moving objects only when one is between the point and the source
//! ([`Solver::gather_point`]).
//!
//! # Two surfaces across a narrow gap
//!
//! A point 1 cm over a floor gets nearly all of its factor to the floor from the
//! few centimetres around its foot, but the gather takes each floor element at its
//! mean radiosity: a box's bottom hung over the floor read the lit floor around the
//! box, many times the path tracer's value under it (BENCHMARKS.md, "The actors'
//! bottom faces, diagnosed"), and the floor under it read the bottom's mean in turn.
//! With [`SolveOptions::near_gap`], the terms of elements facing the point across a
//! gap narrow for their patch, within [`NEAR_REACH`] gaps of the point's foot `y`,
//! are set apart (`F_xy`, factor times visibility, summed). The point then gathers
//! at `y` too, its own near terms (back on the point's surface, `F_yx`) set apart
//! likewise, and the two are solved as a pair that sees the rest of the scene
//! through the gap's rim: `B(x) = E_x + ρ_x (H_x + F_xy B(y))`, `B(y) = E_y + ρ_y
//! (H_y + F_yx B(x))` ([`Solver::across_gap`]). One more gather per such point, where
//! the gap is; BENCHMARKS.md, "Two surfaces across a narrow gap", compares
//! `tests/data/hung_box_room.json`'s gap with the path tracer.

use glam::DVec3;

use super::*;

/// What one reconstruction's final gathers measure their sources against
/// ([`Solver::gather_point`], [`Solver::point_terms`]).
pub(super) struct GatherLimits {
    /// Non-emitting surface sources whose bounds sum below this (absolute
    /// radiosity) at a point take their links' visibility instead of rays
    /// ([`SolveOptions::faint_source`]).
    faint: f64,
    /// A surface source with `r/d · ΔB_s` above this (absolute) is opened
    /// ([`SolveOptions::open_spread`]); infinite: never.
    open_spread: f64,
    /// Per element: `ΔB_s`, the largest channel's spread (max − min) of the leaf
    /// radiosities under it (0 for a leaf). 4 bytes per element.
    spread: Vec<f32>,
    /// Per element: [`oracle::sphere`], centre and bounding radius, computed once
    /// per reconstruction instead of at every term of every point (a sizeable part
    /// of a cluttered scene's run). 32 bytes per element
    /// (a space-time frame's 2 000 elements: 64 KB); empty where each term computes
    /// its own (the error samples).
    spheres: Vec<(DVec3, f64)>,
    /// [`SolveOptions::near_gap`].
    near_gap: f64,
    /// [`SolveOptions::near_field`]: a term whose non-emitting surface source's
    /// bounding sphere has a radius above this times its distance from the point
    /// is noted apart for the reconstruction to mend ([`NearTerms`]); 0: none
    /// (every gather but a static reconstruction's).
    pub(super) near_field: f64,
    /// Sources seen by their quadrants ([`super::reconstruct::FieldShapes`]).
    pub(super) shapes: super::reconstruct::FieldShapes,
    /// `recon_tol · B_ref`: what a partly hidden emitter's visibility noise may
    /// move a point by ([`recast_rays`]).
    recast_tol: f64,
}

impl GatherLimits {
    /// Centre and bounding radius of element `s` (geometry `g`).
    fn sphere(&self, s: usize, g: &Geom) -> (DVec3, f64) {
        self.spheres
            .get(s)
            .copied()
            .unwrap_or_else(|| oracle::sphere(g))
    }
}

/// The transfer terms of one link at one point.
#[derive(Clone, Debug, Default)]
pub(super) struct Terms {
    /// `(element, factor)` with visibility included.
    pub(super) fixed: Vec<(u32, f64)>,
    /// Masked terms with their visibility now.
    pub(super) masked: Vec<(MaskedTerm, f64)>,
}

impl Terms {
    fn clear(&mut self) {
        self.fixed.clear();
        self.masked.clear();
    }

    /// `Σ factor · visibility · B_element` into `sum`, with the factors rounded as
    /// [`PointCache`] keeps them, so that a point gathers the same value whether its
    /// terms were kept or computed afresh.
    fn gather(&self, s: &Solver, sum: &mut PointGather) {
        for &(e, f) in &self.fixed {
            s.add_term(sum, e, f64::from(f as f32));
        }
        for &(t, v) in &self.masked {
            s.add_term(sum, t.elem, t.f as f64 * v);
        }
    }
}

/// Second final gather ([`SolveOptions::source_field`]): a leaf source whose
/// bounding sphere's radius exceeds this times its distance from the point is
/// gathered cell by cell from the first reconstruction (each cell's exact factor
/// times its mean), a farther one by its quadrants. Where a point sees a source
/// large, the source's variation across it is what its mean misses (a ceiling
/// point by a wall gathers most from the wall's top strip).
const CELL_OPEN_RATIO: f64 = 0.3;

/// A part of a cluster source whose factor at a final-gather point is at most
/// this, with no emitter under it, keeps its first rays' visibility where they
/// find it partly hidden, instead of casting [`super::rows::PARTIAL_CLUSTER_RAYS`]
/// times the rays again ([`Solver::point_terms`]): its first rays' fraction is
/// unbiased, and its noise, a few percent of a small term, spreads over the many
/// parts a cluttered scene's points see. Why: in `tools/gen_cubes.py 20` each
/// point walks its cluster links down to hundreds of box faces, most of them
/// partly hidden by other boxes, and their recast rays (64 to a face, 8 first)
/// were most of the final gather, itself 88% of the solve's 214 CPU s
/// (BENCHMARKS.md, "Scale").
const PARTIAL_PART_MIN_FACTOR: f64 = 3e-3;

/// A cluster with no emitter under it, far for its size, whose unoccluded
/// estimate at a final-gather point ([`cluster_kernel`]) is at most this is kept
/// whole there ([`Solver::whole_cluster`]), not walked down to every face
/// ([`Solver::cluster_parts`]).
///
/// Why: a cluster of boxes has faces looking every way, so its cone never
/// tells which face a point sees and the walk opened it to every face, each
/// with its own factor and rays; in `tools/gen_cubes.py 20` a point's walk
/// reached hundreds of box faces, the walk and their rays over 40% of the run.
/// The bound is [`PARTIAL_PART_MIN_FACTOR`]'s: a part below it already took rays
/// by its factor alone.
const WHOLE_CLUSTER_MAX_FACTOR: f64 = PARTIAL_PART_MIN_FACTOR;

/// Fewest rays [`small_part_rays`] gives a part.
const SMALL_PART_MIN_RAYS: u32 = 2;

/// The first rays of a cluster part with factor `k` at a final-gather point that
/// is not cast again ([`PARTIAL_PART_MIN_FACTOR`]): `m` times `k` over that
/// bound, rounded up, at least [`SMALL_PART_MIN_RAYS`].
///
/// Why: a part's visibility noise enters the point's value times its factor,
/// so the rays that make the sum's variance least go to each part in proportion
/// to its factor (times its radiosity and `√(v(1−v))`, which the point does not
/// know before casting). In `tools/gen_cubes.py 20` a point sees hundreds of box
/// faces at factors of 1e-4 to 1e-3, each cast 8 rays, most of the final gather's
/// rays (BENCHMARKS.md, "Scale").
fn small_part_rays(m: u32, k: f64) -> u32 {
    let scaled = (f64::from(m) * k / PARTIAL_PART_MIN_FACTOR).ceil();
    (scaled as u32).clamp(SMALL_PART_MIN_RAYS.min(m), m)
}

/// The rays a partly hidden surface source whose term at a final-gather point
/// weighs `w` (`ρ_x k B_s`: what it hands the point's radiosity wholly visible)
/// is cast again with where its `m` first stratified rays find it partly hidden,
/// for the term's visibility noise to stay within `tol`
/// ([`GatherLimits::recast_tol`], the reconstruction tolerance): `(w / (√2
/// tol))^(4/3)`, rounded up, at most [`super::rows::PARTIAL_CLUSTER_RAYS`] times
/// `m`. An answer of `m` or fewer keeps the first rays. Emitters and non-emitting
/// sources alike ([`Solver::surface_visibility`]).
///
/// Why: `m` jittered rays, one per cell of a grid over the source
/// ([`oracle::ray_params`]), estimate its visible fraction with variance
/// `Σ p_j (1 − p_j) / m²` over the cells (`p_j` the cell's visible part): only the
/// cells a shadow edge cuts count, about `2√m` of them for one straight edge, at
/// most `1/4` each, so `σ_v ≤ (√2/2) m^(-3/4)`, and the point's value is off by
/// `w σ_v`. Setting that to `tol`, the noise the reconstruction accepts between a
/// cell's centre and its corners, gives the count.
///
/// Emitters: with `m = 32` (an emitter's first rays, [`Solver::corner_rays_to`])
/// the first rays are kept while `w < 19 tol` (`0.38 B_ref` at the default
/// `recon_tol` 0.02), and the full 8× recast is reached at `w ≥ 90 tol`. The fixed
/// 8× recast it replaces cast, on the Cornell box with blocks (eps 0.16, one
/// thread), 2.67 of the final gathers' 6.44 million surface rays (the lamp hands
/// the floor's middle `ρ k E ≈ 0.18`); under this rule 11 of its 11 900 partly
/// hidden emitter terms were cast again, 4.0 million surface rays in all, 12% less
/// CPU, the error off the lamp within 1e-4 and at the contact points within 5e-4
/// of it over four seeds (the seeds themselves 0.4–1.0% apart).
///
/// Non-emitting sources: with `m = 8` the first rays are kept while `w < 6.7 tol`
/// and the full 8× recast is reached at `w ≥ 32 tol`. The rule it replaces cast
/// `8 k / 3e-3` rays by the factor `k` alone, at least `2m` (the doubling kept
/// for the row sums of the L-shaped room of `tests/it/solver/enclosures.rs`,
/// where every surface emits, so this branch never ran there), whatever the
/// source's radiosity: a dim wall far across the room got its 16 to 64 rays as
/// a bright one did. Its noise `w σ_v` is what matters, and this rule bounds
/// it as for emitters. Measured (h48rays3, paired with main 7f6e3cf, 2 threads,
/// load 2–5): `tools/gen_cubes.py 16` 42.8 → 39.8 CPU s (−7%, means of four
/// runs), the error 1.66 → 1.67% and 1.68 → 1.69% at seeds 7 and 99, 1.20 →
/// 1.66% at the default seed, where one gap probe reads 18% low (as main reads it
/// at seed 99); the Cornell box with blocks 1.59–1.61 → 1.48–1.50 CPU s at eps
/// 0.16 and 0.83–0.85 → 0.64–0.65 at eps 0.5, the error off the lamp unchanged
/// (0.0098, 0.0166 → 0.0165). In the L-shaped room lit in one arm
/// (`tests/it/solver/l_room_lit.rs`), where all the light of the probes comes
/// through partly hidden non-emitting surfaces, the error is within 0.09 points
/// of the factor rule's at three seeds and three tilings (97% of those terms
/// weigh under `tol`; none reaches the `6.7 tol` of a recast). But the twin
/// solves of `spacetime::tests::surfaces_that_move_as_one_are_linked_once_and_give_the_frames_of_links_evaluated_at_each`
/// (points on a sliding trough's inner faces) drift 0.600% apart at `t =
/// 0` where the factor rule's were 0.289% (bar 0.5%), also at `tol / 4`: not
/// traced (likely the noise of the many light terms the floor cast 16 rays
/// each, adding up).
fn recast_rays(m: u32, w: f64, tol: f64) -> u32 {
    let full = m * super::rows::PARTIAL_CLUSTER_RAYS;
    if tol <= 0.0 {
        return full;
    }
    let need = (w / (std::f64::consts::SQRT_2 * tol))
        .powf(4.0 / 3.0)
        .ceil();
    if need <= f64::from(m) {
        m
    } else {
        need.min(f64::from(full)) as u32
    }
}

/// A source is near a point only if the point's normal is within this cosine of
/// facing it head-on.
const NEAR_COS: f64 = 0.9;

/// How far from the foot, in gaps, an element of the surface across still counts
/// as near: a point at gap `d` over a plane gets `R² / (R² + d²)` of its factor to
/// the plane from the disc of radius `R` around its foot, 90% at `R = 3d`.
const NEAR_REACH: f64 = 3.0;

/// If the surface element `g` is a near source of the point `x` (normal `n`): the
/// point's foot on it, `x` moved along the element's normal into its plane, and
/// whether the element holds the foot. Near:
/// the element faces the point across a gap below `near_gap` times the square root
/// of its patch's area (`patches`), the foot lies inside that patch, and the
/// element comes within [`NEAR_REACH`] gaps of the foot. A point by a corner of two
/// walls (its foot on the other wall's edge, and the walls not facing) is not near.
fn near_foot(
    x: DVec3,
    n: DVec3,
    g: &Geom,
    near_gap: f64,
    patches: &Patches,
) -> Option<(DVec3, bool)> {
    if near_gap <= 0.0 || g.patch == u32::MAX {
        return None;
    }
    let ns = DVec3::from_array(g.normal);
    if n.dot(ns) > -NEAR_COS {
        return None;
    }
    let gap = (x - DVec3::from_array(g.corners[0])).dot(ns);
    let p = g.patch as usize;
    if !(gap > 0.0 && gap * gap < near_gap * near_gap * patches.areas[p]) {
        return None;
    }
    let foot = x - gap * ns;
    let pg = oracle::poly(g);
    (pg.contains(ns, foot, -NEAR_REACH * gap) && patches.polys[p].contains(ns, foot, 0.0))
        .then(|| (foot, pg.contains(ns, foot, 0.0)))
}

/// A point's near sources: what the point gathers from them (`Σ factor ·
/// visibility` over their terms), the point's foot on their plane, and the element
/// the gather at the foot starts from (one that holds the foot if any does, else the
/// one that gives the most). 48 bytes.
#[derive(Clone, Copy, Debug)]
struct NearSources {
    f: f64,
    elem: u32,
    /// `elem` holds the foot.
    holds: bool,
    /// `elem`'s share of `f`.
    f_elem: f64,
    foot: DVec3,
}

/// The terms of one final-gather point whose source looks large from it
/// ([`GatherLimits::near_field`]): `(source element, factor · visibility)`, each
/// also in the point's sum at the source's constant radiosity. The reconstruction
/// mends them from its own field over the source ([`super::reconstruct`], "Near
/// field").
pub(super) type NearTerms = Vec<(u32, f64)>;

/// What a point gathers: `Σ factor · visibility · B_s` over its sources but the near
/// ones, and the near ones apart.
struct PointGather<'a> {
    patches: &'a Patches,
    x: DVec3,
    n: DVec3,
    /// [`SolveOptions::near_gap`] (0: no source is near).
    near_gap: f64,
    h: [f64; 3],
    /// The near sources apart ([`NearSources`]).
    near: Option<NearSources>,
    /// Every element's bounding sphere ([`GatherLimits::spheres`]) and
    /// [`GatherLimits::near_field`]: the terms to note in `field`.
    spheres: &'a [(DVec3, f64)],
    near_field: f64,
    /// The terms noted for the near field ([`NearTerms`]).
    field: NearTerms,
}

impl<'a> PointGather<'a> {
    fn new(patches: &'a Patches, x: DVec3, n: DVec3, limits: &'a GatherLimits) -> Self {
        PointGather {
            patches,
            x,
            n,
            near_gap: limits.near_gap,
            h: [0.0; 3],
            near: None,
            spheres: &limits.spheres,
            near_field: if limits.spheres.is_empty() {
                0.0
            } else {
                limits.near_field
            },
            field: Vec::new(),
        }
    }

    /// Adds the term `fv · B_e` of element `e` (geometry `g`, radiosity `b`).
    #[inline]
    fn add(&mut self, g: &Geom, b: [f32; 3], e: u32, fv: f64) {
        if let Some((foot, holds)) = near_foot(self.x, self.n, g, self.near_gap, self.patches) {
            let m = self.near.get_or_insert(NearSources {
                f: 0.0,
                elem: e,
                holds,
                f_elem: fv,
                foot,
            });
            if (holds && !m.holds) || (holds == m.holds && fv > m.f_elem) {
                (m.elem, m.holds, m.f_elem) = (e, holds, fv);
            }
            m.f += fv;
            return;
        }
        for (h, b) in self.h.iter_mut().zip(b) {
            *h += fv * b as f64;
        }
        if self.near_field > 0.0
            && e & FACET_BIT == 0
            && g.patch != u32::MAX
            && !self.patches.emits(g.patch as usize)
        {
            let (c, r) = self.spheres[e as usize];
            if r > self.near_field * c.distance(self.x) {
                self.field.push((e, fv));
            }
        }
    }
}

/// Terms a point gathers that hold over the window, computed now: `(source << 1 |
/// clear, terms)`.
pub(super) type FreshTerms = Vec<(u32, Terms)>;

/// True if nothing inside the boxes `swept` can lie between the point `x` (normal
/// `n`) and element `g` (the convex hull of the point and a surface element, or the
/// box around the point and a cluster).
fn point_shaft_clear(x: DVec3, n: DVec3, g: &Geom, swept: &[(DVec3, DVec3)]) -> bool {
    if g.patch == u32::MAX {
        let (lo, hi) = geom_box(g);
        return !meets_any(lo.min(x), hi.max(x), swept);
    }
    let k = g.n as usize;
    let corners: [DVec3; 4] = std::array::from_fn(|i| DVec3::from_array(g.corners[i.min(k - 1)]));
    crate::shafts::clear_of_boxes(&[x], n, &corners[..k], DVec3::from_array(g.normal), swept)
}

impl Solver<'_> {
    /// Adds the term `fv · B_e` of source `e` to `sum`: an element, or a facet
    /// ([`FACET_BIT`]) at its own radiosity, placed as its cluster.
    #[inline]
    fn add_term(&self, sum: &mut PointGather, e: u32, fv: f64) {
        let geoms = self.elems.geoms.as_slice();
        let b = self.elems.radiosities.as_slice();
        if e & FACET_BIT != 0 {
            let f = e & !FACET_BIT;
            let g = &geoms[self.facets.owner(f) as usize];
            sum.add(g, self.facet_b[f as usize], e, fv);
        } else {
            sum.add(&geoms[e as usize], b[e as usize], e, fv);
        }
    }

    /// Rays from a reconstruction point to the surface element `gs` (4× to emitters).
    fn corner_rays_to(&self, gs: &Geom) -> u32 {
        if self.patches.emits(gs.patch as usize) {
            self.opts.corner_rays * 4
        } else {
            self.opts.corner_rays
        }
    }

    /// The final gather's rays from the point `x` (normal `n`, on patch
    /// `receiver_patch`) to the surface element `gs` (polygon `pols`), jittered by
    /// `key`: [`Solver::corner_rays_to`] of them, the two patches skipped.
    fn gather_rays<'a>(
        &self,
        x: DVec3,
        n: DVec3,
        receiver_patch: u32,
        gs: &'a Geom,
        pols: &'a crate::geometry::Poly,
        key: u64,
    ) -> oracle::PointRays<'a> {
        oracle::PointRays {
            x,
            n,
            gs,
            pols,
            ns: DVec3::from_array(gs.normal),
            m: self.corner_rays_to(gs),
            key,
            skip: [receiver_patch, gs.patch],
        }
    }

    /// Transfer terms from source `s` to the point `x` (normal `n`): `Σ factor ·
    /// visibility · B_element` over `out` is the radiosity the point gathers from `s`;
    /// exact point-to-polygon factors, visibility by rays unless `clear`, sources
    /// that look large from `x` opened into their children. A cluster source gets
    /// the estimate of its links: [`oracle::cluster_emission`], visibility by
    /// [`oracle::point_cluster_visibility`] from `x`.
    ///
    /// A source whose radiosity varies is opened too: the gather multiplies its
    /// *average* radiosity by the exact factor of the whole source, which is off by
    /// the covariance of `F(x, y)` and `B(y)` over it, about `(r/d) ΔB_s` of the
    /// factor (`r/d` the source's radius over its distance, `ΔB_s` the spread of the
    /// leaf radiosities under it). A surface source is opened while `(r/d) ΔB_s >
    /// open_spread · B_ref` ([`SolveOptions::open_spread`]); its children share the
    /// visible fraction the rays to the whole source measured, so the opening costs
    /// no rays, and where the kernel is linear across the source they share its
    /// exact factor by that kernel ([`Solver::open_shared`]), so it costs one
    /// point-to-polygon factor, not one per child. The errors have one sign where a source's
    /// brightest parts are the nearest (the Cornell ceiling sees the floor's bright
    /// middle nearest; BENCHMARKS.md, "Sources whose radiosity varies"). Where every
    /// child stays whole, each stands for a radiosity that still varies inside it:
    /// their factors move from their area shares by [`WITHIN_CHILD`] times what
    /// their factors say, keeping the sum (the radiosity and kernel linear
    /// across the source; without it the Cornell ceiling read 0.1–0.2% dark).
    ///
    /// Each part of a cluster source ([`Solver::cluster_parts`]) is seen by its
    /// own rays: a surface (a near cluster opened down to its tiles) by stratified
    /// rays, as surface sources are ([`Solver::surface_visibility`]), a
    /// sub-cluster taken whole by rays drawn by power into it
    /// ([`Solver::part_visibility`]), cast again with
    /// [`super::rows::PARTIAL_CLUSTER_RAYS`] times the rays where they disagree or
    /// where the link (`partial`) found the source partly hidden from the point's
    /// leaf. Why: the parts shared the whole cluster's fraction, which is right only
    /// where they are equally hidden. In the L-shaped room of
    /// `tests/it/solver/enclosures.rs` 8 rays drawn by power into a cluster half of
    /// whose area lay in a ceiling point's plane cast 3, all clear, and the floor
    /// tiles beyond the re-entrant corner's wall, 32% visible, counted whole (the
    /// point's factors summed to 1.0088; 1.0000 with 4096 rays per tile). In the
    /// room with a pillar a wall point gave the same fraction, 0.46, to a
    /// sub-cluster the pillar hid whole and to tiles 34–100% visible (its factors
    /// summed to 1.0216).
    ///
    /// A cluster far for its size whose estimate at the point is small
    /// ([`WHOLE_CLUSTER_MAX_FACTOR`]) is kept whole, not walked to its parts
    /// ([`Solver::whole_cluster`]).
    ///
    /// With `swept` (a static point and a static source in a time window), a term
    /// whose shaft from `x` meets a box swept by a moving object becomes a
    /// [`MaskedTerm`] (its rays' static visibility kept); the others are fixed. A
    /// cluster whose box, with `x`, meets a swept box is opened (its rays could be
    /// crossed), so a fixed cluster term holds over the window.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn point_terms(
        &self,
        x: DVec3,
        n: DVec3,
        receiver_patch: u32,
        s: usize,
        clear: bool,
        partial: bool,
        key: u64,
        swept: Option<&[(DVec3, DVec3)]>,
        limits: &GatherLimits,
        out: &mut Terms,
    ) {
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let gs = &geoms[s];
        let node = nodes[s];
        let (c, rad) = limits.sphere(s, gs);
        let d = c.distance(x).max(f64::MIN_POSITIVE);
        // A cluster whose rays from `x` a moving object may cross is opened (down to
        // surfaces, whose terms keep their static rays as masks).
        let swept_cluster = gs.patch == u32::MAX
            && swept.is_some_and(|sw| {
                let (lo, hi) = geom_box(gs);
                meets_any(lo.min(x), hi.max(x), sw)
            });
        // A surface whose radiosity varies is opened too: its average would be off by
        // about `(r/d) ΔB_s` of its factor (see this function's docs).
        let varies = gs.patch != u32::MAX && rad / d * limits.spread[s] as f64 > limits.open_spread;
        let large = rad / d > self.opts.open_ratio || swept_cluster;
        // Not where a moving object may cross the rays: the children would need rays
        // of their own every frame.
        let still = || swept.is_none_or(|sw| point_shaft_clear(x, n, gs, sw));
        if node.child_count > 0 && !large && varies && still() {
            // Opened for its radiosity only: the children share the source's visible
            // fraction, from the rays the source would have had unopened.
            let v = if clear {
                1.0
            } else {
                let ps = oracle::poly(gs);
                let r = self.gather_rays(x, n, receiver_patch, gs, &ps, key);
                oracle::visible_fraction(&self.bvh, &r)
            };
            if v <= 0.0 {
                return;
            }
            let first = out.fixed.len();
            // Children that stay whole, with their terms' places: each stands for a
            // radiosity that goes on varying inside it, and their factors move from
            // their area shares by the part within them too ([`WITHIN_CHILD`]);
            // not where the leaves are seen by their shapes, which hold that part.
            let shaped = !(self.shapes.is_empty()
                && limits.shapes.quadrants.is_empty()
                && limits.shapes.cells.is_empty());
            // The source's exact factor shared among its children by the kernel
            // taken linear across it, as the leaf rows share it
            // ([`Solver::push_opened`]), where that holds.
            if !shaped && self.open_shared(x, n, receiver_patch, s, None, key, limits, out) {
                for t in &mut out.fixed[first..] {
                    t.1 *= v;
                }
                return;
            }
            let mut whole: [(usize, f64); 4] = [(usize::MAX, 0.0); 4];
            let mut n_whole = 0;
            for ch in node.first_child..node.first_child + node.child_count {
                let at = out.fixed.len();
                self.point_terms(
                    x,
                    n,
                    receiver_patch,
                    ch as usize,
                    true,
                    partial,
                    key,
                    None,
                    limits,
                    out,
                );
                let k = (ch - node.first_child) as usize;
                if k < 4 && out.fixed.len() == at + 1 && out.fixed[at].0 == ch {
                    whole[k] = (at, geoms[ch as usize].area);
                    n_whole += 1;
                }
            }
            if !shaped && n_whole == node.child_count as usize && node.child_count <= 4 {
                let k = node.child_count as usize;
                let f: f64 = whole[..k].iter().map(|w| out.fixed[w.0].1).sum();
                let a: f64 = whole[..k].iter().map(|w| w.1).sum();
                if f > 0.0 && a > 0.0 {
                    let new: Vec<f64> = whole[..k]
                        .iter()
                        .map(|w| w.1 / a * f + WITHIN_CHILD * (out.fixed[w.0].1 - w.1 / a * f))
                        .collect();
                    if new.iter().all(|&x| x >= 0.0) {
                        for (w, v) in whole[..k].iter().zip(new) {
                            out.fixed[w.0].1 = v;
                        }
                    }
                }
            }
            for t in &mut out.fixed[first..] {
                t.1 *= v;
            }
            return;
        }
        if node.child_count > 0 && large {
            for ch in node.first_child..node.first_child + node.child_count {
                self.point_terms(
                    x,
                    n,
                    receiver_patch,
                    ch as usize,
                    clear,
                    partial,
                    oracle::hash3(key, self.ray_id(ch), 1),
                    swept,
                    limits,
                    out,
                );
            }
            return;
        }
        if gs.patch == u32::MAX {
            // Visibility from the point itself, as the link's from its receiver
            // (oracle module docs): an opened cluster's children do not inherit it.
            // The rays' targets depend on the source and the receiving patch only, so
            // neighbouring points aim at the same surface points and the estimate is
            // smooth across the patch (independent jitter per point is noise the
            // reconstruction would mesh).
            let key = oracle::hash3(self.opts.seed ^ 0xc105, s as u64, receiver_patch as u64);
            // Visibility by power, emission by axes: the model of the links.
            // `clear`: the caller supplies the visibility.
            // Partly hidden: cast again with more rays (`PARTIAL_CLUSTER_RAYS`).
            let shared = || {
                if clear {
                    1.0
                } else {
                    let cast = |m| {
                        oracle::point_cluster_visibility(
                            &self.elems,
                            &self.bvh,
                            x,
                            n,
                            receiver_patch,
                            ElementId(s as u32),
                            m,
                            key,
                            SOURCES_BY_POWER,
                        )
                        .0
                    };
                    let v = cast(self.opts.cluster_rays);
                    if (v > 0.0 && v < 1.0) || partial {
                        cast(self.opts.cluster_rays * super::rows::PARTIAL_CLUSTER_RAYS)
                    } else {
                        v
                    }
                }
            };
            let at = oracle::Samples {
                points: [x; 4],
                weights: [1.0, 0.0, 0.0, 0.0],
                count: 1,
            };
            // Wholly behind the point's plane: no rays for it either.
            if super::rows::box_behind(gs, &at, n) {
                return;
            }
            if !self.opts.cluster_facets || self.facets.count() == 0 {
                // What the leaf rows take: the cluster estimate, or the parts of a
                // cluster too near for it, each part by its own rays: a surface by
                // stratified rays, as a surface source is, a sub-cluster by rays
                // drawn by power ([`Solver::part_visibility`]); the cluster's
                // fraction where those rays all fall on faces turned away.
                if let Some(t) = self.whole_cluster(x, n, receiver_patch, s as u32, clear, limits) {
                    if t > 0.0 {
                        out.fixed.push((s as u32, t));
                    }
                    return;
                }
                let mut vis = None;
                // Small clusters kept whole ([`Solver::whole_cluster`]), their terms
                // apart while the walk holds `out`.
                let mut wholes: Vec<(u32, f64)> = Vec::new();
                let mut whole =
                    |e: u32| match self.whole_cluster(x, n, receiver_patch, e, clear, limits) {
                        Some(t) => {
                            if t > 0.0 {
                                wholes.push((e, t));
                            }
                            true
                        }
                        None => false,
                    };
                self.cluster_parts_reusing(
                    &at,
                    n,
                    s as u32,
                    &mut |e, k| {
                        if k[0] <= 0.0 {
                            return;
                        }
                        let g = &geoms[e as usize];
                        // A small part with no emitter under it is not cast again
                        // ([`PARTIAL_PART_MIN_FACTOR`]).
                        let recast = k[0] > PARTIAL_PART_MIN_FACTOR
                            || self.emits_under.get(e as usize).copied().unwrap_or(true);
                        // Such a part's first rays, fewer by its factor
                        // ([`small_part_rays`]).
                        let rays = |m: u32| if recast { m } else { small_part_rays(m, k[0]) };
                        let v = if clear {
                            1.0
                        } else if g.patch != u32::MAX {
                            let key = oracle::hash3(key, self.ray_id(e), 1) & u64::from(u32::MAX);
                            let ps = oracle::poly(g);
                            let mut r = self.gather_rays(x, n, receiver_patch, g, &ps, key);
                            if recast {
                                self.surface_visibility(r, k[0], e as usize, limits)
                            } else {
                                r.m = rays(r.m);
                                oracle::visible_fraction(&self.bvh, &r)
                            }
                        } else {
                            let m = rays(self.opts.cluster_rays);
                            let (v, rays) = self.part_visibility(x, n, receiver_patch, e, m, 0);
                            if rays == 0 {
                                *vis.get_or_insert_with(shared)
                            } else if recast && ((v > 0.0 && v < 1.0) || partial) {
                                let m = self.opts.cluster_rays * super::rows::PARTIAL_CLUSTER_RAYS;
                                self.part_visibility(x, n, receiver_patch, e, m, 0).0
                            } else {
                                v
                            }
                        };
                        if v > 0.0 {
                            out.fixed.push((e, k[0] * v));
                        }
                    },
                    &mut whole,
                );
                out.fixed.append(&mut wholes);
                return;
            }
            // With facets, as the leaf rows: each facet by rays to its own patches
            // ([`Solver::part_visibility`]), the other parts by the cluster's
            // fraction (cast once, if a part needs it).
            let mut vis = None;
            self.cluster_parts(&at, n, s as u32, &mut |e, k| {
                if k[0] <= 0.0 {
                    return;
                }
                let own = if e & FACET_BIT != 0 && !clear {
                    let m = self.opts.cluster_rays;
                    let (v, rays) = self.part_visibility(x, n, receiver_patch, e, m, 0);
                    Some(if rays > 0 && v > 0.0 && v < 1.0 {
                        self.part_visibility(
                            x,
                            n,
                            receiver_patch,
                            e,
                            m * super::rows::PARTIAL_CLUSTER_RAYS,
                            0,
                        )
                    } else {
                        (v, rays)
                    })
                    .filter(|&(_, rays)| rays > 0)
                    .map(|(v, _)| v)
                } else {
                    None
                };
                let v = own.unwrap_or_else(|| *vis.get_or_insert_with(shared));
                if v > 0.0 {
                    out.fixed.push((e, k[0] * v));
                }
            });
            return;
        }
        let ps = oracle::poly(gs);
        let cells = limits
            .shapes
            .cells
            .get(&(s as u32))
            .filter(|_| rad / d > CELL_OPEN_RATIO);
        let f = if let Some(cells) = cells {
            cells
                .iter()
                .map(|(pc, r)| *r as f64 * point_to_polygon(x, n, pc))
                .sum()
        } else {
            match limits
                .shapes
                .quadrants
                .get(&(s as u32))
                .or_else(|| self.shapes.get(&(s as u32)))
            {
                Some(r) => shaped_factor(x, n, gs, r),
                None => point_to_polygon(x, n, &ps),
            }
        };
        if f <= 0.0 {
            return;
        }
        if clear {
            out.fixed.push((s as u32, f));
            return;
        }
        // The rays' jitter key, as a masked term keeps it.
        let key = key & u64::from(u32::MAX);
        let r = self.gather_rays(x, n, receiver_patch, gs, &ps, key);
        match swept {
            Some(sw) if r.m <= 64 && !point_shaft_clear(x, n, gs, sw) => {
                // The static mask, its visibility and, where a moving object is now
                // between the point and the source, the visibility now: one pass.
                let near = !point_shaft_clear(x, n, gs, &self.motion.moving_now);
                let rays = oracle::masked_rays(&self.bvh, &r, None, near);
                if rays.mask == 0 {
                    // Hidden by static geometry whatever moves.
                    return;
                }
                let vis_static = rays.vis_static as f32;
                // No ray blocked by a moving object: the kept visibility, as a
                // kept term takes it (`oracle::visible_fraction_moving`).
                let v = if rays.blocked == 0 {
                    f64::from(vis_static)
                } else {
                    rays.vis_now
                };
                let t = MaskedTerm {
                    mask: rays.mask,
                    key: key as u32,
                    elem: s as u32,
                    f: f as f32,
                    vis_static,
                };
                out.masked.push((t, v));
            }
            _ => {
                // A small source with no emitter under it: rays by its factor,
                // not cast again ([`small_part_rays`]).
                let v = if f <= PARTIAL_PART_MIN_FACTOR && self.non_emitting_surface(s) {
                    let mut r = r;
                    r.m = small_part_rays(r.m, f);
                    oracle::visible_fraction(&self.bvh, &r)
                } else {
                    self.surface_visibility(r, f, s, limits)
                };
                if v > 0.0 {
                    out.fixed.push((s as u32, f * v));
                }
            }
        }
    }

    /// Terms of surface source `s` opened for its radiosity at the point `x`
    /// (normal `n`) by shares of its exact factor (`f`, computed if `None`) with the
    /// kernel taken linear across it ([`super::rows::linear_shares`]), as the leaf
    /// rows open a source for its spread ([`Solver::push_opened`]): a child that
    /// varies too is opened likewise, one that stays whole moves its share from
    /// its area's by [`WITHIN_CHILD`] times that. Unoccluded (the caller applies the
    /// source's visible fraction). False, with nothing pushed, where the linear
    /// kernel does not hold for `s` (near or grazing): its children are then
    /// gathered by their own factors.
    ///
    /// Why: the point's gather otherwise takes every child's exact factor down to
    /// the leaves, which was 37% of the empty Cornell box's instructions at eps 0.1
    /// (3.2 million point-to-polygon factors for 2 175 cells).
    #[allow(clippy::too_many_arguments)]
    fn open_shared(
        &self,
        x: DVec3,
        n: DVec3,
        receiver_patch: u32,
        s: usize,
        f: Option<f64>,
        key: u64,
        limits: &GatherLimits,
        out: &mut Terms,
    ) -> bool {
        let geoms = self.elems.geoms.as_slice();
        let node = self.elems.nodes.as_slice()[s];
        let (c, rad) = limits.sphere(s, &geoms[s]);
        if rad > self.opts.open_ratio * c.distance(x) {
            return false;
        }
        let at = oracle::Samples {
            points: [x; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
            count: 1,
        };
        // The spheres' centres are the area centroids, computed once.
        let centroid = |ch: usize| limits.sphere(ch, &geoms[ch]).0;
        let Some(mut shares) =
            super::rows::linear_shares(&at, n, geoms, &geoms[s], (c, rad), node, centroid)
        else {
            return false;
        };
        let f = f.unwrap_or_else(|| point_to_polygon(x, n, &oracle::poly(&geoms[s])));
        if f <= 0.0 {
            return true;
        }
        // Whether child `ch` varies enough to be opened itself (`point_terms`).
        let varies = |ch: usize| {
            let gc = &geoms[ch];
            let (c, rad) = limits.sphere(ch, gc);
            let d = c.distance(x).max(f64::MIN_POSITIVE);
            self.elems.nodes.as_slice()[ch].child_count > 0
                && rad / d * limits.spread[ch] as f64 > limits.open_spread
        };
        let k = node.child_count as usize;
        let mut open = [false; 4];
        let sum = super::rows::within_child_shares(&mut shares, geoms, node, |j, _| {
            open[j] = varies(node.first_child as usize + j);
            !open[j]
        });
        if sum <= 0.0 || shares.iter().take(k).any(|&x| x < 0.0) {
            return false;
        }
        for j in 0..k {
            let ch = (node.first_child as usize) + j;
            let fc = f * shares[j] / sum;
            if open[j] {
                // Near or grazing for the linear kernel: its children's own factors.
                if !self.open_shared(x, n, receiver_patch, ch, Some(fc), key, limits, out) {
                    self.point_terms(
                        x,
                        n,
                        receiver_patch,
                        ch,
                        true,
                        false,
                        key,
                        None,
                        limits,
                        out,
                    );
                }
            } else if fc > 0.0 {
                out.fixed.push((ch as u32, fc));
            }
        }
        true
    }

    /// The term `factor · visibility` of cluster `e` kept whole at the final-gather
    /// point `x` (normal `n`, on patch `receiver_patch`), if it is: in a static
    /// scene, a cluster with no emitter under it, far for its size
    /// ([`SolveOptions::cluster_open_ratio`]), whose unoccluded estimate is at most
    /// [`WHOLE_CLUSTER_MAX_FACTOR`]; its visibility by as many rays as
    /// [`small_part_rays`] gives that factor (none if `clear`). `None`: the caller
    /// opens it (also where every ray falls on faces turned away).
    fn whole_cluster(
        &self,
        x: DVec3,
        n: DVec3,
        receiver_patch: u32,
        e: u32,
        clear: bool,
        limits: &GatherLimits,
    ) -> Option<f64> {
        let i = e as usize;
        let g = &self.elems.geoms.as_slice()[i];
        if self.has_motion()
            || g.patch != u32::MAX
            || self.emits_under.get(i).copied().unwrap_or(true)
        {
            return None;
        }
        let (c, r) = limits.sphere(i, g);
        if r >= self.opts.cluster_open_ratio * c.distance(x) {
            return None;
        }
        let k = self.whole_cluster_factor(x, n, i, (c, r));
        if k > WHOLE_CLUSTER_MAX_FACTOR {
            return None;
        }
        if k <= 0.0 || clear {
            return Some(k.max(0.0));
        }
        let m = small_part_rays(self.opts.cluster_rays, k);
        let (v, rays) = self.part_visibility(x, n, receiver_patch, e, m, 0);
        (rays > 0).then_some(k * v)
    }

    /// The unoccluded factor from the point `x` (normal `n`) to cluster `e`
    /// (bounding sphere `sphere`) taken whole: the links' estimate
    /// ([`cluster_kernel`]), the cluster's light leaving by the axes its surfaces
    /// face ([`oracle::cluster_emission`]). Times the visibility by rays drawn by
    /// power into the cluster ([`Solver::part_visibility`]) and the cluster's
    /// radiosity, it is `Σ F_i V_i B_i` over the cluster's surfaces where their
    /// faces are axis-aligned: `A B̄ R(v)` is then their projected power.
    pub(super) fn whole_cluster_factor(
        &self,
        x: DVec3,
        n: DVec3,
        e: usize,
        sphere: (DVec3, f64),
    ) -> f64 {
        let g = &self.elems.geoms.as_slice()[e];
        let b = self.elems.radiosities.as_slice()[e]
            .iter()
            .copied()
            .fold(0.0f32, f32::max) as f64;
        let dir = &self.elems.directions.as_slice()[e];
        cluster_kernel(g, sphere.0, sphere.1, dir, b, x, n)
    }

    /// The visible fraction of surface source `s` with factor `k` at the point by
    /// the rays `r` ([`Solver::gather_rays`]), cast again where they find it
    /// partly hidden, as many as the term's weight asks for at the reconstruction
    /// tolerance ([`recast_rays`]; none again where the first rays meet it),
    /// emitter or not.
    ///
    /// Why: 8 stratified rays give the fraction in steps of 1/8. In the L-shaped
    /// room of `tests/it/solver/enclosures.rs` a floor point by the re-entrant
    /// corner saw a ceiling tile half hidden by the corner's wall as 0.59 visible
    /// (0.50 with 4096 rays), and with a near cluster's tiles taken at the
    /// cluster's shared fraction its factors summed to 1.0093 (1.0001 with 4096
    /// rays per tile). An emitter's first rays are 4× as many
    /// ([`Solver::corner_rays_to`]), steps of 1/32; in the enclosures of that test
    /// every surface emits, and the rule holds them within their 1%. Where the
    /// light comes through partly hidden non-emitting surfaces (the L-shaped room
    /// lit in one arm, `tests/it/solver/l_room_lit.rs`), a term's step of 1/8
    /// weighs what its radiosity makes it, and the rule casts again only where
    /// that step would show.
    fn surface_visibility(
        &self,
        mut r: oracle::PointRays,
        k: f64,
        s: usize,
        limits: &GatherLimits,
    ) -> f64 {
        let v = oracle::visible_fraction(&self.bvh, &r);
        if v <= 0.0 || v >= 1.0 {
            return v;
        }
        let w = self.term_weight(r.skip[0], s, k);
        let m = recast_rays(r.m, w, limits.recast_tol);
        if m <= r.m {
            return v;
        }
        r.m = m;
        oracle::visible_fraction(&self.bvh, &r)
    }

    /// `ρ_x k B_s` (largest channels): what surface source `s` at factor `k` hands
    /// a point of patch `receiver_patch` wholly visible.
    fn term_weight(&self, receiver_patch: u32, s: usize, k: f64) -> f64 {
        let rho = self
            .patches
            .rhos
            .get(receiver_patch as usize)
            .map_or(self.rho_max, |r| r.iter().copied().fold(0.0, f64::max));
        let b = self.elems.radiosities.as_slice()[s]
            .iter()
            .copied()
            .fold(0.0f32, f32::max);
        rho * k * f64::from(b)
    }

    /// Final gather at point `x` of leaf `leaf`: `(B(x), valid, fresh, near)`.
    /// `key`: the point's place (its rays' jitter) and the leaf its terms are kept
    /// for in a window ([`KeptKey`]). `near`: the terms of sources that look large
    /// from the point ([`NearTerms`]; none unless `limits.near_field`, nor at a
    /// point solved across a gap).
    ///
    /// A point with a near source (module docs, "Two surfaces across a narrow gap")
    /// gathers at its foot on that source too, and the two values are solved
    /// together ([`Solver::across_gap`]).
    pub(super) fn gather_point(
        &self,
        leaf: ElementId,
        x: DVec3,
        known: Option<&PointCache>,
        key: KeptKey,
        admit: bool,
        limits: &GatherLimits,
    ) -> ([f64; 3], bool, FreshTerms, NearTerms) {
        let (mut sum, valid, fresh) = self.gather_sum(leaf, x, known, key, admit, false, limits);
        let p = self.elems.geoms.as_slice()[leaf.ix()].patch;
        let near = if sum.near.is_none() {
            std::mem::take(&mut sum.field)
        } else {
            Vec::new()
        };
        (self.across_gap(p, &sum, key.0, limits), valid, fresh, near)
    }

    /// `B(x) = E + ρ H` at a point of patch `p` whose gather is `sum`. With a near
    /// source, `H` holds `F_xy B(y)` for it, `y` the foot: the gather at `y` (its
    /// own near source, if on `p`, taken as `x`'s radiosity) makes the pair
    /// `B(x) = E_x + ρ_x (H_x + F_xy B(y))`, `B(y) = E_y + ρ_y (H_y + F_yx B(x))`,
    /// solved for `B(x)`.
    fn across_gap(
        &self,
        p: u32,
        sum: &PointGather,
        pk: PointKey,
        limits: &GatherLimits,
    ) -> [f64; 3] {
        let rho = self.patches.rhos[p as usize];
        let em = self.patches.emissions[p as usize];
        let mut b: [f64; 3] = std::array::from_fn(|k| em[k] + rho[k] * sum.h[k]);
        let Some(near) = sum.near else {
            return b;
        };
        let leaf = self.leaf_at(ElementId(near.elem), near.foot);
        // Its own rays: another key than any reconstruction point's.
        let pk_y = (pk.0 ^ 0x6761_7000, pk.1.rotate_left(7), pk.2);
        let (sy, _, _) =
            self.gather_sum(leaf, near.foot, None, (pk_y, ANY_LEAF), false, true, limits);
        let py = self.elems.geoms.as_slice()[leaf.ix()].patch as usize;
        let (rho_y, em_y) = (self.patches.rhos[py], self.patches.emissions[py]);
        let mut hy = sy.h;
        let mut f_yx = 0.0;
        if let Some(m) = sy.near {
            let mp = self.elems.geoms.as_slice()[m.elem as usize].patch;
            if mp == p {
                f_yx = m.f;
            } else {
                // Another surface across from the foot: its mean, as without a gap.
                let bm = self.elems.radiosities.as_slice()[m.elem as usize];
                for k in 0..3 {
                    hy[k] += m.f * bm[k] as f64;
                }
            }
        }
        for k in 0..3 {
            let by = em_y[k] + rho_y[k] * hy[k];
            let loop_gain = (rho[k] * rho_y[k] * near.f * f_yx).min(0.999);
            b[k] = (b[k] + rho[k] * near.f * by) / (1.0 - loop_gain);
        }
        b
    }

    /// The leaf under element `e` that holds the point `y` of its plane: at each
    /// level the child whose polygon holds it (the nearest centre where rounding
    /// leaves it in none).
    pub(super) fn leaf_at(&self, mut e: ElementId, y: DVec3) -> ElementId {
        let geoms = self.elems.geoms.as_slice();
        loop {
            let kids = self.elems.children(e);
            if kids.is_empty() {
                return e;
            }
            let holds = |&c: &u32| {
                let g = &geoms[c as usize];
                oracle::poly(g).contains(DVec3::from_array(g.normal), y, 0.0)
            };
            let nearest = || {
                kids.clone().min_by(|&a, &c| {
                    let d = |i: u32| oracle::poly(&geoms[i as usize]).centroid().distance(y);
                    d(a).total_cmp(&d(c))
                })
            };
            match kids.clone().find(holds).or_else(nearest) {
                Some(c) => e = ElementId(c),
                None => return e,
            }
        }
    }

    /// The sum of the final gather at point `x` of leaf `leaf`, near sources apart:
    /// `(sum, valid, fresh)`.
    ///
    /// In a time window, the terms that stay constant over the window at a static
    /// point are kept in `known` (one merged linear form per point, with the links it
    /// covers): constant links, and varying links whose shaft from the point to the
    /// source misses every box the moving objects sweep. `fresh` returns the terms of
    /// such links computed now, to be merged into `known` by the caller.
    ///
    /// `limits.faint`: non-emitting surface sources whose light at `x` is bounded
    /// (`ρ B_s A_s / (π d²)`, `d` the distance to the source's bounding sphere)
    /// by this **in sum** are gathered with their links' visibility instead of
    /// rays (0: rays always); the sources after the budget is spent cast their
    /// own. A link's visibility is its receiver's mean, not the point's: the
    /// shortcut may miss up to what it bounds. Taken per source, a dim point
    /// lit by many small far sources each under the bound (the Blender box's
    /// ceiling by the open front, 0.22 against a scene RMS of about 0.5) took
    /// most of its light through its chain links' visibility and read 9.3% dark
    /// (blue 19%) against the path tracer; with the sum bounded, 2.4%
    /// (BENCHMARKS.md, the Blender box).
    ///
    /// `once`: a point gathered once and forgotten (a foot across a gap), which
    /// keeps nothing in a window and so is gathered as a moving point is, its rays
    /// cast at the scene as it is now: no static masks, no cluster opened because a
    /// moving object may cross it.
    #[allow(clippy::too_many_arguments)]
    fn gather_sum<'a>(
        &'a self,
        leaf: ElementId,
        x: DVec3,
        known: Option<&PointCache>,
        key: KeptKey,
        admit: bool,
        once: bool,
        limits: &'a GatherLimits,
    ) -> (PointGather<'a>, bool, FreshTerms) {
        // What the faint sources' shortcut may still leave out at this point.
        let mut faint_left = limits.faint;
        let pk = key.0;
        // Ray jitter from the point's place, so that a point gathered again (another
        // frame, another cell) casts the same rays.
        let point_key = oracle::hash3(
            u64::from(pk.0),
            u64::from(pk.1) << 32 | u64::from(pk.2),
            0x9017,
        );
        let geoms = self.elems.geoms.as_slice();
        let ends = self.links.ends.as_slice();
        let tr = self.links.transports.as_slice();
        let g = &geoms[leaf.ix()];
        let n = DVec3::from_array(g.normal);
        let p = g.patch as usize;
        let valid = self.outside_solids(x, n);
        let b = self.elems.radiosities.as_slice();
        let window = self
            .st
            .window
            .as_ref()
            .filter(|_| !once && !self.elem_moving(leaf));
        let cached = known.and_then(|m| m.get(&key));
        let mut sum = PointGather::new(&self.patches, x, n, limits);
        let mut fresh = Vec::new();
        let mut terms = Terms::default();
        // A leaf smaller than the power area takes the visibility of non-emitting
        // surface sources from its row (seen from its quadrature points), and of
        // clusters with no emitter from their link, not from rays.
        let small_leaf = self
            .sys
            .row_cache
            .get(&leaf.0)
            .filter(|_| !self.has_motion() && g.area < self.power_area);
        // A varying link's visibility and shaft test hold at the time it was
        // evaluated; a frame between keyframes that skips its solve gathers from
        // links evaluated at another time.
        let links_now = self.st.links_at == self.motion.now;
        for l in self.chain_links(leaf) {
            let t = &tr[l as usize];
            let s = ends[l as usize].source as usize;
            // A static source seen from a static point: what does not change in
            // the window is kept (fixed terms, and the static part of the rays of
            // the others).
            // Kept per source (the link may be this frame's: a varying link
            // refined at the receiver's end keeps the older source).
            let keep =
                window.filter(|w| !self.elem_moving(ElementId(s as u32)) && s < w.frame.elems_len);
            // A varying link's shaft test holds for one frame only.
            let clear = t.shaft_clear() && !t.varying();
            let ck = (s as u32) << 1 | clear as u32;
            if let Some((fixed, masked)) = keep.and(cached).and_then(|c| c.get(ck)) {
                for t in fixed {
                    self.add_term(&mut sum, t.elem, t.f as f64);
                }
                for t in masked {
                    let gs = &geoms[t.elem as usize];
                    // Rays are only cast where a moving object is now.
                    let near = !point_shaft_clear(x, n, gs, &self.motion.moving_now);
                    let v = if near {
                        let ps = oracle::poly(gs);
                        let r = self.gather_rays(x, n, p as u32, gs, &ps, u64::from(t.key));
                        oracle::visible_fraction_moving(&self.bvh, &r, t.mask, t.vis_static.into())
                    } else {
                        f64::from(t.vis_static)
                    };
                    self.add_term(&mut sum, t.elem, t.f as f64 * v);
                }
                continue;
            }
            terms.clear();
            let key = oracle::hash3(self.opts.seed, self.ray_id(s as u32), point_key);
            // Static sources that can hand this point little light in sum take
            // their links' visibility instead of rays (see `faint_left`).
            let cheap = if self.has_motion() || clear || t.shaft_clear() {
                None
            } else if let Some(v) = small_leaf.and_then(|row| self.leaf_visibility(row, l, s)) {
                Some(v)
            } else if small_leaf.is_some()
                && geoms[s].patch == u32::MAX
                && !self.emits_under.get(s).copied().unwrap_or(true)
            {
                // A cluster with no emitter under it, seen from a small leaf: the
                // link's visibility, as the leaf row takes it.
                Some(t.visibility as f64)
            } else if let Some(bound) = self
                .faint_bound(x, s, b, limits)
                .filter(|&bound| bound < faint_left)
            {
                faint_left -= bound;
                Some(t.visibility as f64)
            } else {
                None
            };
            // A source the leaf's row or its link sees wholly hidden gives nothing:
            // its factors are not worked out (with the clusters' kept spheres,
            // `gen_cubes 20` took 90 CPU s instead of 126, the probes bit for bit
            // the same; BENCHMARKS.md "Scale").
            if cheap.is_none_or(|v| v > 0.0) {
                self.point_terms(
                    x,
                    n,
                    p as u32,
                    s,
                    cheap.is_some()
                        || clear
                        || (keep.is_none() && t.shaft_clear() && (!t.varying() || links_now)),
                    t.visibility > 0.0 && t.visibility < 1.0,
                    key,
                    keep.map(|w| &w.swept[..]),
                    limits,
                    &mut terms,
                );
            }
            if let Some(v) = cheap {
                for term in &mut terms.fixed {
                    term.1 *= v;
                }
            }
            terms.gather(self, &mut sum);
            // Terms on elements of this frame's refinement are not kept: the
            // next frame drops those elements.
            if let Some(w) = keep.filter(|_| admit || cached.is_some()) {
                let shared = |e: u32| (e as usize) < w.frame.elems_len;
                if terms.fixed.iter().all(|t| shared(t.0))
                    && terms.masked.iter().all(|t| shared(t.0.elem))
                {
                    fresh.push((ck, terms.clone()));
                }
            }
        }
        (sum, valid, fresh)
    }

    /// False if the point `x` of a surface facing `n` lies inside a solid: the first
    /// thing straight above it is a back face (a floor point under a block resting
    /// on it).
    pub(super) fn outside_solids(&self, x: DVec3, n: DVec3) -> bool {
        let diam = self.patches.diameter;
        match self.bvh.intersect_front_first(x, n * diam, 1e-7, 1.0) {
            Some(h) => self.patches.normals[h.patch as usize].dot(n) <= 0.0,
            None => true,
        }
    }

    /// True if element `s` is a surface (not a cluster) of a patch that emits nothing:
    /// the sources whose rays the final gather may take from elsewhere.
    fn non_emitting_surface(&self, s: usize) -> bool {
        let p = self.elems.geoms.as_slice()[s].patch;
        p != u32::MAX && !self.patches.emits(p as usize)
    }

    /// The visible fraction of non-emitting surface source `s` (chain link `l`) seen
    /// from the leaf whose kept row is `row`, if every ray the row cast agrees (the
    /// source fully visible or fully hidden from all the leaf's points): a source
    /// partly hidden from the leaf is partly hidden from its points in different
    /// measure, and a point takes its own rays.
    ///
    /// Why: in `tools/gen_cubes.py 20` the floor between two boxes, in full shadow
    /// and lit only by the faces around it, came out 10% too dark at four of the 20
    /// gap probes with the leaf's fraction for every source (the boxes' sides and
    /// the room beyond them are half hidden from a gap leaf, in other measure from
    /// each of its points); with partial fractions cast again, 3.40% → 2.72% over the
    /// 100 probes (BENCHMARKS.md, "Floor gaps in full shadow").
    pub(super) fn leaf_visibility(&self, row: &[KeptCoef], l: u32, s: usize) -> Option<f64> {
        if !self.non_emitting_surface(s) {
            return None;
        }
        let i = row.binary_search_by_key(&l, |k| k.link).ok()?;
        let v = row[i].vis;
        (v <= 0.0 || v >= 1.0).then_some(v as f64)
    }

    /// The limits of a reconstruction at radiosity scale `b_ref`: the options
    /// scaled, and each element's radiosity spread from the pool's radiosities as
    /// they are now (leaves up, children after their parent in the pool); with
    /// `spheres`, every element's bounding sphere (worth it where many points are
    /// gathered, see [`GatherLimits::spheres`]).
    pub(super) fn gather_limits(&self, b_ref: f64, spheres: bool) -> GatherLimits {
        GatherLimits {
            faint: self.opts.faint_source * b_ref,
            open_spread: if self.opts.open_spread > 0.0 {
                self.opts.open_spread * b_ref
            } else {
                f64::INFINITY
            },
            spread: self.radiosity_spread(),
            near_gap: self.opts.near_gap,
            recast_tol: self.opts.recon_tol * b_ref,
            near_field: 0.0,
            shapes: Default::default(),
            spheres: if spheres {
                self.elems
                    .geoms
                    .as_slice()
                    .par_iter()
                    .map(oracle::sphere)
                    .collect()
            } else {
                Vec::new()
            },
        }
    }

    /// Per element: `ΔB_s`, the largest channel's spread (max − min) of the leaf
    /// radiosities under it as the pool holds them now (0 for a leaf).
    pub(super) fn radiosity_spread(&self) -> Vec<f32> {
        let nodes = self.elems.nodes.as_slice();
        let b = self.elems.radiosities.as_slice();
        let mut lo = b.to_vec();
        let mut hi = b.to_vec();
        for i in (0..nodes.len()).rev() {
            let nd = nodes[i];
            for c in nd.first_child..nd.first_child + nd.child_count {
                for k in 0..3 {
                    lo[i][k] = lo[i][k].min(lo[c as usize][k]);
                    hi[i][k] = hi[i][k].max(hi[c as usize][k]);
                }
            }
        }
        lo.iter()
            .zip(&hi)
            .map(|(l, h)| (0..3).map(|k| h[k] - l[k]).fold(0.0f32, f32::max))
            .collect()
    }

    /// What surface source `s`, no emitter, can hand the point `x` at most:
    /// `ρ_max B_s A_s / (π d²)`, `d` from `x` to the source's bounding sphere
    /// (`None` for an emitter, a cluster, a point inside the sphere, or with
    /// `limits.faint` 0). The final gather skips the rays of sources while the
    /// sum of their bounds stays under `limits.faint` ([`Solver::gather_sum`]).
    fn faint_bound(
        &self,
        x: DVec3,
        s: usize,
        b: &[[f32; 3]],
        limits: &GatherLimits,
    ) -> Option<f64> {
        if limits.faint <= 0.0 || !self.non_emitting_surface(s) {
            return None;
        }
        let gs = &self.elems.geoms.as_slice()[s];
        let (c, rad) = limits.sphere(s, gs);
        let d = c.distance(x) - rad;
        if d <= 0.0 {
            return None;
        }
        let bs = b[s].iter().copied().fold(0.0f32, f32::max) as f64;
        Some(self.rho_max * bs * gs.area / (std::f64::consts::PI * d * d))
    }
}
