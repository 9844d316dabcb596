//! The visibility complex of a flatland scene (paper 002 §2.2–2.3) and the exact
//! measure of every bundle of free lines between two elements, by a rotational sweep
//! of the dual arrangement ([`sweep`]).
//!
//! # How it works
//!
//! Lines are points `(theta, p)` of the dual plane (§2.3, with the normal form of
//! [`super::geometry`]); the lines through a scene point `v` form the curve
//! `p = v . n(theta)`. For `theta` in a chart `[theta0, theta0 + pi)` the curves of all
//! points are kept sorted by `p` ("the order"). Between two consecutive curves lies a
//! *gap*: every line in it crosses the same segments in the same order, because no line
//! of the gap passes through a point; so one cast of one line inside the gap gives the
//! labels `(O_l, O_r)` of all its maximal free segments. A gap lives from the event
//! where its two bounding curves became neighbours to the event where one of them
//! crosses another curve (an *event* = the direction of a line through two points; a
//! group of collinear points reverses as a block). The piece of a face of the complex
//! (§2.2) inside one gap is a *cell*; cells of one label that touch are joined into
//! faces ([`CFace`]), bounded by *edges* ([`CEdge`]) and *vertices* ([`CVertex`]).
//! The chart's seam `theta0 + pi ~ theta0` is glued with the order reversed
//! (`p(theta + pi) = -p(theta)`).
//!
//! # Exact measures (eq. 2–3)
//!
//! The measure of the lines of a gap over an angle interval is closed-form
//! (`gap_area`); summed over a face's cells it telescopes into `sum of +- d(v)` over
//! the vertices bounding the face (eq. 3): the string rule. For two elements `i, j`,
//! `mu_ij` (the measure of lines whose free segment joins the lit sides of `i` and `j`)
//! gives `L_i F_ij = mu_ij / 2` (eq. 2; `mu` of all lines meeting a segment of length
//! `L` is `2 L`, which makes closure exact). No quadrature anywhere.
//!
//! # What it does not do
//!
//! It is not the paper's output-sensitive `O(m + n log n)` sweep of Rivière \[17\]: it
//! costs `O(P^2 (log P + n))` ([`sweep`]), so the exact form factors come from
//! [`super::views`], and this sweep remains their reference, the builder of faces
//! with chains and the clipped measure of [`Clip`]. Faces whose rays go to infinity
//! (the paper's external faces) are not stored: only free segments between two
//! segments. In degenerate scenes (three collinear points, segments collinear with
//! other points) the measures stay exact, but face connectivity is only guaranteed
//! in general position; the chains of a face that crosses the seam come in two parts.

use std::collections::HashMap;
use std::f64::consts::PI;

use super::geometry::{FlatGeometry, Hit, PairMap, big_n, proj};

/// Index of a cell in [`Complex::cells`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CellId(pub u32);
/// Index of a face in [`Complex::faces`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FaceId(pub u32);
/// Index of an edge in [`Complex::edges`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EdgeId(pub u32);
/// Index of a vertex in [`Complex::vertices`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct VertexId(pub u32);

/// Events closer than this (radians) are one event group.
const ANGLE_EPS: f64 = 1e-11;
const NONE: u32 = u32::MAX;

/// A piece of a face inside one gap: free segments from element `from` to `to`
/// (in the direction `theta`), lines between the curves of `lower` and `upper`, over
/// `theta[0]..theta[1]`. 48 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Sweep angles (absolute, inside the chart) where the gap was born and died.
    pub theta: [f64; 2],
    /// Measure of the lines of the cell (the gap's area in the dual plane).
    pub area: f64,
    /// Point whose curve bounds the gap from below.
    pub lower: u32,
    /// Point whose curve bounds the gap from above.
    pub upper: u32,
    /// Element left behind along the direction.
    pub from: u32,
    /// Element reached along the direction.
    pub to: u32,
    /// The face (valid once the complex is built).
    pub face: FaceId,
    /// True if the free segments join the lit sides of both elements.
    pub front: bool,
}
const _: () = assert!(std::mem::size_of::<Cell>() == 48);

/// A vertex of the complex: the line through two mutually visible points (a
/// visibility-graph edge, §2.2), with its length `d(v)` (eq. 3). 32 bytes.
///
/// Vertices are the sweep's events whose two points see each other (bitangents);
/// with `record` they are taken from the visibility graph of [`super::views`]
/// (`O(P^2 log P)`, no per-pair `O(n)` test).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CVertex {
    /// Angle of the line (absolute, in the chart).
    pub theta: f64,
    /// `|u - w|`.
    pub length: f64,
    /// First point.
    pub u: u32,
    /// Second point.
    pub w: u32,
    /// Padding to 8-byte alignment.
    pub _pad: u64,
}
const _: () = assert!(std::mem::size_of::<CVertex>() == 32);

/// Which side of its face an edge bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Side {
    /// The edge's curve is below the face (part of the lower chain).
    Lower = 0,
    /// The edge's curve is above the face (part of the upper chain).
    Upper = 1,
}

/// An edge of the complex: rays of one face through one point, over `theta`. 48 bytes.
///
/// Edges (§2.2: rays with one label through one point) are the stretches of a
/// point's curve that bound a face from below or above (the label exists on one side
/// of the curve only); sorted by `theta` they form the face's *lower and upper
/// chains* (§2.3, [`Complex::chains`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CEdge {
    /// Angular extent.
    pub theta: [f64; 2],
    /// The face it bounds.
    pub face: FaceId,
    /// The point whose curve supports it.
    pub point: u32,
    /// The vertices at its ends, when the end is a vertex of the complex (the other
    /// ends are the chart's seam or events with non-visible pairs).
    pub ends: [Option<VertexId>; 2],
    /// Lower or upper chain.
    pub side: Side,
}
const _: () = assert!(std::mem::size_of::<CEdge>() == 48);

/// A face of the complex: a maximal connected bundle of free segments between two
/// elements. 64 bytes.
///
/// A face (§2.2: rays with label `(O_l, O_r)` that can be moved into each other
/// keeping the label) is the union of the cells of one label that touch along a
/// stretch of curve or continue through an event, found with union-find: cells of
/// neighbouring gaps with the same label share a face (a curve can be crossed
/// without a label change only if the point's segments are on neither side of the
/// free segment); regions meeting at an event point only are not joined (faces are
/// open sets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CFace {
    /// Angular extent in the chart.
    pub theta: [f64; 2],
    /// Measure of its lines (`sum` of its cells).
    pub measure: f64,
    /// Its two elements, smaller index first.
    pub objects: [u32; 2],
    /// Range of its cells in [`Complex::face_cells`].
    pub cells: [u32; 2],
    /// Range of its lower chain in [`Complex::chain_edges`] (sorted by angle).
    pub lower: [u32; 2],
    /// Range of its upper chain in [`Complex::chain_edges`].
    pub upper: [u32; 2],
    /// True if the free segments join the lit sides of both elements.
    pub front: bool,
}
const _: () = assert!(std::mem::size_of::<CFace>() == 64);

/// The visibility complex of a posed, meshed scene.
#[derive(Clone, Debug, Default)]
pub struct Complex {
    /// Start of the chart `[theta0, theta0 + pi)`.
    pub theta0: f64,
    /// Cells (face pieces inside gaps).
    pub cells: Vec<Cell>,
    /// Faces.
    pub faces: Vec<CFace>,
    /// Cells grouped by face.
    pub face_cells: Vec<CellId>,
    /// Edges.
    pub edges: Vec<CEdge>,
    /// Edge ids of the chains, grouped by face then side.
    pub chain_edges: Vec<EdgeId>,
    /// Vertices.
    pub vertices: Vec<CVertex>,
}

/// Counters of one sweep.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SweepStats {
    /// Point pairs (events).
    pub events: usize,
    /// Gaps born.
    pub gaps: usize,
    /// Lines cast.
    pub casts: usize,
    /// Front-facing cells integrated (face pieces whose measure was added).
    pub cells: usize,
    /// Event groups whose block reversal had to be replaced by a full re-sort.
    pub resorts: usize,
}

/// The result of a sweep.
#[derive(Clone, Debug, Default)]
pub struct SweepOut {
    /// `mu[(i, j)]`, `i < j`: measure of lines whose free segment joins the lit sides
    /// of elements `i` and `j` (restricted to the clip region when one was given).
    pub mu: PairMap,
    /// Counters.
    pub stats: SweepStats,
    /// The complex, when asked for.
    pub complex: Option<Complex>,
}

/// A region of the dual plane: the lines meeting the convex hull of a point set
/// (for §5: the moving geometry at both times, i.e. the hull of its swept corners).
#[derive(Clone, Debug)]
pub struct Clip {
    /// Convex hull, counter-clockwise, no repeated points.
    hull: Vec<[f64; 2]>,
    /// Bounding circle (centre, radius) for quick rejection.
    circle: ([f64; 2], f64),
    /// Directions (in `[0, pi)`, sorted) of the hull's edges: where the support
    /// function `max_q q . n(theta)` and its opposite change vertex.
    set_angles: Vec<f64>,
}

impl Clip {
    /// The lines meeting the convex hull of all the points of `sets`.
    pub fn new(sets: Vec<Vec<[f64; 2]>>) -> Self {
        let mut pts: Vec<[f64; 2]> = sets.into_iter().flatten().collect();
        pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        pts.dedup();
        let hull = convex_hull(&pts);
        let mut set_angles: Vec<f64> = (0..hull.len())
            .filter(|&i| hull.len() > 1 && hull[i] != hull[(i + 1) % hull.len()])
            .map(|i| line_angle(hull[i], hull[(i + 1) % hull.len()]))
            .collect();
        set_angles.sort_by(f64::total_cmp);
        set_angles.dedup();
        let k = hull.len().max(1) as f64;
        let c = [
            hull.iter().map(|q| q[0]).sum::<f64>() / k,
            hull.iter().map(|q| q[1]).sum::<f64>() / k,
        ];
        let r = hull
            .iter()
            .map(|q| (q[0] - c[0]).hypot(q[1] - c[1]))
            .fold(0.0, f64::max);
        Clip {
            hull,
            circle: (c, r * (1.0 + 1e-12) + 1e-300),
            set_angles,
        }
    }

    /// Measure of the lines of the gap `(u below, w above)` over `[a, b]` in the region.
    pub fn area(&self, u: [f64; 2], w: [f64; 2], a: f64, b: f64) -> f64 {
        let ((sa, ca), (sb, cb)) = (a.sin_cos(), b.sin_cos());
        self.area_sc(u, w, (a, sa, ca), (b, sb, cb))
    }

    /// [`Clip::area`] with `(angle, sin, cos)` of both ends given.
    pub fn area_sc(
        &self,
        u: [f64; 2],
        w: [f64; 2],
        (a, sa, ca): (f64, f64, f64),
        (b, sb, cb): (f64, f64, f64),
    ) -> f64 {
        if self.hull.is_empty() {
            return 0.0;
        }
        // Quick rejection: the lines meeting the hull lie within `r` of the curve of
        // its bounding circle's centre `c`; the gap misses them if `w` stays below
        // `c - r` or `u` above `c + r` over [a, b] (exact extremes of one sinusoid).
        let (c, r) = self.circle;
        let (sa, sb) = ((sa, ca), (sb, cb));
        let (_, w_hi) = curve_range([w[0] - c[0], w[1] - c[1]], sa, sb);
        let (u_lo, _) = curve_range([u[0] - c[0], u[1] - c[1]], sa, sb);
        if w_hi <= -r || u_lo >= r {
            return 0.0;
        }
        self.band(u, w, a, b)
    }

    fn band(&self, u: [f64; 2], w: [f64; 2], a: f64, b: f64) -> f64 {
        let mut bps = vec![a, b];
        let push = |ang: f64, bps: &mut Vec<f64>| {
            // The representative of `ang` (mod pi) inside (a, b), if any.
            let t = ang + PI * ((a - ang) / PI).ceil();
            if t > a && t < b {
                bps.push(t);
            }
        };
        push(line_angle(u, w), &mut bps);
        for &q in &self.hull {
            if q != u {
                push(line_angle(u, q), &mut bps);
            }
            if q != w {
                push(line_angle(w, q), &mut bps);
            }
        }
        // Precomputed set-set directions inside (a, b), found by binary search.
        let a_mod = a.rem_euclid(PI);
        let span = b - a;
        let sa = &self.set_angles;
        let from = sa.partition_point(|&x| x <= a_mod);
        let to = sa.partition_point(|&x| x < (a_mod + span).min(PI));
        bps.extend(sa[from..to].iter().map(|&x| a + (x - a_mod)));
        if a_mod + span > PI {
            let to2 = sa.partition_point(|&x| x < a_mod + span - PI);
            bps.extend(sa[..to2].iter().map(|&x| a + (x + PI - a_mod)));
        }
        bps.sort_by(f64::total_cmp);
        let mut acc = 0.0;
        for s in bps.windows(2) {
            if s[1] <= s[0] {
                continue;
            }
            let (sm, cm) = (0.5 * (s[0] + s[1])).sin_cos();
            let pj = |v: [f64; 2]| -v[0] * sm + v[1] * cm;
            let (mut lo, mut lo_p) = (u, pj(u));
            let (mut hi, mut hi_p) = (w, pj(w));
            let set = &self.hull;
            let (mut smin, mut smin_p) = (set[0], pj(set[0]));
            let (mut smax, mut smax_p) = (smin, smin_p);
            for &q in &set[1..] {
                let pq = pj(q);
                if pq < smin_p {
                    (smin, smin_p) = (q, pq);
                }
                if pq > smax_p {
                    (smax, smax_p) = (q, pq);
                }
            }
            if smin_p > lo_p {
                (lo, lo_p) = (smin, smin_p);
            }
            if smax_p < hi_p {
                (hi, hi_p) = (smax, smax_p);
            }
            if hi_p > lo_p {
                let (n0, n1) = (big_n(s[0]), big_n(s[1]));
                acc += (hi[0] - lo[0]) * (n1[0] - n0[0]) + (hi[1] - lo[1]) * (n1[1] - n0[1]);
            }
        }
        acc
    }
}

/// Convex hull (Andrew's monotone chain) of points sorted by `(x, y)`, deduplicated.
fn convex_hull(pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    use super::scene::orient;
    if pts.len() < 3 {
        return pts.to_vec();
    }
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while h.len() >= start + 2 && orient(h[h.len() - 2], h[h.len() - 1], p) <= 0.0 {
                h.pop();
            }
            h.push(p);
        }
        h.pop();
    }
    h
}

/// Exact `(min, max)` of the curve `v . n(theta)` over `[a, b]` (`b - a <= pi`),
/// given `(sin, cos)` of `a` and `b`. Its derivative is `-v . d(theta)`; an interior
/// sign change means an interior extremum, of value `+- |v|`.
fn curve_range(v: [f64; 2], sa: (f64, f64), sb: (f64, f64)) -> (f64, f64) {
    let (pa, pb) = (-v[0] * sa.0 + v[1] * sa.1, -v[0] * sb.0 + v[1] * sb.1);
    let (da, db) = (-(v[0] * sa.1 + v[1] * sa.0), -(v[0] * sb.1 + v[1] * sb.0));
    let (mut lo, mut hi) = (pa.min(pb), pa.max(pb));
    if da > 0.0 && db < 0.0 {
        hi = (v[0] * v[0] + v[1] * v[1]).sqrt();
    } else if da < 0.0 && db > 0.0 {
        lo = -(v[0] * v[0] + v[1] * v[1]).sqrt();
    }
    (lo, hi)
}

/// Direction of the line through `a` and `b`, in `[0, pi)`.
pub fn line_angle(a: [f64; 2], b: [f64; 2]) -> f64 {
    let mut t = (b[1] - a[1]).atan2(b[0] - a[0]);
    if t < 0.0 {
        t += PI;
    }
    if t >= PI {
        t -= PI;
    }
    t
}

/// An angle with its sine and cosine (computed once per event).
#[derive(Clone, Copy, Debug)]
struct Angle {
    t: f64,
    s: f64,
    c: f64,
}

impl Angle {
    fn new(t: f64) -> Self {
        let (s, c) = t.sin_cos();
        Angle { t, s, c }
    }
}

/// Measure of the lines of the gap `(u below, w above)` over `[a, b]`:
/// `integral (w - u) . n(theta) dtheta = (w - u) . (N(b) - N(a))` with
/// `N = (cos, sin)`. Summed over the cells of a face this telescopes into eq. 3's
/// `sum of +- d(v)`, since `w - u` is parallel to the line at its event.
#[inline]
fn gap_area(u: [f64; 2], w: [f64; 2], a: Angle, b: Angle) -> f64 {
    (w[0] - u[0]) * (b.c - a.c) + (w[1] - u[1]) * (b.s - a.s)
}

/// Sweeps the dual plane of `geom` (see the module header). With `clip`, only the
/// measure inside the clip region is accumulated (and only gaps with a positive
/// clipped measure are cast); with `record`, the complex is built too. The chart's
/// `theta0` is chosen in the widest event-free interval, so that no two curves meet
/// on the seam.
///
/// Cost, for `P` points and `n` segments: all `P (P - 1) / 2` point pairs are events
/// (sorted: `O(P^2 log P)`), each event rebuilds `O(1)` gaps (generic position) with
/// one cast of `O(n)`: `O(P^2 (log P + n))` in all for the cells, and the structure
/// it stores (one cell per free segment per gap) is that large too. The exact form
/// factors do not use this sweep: [`super::views`] sums them in `O(P^2 log P)`
/// (`O(m log m)` once the views are known, `m` the visibility graph's size).
pub fn sweep(geom: &FlatGeometry, clip: Option<&Clip>, record: bool) -> SweepOut {
    let np = geom.points.len();
    let mut out = SweepOut::default();
    if np < 2 {
        if record {
            out.complex = Some(Complex::default());
        }
        return out;
    }
    let pts = &geom.points;
    // 1. Every point pair is an event at the direction of its line.
    let mut pairs: Vec<(f64, u32, u32)> = Vec::with_capacity(np * (np - 1) / 2);
    for u in 0..np {
        for w in u + 1..np {
            pairs.push((line_angle(pts[u], pts[w]), u as u32, w as u32));
        }
    }
    out.stats.events = pairs.len();
    // 2. The chart starts in the middle of the widest event-free interval.
    let mut angles: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    angles.sort_by(f64::total_cmp);
    let mut theta0 = 0.5 * (angles[0] + angles[angles.len() - 1] - PI);
    let mut widest = angles[0] + PI - angles[angles.len() - 1];
    for w in angles.windows(2) {
        if w[1] - w[0] > widest {
            widest = w[1] - w[0];
            theta0 = 0.5 * (w[0] + w[1]);
        }
    }
    drop(angles);
    for p in &mut pairs {
        p.0 = (p.0 - theta0).rem_euclid(PI);
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    // 3. Group events: chains of angles closer than ANGLE_EPS.
    let mut groups: Vec<(usize, usize, f64)> = Vec::new();
    let mut start = 0;
    for i in 1..=pairs.len() {
        if i == pairs.len() || pairs[i].0 - pairs[i - 1].0 > ANGLE_EPS {
            groups.push((start, i, 0.5 * (pairs[start].0 + pairs[i - 1].0)));
            start = i;
        }
    }
    let rel_next = |gi: usize| -> f64 { groups.get(gi + 1).map_or(PI, |g| g.2) };
    let first_mid = theta0 + 0.5 * groups.first().map_or(PI, |g| g.2);
    let mut st = State::new(geom, clip, record, theta0, first_mid);
    // Vertices of the complex: the visibility graph from the views (`O(P^2 log P)`).
    let visible = if record {
        let topo = super::views::Topology::new(geom);
        super::views::visibility_graph(&topo, &super::views::all_views(geom, &topo).0)
    } else {
        Vec::new()
    };
    // 4. Sweep the groups in order.
    let mut comp = vec![NONE; np];
    let mut involved: Vec<u32> = Vec::new();
    for (gi, &(g0, g1, rel)) in groups.iter().enumerate() {
        let theta_e = theta0 + rel;
        let mid = theta0 + 0.5 * (rel + rel_next(gi));
        // Components of the collinear blocks (union-find on the points of the group).
        involved.clear();
        for &(_, u, w) in &pairs[g0..g1] {
            for v in [u, w] {
                if comp[v as usize] == NONE {
                    comp[v as usize] = v;
                    involved.push(v);
                }
            }
            let (ru, rw) = (find(&mut comp, u), find(&mut comp, w));
            if ru != rw {
                comp[ru as usize] = rw;
            }
        }
        // (root, min position, max position, count) per block; groups are small.
        let mut blocks: Vec<(u32, usize, usize, usize)> = Vec::new();
        for &v in &involved {
            let r = find(&mut comp, v);
            let p = st.pos[v as usize] as usize;
            match blocks.iter_mut().find(|b| b.0 == r) {
                Some(e) => {
                    e.1 = e.1.min(p);
                    e.2 = e.2.max(p);
                    e.3 += 1;
                }
                None => blocks.push((r, p, p, 1)),
            }
        }
        for &v in &involved {
            comp[v as usize] = NONE;
        }
        let mut ranges: Vec<(usize, usize)> = blocks.iter().map(|b| (b.1, b.2)).collect();
        ranges.sort_unstable();
        let contiguous = blocks.iter().all(|b| b.2 - b.1 + 1 == b.3);
        let mut changes = if contiguous {
            // Each block of collinear points reverses its order.
            let c: Vec<(usize, Vec<u32>)> = ranges
                .iter()
                .map(|&(lo, hi)| (lo, st.order[lo..=hi].iter().rev().copied().collect()))
                .collect();
            if st.check(&c, mid) { Some(c) } else { None }
        } else {
            None
        };
        if changes.is_none() {
            st.out.stats.resorts += 1;
            changes = Some(st.resort(mid));
        }
        let changes = changes.unwrap_or_default();
        if record {
            for &(_, a, b) in &pairs[g0..g1] {
                let (pu, pw) = (pts[a as usize], pts[b as usize]);
                if visible.binary_search(&(a.min(b), a.max(b))).is_ok() {
                    st.rec.vertices.push(CVertex {
                        theta: theta_e,
                        length: (pw[0] - pu[0]).hypot(pw[1] - pu[1]),
                        u: a,
                        w: b,
                        _pad: 0,
                    });
                }
            }
        }
        st.apply(&changes, theta_e, mid);
    }
    st.finish(theta0 + PI);
    let State { out: sout, rec, .. } = st;
    out.mu = sout.mu;
    out.stats.gaps = sout.stats.gaps;
    out.stats.casts = sout.stats.casts;
    out.stats.cells = sout.stats.cells;
    out.stats.resorts = sout.stats.resorts;
    if record {
        out.complex = Some(rec.build(geom, theta0));
    }
    out
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

/// An edge piece: a curve bounding a cell's face over an angular range.
#[derive(Clone, Copy, Debug)]
struct Piece {
    theta: [f64; 2],
    cell: u32,
    point: u32,
    side: Side,
}

#[derive(Default)]
struct Rec {
    /// Per gap position: the current gap id.
    gid: Vec<u32>,
    /// Per gap id: its cell range.
    gap_cells: Vec<[u32; 2]>,
    cells: Vec<Cell>,
    parent: Vec<u32>,
    /// Per point position `j` (between gap `j - 1` and gap `j`): start of the current
    /// adjacency.
    adj_start: Vec<f64>,
    pieces: Vec<Piece>,
    vertices: Vec<CVertex>,
    initial: Vec<u32>,
}

struct State<'g> {
    geom: &'g FlatGeometry,
    clip: Option<&'g Clip>,
    record: bool,
    order: Vec<u32>,
    pos: Vec<u32>,
    birth: Vec<Angle>,
    probe: Vec<Angle>,
    hits: Vec<Vec<Hit>>,
    cast_done: Vec<bool>,
    out: SweepOut,
    rec: Rec,
}

impl<'g> State<'g> {
    fn new(
        geom: &'g FlatGeometry,
        clip: Option<&'g Clip>,
        record: bool,
        theta0: f64,
        mid: f64,
    ) -> Self {
        let np = geom.points.len();
        let mut order: Vec<u32> = (0..np as u32).collect();
        let key: Vec<f64> = geom.points.iter().map(|&v| proj(v, mid)).collect();
        order.sort_by(|&a, &b| key[a as usize].total_cmp(&key[b as usize]));
        let mut pos = vec![0u32; np];
        for (k, &v) in order.iter().enumerate() {
            pos[v as usize] = k as u32;
        }
        let ng = np - 1;
        let mut st = State {
            geom,
            clip,
            record,
            order,
            pos,
            birth: vec![Angle::new(theta0); ng],
            probe: vec![Angle::new(mid); ng],
            hits: vec![Vec::new(); ng],
            cast_done: vec![false; ng],
            out: SweepOut::default(),
            rec: Rec::default(),
        };
        if record {
            st.rec.gid = vec![NONE; ng];
            st.rec.adj_start = vec![theta0; np];
        }
        let (a0, am) = (Angle::new(theta0), Angle::new(mid));
        for k in 0..ng {
            st.born(k, a0, am);
        }
        if record {
            st.rec.initial = st.rec.gid.clone();
        }
        st
    }

    /// True if the order with `changes` applied is sorted at `theta` around them.
    fn check(&self, changes: &[(usize, Vec<u32>)], theta: f64) -> bool {
        let np = self.order.len();
        let at = |k: usize| -> u32 {
            for (s, vs) in changes {
                if k >= *s && k < s + vs.len() {
                    return vs[k - s];
                }
            }
            self.order[k]
        };
        let (sn, cs) = theta.sin_cos();
        let pj = |v: u32| {
            let q = self.geom.points[v as usize];
            -q[0] * sn + q[1] * cs
        };
        for (s, vs) in changes {
            let lo = s.saturating_sub(1);
            let hi = (s + vs.len()).min(np - 1);
            for k in lo..hi {
                if pj(at(k)) > pj(at(k + 1)) {
                    return false;
                }
            }
        }
        true
    }

    /// Full re-sort at `theta`: the changed runs of positions.
    fn resort(&self, theta: f64) -> Vec<(usize, Vec<u32>)> {
        let mut new = self.order.clone();
        let key: Vec<f64> = self.geom.points.iter().map(|&v| proj(v, theta)).collect();
        new.sort_by(|&a, &b| key[a as usize].total_cmp(&key[b as usize]));
        let mut out = Vec::new();
        let mut k = 0;
        while k < new.len() {
            if new[k] != self.order[k] {
                let s = k;
                while k < new.len() && new[k] != self.order[k] {
                    k += 1;
                }
                out.push((s, new[s..k].to_vec()));
            } else {
                k += 1;
            }
        }
        out
    }

    fn ensure_cast(&mut self, k: usize) {
        if !self.cast_done[k] {
            let th = self.probe[k];
            let u = self.geom.points[self.order[k] as usize];
            let w = self.geom.points[self.order[k + 1] as usize];
            let p = 0.5 * (-(u[0] + w[0]) * th.s + (u[1] + w[1]) * th.c);
            let mut hits = std::mem::take(&mut self.hits[k]);
            self.geom.cast_sc((th.s, th.c), p, &mut hits);
            self.hits[k] = hits;
            self.cast_done[k] = true;
            self.out.stats.casts += 1;
        }
    }

    fn born(&mut self, k: usize, theta: Angle, mid: Angle) {
        self.birth[k] = theta;
        self.probe[k] = mid;
        self.cast_done[k] = false;
        self.out.stats.gaps += 1;
        if self.record {
            self.ensure_cast(k);
            let gid = self.rec.gap_cells.len() as u32;
            let c0 = self.rec.cells.len() as u32;
            let (lower, upper) = (self.order[k], self.order[k + 1]);
            for h in self.hits[k].windows(2) {
                let front = self.geom.fronts_face_sc((mid.s, mid.c), &h[0], &h[1]);
                let id = self.rec.cells.len() as u32;
                self.rec.cells.push(Cell {
                    theta: [theta.t, theta.t],
                    area: 0.0,
                    lower,
                    upper,
                    from: h[0].elem,
                    to: h[1].elem,
                    face: FaceId(NONE),
                    front,
                });
                self.rec.parent.push(id);
            }
            self.rec.gap_cells.push([c0, self.rec.cells.len() as u32]);
            self.rec.gid[k] = gid;
        }
    }

    fn died(&mut self, k: usize, theta: Angle) {
        let u = self.geom.points[self.order[k] as usize];
        let w = self.geom.points[self.order[k + 1] as usize];
        let t0 = self.birth[k];
        let area = match self.clip {
            None => gap_area(u, w, t0, theta),
            Some(c) => c.area_sc(u, w, (t0.t, t0.s, t0.c), (theta.t, theta.s, theta.c)),
        };
        if self.record {
            let [c0, c1] = self.rec.gap_cells[self.rec.gid[k] as usize];
            for c in &mut self.rec.cells[c0 as usize..c1 as usize] {
                c.theta[1] = theta.t;
                c.area = gap_area(u, w, t0, theta);
            }
        }
        if area > 0.0 {
            self.ensure_cast(k);
            let th = self.probe[k];
            for h in self.hits[k].windows(2) {
                if self.geom.fronts_face_sc((th.s, th.c), &h[0], &h[1]) {
                    let key = (h[0].elem.min(h[1].elem), h[0].elem.max(h[1].elem));
                    *self.out.mu.entry(key).or_insert(0.0) += area;
                    self.out.stats.cells += 1;
                }
            }
        }
    }

    /// Ends the adjacency across the point at position `j` (record only).
    fn end_adjacency(&mut self, j: usize, theta: f64) {
        let ng = self.order.len() - 1;
        let below = if j >= 1 { self.rec.gid[j - 1] } else { NONE };
        let above = if j < ng { self.rec.gid[j] } else { NONE };
        let start = self.rec.adj_start[j];
        if theta <= start {
            return;
        }
        let point = self.order[j];
        let range = |g: u32| -> std::ops::Range<usize> {
            if g == NONE {
                0..0
            } else {
                let [a, b] = self.rec.gap_cells[g as usize];
                a as usize..b as usize
            }
        };
        let (rb, ra) = (range(below), range(above));
        let cells = &self.rec.cells;
        let label = |c: usize| (cells[c].from, cells[c].to);
        let mut found = Vec::new();
        for c in ra.clone() {
            if !rb.clone().any(|d| label(d) == label(c)) {
                found.push((c, Side::Lower));
            }
        }
        for c in rb.clone() {
            if !ra.clone().any(|d| label(d) == label(c)) {
                found.push((c, Side::Upper));
            }
        }
        for (c, side) in found {
            self.rec.pieces.push(Piece {
                theta: [start, theta],
                cell: c as u32,
                point,
                side,
            });
        }
    }

    fn union_gaps(&mut self, gaps: &[u32]) {
        let mut keyed: Vec<((u32, u32), u32)> = Vec::new();
        for &g in gaps {
            if g == NONE {
                continue;
            }
            let [a, b] = self.rec.gap_cells[g as usize];
            for c in a..b {
                let cell = &self.rec.cells[c as usize];
                keyed.push(((cell.from.min(cell.to), cell.from.max(cell.to)), c));
            }
        }
        keyed.sort_unstable();
        for w in keyed.windows(2) {
            if w[0].0 == w[1].0 {
                let (ra, rb) = (
                    find(&mut self.rec.parent, w[0].1),
                    find(&mut self.rec.parent, w[1].1),
                );
                if ra != rb {
                    self.rec.parent[ra as usize] = rb;
                }
            }
        }
    }

    /// Applies the order changes of one event group at `theta`.
    fn apply(&mut self, changes: &[(usize, Vec<u32>)], theta: f64, mid: f64) {
        let (at, am) = (Angle::new(theta), Angle::new(mid));
        let np = self.order.len();
        let ng = np - 1;
        // Affected gap ranges (per change) and point positions (adjacencies).
        let gap_range = |s: usize, len: usize| (s.saturating_sub(1), (s + len - 1).min(ng - 1));
        let mut adj: Vec<usize> = Vec::new();
        let mut gaps: Vec<usize> = Vec::new();
        for (s, vs) in changes {
            let (a, b) = gap_range(*s, vs.len());
            gaps.extend(a..=b);
            adj.extend(s.saturating_sub(1)..=(s + vs.len()).min(np - 1));
        }
        gaps.sort_unstable();
        gaps.dedup();
        adj.sort_unstable();
        adj.dedup();
        if self.record {
            for &j in &adj {
                self.end_adjacency(j, theta);
            }
        }
        let dead: Vec<u32> = if self.record {
            gaps.iter().map(|&k| self.rec.gid[k]).collect()
        } else {
            Vec::new()
        };
        for &k in &gaps {
            self.died(k, at);
        }
        for (s, vs) in changes {
            for (i, &v) in vs.iter().enumerate() {
                self.order[s + i] = v;
                self.pos[v as usize] = (s + i) as u32;
            }
        }
        for &k in &gaps {
            self.born(k, at, am);
        }
        if self.record {
            for &j in &adj {
                self.rec.adj_start[j] = theta;
            }
            // Unions (faces are open sets: only regions sharing a stretch of curve or
            // continuing in time are joined, never regions touching at the event
            // point alone, e.g. the two sides of a segment seen along its own line):
            // new neighbours across a curve, and the gaps just above the unchanged
            // point below the block / just below the one above it, which continue
            // through the event.
            for (s, vs) in changes {
                let (a, b) = gap_range(*s, vs.len());
                let dead_at = |k: usize| gaps.binary_search(&k).map_or(NONE, |i| dead[i]);
                for k in a..b {
                    self.union_gaps(&[self.rec.gid[k], self.rec.gid[k + 1]]);
                }
                if *s >= 1 {
                    self.union_gaps(&[dead_at(a), self.rec.gid[a]]);
                    if a >= 1 {
                        self.union_gaps(&[self.rec.gid[a - 1], self.rec.gid[a]]);
                    }
                }
                if s + vs.len() < np {
                    self.union_gaps(&[dead_at(b), self.rec.gid[b]]);
                    if b + 1 < ng {
                        self.union_gaps(&[self.rec.gid[b], self.rec.gid[b + 1]]);
                    }
                }
            }
        }
    }

    fn finish(&mut self, theta_end: f64) {
        let np = self.order.len();
        if self.record {
            for j in 0..np {
                self.end_adjacency(j, theta_end);
            }
        }
        let ae = Angle::new(theta_end);
        for k in 0..np - 1 {
            self.died(k, ae);
        }
        if self.record {
            // Glue the seam: the order at theta0 + pi is the reverse of the order at
            // theta0, so final gap k is initial gap (np - 2 - k).
            let ng = np - 1;
            for k in 0..ng {
                let a = self.rec.gid[k];
                let b = self.rec.initial[ng - 1 - k];
                self.union_gaps(&[a, b]);
            }
        }
    }
}

impl Rec {
    fn build(mut self, geom: &FlatGeometry, theta0: f64) -> Complex {
        let nc = self.cells.len();
        // Faces from union-find roots.
        let mut face_of_root: HashMap<u32, u32> = HashMap::new();
        let mut faces: Vec<CFace> = Vec::new();
        let mut cell_face = vec![0u32; nc];
        for (c, cf) in cell_face.iter_mut().enumerate() {
            let r = find(&mut self.parent, c as u32);
            let f = *face_of_root.entry(r).or_insert_with(|| {
                let cell = &self.cells[c];
                faces.push(CFace {
                    theta: [f64::INFINITY, f64::NEG_INFINITY],
                    measure: 0.0,
                    objects: [cell.from.min(cell.to), cell.from.max(cell.to)],
                    cells: [0, 0],
                    lower: [0, 0],
                    upper: [0, 0],
                    front: cell.front,
                });
                (faces.len() - 1) as u32
            });
            *cf = f;
        }
        let mut cells = self.cells;
        for (c, cell) in cells.iter_mut().enumerate() {
            let f = &mut faces[cell_face[c] as usize];
            cell.face = FaceId(cell_face[c]);
            f.measure += cell.area;
            f.theta[0] = f.theta[0].min(cell.theta[0]);
            f.theta[1] = f.theta[1].max(cell.theta[1]);
        }
        let mut by_face: Vec<u32> = (0..nc as u32).collect();
        by_face.sort_by_key(|&c| (cell_face[c as usize], c));
        let mut face_cells = Vec::with_capacity(nc);
        for (i, &c) in by_face.iter().enumerate() {
            let f = cell_face[c as usize] as usize;
            if i == 0 || cell_face[by_face[i - 1] as usize] as usize != f {
                faces[f].cells[0] = i as u32;
            }
            faces[f].cells[1] = i as u32 + 1;
            face_cells.push(CellId(c));
        }
        // Edges: merge pieces of one (face, point, side) that follow each other.
        let mut pieces = self.pieces;
        pieces.sort_by(|a, b| {
            let ka = (cell_face[a.cell as usize], a.side as u8, a.point);
            let kb = (cell_face[b.cell as usize], b.side as u8, b.point);
            ka.cmp(&kb).then(a.theta[0].total_cmp(&b.theta[0]))
        });
        let mut edges: Vec<CEdge> = Vec::new();
        for p in &pieces {
            let face = FaceId(cell_face[p.cell as usize]);
            if let Some(e) = edges.last_mut()
                && e.face == face
                && e.point == p.point
                && e.side == p.side
                && p.theta[0] - e.theta[1] <= ANGLE_EPS
            {
                e.theta[1] = e.theta[1].max(p.theta[1]);
                continue;
            }
            edges.push(CEdge {
                theta: p.theta,
                face,
                point: p.point,
                ends: [None, None],
                side: p.side,
            });
        }
        // Edge ends at vertices of the complex: same point, same angle.
        let mut at_point: HashMap<u32, Vec<(f64, u32)>> = HashMap::new();
        for (i, v) in self.vertices.iter().enumerate() {
            at_point.entry(v.u).or_default().push((v.theta, i as u32));
            at_point.entry(v.w).or_default().push((v.theta, i as u32));
        }
        for e in &mut edges {
            if let Some(list) = at_point.get(&e.point) {
                for end in 0..2 {
                    e.ends[end] = list
                        .iter()
                        .find(|(t, _)| (t - e.theta[end]).abs() <= 2.0 * ANGLE_EPS)
                        .map(|&(_, i)| VertexId(i));
                }
            }
        }
        // Chains: per face, lower then upper, each sorted by angle.
        let mut order: Vec<u32> = (0..edges.len() as u32).collect();
        order.sort_by(|&a, &b| {
            let (ea, eb) = (&edges[a as usize], &edges[b as usize]);
            (ea.face, ea.side as u8)
                .cmp(&(eb.face, eb.side as u8))
                .then(ea.theta[0].total_cmp(&eb.theta[0]))
        });
        let mut chain_edges = Vec::with_capacity(order.len());
        for (i, &e) in order.iter().enumerate() {
            let edge = &edges[e as usize];
            let f = &mut faces[edge.face.0 as usize];
            let range = match edge.side {
                Side::Lower => &mut f.lower,
                Side::Upper => &mut f.upper,
            };
            if range[1] == 0 && range[0] == 0 {
                range[0] = i as u32;
            }
            range[1] = i as u32 + 1;
            chain_edges.push(EdgeId(e));
        }
        let _ = geom;
        Complex {
            theta0,
            cells,
            faces,
            face_cells,
            edges,
            chain_edges,
            vertices: self.vertices,
        }
    }
}

impl Complex {
    /// Checks the structure's invariants: every index in range, cells grouped by face
    /// with the face's label and side, measures adding up, chains sorted by angle and
    /// made of the face's own edges, edge ends at vertices through the edge's point.
    /// Returns the first violation found.
    pub fn validate(&self, geom: &FlatGeometry) -> Result<(), String> {
        let np = geom.points.len() as u32;
        let ne = geom.elements.len() as u32;
        for (i, c) in self.cells.iter().enumerate() {
            if c.lower >= np || c.upper >= np || c.from >= ne || c.to >= ne {
                return Err(format!("cell {i}: index out of range"));
            }
            if c.face.0 as usize >= self.faces.len()
                || c.theta[0].partial_cmp(&c.theta[1]) == Some(std::cmp::Ordering::Greater)
                || c.theta.iter().any(|t| t.is_nan())
            {
                return Err(format!("cell {i}: bad face or angles"));
            }
        }
        for (fi, f) in self.faces.iter().enumerate() {
            let cells = &self.face_cells[f.cells[0] as usize..f.cells[1] as usize];
            let mut sum = 0.0;
            for id in cells {
                let c = &self.cells[id.0 as usize];
                let label = [c.from.min(c.to), c.from.max(c.to)];
                if c.face.0 as usize != fi || label != f.objects || c.front != f.front {
                    return Err(format!("face {fi}: cell {} does not belong", id.0));
                }
                sum += c.area;
            }
            if (sum - f.measure).abs() > 1e-12 * (1.0 + sum.abs()) {
                return Err(format!(
                    "face {fi}: measure {} != sum of cells {sum}",
                    f.measure
                ));
            }
            for (range, side) in [(f.lower, Side::Lower), (f.upper, Side::Upper)] {
                let chain = &self.chain_edges[range[0] as usize..range[1] as usize];
                for (k, e) in chain.iter().enumerate() {
                    let edge = &self.edges[e.0 as usize];
                    if edge.face.0 as usize != fi || edge.side != side || edge.point >= np {
                        return Err(format!("face {fi}: chain edge {} is foreign", e.0));
                    }
                    if k > 0 && self.edges[chain[k - 1].0 as usize].theta[0] > edge.theta[0] {
                        return Err(format!("face {fi}: chain not sorted"));
                    }
                }
            }
        }
        for (ei, e) in self.edges.iter().enumerate() {
            for v in e.ends.iter().flatten() {
                let v = self
                    .vertices
                    .get(v.0 as usize)
                    .ok_or(format!("edge {ei}: end"))?;
                if v.u != e.point && v.w != e.point {
                    return Err(format!("edge {ei}: end vertex misses its point"));
                }
            }
        }
        for (vi, v) in self.vertices.iter().enumerate() {
            if v.u >= np || v.w >= np || v.u == v.w {
                return Err(format!("vertex {vi}: bad points"));
            }
        }
        Ok(())
    }

    /// The cells containing the line `(theta, p)` (any angle; mapped into the chart).
    pub fn locate(&self, geom: &FlatGeometry, theta: f64, p: f64) -> Vec<CellId> {
        let k = ((theta - self.theta0) / PI).floor();
        let th = theta - k * PI;
        let p = if (k as i64) % 2 == 0 { p } else { -p };
        self.cells
            .iter()
            .enumerate()
            .filter(|(_, c)| {
                c.theta[0] < th
                    && th < c.theta[1]
                    && proj(geom.points[c.lower as usize], th) < p
                    && p < proj(geom.points[c.upper as usize], th)
            })
            .map(|(i, _)| CellId(i as u32))
            .collect()
    }

    /// The edges of a face's lower and upper chains.
    pub fn chains(&self, f: FaceId) -> (&[EdgeId], &[EdgeId]) {
        let face = &self.faces[f.0 as usize];
        (
            &self.chain_edges[face.lower[0] as usize..face.lower[1] as usize],
            &self.chain_edges[face.upper[0] as usize..face.upper[1] as usize],
        )
    }

    /// The face's measure by eq. 3 from its chains: `integral (upper - lower)` written
    /// with the chain edges' supporting points, `sum_upper w . dN - sum_lower u . dN`.
    /// Equals [`CFace::measure`] when the chains are complete (tested).
    pub fn chain_measure(&self, geom: &FlatGeometry, f: FaceId) -> f64 {
        let (lower, upper) = self.chains(f);
        let term = |e: &EdgeId| {
            let e = &self.edges[e.0 as usize];
            let v = geom.points[e.point as usize];
            let (n0, n1) = (big_n(e.theta[0]), big_n(e.theta[1]));
            v[0] * (n1[0] - n0[0]) + v[1] * (n1[1] - n0[1])
        };
        upper.iter().map(term).sum::<f64>() - lower.iter().map(term).sum::<f64>()
    }

    /// The faces whose label contains one of `elems` or whose chains contain an edge on
    /// the curve of one of `points` ("faces related to O", §5.1).
    pub fn related_faces(&self, elems: &[u32], points: &[u32]) -> Vec<FaceId> {
        let mut mark = vec![false; self.faces.len()];
        for (i, f) in self.faces.iter().enumerate() {
            if elems.contains(&f.objects[0]) || elems.contains(&f.objects[1]) {
                mark[i] = true;
            }
        }
        for e in &self.edges {
            if points.contains(&e.point) {
                mark[e.face.0 as usize] = true;
            }
        }
        (0..self.faces.len() as u32)
            .filter(|&i| mark[i as usize])
            .map(FaceId)
            .collect()
    }
}
