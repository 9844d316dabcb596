//! A sweep of the dual plane restricted to the lines meeting a convex region `K`:
//! the faces of the visibility complex "related to" a moving object (paper 002 §5.1) are
//! visited without enumerating the rest of the complex.
//!
//! How it works: at every angle `theta` the lines meeting `K` form the interval
//! `[lo(theta), hi(theta)]` of `p`, bounded by the dual curves of `K`'s vertices (the
//! support function). The *window* is the set of scene points whose curve lies inside
//! that interval, sorted by `p`; the gaps between consecutive window curves (and
//! between the envelope and the first / last one) are the only gaps of the full sweep
//! ([`super::complex`]) that meet the region, clipped to it. The window changes only at
//! three kinds of events, all computed up front:
//!
//! 1. two window points swap: the line through them meets `K` (only those pairs are
//!    kept: an orientation test against `K`'s vertices per pair, no trigonometry);
//! 2. a point enters or leaves: a line through it tangent to `K` (2 per point);
//! 3. the envelope changes vertex: a direction of an edge of `K`.
//!
//! After each group of events the window is re-evaluated (one dot product per point)
//! and re-sorted at the middle of
//! the next event-free interval (robust to degenerate events); a gap whose two bounds
//! did not change continues, the others die (their exact clipped measure, bounded by
//! point curves or by a fixed envelope vertex, is added to every front-facing label of
//! one cast line) and new ones are born. `K` is grown by `1e-9` of the scene size so
//! that the moving object's own corners lie strictly inside it (always in the window).
//!
//! The cost is proportional to the part of line space the motion touches, as in §5.1
//! ("in time proportional to their number"), apart from a quadratic but
//! trigonometry-free selection of the events ([`window_sweep`]); the faces met are
//! counted by joining cells as [`super::complex`] does ([`WindowOut::faces`]).
//!
//! What it does not do: it does not store the faces' chains or vertices, only their
//! measures and their number; the region must be convex.

use std::f64::consts::PI;

use super::complex::line_angle;
use super::geometry::{FlatGeometry, Hit, PairMap};
use super::scene::orient;

const ANGLE_EPS: f64 = 1e-11;
const LO: u32 = u32::MAX - 1;
const HI: u32 = u32::MAX;

/// What a restricted sweep measured.
#[derive(Clone, Debug, Default)]
pub struct WindowOut {
    /// `mu[(i, j)]`, `i < j`: measure of the free lines joining the lit sides of
    /// elements `i` and `j` among the lines meeting `K`.
    pub mu: PairMap,
    /// Front-facing face pieces integrated.
    pub cells: usize,
    /// Lines cast.
    pub casts: usize,
    /// Events inside the region.
    pub events: usize,
    /// Front-facing faces of the complex met (connected pieces inside the region:
    /// a face that leaves the region and comes back counts twice).
    ///
    /// Each gap's front-facing labels come from one cast at its birth; cells of one
    /// label are joined (union-find) across a point curve between neighbouring gaps,
    /// from a dead gap to the new gap with the same lower (upper) bound when that
    /// bound took no part in the event, and across the chart's seam, exactly as in
    /// [`super::complex`]; the roots are the faces visited. Over a region containing
    /// the whole scene they are the complex's front faces (tested).
    pub faces: usize,
}

/// Measures the free lines of `geom` that meet the convex hull of `points` (grown
/// slightly, see the module header).
///
/// Cost: `O(P^2)` orientation tests to select the events, then
/// `O(E_R (P + w log w))` for the `E_R` events inside the region with windows of `w`
/// points, and one `O(n)` cast per gap born.
pub fn window_sweep(geom: &FlatGeometry, points: &[[f64; 2]]) -> WindowOut {
    let mut out = WindowOut::default();
    if points.is_empty() || geom.points.is_empty() {
        return out;
    }
    // 1. K: the hull of the points, each grown by a tiny square.
    let scale = geom
        .points
        .iter()
        .chain(points)
        .map(|p| p[0].abs().max(p[1].abs()))
        .fold(1e-300, f64::max);
    let eps = 1e-9 * scale;
    let mut grown: Vec<[f64; 2]> = points
        .iter()
        .flat_map(|p| {
            [
                [p[0] - eps, p[1] - eps],
                [p[0] + eps, p[1] - eps],
                [p[0] + eps, p[1] + eps],
                [p[0] - eps, p[1] + eps],
            ]
        })
        .collect();
    grown.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    grown.dedup();
    let hull = convex_hull(&grown);
    let pts = &geom.points;
    let inside =
        |v: [f64; 2]| (0..hull.len()).all(|i| orient(hull[i], hull[(i + 1) % hull.len()], v) > 0.0);
    // 2. Events: (absolute angle) of swaps, tangents and envelope changes.
    // (angle, point or NO_POINT, point or NO_POINT, is a tangent); envelope changes
    // name no point.
    let mut events: Vec<(f64, u32, u32, bool)> = Vec::new();
    for i in 0..hull.len() {
        events.push((
            line_angle(hull[i], hull[(i + 1) % hull.len()]),
            NO_POINT,
            NO_POINT,
            false,
        ));
    }
    for (vi, &v) in pts.iter().enumerate() {
        let vi_u = vi as u32;
        if !inside(v) {
            for &q in &hull {
                // Tangent through q: every vertex of K on one side.
                let (mut l, mut r) = (false, false);
                for &h in &hull {
                    let o = orient(v, q, h);
                    l |= o > 0.0;
                    r |= o < 0.0;
                }
                if !(l && r) {
                    events.push((line_angle(v, q), vi as u32, NO_POINT, true));
                }
            }
        }
        for (wi, &w) in pts.iter().enumerate().skip(vi + 1) {
            let (mut l, mut r) = (false, false);
            for &h in &hull {
                let o = orient(v, w, h);
                l |= o > 0.0;
                r |= o < 0.0;
                if l && r {
                    events.push((line_angle(v, w), vi_u, wi as u32, false));
                    break;
                }
            }
        }
    }
    out.events = events.len();
    // 3. Chart start in the widest event-free interval, then groups.
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (first, last) = (events[0].0, events[events.len() - 1].0);
    let mut theta0 = 0.5 * (first + last - PI);
    let mut widest = first + PI - last;
    for w in events.windows(2) {
        if w[1].0 - w[0].0 > widest {
            widest = w[1].0 - w[0].0;
            theta0 = 0.5 * (w[0].0 + w[1].0);
        }
    }
    for e in &mut events {
        e.0 = (e.0 - theta0).rem_euclid(PI);
    }
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    // (absolute angle, range of its events)
    let mut groups: Vec<(f64, usize, usize)> = Vec::new();
    let mut start = 0;
    for i in 1..=events.len() {
        if i == events.len() || events[i].0 - events[i - 1].0 > ANGLE_EPS {
            groups.push((theta0 + 0.5 * (events[start].0 + events[i - 1].0), start, i));
            start = i;
        }
    }
    // 4. Sweep.
    let envelope = |th: f64| -> (usize, f64, usize, f64) {
        let (s, c) = th.sin_cos();
        let (mut lo, mut lo_p, mut hi, mut hi_p) = (0, f64::INFINITY, 0, f64::NEG_INFINITY);
        for (i, h) in hull.iter().enumerate() {
            let p = -h[0] * s + h[1] * c;
            if p < lo_p {
                (lo, lo_p) = (i, p);
            }
            if p > hi_p {
                (hi, hi_p) = (i, p);
            }
        }
        (lo, lo_p, hi, hi_p)
    };
    let window_at = |th: f64| -> Vec<u32> {
        let (_, lo_p, _, hi_p) = envelope(th);
        let (s, c) = th.sin_cos();
        let mut w: Vec<(f64, u32)> = pts
            .iter()
            .enumerate()
            .map(|(i, v)| (-v[0] * s + v[1] * c, i as u32))
            .filter(|&(p, _)| p > lo_p && p < hi_p)
            .collect();
        w.sort_by(|a, b| a.0.total_cmp(&b.0));
        w.into_iter().map(|x| x.1).collect()
    };
    let mut st = Sweep {
        geom,
        hull: &hull,
        gaps: Vec::new(),
        by_lower: Vec::new(),
        hits: Vec::new(),
        out,
        gap_cells: Vec::new(),
        cells: Vec::new(),
        parent: Vec::new(),
        involved: vec![false; pts.len() + 2],
        initial: Vec::new(),
    };
    let mid0 = 0.5 * (theta0 + groups.first().map_or(theta0 + PI, |g| g.0));
    // The window is re-evaluated (one dot product per point) and re-sorted at the
    // middle of every event-free interval.
    st.rebuild(&window_at(mid0), theta0, mid0, true);
    st.initial = st.gaps.clone();
    for (gi, &(th, e0, e1)) in groups.iter().enumerate() {
        let next = groups.get(gi + 1).map_or(theta0 + PI, |g| g.0);
        let mid = 0.5 * (th + next);
        let mut marked = Vec::new();
        for &(_, a, b, tangent) in &events[e0..e1] {
            for v in [a, b] {
                if v != NO_POINT {
                    marked.push(v as usize + 2);
                }
            }
            if tangent {
                marked.extend([0, 1]); // a point crosses the envelope
            }
        }
        for &m in &marked {
            st.involved[m] = true;
        }
        st.rebuild(&window_at(mid), th, mid, false);
        for &m in &marked {
            st.involved[m] = false;
        }
    }
    st.finish(theta0 + PI);
    st.out.faces = st.count_faces();
    st.out
}

#[derive(Clone, Copy, Debug)]
struct Gap {
    lower: u32,
    upper: u32,
    birth: f64,
    probe: f64,
    /// Index in `gap_cells`.
    id: u32,
}

/// No point (in an event naming fewer than two points).
const NO_POINT: u32 = u32::MAX;

struct Sweep<'a> {
    geom: &'a FlatGeometry,
    hull: &'a [[f64; 2]],
    gaps: Vec<Gap>,
    /// Scratch: index in `gaps` of the gap whose lower bound is a given point.
    by_lower: Vec<u32>,
    hits: Vec<Hit>,
    out: WindowOut,
    /// Per gap id: range of its front-facing cells in `cells`.
    gap_cells: Vec<[u32; 2]>,
    /// Front-facing cells: the unordered element pair of each.
    cells: Vec<(u32, u32)>,
    /// Union-find over `cells` (faces of the complex inside the region).
    parent: Vec<u32>,
    /// Per bound slot (`LO`, `HI`, points): touched by the current event group.
    involved: Vec<bool>,
    /// The gaps at the start of the chart (glued to the end, reversed).
    initial: Vec<Gap>,
}

impl Sweep<'_> {
    /// Replaces the gaps by those of `window` at angle `th` (probe angle `mid`).
    fn rebuild(&mut self, window: &[u32], th: f64, mid: f64, first: bool) {
        // Old gaps by their lower bound (each bound is the lower bound of one gap).
        if self.by_lower.len() < self.geom.points.len() + 2 {
            self.by_lower = vec![u32::MAX; self.geom.points.len() + 2];
        }
        for (i, g) in self.gaps.iter().enumerate() {
            self.by_lower[slot(g.lower)] = i as u32;
        }
        let mut kept = vec![false; self.gaps.len()];
        let mut new: Vec<Gap> = Vec::with_capacity(window.len() + 1);
        let mut lower = LO;
        for &upper in window.iter().chain(std::iter::once(&HI)) {
            let i = self.by_lower[slot(lower)];
            let mut cont = None;
            if !first && i != u32::MAX && self.gaps[i as usize].upper == upper {
                // A gap keeps living if its bounds are unchanged, unless it is bounded
                // by the envelope and the envelope's vertex changed.
                let o = self.gaps[i as usize];
                let env = lower == LO || upper == HI;
                if !env || self.same_envelope(o.probe, mid) {
                    cont = Some(o);
                    kept[i as usize] = true;
                }
            }
            let g = match cont {
                Some(o) => o,
                None => self.born(lower, upper, th, mid),
            };
            new.push(g);
            lower = upper;
        }
        for g in &self.gaps {
            self.by_lower[slot(g.lower)] = u32::MAX;
        }
        let old = std::mem::replace(&mut self.gaps, new);
        if first {
            return;
        }
        // Faces: neighbours across a point curve share a face when they share a
        // label; a new gap continues a dead one with the same lower (upper) bound
        // when that bound took no part in the event (regions meeting only at the
        // event point are not joined).
        for k in 0..self.gaps.len().saturating_sub(1) {
            let (a, b) = (self.gaps[k], self.gaps[k + 1]);
            // Pairs of continuing gaps were joined when the younger was born.
            if a.birth == th || b.birth == th {
                self.union_gaps(a.id, b.id);
            }
        }
        let dead: Vec<Gap> = old
            .iter()
            .zip(&kept)
            .filter(|(_, k)| !**k)
            .map(|(g, _)| *g)
            .collect();
        let born: Vec<Gap> = self
            .gaps
            .iter()
            .filter(|g| g.birth == th)
            .copied()
            .collect();
        for d in &dead {
            for &n in &born {
                let same_lower = n.lower == d.lower && !self.involved[slot(n.lower)];
                let same_upper = n.upper == d.upper && !self.involved[slot(n.upper)];
                if same_lower || same_upper {
                    self.union_gaps(d.id, n.id);
                }
            }
        }
        for g in dead {
            self.die(g, th);
        }
    }

    /// A new gap: one line cast at the probe angle gives its labels.
    fn born(&mut self, lower: u32, upper: u32, th: f64, mid: f64) -> Gap {
        let id = self.gap_cells.len() as u32;
        let (u, w) = (self.bound(lower, mid), self.bound(upper, mid));
        let (s, c) = mid.sin_cos();
        let p = 0.5 * (-(u[0] + w[0]) * s + (u[1] + w[1]) * c);
        let mut hits = std::mem::take(&mut self.hits);
        self.geom.cast_sc((s, c), p, &mut hits);
        self.out.casts += 1;
        let c0 = self.cells.len() as u32;
        for h in hits.windows(2) {
            if self.geom.fronts_face_sc((s, c), &h[0], &h[1]) {
                let key = (h[0].elem.min(h[1].elem), h[0].elem.max(h[1].elem));
                self.parent.push(self.cells.len() as u32);
                self.cells.push(key);
            }
        }
        self.hits = hits;
        self.gap_cells.push([c0, self.cells.len() as u32]);
        Gap {
            lower,
            upper,
            birth: th,
            probe: mid,
            id,
        }
    }

    fn union_gaps(&mut self, a: u32, b: u32) {
        let [a0, a1] = self.gap_cells[a as usize];
        let [b0, b1] = self.gap_cells[b as usize];
        for i in a0..a1 {
            for j in b0..b1 {
                if self.cells[i as usize] == self.cells[j as usize] {
                    let (ri, rj) = (self.find(i), self.find(j));
                    if ri != rj {
                        self.parent[ri as usize] = rj;
                    }
                }
            }
        }
    }

    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = p;
        }
        x
    }

    fn count_faces(&mut self) -> usize {
        (0..self.parent.len() as u32)
            .filter(|&i| self.find(i) == i)
            .count()
    }

    fn same_envelope(&self, a: f64, b: f64) -> bool {
        let env = |th: f64| {
            let (s, c) = th.sin_cos();
            let (mut lo, mut lo_p, mut hi, mut hi_p) = (0, f64::INFINITY, 0, f64::NEG_INFINITY);
            for (i, h) in self.hull.iter().enumerate() {
                let p = -h[0] * s + h[1] * c;
                if p < lo_p {
                    (lo, lo_p) = (i, p);
                }
                if p > hi_p {
                    (hi, hi_p) = (i, p);
                }
            }
            (lo, hi)
        };
        env(a) == env(b)
    }

    /// The point bounding a gap at angle `th` (envelope vertex for LO / HI).
    fn bound(&self, id: u32, th: f64) -> [f64; 2] {
        if id < LO {
            return self.geom.points[id as usize];
        }
        let (s, c) = th.sin_cos();
        let key = |h: &&[f64; 2]| -h[0] * s + h[1] * c;
        let it = self.hull.iter();
        let best = if id == LO {
            it.min_by(|a, b| key(a).total_cmp(&key(b)))
        } else {
            it.max_by(|a, b| key(a).total_cmp(&key(b)))
        };
        best.copied().unwrap_or([0.0, 0.0])
    }

    fn die(&mut self, g: Gap, th: f64) {
        if th <= g.birth {
            return;
        }
        let m = 0.5 * (g.birth + th);
        let (u, w) = (self.bound(g.lower, m), self.bound(g.upper, m));
        let (s0, c0) = g.birth.sin_cos();
        let (s1, c1) = th.sin_cos();
        let area = (w[0] - u[0]) * (c1 - c0) + (w[1] - u[1]) * (s1 - s0);
        if area <= 0.0 {
            return;
        }
        let [c0, c1] = self.gap_cells[g.id as usize];
        for c in c0..c1 {
            *self.out.mu.entry(self.cells[c as usize]).or_insert(0.0) += area;
            self.out.cells += 1;
        }
    }

    fn finish(&mut self, th: f64) {
        // The seam: at theta0 + pi the window is the initial one reversed, with the
        // envelope's sides exchanged (p -> -p).
        let swap = |b: u32| match b {
            LO => HI,
            HI => LO,
            v => v,
        };
        let fin = std::mem::take(&mut self.gaps);
        for g in &fin {
            if let Some(i) = self
                .initial
                .iter()
                .find(|i| i.lower == swap(g.upper) && i.upper == swap(g.lower))
            {
                let id = i.id;
                self.union_gaps(g.id, id);
            }
        }
        for g in fin {
            self.die(g, th);
        }
    }
}

fn slot(id: u32) -> usize {
    match id {
        LO => 0,
        HI => 1,
        v => v as usize + 2,
    }
}

/// Convex hull (Andrew's monotone chain), counter-clockwise, of points sorted by
/// `(x, y)` without repeats.
fn convex_hull(pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    if pts.len() < 3 {
        return pts.to_vec();
    }
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = h.len();
        let seq: Vec<[f64; 2]> = if pass == 0 {
            pts.to_vec()
        } else {
            pts.iter().rev().copied().collect()
        };
        for p in seq {
            while h.len() >= start + 2 && orient(h[h.len() - 2], h[h.len() - 1], p) <= 0.0 {
                h.pop();
            }
            h.push(p);
        }
        h.pop();
    }
    h
}
