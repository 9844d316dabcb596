//! The refinement oracle: evaluates a link's transport and error bound, and decides
//! whether to keep it, split its receiver or split its source.
//!
//! **Surface–surface links.** The coefficient is the Galerkin (constant basis) form
//! factor `F_rs = (1/A_r) ∫_{A_r} F(x → A_s) V(x) dx`, with the inner factor exact by
//! Lambert's formula ([`point_to_polygon`]) and the outer integral by Gauss quadrature
//! (2×2 points on quads, 3 on triangles). Visibility is first settled by a shaft
//! ([`Shaft`]): clear → `V = 1`, no ray. Otherwise each quadrature point casts jittered
//! rays to stratified points of the source, weighted by the point kernel. The error
//! bound is the oracle of Hanrahan, Salzman & Aupperle (1991) on `ρ ΔK B`: `ΔK` is
//! the spread of `F(x → A_s)·V(x)` over the receiver's quadrature points, corners
//! and centre, plus the unresolved part of a partial visibility.
//!
//! **Links with a cluster.** A receiving cluster's surfaces see on average a quarter
//! of the normal irradiance (Cauchy's mean projected area; Sillion 1995, "A unified
//! hierarchical algorithm for global illumination with scattering volumes and object
//! clusters", §4). A source cluster radiates with the cosine factor of
//! [`cluster_emission`]: `cos θ` where its power comes from surfaces facing one way,
//! and the rest by the axes its surfaces face (isotropic, 1/4, in Sillion 1995).
//! Visibility is estimated as Sillion (1995, §4.3) and Smits et al. (1994) do: a few
//! rays (`cluster_rays`) between points on the *surfaces* under the two ends (a
//! descent to a surface element, by area at the receiving end and by power at the
//! source's, then a jittered point on it — never a box interior, which may lie
//! inside a solid), each weighted by the point kernel;
//! a pair whose surfaces turn away from each other casts no ray and weighs nothing,
//! and when no pair faces the other the visibility is 0. No shaft test applies (a
//! cluster's box holds its own surfaces, so a shaft from it is never clear).
//!
//! Such a coefficient is only an estimate, so its error bound covers any visibility
//! (see [`evaluate`]): only links that could carry little energy stay at cluster
//! level, hidden or not. Ends closer than `1.5 (r_r + r_s)` (bounding spheres) have
//! no estimate and an unbounded spread; left whole, such a link carries a Monte
//! Carlo factor ([`close_cluster_factor`]).
//!
//! Deterministic: the ray jitter is a hash of (receiver, source, sample), not of the
//! thread or the order of evaluation.

use glam::DVec3;

use crate::geometry::{LastHit, Parts, Poly, SceneBvh, point_to_point_kernel, point_to_polygon};
use crate::pools::elements::Geom;
use crate::pools::links::Transport;
use crate::pools::{ElementId, ElementKind, ElementPool, Emission, LinkState};
use crate::shafts::Shaft;

/// What the oracle knows about a link after evaluating its geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkEval {
    /// Coefficient, spread, visibility, flags (state active).
    pub transport: Transport,
    /// Rays cast to evaluate it.
    pub rays: u32,
    /// True if no energy can flow (the link is dropped, not stored).
    pub empty: bool,
}

/// Settings of the link evaluation.
#[derive(Clone, Copy, Debug)]
pub struct EvalSettings {
    /// Rays per receiver quadrature point for a partly hidden link.
    pub rays_per_point: u32,
    /// Rays between the two ends of a link with a cluster (visibility estimate).
    pub cluster_rays: u32,
    /// Seed of the ray jitter.
    pub seed: u64,
    /// Draw a cluster source's visibility points by power ([`source_point`]), not by
    /// area, and radiate its rest by axes ([`cluster_emission`]). The solver always
    /// does; `false` is Sillion's isotropic cluster seen by area, kept to compare
    /// the two.
    pub sources_by_power: bool,
}

/// The point-evaluation samples of a surface element: quadrature points with weights
/// (summing to 1) and the corners.
pub struct Samples {
    /// Quadrature points.
    pub points: [DVec3; 4],
    /// Quadrature weights.
    pub weights: [f64; 4],
    /// Number of quadrature points (3 or 4).
    pub count: usize,
}

/// Quadrature points of a surface element (2×2 Gauss on the bilinear quad, weighted
/// by the Jacobian; the 3-point interior rule on a triangle).
pub fn samples(g: &Geom) -> Samples {
    let c = |i: usize| DVec3::from_array(g.corners[i]);
    if g.n == 3 {
        let (a, b, cc) = (c(0), c(1), c(2));
        let p = |u: f64, v: f64| a + u * (b - a) + v * (cc - a);
        Samples {
            points: [
                p(1.0 / 6.0, 1.0 / 6.0),
                p(2.0 / 3.0, 1.0 / 6.0),
                p(1.0 / 6.0, 2.0 / 3.0),
                DVec3::ZERO,
            ],
            weights: [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0],
            count: 3,
        }
    } else {
        let g0 = 0.5 - 0.5 / 3f64.sqrt();
        let g1 = 0.5 + 0.5 / 3f64.sqrt();
        let (p0, p1, p2, p3) = (c(0), c(1), c(2), c(3));
        let at = |s: f64, t: f64| {
            let p =
                (1.0 - s) * (1.0 - t) * p0 + s * (1.0 - t) * p1 + s * t * p2 + (1.0 - s) * t * p3;
            let ds = (1.0 - t) * (p1 - p0) + t * (p2 - p3);
            let dt = (1.0 - s) * (p3 - p0) + s * (p2 - p1);
            (p, ds.cross(dt).length())
        };
        let q = [at(g0, g0), at(g1, g0), at(g1, g1), at(g0, g1)];
        let wsum: f64 = q.iter().map(|x| x.1).sum();
        let w = |i: usize| if wsum > 0.0 { q[i].1 / wsum } else { 0.25 };
        Samples {
            points: [q[0].0, q[1].0, q[2].0, q[3].0],
            weights: [w(0), w(1), w(2), w(3)],
            count: 4,
        }
    }
}

/// A finer rule on a surface element: the element cut into four (a quad at its
/// parametric midpoints, a triangle at its edge midpoints), each piece's
/// [`samples`] weighted by its share of the area. 16 points on a quad, 12 on a
/// triangle; weights sum to 1.
pub fn fine_samples(g: &Geom) -> Vec<(DVec3, f64)> {
    let c = |i: usize| DVec3::from_array(g.corners[i]);
    let pieces: Vec<Vec<DVec3>> = if g.n == 3 {
        let (a, b, d) = (c(0), c(1), c(2));
        let (ab, bd, da) = ((a + b) / 2.0, (b + d) / 2.0, (d + a) / 2.0);
        vec![
            vec![a, ab, da],
            vec![ab, b, bd],
            vec![da, bd, d],
            vec![bd, da, ab],
        ]
    } else {
        let (p0, p1, p2, p3) = (c(0), c(1), c(2), c(3));
        let m01 = (p0 + p1) / 2.0;
        let m12 = (p1 + p2) / 2.0;
        let m23 = (p2 + p3) / 2.0;
        let m30 = (p3 + p0) / 2.0;
        let mid = (p0 + p1 + p2 + p3) / 4.0;
        vec![
            vec![p0, m01, mid, m30],
            vec![m01, p1, m12, mid],
            vec![mid, m12, p2, m23],
            vec![m30, mid, m23, p3],
        ]
    };
    let mut out = Vec::with_capacity(16);
    let mut total = 0.0;
    for piece in &pieces {
        let mut sub = *g;
        for (k, v) in piece.iter().enumerate() {
            sub.corners[k] = v.to_array();
        }
        let area = Poly::new(piece).area_vector().length() / 2.0;
        total += area;
        let q = samples(&sub);
        for i in 0..q.count {
            out.push((q.points[i], q.weights[i] * area));
        }
    }
    if total > 0.0 {
        for o in &mut out {
            o.1 /= total;
        }
    }
    out
}

/// The world polygon of a surface element.
pub fn poly(g: &Geom) -> Poly {
    let mut p = Poly {
        v: [DVec3::ZERO; crate::geometry::MAX_CORNERS],
        n: (g.n as usize).min(4),
    };
    for (d, c) in p.v.iter_mut().zip(&g.corners[..p.n]) {
        *d = DVec3::from_array(*c);
    }
    p
}

/// Centre and bounding radius of an element.
#[inline]
pub fn sphere(g: &Geom) -> (DVec3, f64) {
    if g.patch == u32::MAX {
        // About the area centroid, which a cluster estimate takes for the cluster's
        // place: the box's centre may lie far from every surface (two walls of a
        // corner), which errs to first order in `r/d`; the centroid to second.
        // The radius is kept with the box (`Geom::set_cluster_box`).
        (DVec3::from_array(g.corners[2]), g.corners[3][0])
    } else {
        // No `Poly` built: link evaluation and the error samples call this per term.
        let n = (g.n as usize).min(4);
        let v: [DVec3; 4] = std::array::from_fn(|i| DVec3::from_array(g.corners[i]));
        let v = &v[..n];
        let c = crate::geometry::centroid_of(v);
        let r = v.iter().map(|&p| p.distance(c)).fold(0.0, f64::max);
        (c, r)
    }
}

/// Corners of a cluster's box.
fn box_corners(g: &Geom) -> [DVec3; 8] {
    let lo = DVec3::from_array(g.corners[0]);
    let hi = DVec3::from_array(g.corners[1]);
    std::array::from_fn(|i| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Corners of any element (surface corners or cluster box corners).
fn element_points(g: &Geom) -> Vec<DVec3> {
    if g.patch == u32::MAX {
        box_corners(g).to_vec()
    } else {
        (0..g.n as usize)
            .map(|i| DVec3::from_array(g.corners[i]))
            .collect()
    }
}

/// True if every point of `pts` is behind or on the plane of surface element `g`.
fn all_behind(g: &Geom, pts: &[DVec3], eps: f64) -> bool {
    let n = DVec3::from_array(g.normal);
    let o = DVec3::from_array(g.corners[0]);
    pts.iter().all(|&p| n.dot(p - o) <= eps)
}

/// The cosine factor a cluster source radiates with towards the unit direction `v`:
/// `max(0, N·v)/P + (1 − |N|/P) · R(v)`, with `P = A·B̄` the cluster's power (largest
/// channel) and `N = Σ A_i B̄_i n_i` its power-weighted normal ([`Emission::normal`]).
/// A cluster whose power comes from surfaces facing one way (a lamp) radiates like
/// that surface, `cos θ`. The rest of the power, `P − |N|` (surfaces whose normals
/// cancel), leaves by the axes it faces: `R(v) = Σ_k r_k max(0, ±v_k) / Σ_k r_k`,
/// `r` the axis powers ([`Emission::axes`]) less those of `N`'s part, clamped at 0.
/// `R` integrates to `π` over the sphere as the isotropic 1/4 of Sillion (1995) does,
/// so the power is the same; where it goes is not. Why: boxes on a floor have sides
/// whose normals cancel; isotropic, their light went up as much as sideways, and
/// the ceiling of a cluttered room (`tools/gen_cubes.py 20`) came out 1.7% too
/// bright and its walls 2.4% too dark against the path tracer. With no axis power
/// left (`Σ r_k` below `10⁻⁶ P`), `R` is the isotropic 1/4; a dark cluster is taken
/// as isotropic. A rest below [`COHERENT_REST`] is the rounding of a cluster
/// facing one way, and none.
///
/// With `axes` false the rest is isotropic, `R = 1/4` (Sillion 1995): the model
/// that goes with a visibility drawn by area ([`EvalSettings::sources_by_power`]
/// false). Each alone errs one way, the axes darker and the area visibility
/// brighter: axes with area visibility gave `gen_cubes 20` 3.52% against 3.47%
/// with neither; both together give 3.40%.
pub fn cluster_emission(g: &Geom, em: &Emission, b: f64, v: DVec3, axes: bool) -> f64 {
    let p = g.area * b;
    let n = DVec3::new(
        em.normal[0] as f64,
        em.normal[1] as f64,
        em.normal[2] as f64,
    );
    if p.is_nan() || p <= 0.0 {
        return 0.25;
    }
    let len = n.length().min(p);
    let coherent = (n.dot(v).max(0.0) / p).min(1.0);
    let rest = 1.0 - len / p;
    // A cluster whose patches all face one way has no rest: what is left is the
    // rounding of the `f32` sums (see [`COHERENT_REST`]).
    if rest <= COHERENT_REST {
        return coherent;
    }
    if !axes {
        return coherent + 0.25 * rest;
    }
    // Axis powers of the coherent part, a surface of normal N / |N| and power |N|.
    let mut r = [0.0f64; 6];
    let mut rsum = 0.0;
    let nl = n.length();
    for k in 0..3 {
        for (slot, sign) in [(2 * k, 1.0), (2 * k + 1, -1.0)] {
            let nk = n[k] * sign;
            let own = if nl > 0.0 && nk > 0.0 {
                nk * nk / nl
            } else {
                0.0
            };
            r[slot] = (em.axes[slot] as f64 - own).max(0.0);
            rsum += r[slot];
        }
    }
    if rsum <= 1e-6 * p {
        return coherent + 0.25 * rest;
    }
    let dir: f64 = (0..3)
        .map(|k| r[2 * k] * v[k].max(0.0) + r[2 * k + 1] * (-v[k]).max(0.0))
        .sum();
    coherent + rest * dir / rsum
}

/// The largest rest `1 − |N|/P` of a cluster's power ([`cluster_emission`]) that
/// is taken as none: the cluster's patches all face one way, and `|N|` (summed
/// and stored in `f32`, [`Emission`]) misses `P` (its area times the pool's `f32`
/// radiosity) by their rounding, a few `10⁻⁸` either way, at one scale of the
/// scene one way and at another the other.
///
/// Why: counted, that rounding radiated `rest / 4` (~`10⁻⁸`) in every direction,
/// so a link from such a cluster to an element it turns its back on got a factor
/// of ~`10⁻¹⁰` instead of 0 (and rays for its visibility instead of none) at
/// some scales only, and the leaf rows, which drop a surface's link whose
/// factor is 0 and otherwise walk into the cluster's parts, took what the parts
/// give at one scale and nothing at the other. In the touching boxes of
/// `tests/it/solver/scale_free.rs`, contact-meshed with a segment's reach
/// (`geometry::contact`), a cluster of the big box's `−z` faces had a rest of
/// 4.4·10⁻⁸ in metres and none ×1000, and a leaf of the wall `x = 0` in front of
/// their plane (`z` 0.78–1.09) took 5.2·10⁻⁴ of its row from their parts in
/// metres only; a cluster of its `+x` faces gave the ceiling over the lamp (row
/// sum 0.003) a visibility of 1 in metres and 0.70 by rays ×1000, and the probes
/// there read 6.7·10⁻⁴ apart (the bar is 10⁻⁴; with this, 1.0·10⁻⁷).
pub const COHERENT_REST: f64 = 1e-6;

/// Isotropic-cluster coefficient at a receiving point/element (see module docs).
/// `cr`, `cs` are the cosine factors (1/4 for a cluster side).
fn cluster_factor(area_s: f64, cr: f64, cs: f64, d2: f64) -> f64 {
    if d2 <= 0.0 {
        return 0.0;
    }
    area_s * cr * cs / (std::f64::consts::PI * d2)
}

/// Evaluates the link receiver `r` ← source `s`. `ids` are what the rays' jitter
/// is hashed from for the two ends: their element ids, or in a space-time window
/// keys that follow the elements' geometry, so that an element a frame makes again
/// casts the same rays at every frame (`Solver::ray_id`).
///
/// A link with a cluster end gets an estimate, so its error bound is the whole
/// unoccluded transport with every cosine at its bound (1 on a cluster side, which
/// covers the directional estimate), whatever the rays found. A few rays prove
/// neither a clear nor a hidden link, so the bound covers any visibility in
/// `[0, 1]`: a link whose rays are all blocked gets coefficient 0 but keeps that
/// bound, and is refined (down to surface links, whose shafts and rays decide)
/// whenever the light it could carry matters. A link whose ends are too close for
/// the estimate has an unbounded spread: it is opened wherever its error counts.
/// `plane_tol` is the distance within which a point counts as on an element's
/// plane.
pub fn evaluate(
    elems: &ElementPool,
    bvh: &SceneBvh,
    r: ElementId,
    s: ElementId,
    ids: [u64; 2],
    set: &EvalSettings,
    plane_tol: f64,
) -> LinkEval {
    let gr = &elems.geoms.as_slice()[r.ix()];
    let gs = &elems.geoms.as_slice()[s.ix()];
    let empty = LinkEval {
        transport: Transport {
            f: 0.0,
            spread: 0.0,
            visibility: 0.0,
            flags: [LinkState::Active as u8, 0, 0, 0],
        },
        rays: 0,
        empty: true,
    };
    let r_surface = elems.kind(r) == ElementKind::Surface;
    let s_surface = elems.kind(s) == ElementKind::Surface;
    let (pr, ps) = (element_points(gr), element_points(gs));
    // Exact culls: a receiver entirely behind the source, or a source entirely behind
    // the receiver, exchanges nothing (and a patch with itself is coplanar).
    if (s_surface && all_behind(gs, &pr, plane_tol))
        || (r_surface && all_behind(gr, &ps, plane_tol))
    {
        return empty;
    }
    if r_surface && s_surface {
        return evaluate_surfaces(gr, gs, bvh, ids, set);
    }
    // A cluster is involved: isotropic estimate, error = whole transport.
    let (cr_c, rr) = sphere(gr);
    let (cs_c, rs) = sphere(gs);
    let d = cs_c - cr_c;
    let d2 = d.length_squared();
    let dist = d2.sqrt();
    let mut f = 0.0;
    let mut spread = f64::INFINITY;
    if dist > 1.5 * (rr + rs) {
        let u = d / dist;
        // Cosine bounds: the cosine at the centre widened by the other side's angular radius.
        let widen = |n: DVec3, dir: DVec3, rad: f64| (n.dot(dir) + rad / dist).clamp(0.0, 1.0);
        let cr = if r_surface {
            widen(DVec3::from_array(gr.normal), u, rs)
        } else {
            0.25
        };
        let cs = if s_surface {
            widen(DVec3::from_array(gs.normal), -u, rr)
        } else {
            let b = elems.radiosities.as_slice()[s.ix()]
                .iter()
                .copied()
                .fold(0.0f32, f32::max) as f64;
            cluster_emission(
                gs,
                &elems.directions.as_slice()[s.ix()],
                b,
                -u,
                set.sources_by_power,
            )
        };
        f = cluster_factor(gs.area, cr, cs, d2);
        // The true factor lies between 0 and the value with every cosine at its
        // bound (1 on a cluster side): that width is the error bound.
        let cr_max = if r_surface { cr } else { 1.0 };
        let cs_max = if s_surface { cs } else { 1.0 };
        spread = cluster_factor(gs.area, cr_max, cs_max, d2);
    }
    // Visibility by rays between the ends' surfaces; the spread keeps the unoccluded
    // bound (see this function's docs).
    let (mut vis, mut rays) = (1.0, 0);
    let key = hash3(set.seed ^ 0xc105, ids[0], ids[1]);
    if f > 0.0 {
        (vis, rays) = cluster_visibility(
            elems,
            bvh,
            r,
            s,
            set.cluster_rays,
            key,
            set.sources_by_power,
        );
        f *= vis;
    } else if spread.is_infinite() && r != s {
        // Too close for the estimate: the spread stays unbounded (the link is opened
        // wherever its error counts), but a link left whole — the power criterion
        // leaves such links at small receivers — must still carry its light.
        (f, vis, rays) = close_cluster_factor(
            elems,
            bvh,
            r,
            s,
            4 * set.cluster_rays,
            key,
            set.sources_by_power,
        );
    }
    LinkEval {
        transport: Transport {
            f: f as f32,
            spread: spread.min(f32::MAX as f64) as f32,
            visibility: vis as f32,
            flags: [LinkState::Active as u8, 0, 0, 0],
        },
        rays,
        empty: false,
    }
}

/// A point on the surfaces under element `e`, area-weighted, with its normal and
/// patch: from a cluster, descend to a child with probability proportional to its
/// area until a surface element, then a uniform point of it (by its parameters).
/// `h` is the jitter; the same `h` gives the same point.
pub fn surface_point(elems: &ElementPool, e: ElementId, h: u64) -> (DVec3, DVec3, u32) {
    descend(elems, e, h, false)
}

/// [`surface_point`] weighted by the light the surfaces hand on: the descent picks a
/// child with probability proportional to its power (area × largest channel of
/// `B`; by area where no child has any). The source end of a link with a cluster
/// ([`cluster_visibility`]).
pub fn source_point(elems: &ElementPool, e: ElementId, h: u64) -> (DVec3, DVec3, u32) {
    descend(elems, e, h, true)
}

/// [`surface_point`] (`by_power` false) and [`source_point`] (true).
fn descend(elems: &ElementPool, e: ElementId, h: u64, by_power: bool) -> (DVec3, DVec3, u32) {
    let nodes = elems.nodes.as_slice();
    let geoms = elems.geoms.as_slice();
    let bs = elems.radiosities.as_slice();
    let area = |c: usize| geoms[c].area.max(0.0);
    let power = |c: usize| area(c) * bs[c].iter().copied().fold(0.0f32, f32::max) as f64;
    let mut cur = e.ix();
    let mut level = 0u64;
    while geoms[cur].patch == u32::MAX {
        let node = nodes[cur];
        if node.child_count == 0 {
            break;
        }
        let kids = node.first_child as usize..(node.first_child + node.child_count) as usize;
        // By power where the children have any (a NaN fails the test), else by area.
        let power_total: f64 = if by_power {
            kids.clone().map(power).sum()
        } else {
            0.0
        };
        let weight = |c| if power_total > 0.0 { power(c) } else { area(c) };
        let total = if power_total > 0.0 {
            power_total
        } else {
            kids.clone().map(area).sum()
        };
        let u = unit(hash3(h, level, 0x5a3)) * total;
        let mut acc = 0.0;
        let mut pick = kids.start;
        for c in kids {
            pick = c;
            acc += weight(c);
            if u < acc {
                break;
            }
        }
        cur = pick;
        level += 1;
    }
    let g = &geoms[cur];
    if g.patch == u32::MAX {
        // A childless cluster (no surface under it): its centre, no facing.
        return (sphere(g).0, DVec3::ZERO, u32::MAX);
    }
    patch_point(g, h, level)
}

/// The uniform point of surface element `g` (by its parameters) that a descent
/// reaching it at depth `level` with jitter `h` draws, with its normal and patch
/// ([`surface_point`], and a cluster facet's [`crate::solver`] rays).
pub fn patch_point(g: &Geom, h: u64, level: u64) -> (DVec3, DVec3, u32) {
    let hp = hash3(h, level, 0x9e1);
    let su = (hp & 0xffff_ffff) as f64 / 4294967296.0;
    let sv = (hp >> 32) as f64 / 4294967296.0;
    (
        point_in(g, &poly(g), su, sv),
        DVec3::from_array(g.normal),
        g.patch,
    )
}

/// Visibility of cluster `s` from the point `x` (normal `n`, on patch `patch`): the
/// estimate of [`cluster_visibility`] with the receiving end a point (the final
/// gather's). Returns `(visibility, rays cast)`.
#[allow(clippy::too_many_arguments)]
pub fn point_cluster_visibility(
    elems: &ElementPool,
    bvh: &SceneBvh,
    x: DVec3,
    n: DVec3,
    patch: u32,
    s: ElementId,
    m: u32,
    key: u64,
    by_power: bool,
) -> (f64, u32) {
    kernel_weighted_visibility(bvh, m, |j| {
        ((x, n, patch), descend(elems, s, hash3(key, j, 2), by_power))
    })
}

/// [`point_cluster_visibility`] (by power) with what static geometry does to its
/// rays known: `known`, `(mask, targets)` as an earlier call with the same
/// arguments handed back, holds while the points the rays are aimed at are the
/// same (the descent by power picks them from the radiosity, which moves: their
/// hash `targets` is compared), and then only the rays the static part left clear
/// (bit `j` of `mask`) are cast, at the moving objects; otherwise every ray is
/// cast at the static part first and the new `(mask, targets)` is handed back.
/// The answer equals [`point_cluster_visibility`]'s: the same rays, the same sums
/// in the same order (a ray is blocked if a static or a moving triangle blocks
/// it). At most 64 rays; returns `((visibility, rays cast), made)`.
#[allow(clippy::too_many_arguments)]
pub fn point_cluster_visibility_masked(
    elems: &ElementPool,
    bvh: &SceneBvh,
    x: DVec3,
    n: DVec3,
    patch: u32,
    s: ElementId,
    m: u32,
    key: u64,
    known: Option<(u64, u64)>,
) -> ((f64, u32), Option<(u64, u64)>) {
    let m = m.clamp(1, 64) as usize;
    let mut ends = [(DVec3::ZERO, DVec3::ZERO, 0u32); 64];
    let mut targets = 0x7a3e_u64;
    for (j, end) in ends.iter_mut().enumerate().take(m) {
        *end = descend(elems, s, hash3(key, j as u64, 2), true);
        let (y, _, py) = *end;
        targets = hash3(
            targets ^ y.x.to_bits(),
            y.y.to_bits() ^ y.z.to_bits().rotate_left(29),
            py as u64,
        );
    }
    let mask = known.filter(|k| k.1 == targets).map(|k| k.0);
    let (mut wsum, mut vsum, mut rays, mut clear) = (0.0, 0.0, 0, 0u64);
    let (mut last_static, mut last_moving) = (LastHit::default(), LastHit::default());
    for (j, &(y, ny, py)) in ends.iter().enumerate().take(m) {
        let k = point_to_point_kernel(x, n, y, ny);
        if k.is_nan() || k <= 0.0 {
            continue;
        }
        rays += 1;
        wsum += k;
        let open = match mask {
            Some(mask) => mask >> j & 1 == 1,
            None => !bvh.occluded_between(x, y, [patch, py], Parts::Static, &mut last_static),
        };
        if !open {
            continue;
        }
        clear |= 1 << j;
        if !bvh.occluded_between(x, y, [patch, py], Parts::Moving, &mut last_moving) {
            vsum += k;
        }
    }
    let vis = if wsum > 0.0 { vsum / wsum } else { 0.0 };
    ((vis, rays), mask.is_none().then_some((clear, targets)))
}

/// Visibility of a link with a cluster end: `m` rays between [`surface_point`]s of
/// `r` and [`source_point`]s of `s` (`by_power`; else [`surface_point`]s) (Sillion
/// 1995 §4.3), the visible fraction
/// weighted by the point kernel. Pairs facing away from each other cast nothing; if
/// every pair does, the visibility is 0. Returns `(visibility, rays cast)`.
///
/// The source's points are drawn by power, so the fraction is that of the light
/// `s` hands on (`Σ A_i B_i K V / Σ A_i B_i K` over its surfaces), which is what the
/// link's coefficient multiplies by `B_s`; by area, a lit floor seen between black
/// boxes counted the boxes' visible tops as much as the floor's hidden light.
/// Depends on `B` when evaluated: see `Solver::reevaluate_cluster_sources`; a
/// space-time solve of a scene that moves, whose links outlive a frame, draws by
/// area.
pub fn cluster_visibility(
    elems: &ElementPool,
    bvh: &SceneBvh,
    r: ElementId,
    s: ElementId,
    m: u32,
    key: u64,
    by_power: bool,
) -> (f64, u32) {
    kernel_weighted_visibility(bvh, m, |j| {
        (
            surface_point(elems, r, hash3(key, j, 1)),
            descend(elems, s, hash3(key, j, 2), by_power),
        )
    })
}

/// The visible fraction of `m` segments between point pairs `ends(j)` (point,
/// normal, patch skipped by the ray), weighted by the point-to-point kernel; pairs
/// facing away cast nothing, and if every pair does the visibility is 0. Returns
/// `(visibility, rays cast)`.
pub(crate) fn kernel_weighted_visibility(
    bvh: &SceneBvh,
    m: u32,
    mut ends: impl FnMut(u64) -> ((DVec3, DVec3, u32), (DVec3, DVec3, u32)),
) -> (f64, u32) {
    let (mut wsum, mut vsum, mut rays) = (0.0, 0.0, 0);
    let mut last = LastHit::default();
    for j in 0..m.max(1) as u64 {
        let ((x, nx, px), (y, ny, py)) = ends(j);
        let k = point_to_point_kernel(x, nx, y, ny);
        if k.is_nan() || k <= 0.0 {
            continue;
        }
        rays += 1;
        wsum += k;
        if !bvh.occluded_between(x, y, [px, py], Parts::All, &mut last) {
            vsum += k;
        }
    }
    (if wsum > 0.0 { vsum / wsum } else { 0.0 }, rays)
}

/// Form factor of a link with a cluster end too close for the cluster estimate:
/// the Monte Carlo estimate `A_s · mean_j K(x_j, y_j) V(x_j, y_j)` over `m` pairs,
/// `x_j` a [`surface_point`] of the receiver (by area), `y_j` a [`source_point`] of
/// the source (`by_power`, so that `factor · B̄_s` is the light `s` hands on, not its
/// mean radiosity times its mean factor), with the squared distance of a pair held
/// above `A_s / (π m)`, the disc each source sample stands for (the kernel is
/// singular where the ends touch). Unbiased but for that clamp (and colour: the
/// power is the largest channel's); its noise is the link's error, which the
/// infinite spread leaves to refinement wherever it matters. Returns `(factor,
/// kernel-weighted visibility, rays cast)`.
///
/// Why: on a floor crowded with small boxes (`tools/gen_cubes.py`) many of the
/// active links were such links left whole by the power criterion, carrying
/// nothing, and the solve lost much of the emitted power (the scenes of
/// BENCHMARKS.md, "Scale (generated scenes)").
pub fn close_cluster_factor(
    elems: &ElementPool,
    bvh: &SceneBvh,
    r: ElementId,
    s: ElementId,
    m: u32,
    key: u64,
    by_power: bool,
) -> (f64, f64, u32) {
    let a_s = elems.geoms.as_slice()[s.ix()].area;
    let m = m.max(1);
    let r2_min = a_s / (std::f64::consts::PI * m as f64);
    let (mut ksum, mut kvis, mut rays) = (0.0, 0.0, 0);
    let mut last = LastHit::default();
    for j in 0..m as u64 {
        let (x, nx, px) = surface_point(elems, r, hash3(key, j, 1));
        let (y, ny, py) = descend(elems, s, hash3(key, j, 2), by_power);
        let d = y - x;
        let (cx, cy) = (nx.dot(d), -ny.dot(d));
        if cx <= 0.0 || cy <= 0.0 {
            continue;
        }
        let r2 = d.length_squared();
        let k = cx * cy / (std::f64::consts::PI * r2 * r2.max(r2_min));
        if !k.is_finite() {
            continue;
        }
        rays += 1;
        ksum += k;
        if !bvh.occluded_between(x, y, [px, py], Parts::All, &mut last) {
            kvis += k;
        }
    }
    let f = a_s * kvis / m as f64;
    let vis = if ksum > 0.0 { kvis / ksum } else { 0.0 };
    (f, vis, rays)
}

fn evaluate_surfaces(
    gr: &Geom,
    gs: &Geom,
    bvh: &SceneBvh,
    ids: [u64; 2],
    set: &EvalSettings,
) -> LinkEval {
    let nr = DVec3::from_array(gr.normal);
    let ns = DVec3::from_array(gs.normal);
    let (polr, pols) = (poly(gr), poly(gs));
    let q = samples(gr);
    let mut fq = [0.0f64; 4];
    for (f, &x) in fq.iter_mut().zip(&q.points).take(q.count) {
        *f = point_to_polygon(x, nr, &pols);
    }
    // Unoccluded spread over quadrature points, corners and the centre. The
    // centre: a source centred over a large receiver (a lamp over the middle of a
    // floor) peaks there, and the quadrature points and corners, placed
    // symmetrically around it, all see the same lower factor; the spread read 0.009
    // for a 1 m² lamp 3 m over a 6 × 6 m floor whose factor ranges 0.004–0.035, and
    // the floor stayed whole with its direct light 18% short (issue 45).
    let mut fmin = f64::INFINITY;
    let mut fmax: f64 = 0.0;
    for &x in fq[..q.count].iter() {
        fmin = fmin.min(x);
        fmax = fmax.max(x);
    }
    let corners = polr.corners();
    let centre = corners.iter().sum::<DVec3>() / corners.len() as f64;
    for &c in corners.iter().chain(std::iter::once(&centre)) {
        let f = point_to_polygon(c, nr, &pols);
        fmin = fmin.min(f);
        fmax = fmax.max(f);
    }
    let funocc: f64 = (0..q.count).map(|i| q.weights[i] * fq[i]).sum();
    let skip = [gr.patch, gs.patch];
    let shaft = Shaft::new(polr.corners(), nr, pols.corners(), ns);
    // Only the shaft proves a link clear, also where the factor is 0 at the
    // receiver's quadrature points: a source turned away from them may still face
    // part of the receiver (its corners and centre, `spread` above), and the rows
    // and the final gather take a clear link's factor at every point of the
    // receiver's leaves without a ray. Flagged clear at a zero factor, the strip of
    // Blender's back wall 0.1 mm behind the green wall's slab
    // (`tests/data/blender/cornell-box.glb`) took the lamp's top and the ceiling's
    // back side through the ceiling's slab: its rows summed to 1.12–1.15 against the
    // slab 0.1 mm in front (ρ 0.999), the leaf system's GMRES stalled at a residual
    // of 2.7e-3 after 2 000 products and, with the rows weighted by their cells'
    // factors, 1 500 leaves went to −400 in green (issue 45, part 4).
    let clear = shaft.is_clear(bvh, skip);
    if funocc <= 0.0 || clear {
        return LinkEval {
            transport: Transport {
                f: funocc as f32,
                spread: (fmax - fmin.min(fmax)) as f32,
                visibility: 1.0,
                flags: [LinkState::Active as u8, clear as u8, 0, 0],
            },
            rays: 0,
            empty: false,
        };
    }
    // Rays: per quadrature point, kernel-weighted visible fraction of the source.
    let m = set.rays_per_point.max(1);
    let mut vq = [0.0f64; 4];
    let mut rays = 0;
    for (i, (v, &x)) in vq.iter_mut().zip(&q.points).take(q.count).enumerate() {
        let key = hash3(set.seed, ids[0], ids[1] << 8 | i as u64);
        let r = PointRays {
            x,
            n: nr,
            gs,
            pols: &pols,
            ns,
            m,
            key,
            skip,
        };
        *v = visible_fraction(bvh, &r);
        rays += m;
    }
    let f: f64 = (0..q.count).map(|i| q.weights[i] * fq[i] * vq[i]).sum();
    let v = if funocc > 0.0 { f / funocc } else { 0.0 };
    let vmin = vq[..q.count].iter().copied().fold(1.0, f64::min);
    let vmax = vq[..q.count].iter().copied().fold(0.0, f64::max);
    // Spread: kernel spread on the visible part, visibility spread across the
    // receiver, and a partial visibility the quadrature cannot resolve.
    let spread =
        (fmax - fmin.min(fmax)) * v + funocc * (vmax - vmin) + funocc * 4.0 * v * (1.0 - v);
    LinkEval {
        transport: Transport {
            f: f as f32,
            spread: spread as f32,
            visibility: v as f32,
            flags: [LinkState::Active as u8, 0, 0, 0],
        },
        rays,
        empty: false,
    }
}

/// The rays from a point to a surface source that the ray functions below cast:
/// `m` jittered stratified rays of sample `key` from `x` (normal `n`) to the element
/// `gs` (polygon `pols`, normal `ns`), hits on the patches `skip` ignored. 112 bytes.
#[derive(Clone, Copy, Debug)]
pub struct PointRays<'a> {
    /// Where the rays start.
    pub x: DVec3,
    /// The normal there.
    pub n: DVec3,
    /// The source element.
    pub gs: &'a Geom,
    /// Its polygon ([`poly`] of `gs`).
    pub pols: &'a Poly,
    /// Its normal.
    pub ns: DVec3,
    /// How many rays.
    pub m: u32,
    /// Their jitter key.
    pub key: u64,
    /// Patches whose hits do not count (the receiver's and the source's).
    pub skip: [u32; 2],
}

impl PointRays<'_> {
    /// The same rays, at most 64 (one bit each in a mask).
    fn capped(&self) -> Self {
        PointRays {
            m: self.m.min(64),
            ..*self
        }
    }

    /// The `m` jittered stratified target points on `gs`.
    fn targets(&self) -> impl Iterator<Item = (u32, DVec3)> + '_ {
        ray_targets(self.gs, self.pols, self.m, self.key)
    }

    /// Kernel-weighted mean of `visible(j, y)` over the ray targets (the plain mean
    /// when every kernel weight is zero).
    fn weighted(&self, mut visible: impl FnMut(u32, DVec3) -> bool) -> f64 {
        let (mut wsum, mut vsum, mut plain) = (0.0, 0.0, 0.0);
        for (j, y) in self.targets() {
            let k = point_to_point_kernel(self.x, self.n, y, self.ns);
            let vis = if visible(j, y) { 1.0 } else { 0.0 };
            wsum += k;
            vsum += k * vis;
            plain += vis;
        }
        if wsum > 0.0 {
            vsum / wsum
        } else {
            plain / self.m as f64
        }
    }
}

/// Kernel-weighted fraction of the source of `r` visible from its point: the
/// rays cast 64 at a time as fans ([`SceneBvh::occluded_fan`], the same answer
/// ray by ray as [`SceneBvh::occluded_between`]), summed as
/// [`PointRays::weighted`] sums them.
pub fn visible_fraction(bvh: &SceneBvh, r: &PointRays) -> f64 {
    let (mut wsum, mut vsum, mut plain) = (0.0, 0.0, 0.0);
    let mut targets = r.targets();
    let mut ends = [DVec3::ZERO; 64];
    loop {
        let mut k = 0;
        for (slot, (_, y)) in ends.iter_mut().zip(targets.by_ref()) {
            *slot = y;
            k += 1;
        }
        if k == 0 {
            break;
        }
        let blocked = bvh.occluded_fan(r.x, &ends[..k], r.pols.corners(), r.skip, Parts::All);
        for (j, &y) in ends[..k].iter().enumerate() {
            let kw = point_to_point_kernel(r.x, r.n, y, r.ns);
            let vis = if blocked & (1 << j) == 0 { 1.0 } else { 0.0 };
            wsum += kw;
            vsum += kw * vis;
            plain += vis;
        }
        if k < ends.len() {
            break;
        }
    }
    if wsum > 0.0 {
        vsum / wsum
    } else {
        plain / r.m as f64
    }
}

/// [`visible_fraction`] with the rays that got through, one bit each (ray `j` →
/// bit `j`; rays past the 64th set none).
pub fn visible_rays(bvh: &SceneBvh, r: &PointRays) -> (f64, u64) {
    let mut last = LastHit::default();
    let mut bits = 0u64;
    let v = r.weighted(|j, y| {
        let clear = !bvh.occluded_between(r.x, y, r.skip, Parts::All, &mut last);
        if clear && j < 64 {
            bits |= 1 << j;
        }
        clear
    });
    (v, bits)
}

/// The rays of [`visible_fraction`] that nothing static blocks, as a bit mask (ray
/// `j` → bit `j`; at most 64 rays).
/// The solver makes its masks with the one-pass [`masked_rays`]; this and
/// [`visible_fraction_masked`] are the plain definitions its test holds it to.
pub fn static_clear_mask(bvh: &SceneBvh, r: &PointRays) -> u64 {
    let mut mask = 0u64;
    let mut last = LastHit::default();
    for (j, y) in r.capped().targets() {
        if !bvh.occluded_between(r.x, y, r.skip, Parts::Static, &mut last) {
            mask |= 1 << j;
        }
    }
    mask
}

/// [`visible_fraction`] from a [`static_clear_mask`]: only the rays the static part
/// leaves clear are cast, against the moving objects only (`None`: the caller knows
/// no moving object is in the way, and no ray is cast). Equal to
/// [`visible_fraction`] with the same rays.
pub fn visible_fraction_masked(bvh: Option<&SceneBvh>, r: &PointRays, mask: u64) -> f64 {
    let mut last = LastHit::default();
    r.capped().weighted(|j, y| {
        mask & (1 << j) != 0
            && !bvh.is_some_and(|b| b.occluded_between(r.x, y, r.skip, Parts::Moving, &mut last))
    })
}

/// The rays of [`visible_fraction`] split by what blocks them, in one pass over
/// the rays (their targets and kernel weights computed once): [`MaskedRays`].
/// `mask`: the rays nothing static blocks, if known (else cast against the static
/// part, as [`static_clear_mask`] does); `moving`: cast the rays `mask` leaves
/// clear against the moving objects too. At most 64 rays.
pub fn masked_rays(bvh: &SceneBvh, r: &PointRays, mask: Option<u64>, moving: bool) -> MaskedRays {
    let r = r.capped();
    let (mut wsum, mut vs, mut vn, mut ps, mut pn) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut clear, mut blocked) = (0u64, 0u64);
    // One shadow cache for each part the rays are cast at.
    let (mut last_static, mut last_moving) = (LastHit::default(), LastHit::default());
    for (j, y) in r.targets() {
        let bit = 1u64 << j;
        let open = match mask {
            Some(mask) => mask & bit != 0,
            None => !bvh.occluded_between(r.x, y, r.skip, Parts::Static, &mut last_static),
        };
        let k = point_to_point_kernel(r.x, r.n, y, r.ns);
        wsum += k;
        if !open {
            continue;
        }
        clear |= bit;
        // The same sums, in the same order, as `PointRays::weighted`'s.
        vs += k;
        ps += 1.0;
        if moving && bvh.occluded_between(r.x, y, r.skip, Parts::Moving, &mut last_moving) {
            blocked |= bit;
        } else {
            vn += k;
            pn += 1.0;
        }
    }
    let frac = |v: f64, p: f64| if wsum > 0.0 { v / wsum } else { p / r.m as f64 };
    MaskedRays {
        mask: clear,
        vis_static: frac(vs, ps),
        vis_now: frac(vn, pn),
        blocked,
    }
}

/// What [`masked_rays`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskedRays {
    /// Rays nothing static blocks ([`static_clear_mask`]).
    pub mask: u64,
    /// Kernel-weighted fraction of the rays `mask` leaves clear
    /// ([`visible_fraction_masked`] with no moving object).
    pub vis_static: f64,
    /// The same with the moving objects where they are: [`visible_fraction`]
    /// (`vis_static` unless the moving objects were asked).
    pub vis_now: f64,
    /// Rays of `mask` a moving object blocks.
    pub blocked: u64,
}

/// [`visible_fraction_masked`] against the moving objects, for a term whose static
/// visibility `vis_static` ([`MaskedRays::vis_static`], as kept) is known: the rays
/// of `mask` are cast at the moving objects first, and only if one is blocked are
/// the kernel weights computed. With no ray blocked the answer is `vis_static`.
pub fn visible_fraction_moving(bvh: &SceneBvh, r: &PointRays, mask: u64, vis_static: f64) -> f64 {
    let blocked = moving_blocked(bvh, r, mask);
    if blocked == 0 {
        return vis_static;
    }
    let open = mask & !blocked;
    r.capped().weighted(|j, _| open & (1 << j) != 0)
}

/// The rays of `mask` (of `r`'s) that a moving object blocks, one bit each: what
/// [`masked_rays`] hands back as [`MaskedRays::blocked`] for the same rays, without
/// their kernel weights (an interactive move's rows ask it of an entry whose rays
/// may come out as they did at the move that last computed it,
/// `Solver::unchanged_part`).
pub fn moving_blocked(bvh: &SceneBvh, r: &PointRays, mask: u64) -> u64 {
    let r = r.capped();
    let mut blocked = 0u64;
    let mut last = LastHit::default();
    for (j, y) in r.targets() {
        if mask & (1 << j) != 0 && bvh.occluded_between(r.x, y, r.skip, Parts::Moving, &mut last) {
            blocked |= 1 << j;
        }
    }
    blocked
}

/// The `m` jittered stratified target points on `gs` for the rays of sample `key`:
/// one in each of `m` cells of equal area over the unit square, rows of
/// `⌈√m⌉` cells, the last row holding the rest across the whole width.
///
/// Why the last row: with every row `⌈√m⌉` cells high and wide, a count that is
/// not a square left cells empty, and the rays never reached that part of the
/// source (8 rays, a 3 × 3 grid, missed a corner ninth; an emitter's 32, a
/// 6 × 6 grid, the last sixth but a third of a row).
fn ray_targets(gs: &Geom, pols: &Poly, m: u32, key: u64) -> impl Iterator<Item = (u32, DVec3)> {
    ray_params(m, key).map(move |(j, su, sv)| (j, point_in(gs, pols, su, sv)))
}

/// The unit-square parameters `(j, s, t)` of the points `ray_targets` casts at
/// (the source's [`point_in`] takes them to its surface): where each ray lands on
/// the source, which the leaf rows share among the source's children
/// (`Solver::push_opened`).
pub fn ray_params(m: u32, key: u64) -> impl Iterator<Item = (u32, f64, f64)> {
    let side = (m as f64).sqrt().ceil() as u32;
    let square = side * side == m;
    (0..m).map(move |j| {
        let h = hash3(key, j as u64, 0x9e37);
        let ju = (h & 0xffff_ffff) as f64 / 4294967296.0;
        let jv = (h >> 32) as f64 / 4294967296.0;
        let (su, sv) = if square {
            (
                ((j % side) as f64 + ju) / side as f64,
                ((j / side) as f64 + jv) / side as f64,
            )
        } else {
            // Row `r` holds `k` cells of width `1/k` and height `k/m`.
            let r = j / side;
            let k = side.min(m - r * side);
            (
                ((j % side) as f64 + ju) / k as f64,
                ((r * side) as f64 + jv * k as f64) / m as f64,
            )
        };
        (j, su, sv.min(1.0))
    })
}

/// Point of a surface element at unit-square coordinates `(s, t)` (folded into the
/// triangle for triangles).
pub fn point_in(g: &Geom, p: &Poly, s: f64, t: f64) -> DVec3 {
    point_at(p.corners(), g.n == 3, s, t)
}

/// Point at unit-square coordinates `(s, t)` of the polygon with corners `c`:
/// bilinear over a quad, or, for a `triangle`, affine with `(s, t)` folded into it.
#[inline]
pub fn point_at(c: &[DVec3], triangle: bool, s: f64, t: f64) -> DVec3 {
    if triangle {
        let (s, t) = if s + t > 1.0 {
            (1.0 - s, 1.0 - t)
        } else {
            (s, t)
        };
        c[0] + s * (c[1] - c[0]) + t * (c[2] - c[0])
    } else {
        (1.0 - s) * (1.0 - t) * c[0] + s * (1.0 - t) * c[1] + s * t * c[2] + (1.0 - s) * t * c[3]
    }
}

/// SplitMix64 of three words: the deterministic jitter source.
pub fn hash3(a: u64, b: u64, c: u64) -> u64 {
    let mut z = a ^ b.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ c.wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A number uniform in `[0, 1)` from the top 53 bits of a hash word: every jitter,
/// sample and test generator turns its words into numbers this way.
pub fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Numbers uniform in `[0, 1)` from a xorshift generator seeded with `h` (nonzero):
/// the random inputs of the crate's unit tests.
#[cfg(test)]
pub(crate) fn xorshift(mut h: u64) -> impl FnMut() -> f64 {
    move || {
        h ^= h << 13;
        h ^= h >> 7;
        h ^= h << 17;
        unit(h)
    }
}

/// What to do with a link whose error exceeds the threshold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Keep the link as it is.
    Keep,
    /// Replace by links from the receiver's children.
    Receiver,
    /// Replace by links to the source's children.
    Source,
}

/// Size used to choose which end to split: area for surfaces, squared box diagonal
/// over 4 for clusters (so a cluster and a patch of similar extent compare alike).
pub fn size(elems: &ElementPool, e: ElementId) -> f64 {
    let g = &elems.geoms.as_slice()[e.ix()];
    if g.patch == u32::MAX {
        let (_, r) = sphere(g);
        r * r
    } else {
        g.area
    }
}

/// Sizes within this fraction of each other are equal to [`choose_split`]: two
/// ends of one size (twin clusters of a symmetric room, equal tiles) split the
/// receiver, and an element whose children would have exactly `min_area` may
/// split. Compared exactly, the rounding of a scene scaled by 1000 chose the other
/// end and built another hierarchy (issue 45, part 3).
const SIZE_TIE: f64 = 1e-9;

/// Chooses which end of a link to split: the larger one that can split (a surface
/// element can split while its children keep at least `min_area`; a cluster always
/// has children), sizes equal within `SIZE_TIE` (1e-9) splitting the receiver.
/// `force` is set for links that must not stay (cluster self-links, clusters too
/// close for the isotropic estimate).
pub fn choose_split(elems: &ElementPool, r: ElementId, s: ElementId, min_area: f64) -> Split {
    let can = |e: ElementId| match elems.kind(e) {
        ElementKind::Cluster => true,
        ElementKind::Surface => {
            elems.nodes.as_slice()[e.ix()].child_count > 0
                || elems.geoms.as_slice()[e.ix()].area >= 4.0 * min_area * (1.0 - SIZE_TIE)
        }
    };
    let (cr, cs) = (can(r), can(s));
    if r == s {
        return if cr { Split::Receiver } else { Split::Keep };
    }
    match (cr, cs) {
        (false, false) => Split::Keep,
        (true, false) => Split::Receiver,
        (false, true) => Split::Source,
        (true, true) => {
            if size(elems, r) >= size(elems, s) * (1.0 - SIZE_TIE) {
                Split::Receiver
            } else {
                Split::Source
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bytemuck::Zeroable;

    fn geom(corners: &[DVec3]) -> Geom {
        let mut g = Geom::zeroed();
        for (k, c) in corners.iter().enumerate() {
            g.corners[k] = c.to_array();
        }
        g.n = corners.len() as u32;
        g
    }

    /// The finer rule's weights sum to 1 and it integrates a linear function
    /// exactly (its mean over the element is its value at the area centroid), on a
    /// planar trapezoid and on a triangle; every point lies inside the element.
    #[test]
    fn the_finer_rule_integrates_linear_functions_exactly() {
        let f = |x: DVec3| 2.0 * x.x - 3.0 * x.y + 0.5 * x.z + 1.0;
        let shapes: [Vec<DVec3>; 2] = [
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(4.0, 0.0, 0.0),
                DVec3::new(3.0, 2.0, 0.0),
                DVec3::new(1.0, 2.0, 0.0),
            ],
            vec![
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(3.0, 0.0, 1.0),
                DVec3::new(0.5, 2.0, 1.0),
            ],
        ];
        for corners in &shapes {
            let g = geom(corners);
            let rule = fine_samples(&g);
            assert_eq!(rule.len(), if corners.len() == 4 { 16 } else { 12 });
            let wsum: f64 = rule.iter().map(|r| r.1).sum();
            assert!((wsum - 1.0).abs() < 1e-12, "weights sum to {wsum}");
            let mean: f64 = rule.iter().map(|&(x, w)| w * f(x)).sum();
            let exact = f(Poly::new(corners).centroid());
            assert!((mean - exact).abs() < 1e-12, "{mean} vs {exact}");
            let p = Poly::new(corners);
            let n = p.area_vector().normalize();
            for &(x, _) in &rule {
                let v = p.corners();
                let inside = (0..v.len())
                    .all(|k| (v[(k + 1) % v.len()] - v[k]).cross(x - v[k]).dot(n) > 0.0);
                assert!(inside, "{x:?} outside");
            }
        }
    }

    /// A cluster of `faces` (unit normal, area, radiosity): its [`Emission`] and a
    /// cluster geometry with their summed area.
    fn cluster_of(faces: &[([f64; 3], f64, f64)]) -> (Geom, Emission, f64) {
        let mut g = Geom::zeroed();
        g.patch = u32::MAX;
        g.area = faces.iter().map(|f| f.1).sum();
        let (mut sn, mut sa) = ([0.0; 3], [0.0; 6]);
        for &(n, a, b) in faces {
            let (fn_, fa) = Emission::surface_parts(a, b, n);
            sn = std::array::from_fn(|k| sn[k] + fn_[k]);
            sa = std::array::from_fn(|k| sa[k] + fa[k]);
        }
        let em = Emission::from_parts(sn, sa);
        let b = faces.iter().map(|f| f.1 * f.2).sum::<f64>() / g.area;
        (g, em, b)
    }

    /// `∫ cluster_emission dω` over the sphere by a midpoint rule in (cos θ, φ).
    fn over_sphere(f: impl Fn(DVec3) -> f64) -> f64 {
        let (nt, np) = (400, 400);
        let mut sum = 0.0;
        for i in 0..nt {
            let z = -1.0 + (i as f64 + 0.5) * 2.0 / nt as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = (j as f64 + 0.5) * std::f64::consts::TAU / np as f64;
                sum += f(DVec3::new(r * phi.cos(), r * phi.sin(), z));
            }
        }
        sum * 4.0 * std::f64::consts::PI / (nt * np) as f64
    }

    /// A floor with four box sides around it (normals that cancel): up, it radiates
    /// the floor's power with `cos θ` and nothing of the sides'; sideways, the side
    /// facing that way. The power is the same as the isotropic model's (`∫ = π`), a
    /// single tilted surface radiates `cos θ` exactly, and a dark cluster is
    /// isotropic.
    #[test]
    fn a_cluster_radiates_by_the_axes_its_surfaces_face() {
        let side = 0.5;
        let faces = [
            ([0.0, 1.0, 0.0], 4.0, 1.0),
            ([1.0, 0.0, 0.0], side, 1.0),
            ([-1.0, 0.0, 0.0], side, 1.0),
            ([0.0, 0.0, 1.0], side, 1.0),
            ([0.0, 0.0, -1.0], side, 1.0),
        ];
        let (g, em, b) = cluster_of(&faces);
        let p = g.area * b;
        let up = cluster_emission(&g, &em, b, DVec3::Y, true);
        assert!((up * p - 4.0).abs() < 1e-5, "up: {}", up * p);
        // Straight along +x: the +x side (cos 1) and nothing of the floor (cos 0).
        let east = cluster_emission(&g, &em, b, DVec3::X, true);
        assert!((east * p - side).abs() < 1e-5, "east: {}", east * p);
        // Straight down: nothing faces down.
        assert!(cluster_emission(&g, &em, b, -DVec3::Y, true).abs() < 1e-7);
        // Every way, the power: the same integral as the isotropic 1/4.
        let total = over_sphere(|v| cluster_emission(&g, &em, b, v, true));
        assert!((total / std::f64::consts::PI - 1.0).abs() < 1e-3, "{total}");
        // One tilted surface (a cluster of coplanar pieces): exactly cos θ.
        let n = DVec3::new(1.0, 2.0, -0.5).normalize();
        let (g1, em1, b1) = cluster_of(&[(n.to_array(), 2.0, 0.7), (n.to_array(), 1.0, 0.3)]);
        for v in [n, DVec3::X, DVec3::new(-1.0, 1.0, 1.0).normalize(), -n] {
            let c = cluster_emission(&g1, &em1, b1, v, true);
            assert!((c - n.dot(v).max(0.0)).abs() < 1e-6, "{v}: {c}");
        }
        // Dark: isotropic.
        assert_eq!(cluster_emission(&g, &em, 0.0, DVec3::X, true), 0.25);
        // Without axes the rest is isotropic: up, the floor plus a quarter of the
        // sides' share; the same power.
        let iso = cluster_emission(&g, &em, b, DVec3::Y, false);
        assert!(
            (iso * p - (4.0 + 0.25 * 4.0 * side)).abs() < 1e-5,
            "{}",
            iso * p
        );
        let total = over_sphere(|v| cluster_emission(&g, &em, b, v, false));
        assert!((total / std::f64::consts::PI - 1.0).abs() < 1e-3, "{total}");
    }

    /// A link whose factor is 0 at the receiver's quadrature points is flagged
    /// clear only where its shaft is: a wall 2 m high (`z = 0`, facing `+z`) and
    /// an emitter facing up at `y = 0.7`, above the wall's Gauss points (`y =
    /// ±0.58`) but below its top, with and without a plate 0.15 m in front of the
    /// wall's top that hides the emitter from it. Flagged clear at a zero factor
    /// (before), the wall's leaves above `y = 0.7` took the emitter through the
    /// plate ([`evaluate_surfaces`]).
    #[test]
    fn a_link_with_no_factor_at_its_points_is_clear_only_where_its_shaft_is() {
        use crate::geometry::{Patches, SceneBvh};
        use crate::scene::{Material, MaterialId, Object, Polygon, Scene};
        let quad = |v: [[f64; 3]; 4]| Polygon {
            vertices: v.iter().map(|a| DVec3::from_array(*a)).collect(),
            material: MaterialId(0),
        };
        let wall = quad([
            [0.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]);
        let lamp = quad([
            [0.0, 0.7, 0.3],
            [0.0, 0.7, 1.3],
            [1.0, 0.7, 1.3],
            [1.0, 0.7, 0.3],
        ]);
        let plate = quad([
            [-1.0, 0.5, 0.15],
            [2.0, 0.5, 0.15],
            [2.0, 1.2, 0.15],
            [-1.0, 1.2, 0.15],
        ]);
        let set = EvalSettings {
            rays_per_point: 4,
            cluster_rays: 4,
            seed: 1,
            sources_by_power: true,
        };
        for (hidden, polygons) in [
            (true, vec![wall.clone(), lamp.clone(), plate]),
            (false, vec![wall, lamp]),
        ] {
            let scene = Scene {
                materials: vec![Material {
                    name: "m".into(),
                    rho: [0.5; 3],
                    emission: [1.0; 3],
                }],
                objects: vec![Object::still("o", polygons)],
                ..Scene::default()
            };
            let patches = Patches::at_time(&scene, 0.0);
            let bvh = SceneBvh::build_static(&patches);
            let elem = |p: usize| {
                let c = patches.polys[p].corners();
                let mut g = geom(c);
                g.normal = patches.polys[p].normal().to_array();
                g.area = patches.polys[p].area();
                g.patch = p as u32;
                g
            };
            let (gr, gs) = (elem(0), elem(1));
            let q = samples(&gr);
            assert!(q.points[..q.count].iter().all(|x| x.y < 0.7));
            let ev = evaluate_surfaces(&gr, &gs, &bvh, [0, 1], &set);
            assert_eq!(ev.transport.f, 0.0, "hidden {hidden}");
            assert!(
                ev.transport.spread > 0.0,
                "hidden {hidden}: the wall's top sees the lamp"
            );
            assert_eq!(ev.transport.shaft_clear(), !hidden, "hidden {hidden}");
        }
    }

    /// A cluster of faces that all face one way (a box's `−z` side in two tiles)
    /// radiates nothing behind it, exactly, in metres, millimetres or kilometres:
    /// its stored normal power `|N|` (`f32`) and its power `P` (area times the
    /// pool's `f32` radiosity) differ by their rounding, which left a rest of a few
    /// `10⁻⁸` radiated every way at some scales ([`COHERENT_REST`]). In front it
    /// radiates `cos θ`.
    #[test]
    fn a_cluster_facing_one_way_radiates_nothing_behind_it_at_any_scale() {
        let n = [0.0, 0.0, -1.0];
        let behind = DVec3::new(-0.96, 0.26, 0.08).normalize();
        let front = DVec3::new(0.3, 0.2, -0.9).normalize();
        let mut rounded_low = 0;
        for s in [1.0, 1000.0, 1e-3, 1024.0] {
            for b in [0.171_209_69, 0.224_096_82, 0.3, 0.55] {
                let faces = [(n, 0.12 * s * s, b), (n, 0.1 * s * s, 0.8 * b)];
                let (g, em, b) = cluster_of(&faces);
                // As the solver reads it: the pool's radiosity is `f32`.
                let b = b as f32 as f64;
                let len = DVec3::from_array(em.normal.map(f64::from)).length();
                rounded_low += usize::from(len < g.area * b * (1.0 - 1e-9));
                assert_eq!(
                    cluster_emission(&g, &em, b, behind, true),
                    0.0,
                    "×{s} B {b}"
                );
                assert_eq!(
                    cluster_emission(&g, &em, b, behind, false),
                    0.0,
                    "×{s} B {b}"
                );
                let c = cluster_emission(&g, &em, b, front, true);
                assert!((c - front.z.abs()).abs() < 1e-6, "×{s} B {b}: {c}");
            }
        }
        // The case the rest came from: `|N|` rounded below `P` somewhere.
        assert!(rounded_low > 0);
    }
}
