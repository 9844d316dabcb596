//! Views: the visibility polygon of every point, by a rotational sweep around the
//! point with a balanced tree, and the exact form factors (string rule, eq. 2–3)
//! summed from the views — the output-sensitive part of the visibility complex
//! (paper 002 §2.2–2.3) in `O(P^2 log P)`, without casting lines.
//!
//! # Views
//!
//! The *view* of a point `v` is the cyclic sequence of its *boundaries*: the
//! directions, counter-clockwise, of the points `v` sees (the visibility-graph edges
//! at `v`, i.e. the vertices of the complex on `v`'s dual curve), each with the
//! element first hit by the rays from `v` just after that direction. It is computed by
//! Lee's rotational sweep ([`view_of`]) in `O(P log P)` per point, `O(P^2 log P)` for
//! all, with `O(P + n)` memory per sweep.
//!
//! # Form factors from the views
//!
//! In the dual plane the measure of a face is `integral (upper - lower) . n dtheta`
//! over its cells (see [`super::complex`]); regrouped by point it is a sum over the
//! stretches of curve of each point `v` bounding a face: `+ v . dN` where `v` bounds
//! the face from above, `- v . dN` from below (`dN = N(theta1) - N(theta0)`, eq. 3
//! written per edge). A point contributes `O(deg v)` terms ([`contributions`]), so
//! all form factors cost `O(m log m)` once the views are known (`m` = visibility-graph
//! size), the sum being exact (no quadrature), equal to the dual sweep's to round-off
//! (tested).
//!
//! # What it does not do
//!
//! It does not group the edges into faces (the faces with chains come from
//! [`super::complex::sweep`]); the rotational sweep is Lee's `O(n^2 log n)`, not the
//! optimal `O(m + n log n)` topological sweep of Pocchiola–Vegter / Rivière. The
//! tree's order assumes non-crossing segments (the loader refuses crossings); on a
//! float-inconsistent order the removal falls back to a linear scan, never a panic.

use std::cmp::Ordering;
use std::collections::{BTreeSet, HashMap};
use std::f64::consts::{PI, TAU};

use super::geometry::{FlatGeometry, PairMap};
use super::scene::orient;

/// No element (a ray that escapes to infinity).
pub const NO_ELEM: u32 = u32::MAX;
/// Directions closer than this (radians) are one event of a rotational sweep.
const DIR_EPS: f64 = 1e-12;

/// One boundary of a view: the direction of `point`, and the element first hit by
/// the rays just counter-clockwise of it. 12 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Boundary {
    /// The point whose direction this is.
    pub point: u32,
    /// Element hit by the rays after this direction until the next boundary
    /// ([`NO_ELEM`] if they escape).
    pub hit_after: u32,
    /// True if `v` sees `point` (a vertex of the complex unless `v` and `point` are
    /// the two ends of one element); false for a change of the hit element at a
    /// hidden point (only in degenerate, collinear configurations).
    pub visible: bool,
}
const _: () = assert!(std::mem::size_of::<Boundary>() == 12);

/// The view of one point: its boundaries in counter-clockwise order, starting at the
/// smallest point index (a canonical rotation, so equal views compare equal).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct View {
    /// Boundaries, counter-clockwise.
    pub boundaries: Vec<Boundary>,
    /// The element hit in every direction when there is no boundary ([`NO_ELEM`]
    /// otherwise).
    pub hit_all: u32,
}

/// Endpoints of elements as point indices, and the elements incident to each point.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// `ends[e]`: the points at the two ends of element `e`.
    pub ends: Vec<[u32; 2]>,
    /// `incident[v]`: the elements having `v` as an end.
    pub incident: Vec<Vec<u32>>,
}

impl Topology {
    /// Element ends of `geom`, matched to its points by exact position.
    pub fn new(geom: &FlatGeometry) -> Self {
        let key = |p: [f64; 2]| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits());
        let index: HashMap<(u64, u64), u32> = geom
            .points
            .iter()
            .enumerate()
            .map(|(i, &p)| (key(p), i as u32))
            .collect();
        let mut incident = vec![Vec::new(); geom.points.len()];
        let mut ends = Vec::with_capacity(geom.elements.len());
        for (e, el) in geom.elements.iter().enumerate() {
            let a = index.get(&key(el.a)).copied().unwrap_or(0);
            let b = index.get(&key(el.b)).copied().unwrap_or(0);
            ends.push([a, b]);
            incident[a as usize].push(e as u32);
            if b != a {
                incident[b as usize].push(e as u32);
            }
        }
        Topology { ends, incident }
    }

    /// The end of element `e` other than `v`.
    pub fn far(&self, e: u32, v: u32) -> u32 {
        let [a, b] = self.ends[e as usize];
        if a == v { b } else { a }
    }
}

/// Counters of [`all_views`] / [`crate::flatland::radiosity::form_factors`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ViewStats {
    /// Points swept.
    pub points: usize,
    /// Event groups processed by the rotational sweeps.
    pub events: usize,
    /// Boundaries of all views (twice the visibility-graph size, plus edges seen
    /// along their own line).
    pub boundaries: usize,
    /// Angular intervals integrated (complex edges and their neighbours).
    pub intervals: usize,
}

/// An element in the sweep's tree, ordered by distance from `c` along the ray.
#[derive(Clone, Copy, Debug)]
struct Act {
    a: [f64; 2],
    b: [f64; 2],
    c: [f64; 2],
    elem: u32,
}

impl Act {
    /// Is `self` nearer to `c` than `o` on the rays meeting both (non-crossing)?
    fn nearer(&self, o: &Act) -> Ordering {
        let oc = orient(self.a, self.b, self.c);
        let (oa, ob) = (orient(self.a, self.b, o.a), orient(self.a, self.b, o.b));
        if oa * oc <= 0.0 && ob * oc <= 0.0 && (oa != 0.0 || ob != 0.0) {
            return Ordering::Less; // o beyond self's line
        }
        if oa * oc >= 0.0 && ob * oc >= 0.0 && (oa != 0.0 || ob != 0.0) {
            return Ordering::Greater; // o on c's side of self's line
        }
        // o straddles self's line: self lies on one side of o's line.
        let pc = orient(o.a, o.b, o.c);
        let (pa, pb) = (orient(o.a, o.b, self.a), orient(o.a, o.b, self.b));
        if pa * pc >= 0.0 && pb * pc >= 0.0 {
            Ordering::Less
        } else {
            Ordering::Greater
        }
    }
}

impl PartialEq for Act {
    fn eq(&self, o: &Self) -> bool {
        self.elem == o.elem
    }
}
impl Eq for Act {}
impl PartialOrd for Act {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Act {
    fn cmp(&self, o: &Self) -> Ordering {
        if self.elem == o.elem {
            Ordering::Equal
        } else {
            self.nearer(o)
        }
    }
}

/// Direction of `w - c` in `[0, 2 pi)`.
#[inline]
fn dir(c: [f64; 2], w: [f64; 2]) -> f64 {
    (w[1] - c[1]).atan2(w[0] - c[0]).rem_euclid(TAU)
}

/// The nearest point among the point events (kind 1) of one sweep `group` of
/// events `(direction, kind, id)` seen from `c`, and whether `c` sees it: no
/// element of `tree` (those the ray crosses, nearest first) lies between them.
fn nearest_seen(
    group: &[(f64, u8, u32)],
    pts: &[[f64; 2]],
    c: [f64; 2],
    tree: &BTreeSet<Act>,
) -> (Option<u32>, bool) {
    let d2 = |w: u32| {
        let q = pts[w as usize];
        (q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)
    };
    let nearest = group
        .iter()
        .filter(|g| g.1 == 1)
        .map(|g| g.2)
        .min_by(|&x, &y| d2(x).total_cmp(&d2(y)));
    let visible = nearest.is_some_and(|w| {
        tree.first().is_none_or(|m| {
            let q = pts[w as usize];
            orient(m.a, m.b, q) * orient(m.a, m.b, c) >= 0.0
        })
    });
    (nearest, visible)
}

/// The view of point `v` (module header), and the number of event groups swept.
///
/// Lee's rotational sweep: every element not on a segment through `v` and not
/// collinear with it is an arc of directions; the arcs met by the current ray sit in
/// a [`BTreeSet`] ordered by distance along the ray (a fixed order for non-crossing
/// segments, decided exactly by orientation tests, no angle). At each direction of a
/// point (events grouped within `1e-12` rad) the ending arcs leave, the nearest point
/// of the group is visible unless the nearest arc is strictly in front of it (a point
/// touching the open segment blocks, as [`FlatGeometry::sees`]), the starting arcs
/// enter, and the tree's first element is the hit of the next interval.
pub fn view_of(geom: &FlatGeometry, topo: &Topology, v: u32) -> (View, usize) {
    let pts = &geom.points;
    let c = pts[v as usize];
    let np = pts.len();
    let ang: Vec<f64> = pts.iter().map(|&w| dir(c, w)).collect();
    // Start the rotation in the widest direction gap (no event there).
    let mut sorted: Vec<f64> = (0..np)
        .filter(|&w| w != v as usize)
        .map(|w| ang[w])
        .collect();
    if sorted.is_empty() {
        return (View::default(), 0);
    }
    sorted.sort_by(f64::total_cmp);
    let mut start = sorted[sorted.len() - 1] - TAU;
    let mut widest = sorted[0] - start;
    for w in sorted.windows(2) {
        if w[1] - w[0] > widest {
            widest = w[1] - w[0];
            start = w[0];
        }
    }
    let start = start + 0.5 * widest;
    let rel = |x: f64| (x - start).rem_euclid(TAU);
    // Events: (relative angle, kind, id); kind 0 = arc ends, 1 = point, 2 = arc starts.
    let mut events: Vec<(f64, u8, u32)> = Vec::with_capacity(np + 2 * geom.elements.len());
    let mut tree: BTreeSet<Act> = BTreeSet::new();
    let mut acts: Vec<Option<Act>> = vec![None; geom.elements.len()];
    for (e, &[ia, ib]) in topo.ends.iter().enumerate() {
        let seg = geom.elements[e].segment;
        if ia == v || ib == v || geom.point_segments[v as usize].contains(&seg) {
            continue; // incident, or on a segment through v (collinear with v)
        }
        let (a, b) = (pts[ia as usize], pts[ib as usize]);
        let o = orient(c, a, b);
        if o == 0.0 {
            continue; // seen edge-on: blocks no open interval of directions
        }
        let (s, t) = if o > 0.0 { (ia, ib) } else { (ib, ia) };
        let (rs, rt) = (rel(ang[s as usize]), rel(ang[t as usize]));
        let act = Act {
            a,
            b,
            c,
            elem: e as u32,
        };
        acts[e] = Some(act);
        events.push((rs, 2, e as u32));
        events.push((rt, 0, e as u32));
        if rs > rt {
            tree.insert(act); // active at the start direction
        }
    }
    for (w, &a) in ang.iter().enumerate() {
        if w != v as usize {
            events.push((rel(a), 1, w as u32));
        }
    }
    events.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let first = |tree: &BTreeSet<Act>| tree.first().map_or(NO_ELEM, |a| a.elem);
    let mut hit = first(&tree);
    let hit_all = hit;
    let mut out: Vec<Boundary> = Vec::new();
    let mut groups = 0;
    let mut i = 0;
    while i < events.len() {
        let mut j = i + 1;
        while j < events.len() && events[j].0 - events[j - 1].0 <= DIR_EPS {
            j += 1;
        }
        groups += 1;
        let group = &events[i..j];
        for &(_, kind, id) in group {
            if kind == 0
                && let Some(act) = acts[id as usize]
                && !tree.remove(&act)
            {
                tree.retain(|x| x.elem != id);
            }
        }
        // The nearest point of the group, and whether v sees it.
        let (nearest, visible) = nearest_seen(group, pts, c, &tree);
        for &(_, kind, id) in group {
            if kind == 2
                && let Some(act) = acts[id as usize]
            {
                tree.insert(act);
            }
        }
        let new_hit = first(&tree);
        if let Some(w) = nearest
            && (visible || new_hit != hit)
        {
            out.push(Boundary {
                point: w,
                hit_after: new_hit,
                visible,
            });
        }
        hit = new_hit;
        i = j;
    }
    // Canonical rotation: start at the smallest point index.
    if let Some(k) = (0..out.len()).min_by_key(|&k| out[k].point) {
        out.rotate_left(k);
    }
    let hit_all = if out.is_empty() { hit_all } else { NO_ELEM };
    (
        View {
            boundaries: out,
            hit_all,
        },
        groups,
    )
}

/// The views of all points.
pub fn all_views(geom: &FlatGeometry, topo: &Topology) -> (Vec<View>, ViewStats) {
    let mut stats = ViewStats {
        points: geom.points.len(),
        ..Default::default()
    };
    let views = (0..geom.points.len() as u32)
        .map(|v| {
            let (view, g) = view_of(geom, topo, v);
            stats.events += g;
            stats.boundaries += view.boundaries.len();
            view
        })
        .collect();
    (views, stats)
}

/// The visibility graph (vertices of the complex): pairs `u < w` that see each other
/// and are not the two ends of one element, from the views.
pub fn visibility_graph(topo: &Topology, views: &[View]) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for (u, view) in views.iter().enumerate() {
        let u = u as u32;
        for b in &view.boundaries {
            let joined = topo.incident[u as usize]
                .iter()
                .any(|&e| topo.far(e, u) == b.point);
            if b.visible && b.point > u && !joined {
                out.push((u, b.point));
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// `(element pair, measure)` terms of one point, sorted by pair.
pub type Contributions = Vec<((u32, u32), f64)>;

/// Contributions of point `v` with `view` to the measures `mu` at the positions of
/// `geom` (module header): `(element pair, measure)` sorted by pair, merged; and the
/// number of angular intervals integrated.
///
/// The lines just above and just below `v`'s curve at `theta` have the same free
/// segments except near `v`: along the direction `d(theta)` they hit `[back,
/// incident elements of v on that side..., forward]`, where `forward` / `back` are
/// `v`'s view at `theta` / `theta + pi` and the incident elements are ordered by
/// where a line shifted by `eps` crosses them. Labels present on one side only are
/// the complex's *edges* on `v`'s curve (§2.2); their lit-side pairs carry
/// `-+ v . dN`. These change only at `v`'s boundaries and at the directions of its
/// incident elements, hence `O(deg v)` terms.
pub fn contributions(
    geom: &FlatGeometry,
    topo: &Topology,
    v: u32,
    view: &View,
) -> (Contributions, usize) {
    let pts = &geom.points;
    let c = pts[v as usize];
    // Boundaries sorted by their direction now.
    let mut bd: Vec<(f64, u32)> = view
        .boundaries
        .iter()
        .map(|b| (dir(c, pts[b.point as usize]), b.hit_after))
        .collect();
    bd.sort_by(|x, y| x.0.total_cmp(&y.0));
    let hit_at = |phi: f64| -> u32 {
        if bd.is_empty() {
            return view.hit_all;
        }
        let k = bd.partition_point(|x| x.0 <= phi);
        if k == 0 {
            bd[bd.len() - 1].1
        } else {
            bd[k - 1].1
        }
    };
    let inc = &topo.incident[v as usize];
    let mut cuts: Vec<f64> = vec![0.0, PI];
    cuts.extend(bd.iter().map(|x| x.0 % PI));
    cuts.extend(
        inc.iter()
            .map(|&e| dir(c, pts[topo.far(e, v) as usize]) % PI),
    );
    cuts.sort_by(f64::total_cmp);
    let normal = |e: u32| geom.segments[geom.elements[e as usize].segment as usize].n;
    let mut out: Vec<((u32, u32), f64)> = Vec::new();
    let mut intervals = 0;
    let mut above: Vec<(f64, u32)> = Vec::new();
    let mut below: Vec<(f64, u32)> = Vec::new();
    let mut la: Vec<(u32, u32)> = Vec::new();
    let mut lb: Vec<(u32, u32)> = Vec::new();
    for w in cuts.windows(2) {
        let (t0, t1) = (w[0], w[1]);
        if t1 <= t0 {
            continue;
        }
        intervals += 1;
        let tm = 0.5 * (t0 + t1);
        let (s, co) = tm.sin_cos();
        let (d, n) = ([co, s], [-s, co]);
        let (fwd, back) = (hit_at(tm), hit_at(tm + PI));
        above.clear();
        below.clear();
        for &e in inc {
            let q = pts[topo.far(e, v) as usize];
            let u = [q[0] - c[0], q[1] - c[1]];
            let (un, ud) = (u[0] * n[0] + u[1] * n[1], u[0] * d[0] + u[1] * d[1]);
            if un > 0.0 {
                above.push((ud / un, e));
            } else if un < 0.0 {
                below.push((-ud / un, e));
            }
        }
        above.sort_by(|x, y| x.0.total_cmp(&y.0));
        below.sort_by(|x, y| x.0.total_cmp(&y.0));
        let labels = |side: &[(f64, u32)], out: &mut Vec<(u32, u32)>| {
            out.clear();
            let mut prev = back;
            for e in side.iter().map(|x| x.1).chain(std::iter::once(fwd)) {
                if prev != NO_ELEM && e != NO_ELEM {
                    let (n0, n1) = (normal(prev), normal(e));
                    if d[0] * n0[0] + d[1] * n0[1] > 0.0 && d[0] * n1[0] + d[1] * n1[1] < 0.0 {
                        out.push((prev, e));
                    }
                }
                prev = e;
            }
        };
        labels(&above, &mut la);
        labels(&below, &mut lb);
        let (s0, c0) = t0.sin_cos();
        let (s1, c1) = t1.sin_cos();
        let val = c[0] * (c1 - c0) + c[1] * (s1 - s0);
        for l in &la {
            if !lb.contains(l) {
                out.push(((l.0.min(l.1), l.0.max(l.1)), -val));
            }
        }
        for l in &lb {
            if !la.contains(l) {
                out.push(((l.0.min(l.1), l.0.max(l.1)), val));
            }
        }
    }
    out.sort_by_key(|x| x.0);
    let mut merged: Vec<((u32, u32), f64)> = Vec::with_capacity(out.len());
    for (k, x) in out {
        match merged.last_mut() {
            Some(last) if last.0 == k => last.1 += x,
            _ => merged.push((k, x)),
        }
    }
    (merged, intervals)
}

/// Exact measures `mu` of all element pairs (see [`super::radiosity`]) from the views
/// of all points; entries below `1e-13` of the largest element's length are dropped
/// (pairs whose contributions cancel).
pub fn form_factors_mu(geom: &FlatGeometry) -> (PairMap, ViewStats) {
    let topo = Topology::new(geom);
    let (views, mut stats) = all_views(geom, &topo);
    let mut mu = PairMap::default();
    for (v, view) in views.iter().enumerate() {
        let (contrib, k) = contributions(geom, &topo, v as u32, view);
        stats.intervals += k;
        for (key, x) in contrib {
            *mu.entry(key).or_insert(0.0) += x;
        }
    }
    let scale = geom.elements.iter().map(|e| e.len).fold(0.0, f64::max);
    mu.retain(|_, x| *x > 1e-13 * scale);
    (mu, stats)
}

/// The elements hit by `x`'s view around the direction `u` (a vector): the interval
/// containing it and its two neighbours, at the positions of `geom`. The view's
/// boundaries are in counter-clockwise order, so the interval is found by orientation
/// tests along the view (`O(deg x)`, no angle).
fn hits_near(geom: &FlatGeometry, view: &View, x: u32, u: [f64; 2], out: &mut Vec<u32>) {
    let n = view.boundaries.len();
    if n == 0 {
        out.push(view.hit_all);
        return;
    }
    let c = geom.points[x as usize];
    let vec = |k: usize| {
        let q = geom.points[view.boundaries[k % n].point as usize];
        [q[0] - c[0], q[1] - c[1]]
    };
    let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    // Is u in the counter-clockwise sweep [a, b)?
    let between = |a: [f64; 2], b: [f64; 2]| {
        let (ab, au, ub) = (cross(a, b), cross(a, u), cross(u, b));
        if ab > 0.0 || (ab == 0.0 && dot(a, b) < 0.0) {
            au >= 0.0 && ub > 0.0 && !(au == 0.0 && dot(a, u) < 0.0)
        } else {
            // Reflex (or full-turn) sweep: not in the complementary [b, a).
            !(cross(b, u) >= 0.0 && cross(u, a) > 0.0 && !(cross(b, u) == 0.0 && dot(b, u) < 0.0))
        }
    };
    let found = if n == 1 {
        Some(0)
    } else {
        (0..n).find(|&k| between(vec(k), vec(k + 1)))
    };
    match found {
        Some(k) => {
            for j in [k + n - 1, k, k + 1] {
                out.push(view.boundaries[j % n].hit_after);
            }
        }
        // Not found (round-off): every hit of the view is a candidate.
        None => out.extend(view.boundaries.iter().map(|b| b.hit_after)),
    }
}

/// The result of [`splice_event`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Splice {
    /// The view is not changed by the event (`v` sees neither `p` nor `r`).
    Unchanged,
    /// The updated view.
    New(View),
}

/// The local update of the view of `v` at the elementary event of §5.2 (Figure 15):
/// `p` lies between `v` and `r` on one line, so `r` appears in or leaves `v`'s view
/// right next to `p`. Only the window of directions between the boundaries around
/// `p` (and `r`) changes; it is re-swept with the few elements that can be hit there:
/// the old hits of the window, the elements at `p` and `r`, and what `p` and `r` see
/// beyond themselves along the line (from their own views), so the cost is
/// `O(deg p + deg r)`, independent of the scene size. `views` hold the views before
/// the event; `geom` is posed just after it. `None` when the local case does not
/// apply (`p` not seen by `v`, `r` seen but not next to `p`, fewer than four
/// boundaries): the caller re-sweeps the whole view.
pub fn splice_event(
    geom: &FlatGeometry,
    topo: &Topology,
    views: &[View],
    v: u32,
    p: u32,
    r: u32,
) -> Option<Splice> {
    let old = &views[v as usize];
    let n = old.boundaries.len();
    if n < 4 {
        return None;
    }
    let pos = |w: u32| {
        old.boundaries
            .iter()
            .position(|b| b.point == w && b.visible)
    };
    let pts = &geom.points;
    let c = pts[v as usize];
    let Some(ip) = pos(p) else {
        // `v` sees neither `p` nor `r`: the segment `v p` is blocked at the event, so
        // `v r` is blocked on both sides of it and the view does not change (a point
        // touching `v p` at the same time is a simultaneous event at `v`, handled by
        // the caller's re-sweep).
        return if pos(r).is_none() {
            Some(Splice::Unchanged)
        } else {
            None
        };
    };
    let (first, last) = match pos(r) {
        None => (ip, ip),
        Some(ir) if ir == (ip + 1) % n => (ip, ir),
        Some(ir) if ip == (ir + 1) % n => (ir, ip),
        Some(_) => return None,
    };
    let lo = (first + n - 1) % n;
    let hi = (last + 1) % n;
    if hi == lo || hi == first {
        return None;
    }
    // Candidate elements.
    let mut elems: Vec<u32> = vec![old.boundaries[lo].hit_after];
    let mut k = first;
    loop {
        elems.push(old.boundaries[k].hit_after);
        if k == last {
            break;
        }
        k = (k + 1) % n;
    }
    elems.extend(&topo.incident[p as usize]);
    elems.extend(&topo.incident[r as usize]);
    let (qp, qr) = (pts[p as usize], pts[r as usize]);
    hits_near(
        geom,
        &views[p as usize],
        p,
        [qp[0] - c[0], qp[1] - c[1]],
        &mut elems,
    );
    hits_near(
        geom,
        &views[r as usize],
        r,
        [qr[0] - c[0], qr[1] - c[1]],
        &mut elems,
    );
    elems.retain(|&e| e != NO_ELEM);
    elems.sort_unstable();
    elems.dedup();
    let mut points: Vec<u32> = elems
        .iter()
        .flat_map(|&e| topo.ends[e as usize])
        .chain([p, r])
        .filter(|&w| w != v)
        .collect();
    points.sort_unstable();
    points.dedup();
    // Sweep the window (lo, hi) with the candidates only.
    let phi_lo = dir(c, pts[old.boundaries[lo].point as usize]);
    let rel = |x: f64| (x - phi_lo).rem_euclid(TAU);
    let width = rel(dir(c, pts[old.boundaries[hi].point as usize]));
    let mut events: Vec<(f64, u8, u32)> = Vec::new();
    let mut tree: BTreeSet<Act> = BTreeSet::new();
    let mut acts: HashMap<u32, Act> = HashMap::new();
    for &e in &elems {
        let [ia, ib] = topo.ends[e as usize];
        let seg = geom.elements[e as usize].segment;
        if ia == v || ib == v || geom.point_segments[v as usize].contains(&seg) {
            continue;
        }
        let (a, b) = (pts[ia as usize], pts[ib as usize]);
        let o = orient(c, a, b);
        if o == 0.0 {
            continue;
        }
        let (s, t) = if o > 0.0 { (a, b) } else { (b, a) };
        let (rs, rt) = (rel(dir(c, s)), rel(dir(c, t)));
        let act = Act { a, b, c, elem: e };
        acts.insert(e, act);
        events.push((rs, 2, e));
        events.push((rt, 0, e));
        if rs > rt {
            tree.insert(act);
        }
    }
    for &w in &points {
        events.push((rel(dir(c, pts[w as usize])), 1, w));
    }
    events.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let first_of = |tree: &BTreeSet<Act>| tree.first().map_or(NO_ELEM, |a| a.elem);
    let mut new: Vec<Boundary> = Vec::new();
    let mut hit = first_of(&tree);
    let mut hit_lo = hit;
    let mut i = 0;
    while i < events.len() {
        let mut j = i + 1;
        while j < events.len() && events[j].0 - events[j - 1].0 <= DIR_EPS {
            j += 1;
        }
        let group = &events[i..j];
        let at_lo = group[0].0 <= DIR_EPS;
        if group[0].0 >= width - DIR_EPS {
            break;
        }
        for &(_, kind, id) in group {
            if kind == 0
                && let Some(act) = acts.get(&id)
                && !tree.remove(act)
            {
                tree.retain(|x| x.elem != id);
            }
        }
        let (nearest, visible) = nearest_seen(group, pts, c, &tree);
        for &(_, kind, id) in group {
            if kind == 2
                && let Some(act) = acts.get(&id)
            {
                tree.insert(*act);
            }
        }
        let new_hit = first_of(&tree);
        if at_lo {
            hit_lo = new_hit;
        } else if let Some(w) = nearest
            && (visible || new_hit != hit)
        {
            new.push(Boundary {
                point: w,
                hit_after: new_hit,
                visible,
            });
        }
        hit = new_hit;
        i = j;
    }
    // Splice: boundaries lo, new..., hi, and the rest in order.
    let mut out: Vec<Boundary> = Vec::with_capacity(n + 1);
    let mut b_lo = old.boundaries[lo];
    b_lo.hit_after = hit_lo;
    out.push(b_lo);
    out.extend(new);
    let mut k = hi;
    while k != lo {
        out.push(old.boundaries[k]);
        k = (k + 1) % n;
    }
    if let Some(k) = (0..out.len()).min_by_key(|&k| out[k].point) {
        out.rotate_left(k);
    }
    Some(Splice::New(View {
        boundaries: out,
        hit_all: NO_ELEM,
    }))
}
