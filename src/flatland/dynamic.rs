//! Moving polygons (paper 002 §5): the form factors kept up to date event by event.
//!
//! # How it works
//!
//! The state is the views of all points ([`super::views`]: for each point, the
//! cyclic list of the points it sees with the element hit between them — the vertices
//! and edges of the visibility complex on that point's dual curve) and each point's
//! contribution to the measures `mu` (eq. 3 per edge); `mu` is their sum. A step
//! `t0 -> t1` of rigidly moving objects ([`Dynamic::step`]):
//!
//! 1. **Events (§5.2).** [`super::events::find_events`] finds the times where three
//!    points become collinear (a point crossing the segment between two others) and
//!    queues them in a [`std::collections::BinaryHeap`] by time.
//! 2. **In order.** Events are applied earliest first, simultaneous ones as a group.
//!    The elementary change of §5.2 (Figure 15: `p` crosses the segment `l r`)
//!    modifies only the views of `l` and `r`, and only in the window of directions
//!    around the line `l p r`, which [`super::views::splice_event`] re-sweeps and
//!    splices in; where that local case does not apply the whole view is re-swept.
//!    An event whose views changed is a topological change of the complex
//!    ([`StepReport::events`]). After the last event every view is the view at `t1`.
//! 3. **Measures (§5.1).** Only the points whose contribution can have changed are
//!    re-evaluated at `t1`: the moving points, the points whose view contains a moving
//!    point (their edges end at vertices through the moving object: the faces
//!    *related to* the object), and the points whose view changed at an event (the
//!    faces created and destroyed). `mu += new - old` over their terms; every other
//!    term, hence every other form factor, is kept as is.
//!
//! The result equals a from-scratch solve at every step to round-off (tested against
//! [`super::radiosity::form_factors`], with paths through many topological changes,
//! rotations included).
//!
//! # What it does not do
//!
//! It is not the paper's constant-time update: an event costs `O(deg)`, the events
//! are found by testing every triple with a moving point rather than by a kinetic
//! queue, and some steps are full recomputations (what is local and what is not:
//! [`Dynamic::step`]). With the discontinuity mesh the elements themselves move with
//! the shadows, so every step is a full recomputation (reported as such).

use std::collections::HashSet;
use std::time::Instant;

use super::events::{Trajectories, find_events};
use super::geometry::{FlatGeometry, PairMap};
use super::mesh::{Mesh, splits};
use super::radiosity::FormFactors;
use super::scene::FlatScene;
use super::views::{
    Contributions, Splice, Topology, View, all_views, contributions, splice_event, view_of,
};

/// What one update step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Time reached.
    pub t: f64,
    /// Topological changes of the complex applied (events whose views changed, §5.2).
    pub events: usize,
    /// Collinear triples found and queued (candidate events, including those hidden
    /// behind other segments, which change nothing).
    pub event_candidates: usize,
    /// Event groups popped from the queue (simultaneous events form one group).
    pub event_groups: usize,
    /// Point triples tested for collinearity.
    pub triples_tested: usize,
    /// Views updated locally at an event ([`super::views::splice_event`]: only the
    /// window of directions around the event's line, `O(deg)` work).
    pub views_spliced: usize,
    /// Views re-swept in full, `O(P log P)` each (event ends where the local case
    /// does not apply or that take part in several simultaneous events, plus the
    /// points of triples
    /// collinear at the end time, see [`super::events::EventQueue::at_end`]).
    pub views_reswept: usize,
    /// Points whose contribution was re-evaluated.
    pub points_evaluated: usize,
    /// Angular intervals of their curves integrated (complex edges and the stretches
    /// between them).
    pub edges_visited: usize,
    /// Faces of the complex visited, counted by label: distinct element pairs bounded
    /// by the edges re-evaluated.
    pub faces_visited: usize,
    /// Form factors `F_ij` recomputed (ordered pairs): those whose measure has a term
    /// that changed — the pairs on the moving object or seeing each other past it
    /// (§5.1) and the pairs of faces created or destroyed (§5.2).
    pub ff_recomputed: usize,
    /// Non-zero form factors after the step (ordered pairs).
    pub ff_total: usize,
    /// Element pairs that started to see each other (faces created, §5.2).
    pub pairs_appeared: usize,
    /// Element pairs that stopped seeing each other (faces destroyed).
    pub pairs_vanished: usize,
    /// Wall time of the step, seconds.
    pub seconds: f64,
    /// Of which: finding and queueing the events.
    pub seconds_find: f64,
    /// Of which: applying the events to the views.
    pub seconds_apply: f64,
    /// Of which: re-evaluating the measures at `t1`.
    pub seconds_measure: f64,
    /// True if the step was a full recomputation (first time, discontinuity mesh,
    /// or a change of the point set).
    pub full: bool,
}

/// The form factors of a scene kept up to date while objects move.
#[derive(Clone, Debug)]
pub struct Dynamic<'s> {
    scene: &'s FlatScene,
    mesh: Mesh,
    splits: Vec<Vec<f64>>,
    t: f64,
    geom: FlatGeometry,
    topo: Topology,
    views: Vec<View>,
    contrib: Vec<Contributions>,
    mu: PairMap,
}

/// Entries of `mu` at most this fraction of the largest element length are zero.
const TINY: f64 = 1e-12;

impl<'s> Dynamic<'s> {
    /// Computes everything at `t0` from scratch.
    pub fn new(scene: &'s FlatScene, mesh: Mesh, t0: f64) -> (Self, StepReport) {
        let start = Instant::now();
        let posed = scene.posed(t0);
        let emitters = emitters(scene);
        let sp = splits(&posed, &emitters, mesh);
        let geom = FlatGeometry::new(posed, &sp);
        let topo = Topology::new(&geom);
        let (views, stats) = all_views(&geom, &topo);
        let mut mu = PairMap::default();
        let mut contrib = Vec::with_capacity(views.len());
        let mut edges = 0;
        for (v, view) in views.iter().enumerate() {
            let (c, k) = contributions(&geom, &topo, v as u32, view);
            edges += k;
            for &(key, x) in &c {
                *mu.entry(key).or_insert(0.0) += x;
            }
            contrib.push(c);
        }
        let scale = geom.elements.iter().map(|e| e.len).fold(0.0, f64::max);
        mu.retain(|_, x| *x > TINY * scale);
        let d = Dynamic {
            scene,
            mesh,
            splits: sp,
            t: t0,
            geom,
            topo,
            views,
            contrib,
            mu,
        };
        let ff_total = d.form_factors().nonzeros();
        let rep = StepReport {
            t: t0,
            views_reswept: stats.points,
            points_evaluated: stats.points,
            edges_visited: edges,
            faces_visited: d.mu.len(),
            ff_recomputed: ff_total,
            ff_total,
            seconds: start.elapsed().as_secs_f64(),
            full: true,
            ..Default::default()
        };
        (d, rep)
    }

    /// The current geometry.
    pub fn geometry(&self) -> &FlatGeometry {
        &self.geom
    }

    /// The current time.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The current views (one per point of [`Dynamic::geometry`]).
    pub fn views(&self) -> &[View] {
        &self.views
    }

    /// The current form factors.
    pub fn form_factors(&self) -> FormFactors {
        FormFactors::from_mu(&self.geom, self.mu.clone())
    }

    /// Moves to time `t1`, applying the visibility events in order and updating only
    /// what the motion changes (module header).
    ///
    /// Events within `1e-12 (t1 - t0)` of each other form one group, applied on the
    /// geometry posed at the middle of the event-free interval that follows. At an
    /// event where `p` crosses `l r`, [`super::views::splice_event`] re-sweeps the
    /// window of directions around the line `l p r` with the few elements that can be
    /// hit there (the window's old hits, the elements at `p` and `r`, what `p` and `r`
    /// see beyond themselves), `O(deg p + deg r)` work independent of the scene size.
    /// When the local case does not apply (a point in several simultaneous events,
    /// `l` seeing neither `p` nor an element hiding it) the whole view is re-swept
    /// (`O(P log P)`). Events whose triple is hidden behind other segments change
    /// nothing. After the last event every view is the view at `t1` (tested against
    /// from-scratch views).
    ///
    /// Local: each event touches the views of its two outer points, and within them
    /// only the window of directions around the event's line (the analogue of the
    /// paper's constant-time update once the triple is known); the measure update
    /// touches only the edges on the curves of the points re-evaluated
    /// ([`StepReport::edges_visited`]), and the form factors of the element pairs
    /// those edges bound ([`StepReport::ff_recomputed`]). Not local: (a) a view
    /// spliced or re-swept is compared with the stored one (`O(deg)`), and the
    /// window's directions are found by computing the angles of `p`'s and `r`'s views
    /// (`O(deg p + deg r)`, not `O(1)`); simultaneous events at one point and the
    /// end-time re-sweeps cost `O(P log P)` per view; (b) finding the events tests all
    /// `O(k P^2)` triples with a moving point by sampling (see [`super::events`])
    /// rather than the paper's kinetic queue of `O(log m_O)` per event; (c) the points
    /// re-evaluated at `t1` are re-integrated over their whole view (`O(deg)` each),
    /// and finding the points whose view contains a moving point scans all views
    /// (`O(m)`, no reverse index). A step where two points coincide (the point set
    /// changes) or where a point crosses a segment (objects interpenetrating between
    /// keyframes, found as an event whose two ends lie on one segment) is a full
    /// recomputation, as is every step with the discontinuity mesh.
    pub fn step(&mut self, t1: f64) -> StepReport {
        let start = Instant::now();
        let full = |s: &mut Self| {
            let (d, mut rep) = Dynamic::new(s.scene, s.mesh, t1);
            *s = d;
            rep.seconds = start.elapsed().as_secs_f64();
            rep
        };
        if self.mesh == Mesh::Discontinuity {
            return full(self);
        }
        let geom1 = FlatGeometry::new(self.scene.posed(t1), &self.splits);
        if geom1.point_segments != self.geom.point_segments {
            return full(self);
        }
        let mut rep = StepReport {
            t: t1,
            ..Default::default()
        };
        let (ta, tb) = (self.t.min(t1), self.t.max(t1));
        let moving = self.scene.moving_between(ta, tb);
        if !moving.is_empty() {
            let traj = Trajectories::new(self.scene, &self.geom, self.t);
            // Events of the motion from self.t to t1, popped from the queue earliest
            // first (backwards in time: the same events, applied latest first).
            let backwards = t1 < self.t;
            let lap = Instant::now();
            let mut queue = find_events(self.scene, &traj, &moving, ta, tb);
            rep.seconds_find = lap.elapsed().as_secs_f64();
            let lap = Instant::now();
            let mut events: Vec<super::events::Event> = queue.drain_sorted();
            if backwards {
                events.reverse();
            }
            // A point crossing a segment (the ends of the event on one segment, the
            // middle point elsewhere) means the objects interpenetrate between the
            // keyframes: the event picture does not apply, recompute in full.
            let ps = &self.geom.point_segments;
            if events.iter().any(|e| {
                let [a, b] = e.ends.map(|v| &ps[v as usize]);
                a.iter()
                    .any(|s| b.contains(s) && !ps[e.mid as usize].contains(s))
            }) {
                return full(self);
            }
            rep.triples_tested = queue.triples;
            rep.event_candidates = events.len();
            let tol = 1e-12 * (tb - ta);
            let moving_points: Vec<u32> = (0..self.views.len() as u32)
                .filter(|&i| moving.contains(&traj.object[i as usize]))
                .collect();
            let mut changed = vec![false; self.views.len()];
            let events = EventsToApply {
                events: &events,
                traj: &traj,
                moving_points: &moving_points,
                t1,
                tol,
            };
            self.apply_events(events, &mut changed, &mut rep);
            // Triples collinear at t1 or sliding along a line: views re-swept at t1.
            let mut slid: Vec<u32> = queue.at_end.iter().flatten().copied().collect();
            slid.sort_unstable();
            slid.dedup();
            for v in slid {
                let (view, _) = view_of(&geom1, &self.topo, v);
                rep.views_reswept += 1;
                if view != self.views[v as usize] {
                    self.views[v as usize] = view;
                    changed[v as usize] = true;
                }
            }
            rep.seconds_apply = lap.elapsed().as_secs_f64();
            let lap = Instant::now();
            // Points whose contribution may differ at t1 (§5.1 and §5.2).
            let is_moving: Vec<bool> = (0..self.views.len())
                .map(|i| moving.contains(&traj.object[i]))
                .collect();
            let dirty: Vec<u32> = (0..self.views.len())
                .filter(|&v| {
                    is_moving[v]
                        || changed[v]
                        || self.views[v]
                            .boundaries
                            .iter()
                            .any(|b| is_moving[b.point as usize])
                })
                .map(|v| v as u32)
                .collect();
            rep.points_evaluated = dirty.len();
            self.update_measure(&geom1, &dirty, &mut rep);
            rep.seconds_measure = lap.elapsed().as_secs_f64();
        }
        self.geom = geom1;
        self.t = t1;
        rep.ff_total = self
            .mu
            .iter()
            .filter(|(_, m)| **m > 0.0)
            .map(|(k, _)| if k.0 == k.1 { 1 } else { 2 })
            .sum();
        rep.seconds = start.elapsed().as_secs_f64();
        rep
    }

    /// Applies `events` (sorted in the direction of the step) group by group: the
    /// events of one time are applied together, with the moving points placed just
    /// after them; each view an event's outer point has is spliced locally where the
    /// point takes part in one event of the group, and re-swept otherwise. Views that
    /// change are marked in `changed`.
    fn apply_events(&mut self, at: EventsToApply, changed: &mut [bool], rep: &mut StepReport) {
        let EventsToApply {
            events,
            traj,
            moving_points,
            t1,
            tol,
        } = at;
        let mut gm = self.geom.clone();
        let mut k = 0;
        while k < events.len() {
            let mut j = k + 1;
            while j < events.len() && (events[j].time - events[j - 1].time).abs() <= tol {
                j += 1;
            }
            rep.event_groups += 1;
            let next = events.get(j).map_or(t1, |e| e.time);
            let tm = 0.5 * (events[j - 1].time + next);
            // The views read only the points' positions: move the moving ones.
            for &i in moving_points {
                gm.points[i as usize] = traj.point(self.scene, i, tm);
            }
            let mut ends: Vec<u32> = events[k..j].iter().flat_map(|e| e.ends).collect();
            ends.sort_unstable();
            let once: Vec<u32> = ends
                .iter()
                .copied()
                .filter(|v| ends.iter().filter(|w| *w == v).count() == 1)
                .collect();
            ends.dedup();
            let mut group_changed: Vec<u32> = Vec::new();
            for v in ends {
                // Local splice when v takes part in one event of the group only.
                let local = if once.contains(&v) {
                    events[k..j]
                        .iter()
                        .find(|e| e.ends.contains(&v))
                        .and_then(|e| {
                            let other = if e.ends[0] == v { e.ends[1] } else { e.ends[0] };
                            splice_event(&gm, &self.topo, &self.views, v, e.mid, other)
                        })
                } else {
                    None
                };
                let view = match local {
                    Some(Splice::Unchanged) => continue,
                    Some(Splice::New(view)) => {
                        rep.views_spliced += 1;
                        view
                    }
                    None => {
                        rep.views_reswept += 1;
                        view_of(&gm, &self.topo, v).0
                    }
                };
                if view != self.views[v as usize] {
                    self.views[v as usize] = view;
                    changed[v as usize] = true;
                    group_changed.push(v);
                }
            }
            rep.events += events[k..j]
                .iter()
                .filter(|e| e.ends.iter().any(|v| group_changed.contains(v)))
                .count();
            k = j;
        }
    }

    /// Re-evaluates the contributions of the `dirty` points at the step's end
    /// (geometry `geom1`) and updates the measure of every pair one of whose terms
    /// (per point, summed in a fixed order) differs from the stored one.
    fn update_measure(&mut self, geom1: &FlatGeometry, dirty: &[u32], rep: &mut StepReport) {
        // Re-evaluate; a pair's measure is recomputed only where one of its terms
        // (per point, summed in a fixed order) differs from the stored one.
        let mut visited: HashSet<(u32, u32)> = HashSet::new();
        let mut touched: HashSet<(u32, u32)> = HashSet::new();
        let mut deltas: Vec<((u32, u32), f64, f64)> = Vec::new();
        for &v in dirty {
            let (new, edges) = contributions(geom1, &self.topo, v, &self.views[v as usize]);
            rep.edges_visited += edges;
            let old = std::mem::replace(&mut self.contrib[v as usize], new);
            let new = &self.contrib[v as usize];
            visited.extend(new.iter().map(|x| x.0));
            let (mut a, mut b) = (0, 0);
            while a < old.len() || b < new.len() {
                let ka = old.get(a).map(|x| x.0);
                let kb = new.get(b).map(|x| x.0);
                let (key, xo, xn) = match (ka, kb) {
                    (Some(p), Some(q)) if p == q => {
                        a += 1;
                        b += 1;
                        (p, old[a - 1].1, new[b - 1].1)
                    }
                    (Some(p), Some(q)) if p < q => {
                        a += 1;
                        (p, old[a - 1].1, 0.0)
                    }
                    (Some(p), None) => {
                        a += 1;
                        (p, old[a - 1].1, 0.0)
                    }
                    (_, Some(q)) => {
                        b += 1;
                        (q, 0.0, new[b - 1].1)
                    }
                    (None, None) => break,
                };
                if xo != xn {
                    touched.insert(key);
                    deltas.push((key, xo, xn));
                }
            }
        }
        let before: HashSet<(u32, u32)> = touched
            .iter()
            .filter(|k| self.mu.contains_key(k))
            .copied()
            .collect();
        for (key, xo, xn) in deltas {
            *self.mu.entry(key).or_insert(0.0) += xn - xo;
        }
        // Pairs whose terms cancel (destroyed faces) are zero to round-off.
        let scale = geom1.elements.iter().map(|e| e.len).fold(0.0, f64::max);
        for key in &touched {
            if self.mu.get(key).is_some_and(|&x| x <= TINY * scale) {
                self.mu.remove(key);
            }
            match (before.contains(key), self.mu.contains_key(key)) {
                (false, true) => rep.pairs_appeared += 1,
                (true, false) => rep.pairs_vanished += 1,
                _ => {}
            }
        }
        rep.faces_visited = visited.len();
        rep.ff_recomputed = touched.iter().map(|k| if k.0 == k.1 { 1 } else { 2 }).sum();
    }
}

/// The events of one step, as [`Dynamic::apply_events`] takes them.
struct EventsToApply<'e> {
    /// Sorted in the direction of the step.
    events: &'e [super::events::Event],
    traj: &'e Trajectories,
    /// The points of the moving objects.
    moving_points: &'e [u32],
    /// The step's end time.
    t1: f64,
    /// Events closer in time than this are one group.
    tol: f64,
}

/// Whether each segment (global order) emits in any channel.
pub fn emitters(scene: &FlatScene) -> Vec<bool> {
    scene
        .segments()
        .map(|(_, s)| s.emission.iter().any(|&e| e > 0.0))
        .collect()
}
