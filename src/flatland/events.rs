//! Visibility events of moving objects (paper §5.2): the times at which three points
//! become collinear while objects move rigidly, in a priority queue ordered by time.
//!
//! How it works: every change of the visibility complex's topology is the
//! elementary change of §5.2 (Figure 15): a point `p` crosses the segment `l r`
//! between two points, so `l` and `r` start or stop seeing each other, and the
//! views of `l` and `r` ([`super::views`]) change — nothing else does (a view
//! changes only when a point enters or leaves it, which needs three collinear
//! points with the view's owner at an end). So the events are the roots in time of
//! `orient(a(t), b(t), c(t))` for the triples of points not all fixed to one rigid
//! body (one moving point and a static pair, two moving points and a static one,
//! three moving points of different objects; `O(k P^2)` triples for `k` moving
//! points). Motion is the scene's piecewise-linear interpolation of translation and
//! rotation, so each triple's orientation is a smooth function of time; it is
//! sampled at the keyframe times inside `[t0, t1]` and uniformly in between (4
//! samples per piece, plus 16 per half-turn of rotation of the fastest moving
//! object in that piece), each sign change is refined by regula falsi (Illinois,
//! kept inside the bracket) to `1e-12 (t1 - t0)`, and the event is queued in a
//! [`BinaryHeap`] keyed by time with the two outer points of the collinear triple
//! as the ends whose views change.
//!
//! Tolerance, honestly: two roots of one triple between two consecutive samples (the
//! triple becomes collinear and un-collinear again within `~(t1 - t0) / 4`) cancel and
//! are not reported; the topology at the end of the interval is still right (both
//! changes undone), only the brief intermediate topology is skipped. A triple is
//! collinear at a sample when the sine of its angle is below `1e-12`. A triple
//! collinear at two consecutive samples (a point sliding along a line through two
//! others) or at `t1` itself is listed in [`EventQueue::at_end`]: its points' views
//! must be re-swept at `t1` on the geometry posed there (the sign of a near-zero
//! orientation is not trusted across two computations of the positions). A triple
//! collinear at `t0` and leaving collinearity is an event at `t0`.
//!
//! What it does not do: the paper's kinetic priority queue costs `O(log m_O)` per
//! event after an `O(m_O log m_O)` initialisation (only the certificates of the moving
//! object's visibility polygon); here all `O(k P^2)` triples are tested by sampling at
//! every step (trigonometry-free orientation tests on precomputed positions), which
//! is simple and robust but quadratic in the scene size.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::PI;

use super::geometry::FlatGeometry;
use super::scene::{FlatKey, FlatScene, orient};

/// A visibility event: three points collinear at `time`; `ends` are the outer two
/// (whose views change), `mid` the one between them. 24 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// Time of the collinearity.
    pub time: f64,
    /// The two outer points.
    pub ends: [u32; 2],
    /// The middle point.
    pub mid: u32,
    /// Padding.
    pub _pad: u32,
}
const _: () = assert!(std::mem::size_of::<Event>() == 24);

/// A queued event, ordered so that the [`BinaryHeap`] pops the earliest first.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Queued(Event);
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.time
            .total_cmp(&self.0.time)
            .then_with(|| (o.0.ends, o.0.mid).cmp(&(self.0.ends, self.0.mid)))
    }
}

/// The events of one time interval in a priority queue (earliest first).
#[derive(Clone, Debug, Default)]
pub struct EventQueue {
    heap: BinaryHeap<Queued>,
    /// Triples tested.
    pub triples: usize,
    /// Sample times used per triple.
    pub samples: usize,
    /// Triples collinear at the end time, or over a whole sample interval (module
    /// header): their points' views must be re-swept at the end time itself.
    pub at_end: Vec<[u32; 3]>,
}

impl EventQueue {
    /// Queues an event (`O(log E)`).
    pub fn push(&mut self, e: Event) {
        self.heap.push(Queued(e));
    }
    /// The earliest event (`O(log E)`).
    pub fn pop(&mut self) -> Option<Event> {
        self.heap.pop().map(|q| q.0)
    }
    /// Time of the earliest event.
    pub fn peek_time(&self) -> Option<f64> {
        self.heap.peek().map(|q| q.0.time)
    }
    /// Events still queued.
    pub fn len(&self) -> usize {
        self.heap.len()
    }
    /// True if no event is queued.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
    /// All events, earliest first (drains the queue).
    pub fn drain_sorted(&mut self) -> Vec<Event> {
        let mut out = Vec::with_capacity(self.len());
        while let Some(e) = self.pop() {
            out.push(e);
        }
        out
    }
}

/// Where each point of a posed geometry comes from: its object and its position in
/// object space, so that it can be placed at any time.
#[derive(Clone, Debug)]
pub struct Trajectories {
    /// Object of each point.
    pub object: Vec<u32>,
    /// Object-space position of each point.
    pub local: Vec<[f64; 2]>,
}

fn place(pivot: [f64; 2], key: &FlatKey, p: [f64; 2]) -> [f64; 2] {
    let (s, c) = key.rotation.sin_cos();
    let (dx, dy) = (p[0] - pivot[0], p[1] - pivot[1]);
    [
        pivot[0] + c * dx - s * dy + key.translation[0],
        pivot[1] + s * dx + c * dy + key.translation[1],
    ]
}

impl Trajectories {
    /// The trajectories of the points of `geom`, posed from `scene` at `t`.
    pub fn new(scene: &FlatScene, geom: &FlatGeometry, t: f64) -> Self {
        let mut object = Vec::with_capacity(geom.points.len());
        let mut local = Vec::with_capacity(geom.points.len());
        for (i, &x) in geom.points.iter().enumerate() {
            let o = geom.point_segments[i]
                .first()
                .map_or(0, |&s| geom.segments[s as usize].object);
            let obj = &scene.objects[o as usize];
            let key = obj.pose_at(t);
            let (s, c) = key.rotation.sin_cos();
            let (dx, dy) = (
                x[0] - key.translation[0] - obj.pivot[0],
                x[1] - key.translation[1] - obj.pivot[1],
            );
            object.push(o);
            local.push([
                obj.pivot[0] + c * dx + s * dy,
                obj.pivot[1] - s * dx + c * dy,
            ]);
        }
        Trajectories { object, local }
    }

    /// Positions of all points at time `t`.
    pub fn positions(&self, scene: &FlatScene, t: f64) -> Vec<[f64; 2]> {
        let keys: Vec<FlatKey> = scene.objects.iter().map(|o| o.pose_at(t)).collect();
        (0..self.local.len())
            .map(|i| {
                let o = self.object[i] as usize;
                place(scene.objects[o].pivot, &keys[o], self.local[i])
            })
            .collect()
    }

    /// Position of point `i` at time `t`.
    pub fn point(&self, scene: &FlatScene, i: u32, t: f64) -> [f64; 2] {
        let o = &scene.objects[self.object[i as usize] as usize];
        place(o.pivot, &o.pose_at(t), self.local[i as usize])
    }
}

/// The sample times over `[t0, t1]` for the objects `moving` (module header).
fn sample_times(scene: &FlatScene, moving: &[u32], t0: f64, t1: f64) -> Vec<f64> {
    let mut cuts = vec![t0, t1];
    for &o in moving {
        for k in &scene.objects[o as usize].motion {
            if k.t > t0 && k.t < t1 {
                cuts.push(k.t);
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut out = vec![t0];
    for w in cuts.windows(2) {
        let rot = moving
            .iter()
            .map(|&o| {
                let ob = &scene.objects[o as usize];
                (ob.pose_at(w[1]).rotation - ob.pose_at(w[0]).rotation).abs()
            })
            .fold(0.0, f64::max);
        let n = 4 + (16.0 * rot / PI).ceil() as usize;
        for k in 1..=n {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / n as f64);
        }
    }
    out
}

/// Finds the visibility events of the motion of the objects `moving` between `t0`
/// and `t1` for the points of `traj`, in a priority queue (module header).
pub fn find_events(
    scene: &FlatScene,
    traj: &Trajectories,
    moving: &[u32],
    t0: f64,
    t1: f64,
) -> EventQueue {
    let mut q = EventQueue::default();
    if t1 <= t0 || moving.is_empty() {
        return q;
    }
    let times = sample_times(scene, moving, t0, t1);
    q.samples = times.len();
    let xs: Vec<Vec<[f64; 2]>> = times.iter().map(|&t| traj.positions(scene, t)).collect();
    let np = traj.local.len() as u32;
    let is_moving: Vec<bool> = (0..np)
        .map(|i| moving.contains(&traj.object[i as usize]))
        .collect();
    let (mov, stat): (Vec<u32>, Vec<u32>) = (0..np).partition(|&i| is_moving[i as usize]);
    let tol = 1e-12 * (t1 - t0);
    let mut f = vec![0.0; times.len()];
    let mut test = |a: u32, b: u32, c: u32, q: &mut EventQueue| {
        q.triples += 1;
        for (k, x) in xs.iter().enumerate() {
            let (pa, pb, pc) = (x[a as usize], x[b as usize], x[c as usize]);
            let o = orient(pa, pb, pc);
            // Collinear to round-off: the sine of the angle at `a` below 1e-12.
            let lb = (pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2);
            let lc = (pc[0] - pa[0]).powi(2) + (pc[1] - pa[1]).powi(2);
            f[k] = if o * o <= 1e-24 * lb * lc { 0.0 } else { o };
        }
        let mut last: Option<usize> = None;
        let mut persistent = false;
        for k in 0..f.len() {
            if f[k] == 0.0 {
                persistent |= k > 0 && f[k - 1] == 0.0;
                continue;
            }
            let root = match last {
                None if k > 0 => Some(times[k - 1]), // collinear at t0, leaving it
                Some(l) if f[l].signum() != f[k].signum() => Some(if k - l > 1 {
                    times[l + 1]
                } else {
                    // Regula falsi (Illinois) on [times[l], times[k]], kept inside
                    // the bracket, down to `tol`.
                    let fat = |m: f64| {
                        let q = [a, b, c].map(|i| {
                            if is_moving[i as usize] {
                                traj.point(scene, i, m)
                            } else {
                                xs[0][i as usize]
                            }
                        });
                        orient(q[0], q[1], q[2])
                    };
                    let (mut lo, mut hi) = (times[l], times[k]);
                    let (mut flo, mut fhi) = (f[l], f[k]);
                    let mut side = 0i8;
                    for _ in 0..200 {
                        if hi - lo <= tol {
                            break;
                        }
                        let mut m = (lo * fhi - hi * flo) / (fhi - flo);
                        if !(m > lo && m < hi) {
                            m = 0.5 * (lo + hi);
                        }
                        let fm = fat(m);
                        if fm == 0.0 {
                            (lo, hi) = (m, m);
                        } else if fm.signum() == flo.signum() {
                            (lo, flo) = (m, fm);
                            if side == -1 {
                                fhi *= 0.5;
                            }
                            side = -1;
                        } else {
                            (hi, fhi) = (m, fm);
                            if side == 1 {
                                flo *= 0.5;
                            }
                            side = 1;
                        }
                    }
                    0.5 * (lo + hi)
                }),
                _ => None,
            };
            if let Some(tau) = root {
                q.push(event(scene, traj, [a, b, c], tau));
            }
            last = Some(k);
        }
        if persistent || f[f.len() - 1] == 0.0 {
            q.at_end.push([a, b, c]);
        }
    };
    let same = |a: u32, b: u32| traj.object[a as usize] == traj.object[b as usize];
    for (i, &m) in mov.iter().enumerate() {
        // One moving point, a static pair.
        for (j, &a) in stat.iter().enumerate() {
            for &b in &stat[j + 1..] {
                test(m, a, b, &mut q);
            }
        }
        // Two moving points, a static one; three moving points of two or three objects.
        for (j, &m2) in mov.iter().enumerate().skip(i + 1) {
            for &s in &stat {
                test(m, m2, s, &mut q);
            }
            for &m3 in &mov[j + 1..] {
                if !(same(m, m2) && same(m2, m3)) {
                    test(m, m2, m3, &mut q);
                }
            }
        }
    }
    q
}

/// The event of the triple collinear at `tau`: its outer points are the ends.
fn event(scene: &FlatScene, traj: &Trajectories, tri: [u32; 3], tau: f64) -> Event {
    let p = tri.map(|i| traj.point(scene, i, tau));
    let d2 = |x: [f64; 2], y: [f64; 2]| (x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2);
    // The middle point is the one opposite the longest side.
    let sides = [d2(p[1], p[2]), d2(p[0], p[2]), d2(p[0], p[1])];
    let mid = (0..3)
        .max_by(|&x, &y| sides[x].total_cmp(&sides[y]))
        .unwrap_or(0);
    let ends = [tri[(mid + 1) % 3], tri[(mid + 2) % 3]];
    Event {
        time: tau,
        ends: [ends[0].min(ends[1]), ends[0].max(ends[1])],
        mid: tri[mid],
        _pad: 0,
    }
}
