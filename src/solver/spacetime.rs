//! Space-time solve of an animation whose motion is known, streamed in time order
//! (Damez & Sillion, "Space-Time Hierarchical Radiosity", EGWR 1999; paper 001).
//!
//! **Constant and varying.** The radiosity equation holds at each instant on its own
//! (paper eq. 1–2: `K` carries `δ(t, t')`), so time couples only through what can be
//! *reused*. Per §5.2 a link whose ends share a motion has a constant kernel, and one
//! whose shaft no moving object crosses has constant visibility; here both are
//! decided without time sampling, against the boxes the moving objects sweep (the
//! motion volumes of §7 item 1): over a time range a link is **constant** or
//! **varying** (`Solver::varying`).
//!
//! The solve runs in three stages:
//! 1. *Shared part* ([`Solver::run_shared`]): the usual rounds at the start time,
//!    links classified over the whole animation and only constant links refined;
//!    computed once and kept for every window.
//! 2. *Windows*, earliest first, of [`WINDOW_KEYS`] key intervals, keyframes spaced
//!    by motion ([`time_layout`]). A window re-classifies the links against the boxes
//!    swept during it and refines those that became constant; each frame places the
//!    moving objects, refines only its varying links and solves the leaf system
//!    warm-started from the frame before (`window.rs`). What holds over the window
//!    is kept: constant links' coefficients, leaf-row entries (`rows.rs`) and
//!    final-gather terms (`kept.rs`). Keyframes are reconstructed by a final gather
//!    at every point; the frames between are solved by bisection ([`solve_order`],
//!    the paper's time split at the midpoint, §4.3) and take on the line between the
//!    solved frames around them what they allow, gathering the rest ([`Between`]).
//! 3. *Release* ([`Solver::release_window`]): the window's leaves go to the output (a
//!    `.rhier` chunk), the pools are restored to the shared part, so memory does not
//!    grow with the animation's length; the final-gather terms that still hold are
//!    the only state handed to the next window (and journaled beside it).
//!
//! **Elements with time ranges.** A cell whose corners stay within `merge_tol · B_ref`
//! of their running mean over consecutive frames becomes one leaf with a longer time
//! range (§4.3, eq. 8–9; `TimeMerge`); a leaf-row entry with a moving end is linear
//! over a time range where its light allows ([`crate::solver::TimeRange`]).
//!
//! **How this departs from the paper.** It splits *elements* in time and keeps every
//! time level in one hierarchy (§6); here varying links are evaluated per frame,
//! constant ones once, and leaves merged in time where their values hold. No light
//! flows between times (inter-temporal exchange is an artefact of the discretisation,
//! §4.3). Compared: BENCHMARKS.md, "Space-time against frame by frame (ACTOR, LIGHT)".

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use bytemuck::Zeroable;
use glam::DVec3;

pub use super::frames::frame_instants;
use super::frames::frame_range;
use super::{
    Between, FrameCost, FrameRows, KeyValues, Leaf, RoundRecord, SharedRadiosity, SolveOptions,
    Solver, TimeRange,
};
use crate::Result;
use crate::pools::Column;
use crate::scene::Scene;

/// Settings of the time dimension.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SpaceTimeOptions {
    /// Frames per second: the times at which radiosity is solved.
    pub fps: f64,
    /// Window length in seconds (at least one frame); `None`: a window spans
    /// [`WINDOW_KEYS`] key intervals ([`time_layout`]), so it is as long in motion
    /// as its keyframes are, whatever the frame rate or the speed.
    pub window: Option<f64>,
    /// A cell keeps one value over consecutive frames while its corners stay within
    /// this fraction of the RMS reflected radiosity of their running mean.
    pub merge_tol: f64,
    /// Most bytes a window keeps in final-gather terms and leaf rows
    /// ([`Solver::set_kept_budget`]); `None`: everything that holds over the window.
    /// Changes the work, not the result.
    pub kept_budget: Option<u64>,
    /// Every `key_stride`-th frame of a window (and its first and last) is a
    /// keyframe, reconstructed by final gathers at every point; the frames between
    /// two keyframes, taken by bisection ([`solve_order`]), interpolate the points
    /// where the solved frames around allow it ([`Between`]). 1: every frame is a
    /// keyframe. `None`: keyframes are spaced by motion, `key_motion` apart
    /// ([`time_layout`]).
    pub key_stride: Option<u32>,
    /// With `key_stride: None`, the next keyframe is the last frame no point of a
    /// moving object has moved more than this fraction of the scene's diameter
    /// since the keyframe before ([`frame_motion`]), and at most
    /// [`MAX_KEY_FRAMES`] frames on.
    pub key_motion: f64,
    /// A point is interpolated between two solved frames when their values differ by
    /// at most this fraction of the RMS reflected radiosity in every channel, or the
    /// earlier lies within it of the line through the frame as far before and the
    /// later ([`Between`]).
    pub interp_tol: f64,
    /// A frame between two solved frames over which no moving object travels more
    /// than this fraction of the scene's diameter ([`frame_motion`]) takes the line
    /// between them at every point both know, without the test of `interp_tol`,
    /// and skips its leaf solve: the shortest time a light change is resolved
    /// over, in motion, not in frames ([`Between::free`]). 0: never, every frame
    /// between is tested.
    pub interp_motion: f64,
    /// A frame between two solved frames skips its leaf solve, and takes the
    /// shared radiosity on the line between them, when no moving surface's power
    /// changes between them by more than this fraction of the moving surfaces'
    /// total ([`MOVING_POWER_TOL`]); 0: only where it does not change at all.
    pub moving_power_tol: f64,
    /// The points on moving surfaces keep their direct light apart: a frame
    /// between two solved frames computes it anew and takes the line over the rest
    /// of their light only (`Solver::direct_light`, [`Between`]). A panel
    /// sliding past a lamp is lit along a curve the line cannot follow; its
    /// inter-reflections with what it passes follow it less steeply. `false`: the
    /// line over the whole light, as in a scene lit by more than 16 emitting
    /// patches, where the direct light would cost too many rays.
    pub direct_apart: bool,
}

impl SpaceTimeOptions {
    /// Checks the time settings before any work (as [`SolveOptions::validate`]):
    /// `fps`, `window`, `key_motion`, `merge_tol` and `interp_tol` finite and > 0,
    /// `interp_motion` and `moving_power_tol` finite and >= 0, `key_stride` >= 1,
    /// each named by its `rhier solve` flag.
    pub fn validate(&self) -> Result<()> {
        super::check_domains(
            &[
                ("--fps", Some(self.fps)),
                ("--window", self.window),
                ("--key-motion", Some(self.key_motion)),
                ("--merge-tol", Some(self.merge_tol)),
                ("--interp-tol", Some(self.interp_tol)),
            ],
            &[
                ("--interp-motion", Some(self.interp_motion)),
                ("--moving-power-tol", Some(self.moving_power_tol)),
            ],
            &[("--key-stride", self.key_stride.unwrap_or(1))],
        )
    }
}

impl Default for SpaceTimeOptions {
    fn default() -> Self {
        SpaceTimeOptions {
            fps: 25.0,
            window: None,
            merge_tol: 0.01,
            kept_budget: None,
            key_stride: None,
            key_motion: 0.05,
            interp_tol: 0.01,
            interp_motion: INTERP_MOTION,
            moving_power_tol: MOVING_POWER_TOL,
            direct_apart: true,
        }
    }
}

/// Default [`SpaceTimeOptions::interp_motion`]: 3% of the scene's diameter, under
/// two thirds of the default `key_motion`, so the bisection of a key interval tests
/// its midpoint and takes the line over each half below it (ACTOR: keyframes 8
/// frames apart, the actors travel 2.5% in four frames).
///
/// Measured (BENCHMARKS.md, "Frames between on the line over half a key
/// interval"), against the reference's probes at every reference time, two threads:
/// - ACTOR `--eps 1 --recon-tol 0.08 --recon-tol-moving 0.08`: 2.89% (worst time
///   3.29%) in 7.8–8.7 s; at 0.015 `--recon-tol 0.10` gave 3.03% (worst 3.34%) in
///   9.5–10.9 s. Per-frame's `--eps 0.35` is at 3.15% (worst 3.64%).
/// - LIGHT `--eps 0.5 --recon-tol 0.06`: 3.52% (worst 4.45%, the board 0.94%) in
///   6.6–6.9 s, against 3.51% (4.48%, 0.94%) in about 10 s at 0.015.
///
/// Further out the line leaves stains: ACTOR with keyframes 10% apart and 0.05
/// here (the halves of 8 frames free) is at 3.18% over all times but 4.52% at its
/// worst, and LIGHT's board went from 0.94% to 6.5%.
pub const INTERP_MOTION: f64 = 0.03;

/// Key intervals per window when `--window` is not given ([`time_layout`]).
///
/// A window's start costs about a keyframe more than a keyframe: the window before
/// ends on a keyframe and this one starts on the next frame, and the first one
/// gathers with the terms handed on only (ACTOR: 0.81–0.89 s against 0.32–0.44 s,
/// two threads). A longer window sweeps larger boxes, so more of its links vary,
/// but on ACTOR and LIGHT that costs less than the starts it saves, and its peak
/// RSS is the same (the kept terms go stale and are dropped; the leaves are on the
/// pools' storage). Measured (BENCHMARKS.md, "Longer windows"), two threads, at
/// 3 / 6 / 9 / 12 intervals: ACTOR 11.5 / 10.6–10.8 / 10.1–10.6 / 9.4–10.5 s at
/// 3.01–3.03% error; ACTOR750 (30 s) 109.9 s against 92.8 s at 12, 29.9 against
/// 29.8 MB. LIGHT's one window reconstructs against its first frame's radiosity
/// scale, lower than its second window's was, so it meshes finer (3.44% against
/// 3.49% at `--recon-tol 0.04`, 13.7 s against 11.4 s); at `--recon-tol 0.05` it is
/// at the old error (3.49%) in the old time (11.2 s). At most `WINDOW_KEYS ·
/// MAX_KEY_FRAMES + 1` frames are lost when a solve is interrupted.
pub const WINDOW_KEYS: usize = 12;

/// Most frames from one keyframe to the next when keyframes are spaced by motion
/// ([`time_layout`]): where nothing moves, a window still ends every
/// `WINDOW_KEYS · MAX_KEY_FRAMES + 1` frames, so an interrupted solve loses at most
/// that many and a bisection looks back over at most five levels.
pub const MAX_KEY_FRAMES: usize = 32;

/// Default [`SpaceTimeOptions::moving_power_tol`]. Frames between two keyframes
/// skip their leaf solve when no moving surface's power changes by more than this
/// fraction of the moving surfaces' total between the two nearest solved frames
/// (the shared radiosity is then taken on the line between them,
/// [`Solver::place_between`]). What the two scenes' midpoints measure
/// (BENCHMARKS.md, "Midpoints skip their solve where the actors' light holds"):
/// ACTOR's change by 1.1–2.4% over their key interval (actors walking through the
/// room's light), LIGHT's by 6.5–54% (the board passing its lamp). At 0.03 every
/// midpoint of ACTOR skips its solve, 8.35 s against 9.08 s at 0.01 (five
/// alternated runs each), at the same error (2.887%, worst time 3.29%; actors
/// 6.49% against 6.39%), and LIGHT solves the frames it solved at 0.01. Skipping
/// every one, LIGHT's error is 6.2% against 3.5% (worst time 10.6%): points beside
/// the lamp the panel slides over.
pub const MOVING_POWER_TOL: f64 = 0.03;

/// One frame of a window's solve order: a keyframe (`brackets: None`), or a frame
/// between two frames already solved, the nearest on each side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// Frame index within the window.
    pub frame: usize,
    /// The frames already solved just before and just after it.
    pub brackets: Option<(usize, usize)>,
}

/// The order a window's frames are solved in: each keyframe, then the frames
/// between it and the keyframe before by bisection of their interval: its midpoint
/// between the two keyframes, then the midpoints of both halves between the
/// keyframe and that midpoint, and so on (the paper's time split at the midpoint,
/// §4.3, applied to the reconstruction). A frame interpolates its brackets where
/// they allow it ([`Between`]), so a point gathered at the midpoint because a
/// shadow passed in one half need not be gathered in the other.
pub fn solve_order(keys: &[usize]) -> Vec<Step> {
    fn halves(lo: usize, hi: usize, out: &mut Vec<Step>) {
        if hi - lo < 2 {
            return;
        }
        let mid = lo + (hi - lo) / 2;
        out.push(Step {
            frame: mid,
            brackets: Some((lo, hi)),
        });
        halves(lo, mid, out);
        halves(mid, hi, out);
    }
    let key = |frame| Step {
        frame,
        brackets: None,
    };
    let mut order: Vec<Step> = keys.iter().take(1).map(|&k| key(k)).collect();
    for pair in keys.windows(2) {
        order.push(key(pair[1]));
        halves(pair[0], pair[1], &mut order);
    }
    order
}

/// The frame whose values tell whether a frame between `lo` and `hi` lies on a
/// line through time ([`Between::before`]): as far before `lo` as `hi` is after.
fn before(lo: usize, hi: usize) -> Option<usize> {
    lo.checked_sub(hi - lo)
}

/// What one frame cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameRecord {
    /// Frame index.
    pub frame: u32,
    /// Window index.
    pub window: u32,
    /// Time of the frame.
    pub t: f64,
    /// Seconds since the solve began.
    pub seconds: f64,
    /// Reconstruction cells of the frame.
    pub cells: u64,
    /// Elements in the pool.
    pub elements: u64,
    /// Links in the pool (active and passive).
    pub links: u64,
    /// Varying links re-evaluated.
    pub varying_links: u64,
    /// Rays cast by link evaluation and leaf rows.
    pub rays: u64,
    /// Leaf-row entries with a moving end taken between the solved frames around
    /// instead of computed ([`crate::solver::TimeRange`]).
    pub rows_between: u64,
    /// Leaf-row entries with a moving end.
    pub rows_moving: u64,
    /// Bytes of the element and link pools.
    pub bytes_pools: u64,
    /// Bytes of the final-gather terms and leaf rows the window keeps.
    pub bytes_kept: u64,
    /// GMRES relative residual.
    pub residual: f64,
    /// Reconstruction points gathered at this frame.
    pub gathered: u64,
    /// Reconstruction points interpolated between keyframes.
    pub interpolated: u64,
}

impl FrameRecord {
    /// One line for the terminal.
    pub fn summary(&self) -> String {
        format!(
            "frame {:4} (window {}) t={:.3}  {:7.2}s  cells {} (points: {} gathered, {} interpolated)  elements {}  links {} ({} varying)  rays {}  moving rows {} ({} between)  pools {:.1} MB  kept {:.1} MB  residual {:.1e}",
            self.frame,
            self.window,
            self.t,
            self.seconds,
            self.cells,
            self.gathered,
            self.interpolated,
            self.elements,
            self.links,
            self.varying_links,
            self.rays,
            self.rows_moving,
            self.rows_between,
            self.bytes_pools as f64 / 1e6,
            self.bytes_kept as f64 / 1e6,
            self.residual
        )
    }
}

/// The leaves of one finished window.
#[derive(Debug, PartialEq)]
pub struct WindowOutput {
    /// Window index.
    pub index: u32,
    /// Time range of the window.
    pub t0: f64,
    /// End of the window.
    pub t1: f64,
    /// Leaves starting in the window, sorted by start time, patch and parameters,
    /// on the pools' storage: out of core on `--storage mmap`, where
    /// [`Column::release_resident`] hands back the pages a reader of them touched.
    pub leaves: Column<Leaf>,
    /// Sum over the window's frames of their cell counts (what storing every frame
    /// separately would hold).
    pub frame_cells: u64,
}

/// Totals of a space-time solve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpaceTimeStats {
    /// Frames solved (skipped windows excluded).
    pub frames: u32,
    /// Windows in the animation.
    pub windows: u32,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Seconds of the shared part.
    pub shared_seconds: f64,
    /// Elements and links of the shared part.
    pub shared_elements: u64,
    /// Links of the shared part.
    pub shared_links: u64,
    /// Largest element and link pool bytes seen at a frame.
    pub peak_pool_bytes: u64,
    /// Largest bytes of kept terms seen at a frame.
    pub peak_kept_bytes: u64,
    /// Rounds of the shared part.
    pub rounds: Vec<RoundRecord>,
    /// RMS reflected radiosity of the shared solution (the error scale).
    pub b_ref: f64,
}

/// How far the moving objects of `scene` move between consecutive frames, as a
/// fraction of `diameter`: entry `i` bounds the distance any point of a moving
/// object travels from `times[i]` to `times[i + 1]` (the straight-line distance
/// between its two placements). The bound is taken at the corners of each object's
/// own box, which is exact for the largest: a point's displacement between two affine
/// placements is an affine function of the point, so its length is convex and
/// largest at a corner. What [`time_layout`] spaces keyframes by.
pub fn frame_motion(scene: &Scene, times: &[f64], diameter: f64) -> Vec<f64> {
    let mut out = vec![0.0; times.len().saturating_sub(1)];
    let scale = if diameter > 0.0 { 1.0 / diameter } else { 0.0 };
    for obj in scene.objects.iter().filter(|o| o.is_moving()) {
        let (lo, hi) = obj
            .polygons
            .iter()
            .flat_map(|p| p.vertices.iter().copied())
            .fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), v| (lo.min(v), hi.max(v)),
            );
        if !lo.x.is_finite() {
            continue;
        }
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let place = |t: f64| {
            let m = obj.to_world(t);
            corners.map(|c| m.transform_point3(c))
        };
        let mut prev = times.first().map(|&t| place(t));
        for (d, &t) in out.iter_mut().zip(times.iter().skip(1)) {
            let cur = place(t);
            if let Some(p) = prev {
                let step = p
                    .iter()
                    .zip(&cur)
                    .map(|(a, b)| a.distance(*b))
                    .fold(0.0, f64::max);
                *d = f64::max(*d, step * scale);
            }
            prev = Some(cur);
        }
    }
    out
}

/// One window's frames and keyframes, as [`time_layout`] plans them.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowPlan {
    /// Frame times, earliest first.
    pub times: Vec<f64>,
    /// Keyframes: indices into `times`, increasing, from the first to the last.
    pub keys: Vec<usize>,
}

/// The animation's frames (`times`, with `motion` from [`frame_motion`]) grouped
/// into windows, earliest first, each with its keyframes.
///
/// Keyframes are every `key_stride`-th frame of a window, or, without one, spaced
/// by motion: the next keyframe is the last frame before some point of a moving
/// object has moved more than `key_motion` of the scene's diameter since the one
/// before (at least one frame on, at most [`MAX_KEY_FRAMES`]). Damez & Sillion split
/// an element in time where its light changes (§4.3, §5.2), not every so many
/// frames: the same motion over twice the frames (their length measure, §6) then
/// makes as many keyframes, and only the cheap frames between them double. A window
/// is `window` seconds of frames, or, without one, [`WINDOW_KEYS`] key intervals: as
/// long in motion as its keys are, so its swept boxes (what it classifies links
/// against) and its start's cost do not depend on how slowly the motion is played.
/// Either way a last window shorter than half the one before joins it (a window's
/// start costs more than a frame). ACTOR moves about 0.6% of its diameter a frame at
/// 25 fps, so the default `key_motion` 0.05 spaces its keyframes 8 frames apart, as the
/// former default stride did, and its 76 frames make one window.
pub fn time_layout(times: &[f64], motion: &[f64], st: &SpaceTimeOptions) -> Vec<WindowPlan> {
    let n = times.len();
    let mut cum = Vec::with_capacity(n);
    cum.push(0.0);
    for (i, &d) in motion.iter().take(n.saturating_sub(1)).enumerate() {
        cum.push(cum[i] + d);
    }
    cum.resize(n.max(1), cum[cum.len() - 1]);
    // The keyframe after frame `k`, no later than `last`.
    let next_key = |k: usize, last: usize| -> usize {
        match st.key_stride {
            Some(s) => (k + s.max(1) as usize).min(last),
            None => {
                let far = (k + MAX_KEY_FRAMES).min(last);
                let mut j = (k + 1).min(last);
                while j < far && cum[j + 1] - cum[k] <= st.key_motion {
                    j += 1;
                }
                j
            }
        }
    };
    let mut ranges: Vec<(usize, usize)> = Vec::new();
    match st.window {
        Some(w) => {
            let per_window = ((w * st.fps).round() as usize).max(1);
            let mut a = 0;
            while a < n {
                let b = (a + per_window).min(n) - 1;
                ranges.push((a, b));
                a = b + 1;
            }
        }
        None => {
            let mut a = 0;
            while a < n {
                let mut k = a;
                for _ in 0..WINDOW_KEYS {
                    if k + 1 >= n {
                        break;
                    }
                    k = next_key(k, n - 1);
                }
                ranges.push((a, k));
                a = k + 1;
            }
        }
    }
    if let [.., (pa, _), (a, b)] = ranges[..] {
        if (b + 1 - a) * 2 < a - pa {
            ranges.pop();
            if let Some(last) = ranges.last_mut() {
                last.1 = b;
            }
        }
    }
    ranges
        .into_iter()
        .map(|(a, b)| {
            let mut keys = vec![0];
            let mut k = a;
            while k < b {
                k = next_key(k, b);
                keys.push(k - a);
            }
            WindowPlan {
                times: times[a..=b].to_vec(),
                keys,
            }
        })
        .collect()
}

/// The times a sweep over `[t0, t1]` places an object on `track` at, in order: 17
/// evenly spaced and the track's keys inside the range (so that between two of them
/// the track translates linearly and turns at a steady rate about one axis).
pub(super) fn sweep_times(track: Option<&crate::scene::MotionTrack>, t0: f64, t1: f64) -> Vec<f64> {
    let mut times: Vec<f64> = (0..=16).map(|i| t0 + (t1 - t0) * i as f64 / 16.0).collect();
    if let Some(m) = track {
        times.extend(m.keys.iter().map(|k| k.t).filter(|&t| t > t0 && t < t1));
    }
    times.sort_by(f64::total_cmp);
    times
}

/// Boxes swept over `[t0, t1]` by each moving object of `scene`: the union of its
/// box at 17 evenly spaced times and at the track's keys inside the range, widened by
/// the largest distance a vertex travels between two consecutive samples (so the
/// positions in between are covered too).
pub fn swept_boxes(scene: &Scene, t0: f64, t1: f64) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for obj in scene.objects.iter().filter(|o| o.is_moving()) {
        let times = sweep_times(obj.motion.as_ref(), t0, t1);
        let verts: Vec<DVec3> = obj
            .polygons
            .iter()
            .flat_map(|p| p.vertices.iter().copied())
            .collect();
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut step: f64 = 0.0;
        let mut prev: Option<glam::DAffine3> = None;
        for &t in &times {
            let m = obj.to_world(t);
            for &v in &verts {
                let p = m.transform_point3(v);
                lo = lo.min(p);
                hi = hi.max(p);
                if let Some(pm) = prev {
                    step = step.max(pm.transform_point3(v).distance(p));
                }
            }
            prev = Some(m);
        }
        if lo.x.is_finite() {
            let pad = DVec3::splat(step);
            out.push((lo - pad, hi + pad));
        }
    }
    out
}

/// A leaf being extended over consecutive frames, 112 bytes (its patch and corners
/// are its key in [`TimeMerge::runs`]: a window keeps thousands open).
struct Run {
    sum: [[f64; 3]; 4],
    /// Start of its time range.
    start: f32,
    corners: u32,
    frames: u32,
    /// Frame (within the window) it was last extended at.
    last: u32,
}

const _: () = assert!(std::mem::size_of::<Run>() == 112);

impl Run {
    fn mean(&self) -> [[f64; 3]; 4] {
        self.sum.map(|c| c.map(|v| v / self.frames.max(1) as f64))
    }

    fn close(self, key: &CellKey, end: f64) -> Leaf {
        Leaf {
            patch: key.0,
            corners: self.corners,
            time: [self.start, end as f32],
            uv: key.1.map(|c| c.map(f32::from_bits)),
            b: self.mean().map(|c| c.map(|x| x as f32)),
        }
    }
}

type CellKey = (u32, [[u32; 2]; 4]);

/// Consecutive frames' cells merged into leaves with longer time ranges while their
/// corners hold within `tol` of the running mean (module docs, "Elements with time
/// ranges"): where nothing changes, a window stores each cell once.
struct TimeMerge {
    runs: super::FastMap<CellKey, Run>,
    /// Closed leaves, in the order their runs closed: on the pools' storage, so out
    /// of core on `--storage mmap` ([`in_file_order`] sorts them).
    done: Column<Leaf>,
    tol: f64,
}

impl TimeMerge {
    /// Adds the cells of frame `k` of the window (frames in time order), whose time
    /// range starts at `f0`.
    fn push_frame(&mut self, cells: &[Leaf], k: u32, f0: f64) -> Result<()> {
        // Cells absent from this frame end where it begins; they are closed first,
        // so the map never holds more than one frame's cells (its table doubles
        // past 7/8 full and never shrinks: 2.5 MB instead of 1.2 on LIGHT).
        for cell in cells {
            if let Some(r) = self.runs.get_mut(&cell_key(cell)) {
                r.last = k;
            }
        }
        let gone: Vec<CellKey> = self
            .runs
            .iter()
            .filter(|(_, r)| r.last != k)
            .map(|(key, _)| *key)
            .collect();
        for key in gone {
            if let Some(r) = self.runs.remove(&key) {
                self.done.push(r.close(&key, f0))?;
            }
        }
        let tol = self.tol;
        for cell in cells {
            let key = cell_key(cell);
            let vals = cell.b.map(|c| c.map(f64::from));
            let fresh = Run {
                sum: vals,
                start: f0 as f32,
                corners: cell.corners,
                frames: 1,
                last: k,
            };
            match self.runs.get_mut(&key) {
                Some(r) => {
                    let m = r.mean();
                    let holds = (0..cell.corners as usize)
                        .all(|i| (0..3).all(|c| (vals[i][c] - m[i][c]).abs() <= tol));
                    if holds {
                        for (s, v) in r.sum.iter_mut().zip(vals) {
                            for c in 0..3 {
                                s[c] += v[c];
                            }
                        }
                        r.frames += 1;
                    } else {
                        let closed = std::mem::replace(r, fresh);
                        self.done.push(closed.close(&key, f0))?;
                    }
                }
                None => {
                    self.runs.insert(key, fresh);
                }
            }
        }
        Ok(())
    }

    /// Closes the runs still open at the window's end `end` and returns every leaf.
    fn finish(mut self, end: f64) -> Result<Column<Leaf>> {
        for (key, r) in self.runs.drain() {
            self.done.push(r.close(&key, end))?;
        }
        Ok(self.done)
    }
}

/// The leaves of a window, closed in merge order, in the order the file keeps them:
/// by start time, then patch and corners (a total order: cells of one patch
/// starting at one time are one frame's, and differ in their corners), so that the
/// hash map's order never reaches the file and neighbours in the file are
/// neighbours on the surface (zstd packs them better: 1.3% smaller on LIGHT than
/// in the order they closed).
///
/// A counting sort on the start time (a window has one per frame): one pass
/// counts each start's leaves, one scatters them into their bucket of a column on
/// `storage`, then each bucket (at most one frame's cells) is sorted in place.
/// Every pass hands the pages of both columns back as it goes, so out of core a
/// window's leaves are never resident at once; the work is linear in the leaves
/// whatever the window's length.
fn in_file_order(closed: Column<Leaf>, storage: &crate::pools::Storage) -> Result<Column<Leaf>> {
    let block = crate::store::writer::LEAF_BLOCK;
    let mut starts: Vec<(f32, usize)> = Vec::new();
    for l in closed.iter() {
        match starts.binary_search_by(|(t, _)| t.total_cmp(&l.time[0])) {
            Ok(i) => starts[i].1 += 1,
            Err(i) => starts.insert(i, (l.time[0], 1)),
        }
    }
    closed.release_resident();
    let mut out = Column::new(storage, "window-leaves")?;
    let zeros = vec![Leaf::zeroed(); block.min(closed.len())];
    while out.len() < closed.len() {
        let k = (closed.len() - out.len()).min(zeros.len());
        out.extend_from_slice(&zeros[..k])?;
        out.release_resident();
    }
    // Each bucket's next slot, then its range once filled.
    let mut next: Vec<usize> = starts
        .iter()
        .scan(0, |at, &(_, count)| {
            let first = *at;
            *at += count;
            Some(first)
        })
        .collect();
    for (k, l) in closed.iter().enumerate() {
        let i = starts
            .binary_search_by(|(t, _)| t.total_cmp(&l.time[0]))
            .expect("the first pass counted every start");
        out.as_mut_slice()[next[i]] = *l;
        next[i] += 1;
        if (k + 1) % block == 0 {
            closed.release_resident();
            out.release_resident();
        }
    }
    drop(closed);
    for (&end, &(_, count)) in next.iter().zip(&starts) {
        // A cell's key is its patch, then its corners' bits.
        out.as_mut_slice()[end - count..end].sort_unstable_by_key(cell_key);
        out.release_resident();
    }
    Ok(out)
}

fn cell_key(l: &Leaf) -> CellKey {
    (l.patch, l.uv.map(|c| c.map(f32::to_bits)))
}

/// A space-time solve in progress: the shared part is solved by
/// [`SpaceTime::new`], then the caller asks for the windows in time order with
/// [`SpaceTime::solve_window`] (skipping those an interrupted run already wrote,
/// after [`SpaceTime::decode_carried`] with what the last of them handed on: a
/// window depends on the ones before it only through that).
pub struct SpaceTime<'a> {
    /// How far the moving objects travel from each frame of the animation to the
    /// next ([`frame_motion`]).
    motion: Vec<f64>,
    solver: Solver<'a>,
    st: SpaceTimeOptions,
    /// Frame times and keyframes of each window.
    windows: Vec<WindowPlan>,
    shared_tr: Vec<crate::pools::links::Transport>,
    shared_b: Vec<[f32; 3]>,
    /// The shared part's directional power ([`crate::pools::Emission`]; cluster emission depends on `B`).
    shared_dir: Vec<crate::pools::Emission>,
    start: Instant,
    /// Totals so far.
    pub stats: SpaceTimeStats,
}

impl<'a> SpaceTime<'a> {
    /// Builds the solver at the scene's start time and solves the shared part.
    pub fn new(
        scene: &'a Scene,
        opts: SolveOptions,
        st: SpaceTimeOptions,
        on_round: impl FnMut(&mut RoundRecord, &Solver),
    ) -> Result<Self> {
        st.validate()?;
        static_only(&opts)?;
        let start = Instant::now();
        let (t_start, t_end) = (scene.time.start, scene.time.end);
        let times = frame_instants(scene.time, st.fps)?;
        let mut solver = Solver::at_time(scene, opts, t_start, [t_start as f32, t_end as f32])?;
        let motion = frame_motion(scene, &times, solver.patches.diameter);
        let windows = time_layout(&times, &motion, &st);
        solver.set_kept_budget(st.kept_budget);
        solver.set_direct_apart(st.direct_apart);
        let rounds = solver.run_shared([t_start, t_end], on_round)?;
        let b_ref = solver.radiosity_scale().max(f64::MIN_POSITIVE);
        let stats = SpaceTimeStats {
            windows: windows.len() as u32,
            shared_seconds: start.elapsed().as_secs_f64(),
            shared_elements: solver.elems.len() as u64,
            shared_links: solver.links.len() as u64,
            rounds,
            b_ref,
            ..SpaceTimeStats::default()
        };
        // The state every window starts from (with the terms the last one handed on).
        let shared_tr = solver.links.transports.as_slice().to_vec();
        let shared_b = solver.elems.radiosities.as_slice().to_vec();
        let shared_dir = solver.elems.directions.as_slice().to_vec();
        Ok(SpaceTime {
            motion,
            solver,
            st,
            windows,
            shared_tr,
            shared_b,
            shared_dir,
            start,
            stats,
        })
    }

    /// Number of windows.
    pub fn window_count(&self) -> usize {
        self.windows.len()
    }

    /// Index of the first frame of window `w`.
    fn first_frame(&self, w: usize) -> u32 {
        self.windows[..w].iter().map(|p| p.times.len() as u32).sum()
    }

    /// The patches leaves refer to (for the file's header).
    pub fn patches(&self) -> &[super::PatchGeometry] {
        &self.solver.patches.geometry
    }

    /// Writes the final-gather terms the last solved window hands the next (those
    /// on the shared part, `Solver::on_shared_part`; nothing before the first) in
    /// `PointCache::encode`'s format: a journal keeps them beside the window, and
    /// `solve --resume` continues with the next window exactly as an uninterrupted
    /// solve does.
    pub fn encode_carried(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let s = &self.solver;
        s.carried
            .as_ref()
            .map_or(Ok(()), |c| c.encode(w, |src| s.on_shared_part(src)))
    }

    /// Takes the terms [`SpaceTime::encode_carried`] wrote (`len` bytes from
    /// `path`) as the ones the last window handed on, before the first window a
    /// resumed solve solves, checking that every point lies on a static patch and
    /// every element is one of the shared part (all the pools hold between
    /// windows).
    pub fn decode_carried(
        &mut self,
        r: &mut dyn std::io::Read,
        len: u64,
        path: &std::path::Path,
    ) -> Result<()> {
        let s = &mut self.solver;
        let shared = s.elems.len();
        let moving = &s.moving_patch;
        let c = super::kept::PointCache::decode(
            r,
            len,
            path,
            &s.opts.storage,
            |e| (e as usize) < shared,
            |p| moving.get(p as usize) == Some(&false),
        )?;
        s.carried = Some(c);
        Ok(())
    }

    /// The solver (pools, geometry) as it stands.
    pub fn solver(&self) -> &Solver<'a> {
        &self.solver
    }

    /// Solves window `wi` frame by frame and returns its leaves; the pools are back to
    /// the shared part afterwards. `on_frame` sees every frame's record.
    pub fn solve_window(
        &mut self,
        wi: usize,
        mut on_frame: impl FnMut(&FrameRecord),
    ) -> Result<WindowOutput> {
        let scene = self.solver.scene;
        let fps = self.st.fps;
        let WindowPlan {
            times: frames,
            keys,
        } = self.windows[wi].clone();
        let first = self.first_frame(wi);
        let b_ref = self.stats.b_ref;
        let tol = self.st.merge_tol * b_ref;
        let n = self.windows.iter().map(|w| w.times.len()).sum();
        let w0 = frame_range(first as usize, n, scene.time, fps)[0];
        let w1 = frame_range(first as usize + frames.len() - 1, n, scene.time, fps)[1];
        let solver = &mut self.solver;
        solver.set_time(frames[0]);
        solver.begin_window([w0, w1], b_ref)?;
        let mut merge = TimeMerge {
            runs: Default::default(),
            done: Column::new(&solver.opts.storage, "window-leaves")?,
            tol,
        };
        let mut frame_cells = 0u64;
        let interp_tol = self.st.interp_tol * b_ref;
        let order = solve_order(&keys);
        // The values of the frames that later frames interpolate (about 0.9 MB each
        // on ACTOR: the keyframes around the interval being solved, its frames
        // solved so far and the frames before it a bisection step looks back to),
        // the shared radiosity of the interval's solved frames, and finished frames
        // waiting for the ones before them to be merged in time order.
        let mut values: HashMap<usize, KeyValues> = HashMap::new();
        let mut rad: HashMap<usize, SharedRadiosity> = HashMap::new();
        // The row entries with a moving end of the same solved frames.
        let mut rows_at: HashMap<usize, Arc<FrameRows>> = HashMap::new();
        let mut pending: std::collections::BTreeMap<usize, Arc<[Leaf]>> = Default::default();
        let mut next_merge = 0;
        for (at, step) in order.iter().enumerate() {
            let k = step.frame;
            let t = frames[k];
            let (cost, r) = match step.brackets {
                None => {
                    let cost = solver.frame(t, b_ref)?;
                    rad.insert(k, solver.shared_radiosity());
                    // Where the moving light holds between this keyframe and the
                    // one before, the frames between skip their solve: the one
                    // before ends no range of rows any more, and this one is
                    // kept only if the light did not hold (the next interval
                    // likely does as this one did; ACTOR's mostly hold, LIGHT's
                    // never).
                    let i = keys.partition_point(|&f| f < k);
                    let prev = i.checked_sub(1).map(|i| keys[i]);
                    let held = prev.and_then(|p| rad.get(&p)).is_some_and(|ra| {
                        SharedRadiosity::moving_power_holds(ra, &rad[&k], self.st.moving_power_tol)
                    });
                    let rows = solver.take_frame_rows();
                    if let Some(p) = prev.filter(|_| held) {
                        rows_at.remove(&p);
                    } else {
                        rows_at.insert(k, Arc::new(rows));
                    }
                    (cost, solver.reconstruct_between(None))
                }
                Some((lo, hi)) => {
                    // The keyframe starting the interval (`solve_order` solves the
                    // one ending it just before the frames in it).
                    let a = keys[keys.partition_point(|&f| f < k) - 1];
                    // What the rest of the window still reads: the brackets and
                    // look-back frames of the steps to come.
                    let to_come = || order[at..].iter().filter_map(|s| s.brackets);
                    let brackets: std::collections::HashSet<usize> =
                        to_come().flat_map(|(l, h)| [l, h]).collect();
                    let looked_back: std::collections::HashSet<usize> =
                        to_come().filter_map(|(l, h)| before(l, h)).collect();
                    values.retain(|f, _| brackets.contains(f) || looked_back.contains(f));
                    rad.retain(|&f, _| f >= a);
                    // Rows end ranges only.
                    rows_at.retain(|f, _| brackets.contains(f));
                    // The solved frames nearest on either side (the keyframes, or
                    // a midpoint that had to be solved): the moving surfaces' light
                    // is checked, and the shared radiosity interpolated, between
                    // them.
                    let sa = rad.keys().filter(|&&f| f < k).max().copied();
                    let sb = rad.keys().filter(|&&f| f > k).min().copied();
                    // Brackets closer in motion than `interp_motion`: the frame
                    // takes the line at every point (`Between::free`), and its
                    // gathers (cells the brackets lack) need no solve.
                    let (f0, f1) = (first as usize + lo, first as usize + hi);
                    let travel: f64 = self.motion[f0..f1].iter().sum();
                    let free = self.st.interp_motion > 0.0 && travel <= self.st.interp_motion;
                    let holds = match (sa, sb) {
                        (Some(sa), Some(sb)) => {
                            let (ra, rb) = (&rad[&sa], &rad[&sb]);
                            (free
                                || SharedRadiosity::moving_power_holds(
                                    ra,
                                    rb,
                                    self.st.moving_power_tol,
                                ))
                            .then_some((sa, ra, sb, rb))
                        }
                        _ => None,
                    };
                    let cost = match holds {
                        Some((sa, ra, sb, rb)) => {
                            let alpha = (k - sa) as f64 / (sb - sa) as f64;
                            solver.place_between(t, ra, rb, alpha);
                            FrameCost::default()
                        }
                        None => {
                            // Row entries with a moving end that hold over the
                            // solved frames around are taken between them.
                            let range = sa.zip(sb).and_then(|(sa, sb)| {
                                Some(TimeRange {
                                    a: rows_at.get(&sa)?.clone(),
                                    b: rows_at.get(&sb)?.clone(),
                                    alpha: (k - sa) as f64 / (sb - sa) as f64,
                                    tol: interp_tol,
                                })
                            });
                            solver.set_time_range(range);
                            let cost = solver.frame(t, b_ref);
                            solver.set_time_range(None);
                            let cost = cost?;
                            rad.insert(k, solver.shared_radiosity());
                            rows_at.insert(k, Arc::new(solver.take_frame_rows()));
                            cost
                        }
                    };
                    let known = |f: Option<usize>| Some((f? as f64, values.get(&f?)?));
                    let between = known(Some(lo)).zip(known(Some(hi))).map(|(a, b)| Between {
                        free,
                        before: known(before(lo, hi)),
                        a,
                        b,
                        t: k as f64,
                        tol: interp_tol,
                    });
                    (cost, solver.reconstruct_between(between.as_ref()))
                }
            };
            let (gathered, interpolated) = (r.gathered, r.interpolated);
            // The frame's cells are shared by the time merge and its values (which
            // later frames interpolate where the frame did not gather).
            let cells: Arc<[Leaf]> = r.leaves.into();
            values.insert(k, r.values.with_cells(cells.clone()));
            // The frame's gathers leave the heaps fragmented (ACTOR, out of core:
            // 6 MB less resident at the end of a window); a frame that gathered
            // nothing allocated what the next one reuses.
            if gathered > 0 {
                super::release_free_memory();
            }
            frame_cells += cells.len() as u64;
            let n_cells = cells.len() as u64;
            pending.insert(k, cells);
            while let Some(cells) = pending.remove(&next_merge) {
                let [f0, _] = frame_range(first as usize + next_merge, n, scene.time, fps);
                merge.push_frame(&cells, next_merge as u32, f0)?;
                next_merge += 1;
            }
            // Out of core: the closed leaves' pages go back to the scratch file.
            merge.done.release_resident();
            let bytes = (solver.elems.bytes() + solver.links.bytes()) as u64;
            self.stats.peak_pool_bytes = self.stats.peak_pool_bytes.max(bytes);
            let kept = solver.kept_bytes();
            self.stats.peak_kept_bytes = self.stats.peak_kept_bytes.max(kept);
            self.stats.frames += 1;
            on_frame(&FrameRecord {
                frame: first + k as u32,
                window: wi as u32,
                t,
                seconds: self.start.elapsed().as_secs_f64(),
                cells: n_cells,
                elements: solver.elems.len() as u64,
                links: solver.links.len() as u64,
                varying_links: cost.varying_links,
                rays: cost.rays,
                rows_between: cost.rows_between,
                rows_moving: cost.rows_moving,
                bytes_pools: bytes,
                bytes_kept: kept,
                residual: cost.residual,
                gathered,
                interpolated,
            });
        }
        let closed = merge.finish(w1)?;
        solver.release_window();
        solver
            .links
            .transports
            .as_mut_slice()
            .copy_from_slice(&self.shared_tr);
        solver
            .elems
            .radiosities
            .as_mut_slice()
            .copy_from_slice(&self.shared_b);
        solver
            .elems
            .directions
            .as_mut_slice()
            .copy_from_slice(&self.shared_dir);
        // Sorted once the window's memory is back (out of core the two columns are
        // paged through a bucket at a time).
        let leaves = in_file_order(closed, &solver.opts.storage)?;
        self.stats.seconds = self.start.elapsed().as_secs_f64();
        Ok(WindowOutput {
            index: wi as u32,
            t0: w0,
            t1: w1,
            leaves,
            frame_cells,
        })
    }
}

/// Refuses the settings a space-time solve has no use for: `leaf_shapes` and
/// `split_spread` act after the last round of one static solve, and a window's
/// frames gather from leaves shared over time without reaching that point.
/// [`SpaceTime::new`] calls it; a caller may call it before creating its output.
pub fn static_only(opts: &SolveOptions) -> Result<()> {
    for (on, flag) in [
        (opts.leaf_shapes > 0.0, "--leaf-shapes"),
        (opts.split_spread > 0.0, "--split-spread"),
    ] {
        if on {
            return Err(crate::Error::Usage(format!(
                "{flag} applies to static solves and to the frames of --per-frame; a space-time solve of a moving scene does not use it"
            )));
        }
    }
    Ok(())
}

/// Solves every window of `scene` in order (see the module docs); `on_window`
/// receives each finished window (write it to a `.rhier` chunk).
pub fn solve(
    scene: &Scene,
    opts: SolveOptions,
    st: &SpaceTimeOptions,
    mut on_frame: impl FnMut(&FrameRecord),
    mut on_window: impl FnMut(WindowOutput) -> Result<()>,
) -> Result<SpaceTimeStats> {
    let mut run = SpaceTime::new(scene, opts, *st, |_, _| {})?;
    for w in 0..run.window_count() {
        let out = run.solve_window(w, &mut on_frame)?;
        on_window(out)?;
    }
    Ok(run.stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The frame instants of `[start, end]` at `fps`.
    fn instants(start: f64, end: f64, fps: f64) -> Vec<f64> {
        frame_instants(crate::scene::TimeDomain { start, end }, fps).unwrap()
    }
    use crate::pools::Storage;
    use crate::scene::{MaterialId, MotionKey, MotionTrack, Object, Polygon, cornell_box};

    /// The empty Cornell box with a trough that slides 150 mm along z over `[0, 1]`
    /// s: a floor plate at y = 100 and two walls facing each other across it (x =
    /// 200 and 320), one object. With `blade`, a static blade hangs from the
    /// ceiling down to y = 160 at x = 260, z 330–350: the trough's walls pass on
    /// either side of it from t ≈ 0.5, and it comes between them. With `split`, the
    /// left wall is an object of its own on the trough's track with a key added
    /// halfway: the same motion, told apart only by its data, so the solver cannot
    /// know that the walls move as one.
    fn trough(blade: bool, split: bool) -> Scene {
        let mut scene = cornell_box(false);
        scene.time.start = 0.0;
        scene.time.end = 1.0;
        let quad = |v: [[f64; 3]; 4]| Polygon {
            vertices: v.iter().map(|&p| DVec3::from_array(p)).collect(),
            material: MaterialId(3),
        };
        let track = |keys: &[f64]| {
            Some(MotionTrack {
                keys: keys
                    .iter()
                    .map(|&t| MotionKey {
                        t,
                        translation: DVec3::new(0.0, 0.0, 150.0 * t),
                        rotation: glam::DQuat::IDENTITY,
                        scale: DVec3::ONE,
                    })
                    .collect(),
            })
        };
        let left = quad([
            [200., 100., 150.],
            [200., 260., 150.],
            [200., 260., 270.],
            [200., 100., 270.],
        ]);
        let mut rest = vec![
            quad([
                [320., 100., 150.],
                [320., 100., 270.],
                [320., 260., 270.],
                [320., 260., 150.],
            ]),
            quad([
                [200., 100., 150.],
                [200., 100., 270.],
                [320., 100., 270.],
                [320., 100., 150.],
            ]),
        ];
        if split {
            scene.objects.push(Object {
                name: "trough_left".into(),
                polygons: vec![left],
                motion: track(&[0.0, 0.5, 1.0]),
            });
        } else {
            rest.insert(0, left);
        }
        scene.objects.push(Object {
            name: "trough".into(),
            polygons: rest,
            motion: track(&[0.0, 1.0]),
        });
        if blade {
            scene.objects.push(Object {
                name: "blade".into(),
                polygons: vec![quad([
                    [260., 160., 330.],
                    [260., 548., 330.],
                    [260., 548., 350.],
                    [260., 160., 350.],
                ])],
                motion: None,
            });
        }
        scene
    }

    /// The varying flags of the active links of a window over `span` of `scene`,
    /// those between two of the trough's surfaces that exchange light and those
    /// between the trough and the rest.
    fn trough_links(scene: &Scene, span: [f64; 2]) -> (Vec<bool>, Vec<bool>) {
        let mut s =
            Solver::at_time(scene, SolveOptions::default(), span[0], [0.0, 1.0]).expect("solver");
        s.run_shared([0.0, 1.0], |_, _| {}).expect("shared part");
        let b_ref = s.radiosity_scale();
        s.begin_window(span, b_ref).expect("window");
        let geoms = s.elems.geoms.as_slice();
        let on_trough = |e: u32| {
            let p = geoms[e as usize].patch;
            p != u32::MAX && scene.objects[s.patches.objects[p as usize] as usize].name == "trough"
        };
        let (mut inside, mut across) = (Vec::new(), Vec::new());
        for l in s.active_links(false) {
            let e = s.links.ends.as_slice()[l.ix()];
            let t = s.links.transports.as_slice()[l.ix()];
            match (on_trough(e.receiver), on_trough(e.source)) {
                (true, true) if t.f > 0.0 => inside.push(t.varying()),
                (true, false) | (false, true) => across.push(t.varying()),
                _ => {}
            }
        }
        (inside, across)
    }

    #[test]
    fn surfaces_that_move_as_one_keep_their_links_constant_until_something_comes_between() {
        // Paper 001 §5.2: a link whose ends share a motion has a constant kernel,
        // and a constant visibility while nothing with another motion crosses it.
        let (inside, across) = trough_links(&trough(false, false), [0.0, 1.0]);
        assert!(
            inside.len() >= 4,
            "{} links inside the trough",
            inside.len()
        );
        assert!(inside.iter().all(|&v| !v), "{inside:?}");
        assert!(!across.is_empty() && across.iter().all(|&v| v));
        // The blade comes between the walls in the second half of the time only.
        let (inside, _) = trough_links(&trough(true, false), [0.0, 1.0]);
        assert!(inside.iter().any(|&v| v), "{inside:?}");
        let (inside, _) = trough_links(&trough(true, false), [0.0, 0.25]);
        assert!(inside.iter().all(|&v| !v), "{inside:?}");
    }

    /// Points on the trough's inner faces at time `t` (it slides 150 mm a second).
    fn trough_points(t: f64) -> Vec<crate::playback::ProbePoint> {
        use crate::playback::ProbePoint;
        let dz = 150.0 * t;
        let mut pts = Vec::new();
        for a in [0.25, 0.5, 0.75] {
            for b in [0.25, 0.5, 0.75] {
                let (y, z) = (100.0 + 160.0 * a, 150.0 + 120.0 * b + dz);
                pts.push(ProbePoint {
                    p: DVec3::new(200.0, y, z),
                    n: DVec3::X,
                });
                pts.push(ProbePoint {
                    p: DVec3::new(320.0, y, z),
                    n: -DVec3::X,
                });
                pts.push(ProbePoint {
                    p: DVec3::new(200.0 + 120.0 * a, 100.0, z),
                    n: DVec3::Y,
                });
            }
        }
        pts
    }

    #[test]
    fn surfaces_that_move_as_one_are_linked_once_and_give_the_frames_of_links_evaluated_at_each() {
        // Paper 001 §5.2: the links between surfaces that share a motion keep their
        // kernel (and here their visibility: nothing comes between the walls), so
        // they are constant and evaluated once, not at every frame. The frames must
        // be those of a solve that evaluates them at every frame (the same walls on
        // tracks the solver cannot tell are one) and of the static solve of each
        // frame.
        use crate::playback::probe;
        use crate::solution::relative_rms;
        use crate::solution::{Solution, SolveStats};
        let st = SpaceTimeOptions {
            fps: 5.0,
            window: Some(0.5),
            key_stride: Some(8),
            ..SpaceTimeOptions::default()
        };
        // The frames' leaves and the varying links over all frames.
        let run = |scene: &Scene| {
            let (mut leaves, mut varying) = (Vec::new(), 0);
            solve(
                scene,
                SolveOptions::default(),
                &st,
                |f| varying += f.varying_links,
                |w| {
                    leaves.extend(w.leaves.iter().copied());
                    Ok(())
                },
            )
            .expect("space-time solve");
            (leaves, varying)
        };
        let (scene_one, scene_split) = (trough(false, false), trough(false, true));
        let (one, v_one) = run(&scene_one);
        let (split, v_split) = run(&scene_split);
        eprintln!("varying links over the frames: {v_one} as one object, {v_split} split");
        assert!(v_one < v_split);
        for t in [0.0, 0.6, 1.0] {
            let pts = trough_points(t);
            let fixed = |scene: &Scene| {
                let mut s =
                    Solver::at_time(scene, SolveOptions::default(), t, [0.0, 1.0]).expect("solver");
                s.freeze_motion();
                s.run(|_, _| {}).expect("static solve");
                s.solution()
            };
            // The stored leaves with the patches of a static solve.
            let stored = |scene: &Scene, base: &Solution, leaves: &[Leaf]| Solution {
                scene: scene.clone(),
                patches: base.patches.clone(),
                leaves: leaves.to_vec(),
                stats: SolveStats::default(),
            };
            let (base_one, base_split) = (fixed(&scene_one), fixed(&scene_split));
            let b_one = probe(&stored(&scene_one, &base_one, &one), &pts, t).expect("probe");
            let b_split =
                probe(&stored(&scene_split, &base_split, &split), &pts, t).expect("probe");
            let b_static = probe(&base_one, &pts, t).expect("probe");
            let (apart, from_static) = (
                relative_rms(&b_one, &b_split),
                relative_rms(&b_one, &b_static),
            );
            eprintln!(
                "t = {t}: as one object {:.3}% from split, {:.3}% from the static solve ({:.3}% split)",
                apart * 100.0,
                from_static * 100.0,
                relative_rms(&b_split, &b_static) * 100.0
            );
            assert!(apart < 0.005 && from_static < 0.015, "t = {t}");
        }
    }

    #[test]
    fn closed_leaves_come_out_in_the_file_order() {
        // Leaves of 7 start times, 3 patches and 6 first corners (each its own cell),
        // closed in a scrambled order (blocks of the scatter pass cross buckets).
        let mut leaves = Vec::new();
        for i in 0..(7 * 3 * 6 * 500) {
            let h = crate::oracle::hash3(i as u64, 17, 3);
            let u = (h % 6) as f32 / 8.0;
            leaves.push(Leaf {
                patch: (h >> 8) as u32 % 3,
                corners: 4,
                time: [((h >> 16) % 7) as f32 * 0.04, 1.0],
                uv: [[u, 0.0], [u + 0.1, 0.0], [u + 0.1, i as f32], [u, i as f32]],
                b: [[i as f32; 3]; 4],
            });
        }
        let mut expected = leaves.clone();
        expected.sort_by(|a, b| {
            a.time[0]
                .total_cmp(&b.time[0])
                .then(a.patch.cmp(&b.patch))
                .then_with(|| {
                    let bits = |l: &Leaf| l.uv.map(|c| c.map(f32::to_bits));
                    bits(a).cmp(&bits(b))
                })
        });
        let dir = tempfile::tempdir().expect("tempdir");
        for storage in [Storage::Ram, Storage::Mmap(dir.path().to_path_buf())] {
            let mut closed = Column::new(&storage, "closed").expect("column");
            closed.extend_from_slice(&leaves).expect("extend");
            let sorted = in_file_order(closed, &storage).expect("sort");
            assert_eq!(sorted.is_mapped(), storage != Storage::Ram);
            assert!(sorted.as_slice() == expected.as_slice(), "{storage:?}");
        }
        // Nothing is left in the scratch directory but what was returned (dropped).
        assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
    }

    /// The layout of `n` frames at 25 fps moving `step` of the diameter a frame
    /// (`window` seconds, `stride`: `None` for the defaults), as window lengths and
    /// keyframes.
    fn layout(
        n: usize,
        step: f64,
        window: Option<f64>,
        stride: Option<u32>,
    ) -> (Vec<usize>, Vec<Vec<usize>>) {
        let times: Vec<f64> = (0..n).map(|i| i as f64 / 25.0).collect();
        let st = SpaceTimeOptions {
            window,
            key_stride: stride,
            ..SpaceTimeOptions::default()
        };
        let plans = time_layout(&times, &vec![step; n.saturating_sub(1)], &st);
        // Every frame once, in order; keys from the first frame to the last.
        assert_eq!(
            plans
                .iter()
                .flat_map(|p| p.times.clone())
                .collect::<Vec<_>>(),
            times
        );
        for p in &plans {
            assert_eq!(p.keys.first(), Some(&0));
            assert_eq!(p.keys.last(), Some(&(p.times.len() - 1)));
            assert!(p.keys.windows(2).all(|k| k[0] < k[1]), "{:?}", p.keys);
        }
        (
            plans.iter().map(|p| p.times.len()).collect(),
            plans.into_iter().map(|p| p.keys).collect(),
        )
    }

    #[test]
    fn a_short_tail_joins_the_last_window() {
        let times = instants(0.0, 3.0, 25.0);
        assert_eq!(times.len(), 76);
        let sizes = |n, window| layout(n, 0.0, Some(window), Some(8)).0;
        assert_eq!(sizes(76, 1.0), [25, 25, 26]);
        // A tail of half a window or more stays a window of its own.
        assert_eq!(sizes(63, 1.0), [25, 25, 13]);
        assert_eq!(sizes(5, 0.08), [2, 2, 1]);
        assert_eq!(sizes(3, 1.0), [3]);
        assert_eq!(sizes(1, 1.0), [1]);
        // Windows of `WINDOW_KEYS` key intervals, for a stride too: twelve of 8
        // frames hold ACTOR's 76, and 300 make windows of 97 frames, the short
        // tail joining the last.
        assert_eq!(layout(76, 0.0, None, Some(8)).0, [76]);
        assert_eq!(layout(300, 0.0, None, Some(8)).0, [97, 97, 106]);
    }

    #[test]
    fn keyframes_follow_motion_not_frames() {
        // ACTOR's pace (0.6% of the diameter a frame, under 0.05 over 8 frames, over
        // it at 9): keyframes 8 frames apart, as the stride 8 gave, and its 76
        // frames one window.
        let (sizes, keys) = layout(76, 0.006, None, None);
        assert_eq!(sizes, [76]);
        assert_eq!(keys[0], [0, 8, 16, 24, 32, 40, 48, 56, 64, 72, 75]);
        assert_eq!((sizes, keys), layout(76, 0.006, Some(3.04), Some(8)));
        // The same motion over twice the frames (the paper's length measure, §6):
        // as many windows and keyframes, twice as far apart in frames.
        let (sizes, keys) = layout(151, 0.003, None, None);
        assert_eq!(sizes, [151]);
        assert_eq!(keys[0], [0, 16, 32, 48, 64, 80, 96, 112, 128, 144, 150]);
        // Nothing moving: keyframes at most MAX_KEY_FRAMES apart, and a window
        // every `WINDOW_KEYS` of them.
        let (sizes, keys) = layout(800, 0.0, None, None);
        assert_eq!(sizes, [385, 415]);
        assert_eq!(keys[0], (0..=384).step_by(32).collect::<Vec<_>>());
        // Faster than `key_motion` a frame: every frame a keyframe.
        let (sizes, keys) = layout(30, 0.2, None, None);
        assert_eq!(sizes, [13, 17]);
        assert_eq!(keys[0], (0..13).collect::<Vec<_>>());
        // Motion that starts late: sparse keys while still, dense once it moves.
        let times: Vec<f64> = (0..60).map(|i| i as f64 / 25.0).collect();
        let motion: Vec<f64> = (0..59).map(|i| if i < 40 { 0.0 } else { 0.02 }).collect();
        let plans = time_layout(&times, &motion, &SpaceTimeOptions::default());
        let starts: Vec<usize> = plans
            .iter()
            .scan(0, |at, p| {
                let s = *at;
                *at += p.times.len();
                Some(p.keys.iter().map(move |k| s + k))
            })
            .flatten()
            .collect();
        assert_eq!(starts, [0, 32, 42, 44, 46, 48, 50, 52, 54, 56, 58, 59]);
    }

    proptest::proptest! {
        // No regression file: it would sit in a `proptest-regressions/` at the top
        // of the repository, where only the crate's own directories belong.
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 256,
            failure_persistence: None,
            .. Default::default()
        })]
        /// Whatever the motion: every frame in one window, in order; each key
        /// interval at most `MAX_KEY_FRAMES` frames and, unless it is one frame, no
        /// more than `key_motion` of travel; a key interval ends only where the next
        /// frame would exceed that (or at the cap, or at the window's end); a window
        /// of at most `WINDOW_KEYS` intervals but the last (which may have taken the
        /// tail).
        #[test]
        fn a_motion_layout_keeps_its_promises(
            motion in proptest::collection::vec(
                proptest::prop_oneof![proptest::strategy::Just(0.0), 0.0..0.08f64],
                0..300,
            ),
            key_motion in 0.01..0.2f64,
        ) {
            let n = motion.len() + 1;
            let times: Vec<f64> = (0..n).map(|i| i as f64 / 25.0).collect();
            let st = SpaceTimeOptions { key_motion, ..SpaceTimeOptions::default() };
            let plans = time_layout(&times, &motion, &st);
            let flat: Vec<f64> = plans.iter().flat_map(|p| p.times.clone()).collect();
            proptest::prop_assert_eq!(flat, times);
            let mut first = 0;
            for (w, p) in plans.iter().enumerate() {
                let len = p.times.len();
                proptest::prop_assert_eq!(p.keys.first(), Some(&0));
                proptest::prop_assert_eq!(p.keys.last(), Some(&(len - 1)));
                let intervals = p.keys.len() - 1;
                if w + 1 < plans.len() {
                    proptest::prop_assert!(intervals <= WINDOW_KEYS, "window {w}: {:?}", p.keys);
                }
                for k in p.keys.windows(2) {
                    let (a, b) = (first + k[0], first + k[1]);
                    let travel: f64 = motion[a..b].iter().sum();
                    proptest::prop_assert!(b - a <= MAX_KEY_FRAMES);
                    proptest::prop_assert!(
                        b - a == 1 || travel <= key_motion + 1e-12,
                        "{a}..{b}: {travel}"
                    );
                    // Not cut short: the next frame would be too far, or the cap or
                    // the window's end is reached.
                    let end = first + len - 1;
                    if b < end && b - a < MAX_KEY_FRAMES && k[1] != p.keys[p.keys.len() - 1] {
                        proptest::prop_assert!(travel + motion[b] > key_motion - 1e-12, "{a}..{b}");
                    }
                }
                first += len;
            }
        }
    }

    #[test]
    fn frame_motion_bounds_what_a_moving_point_travels() {
        use crate::scene::actor_scene;
        let scene = actor_scene(75);
        let times = instants(0.0, 3.0, 25.0);
        let diameter = crate::geometry::Patches::at_time(&scene, 0.0).diameter;
        let motion = frame_motion(&scene, &times, diameter);
        assert_eq!(motion.len(), 75);
        // Actor A walks 1 m/s, swaying: a frame moves its corners 4 cm and a little.
        for (i, &m) in motion.iter().enumerate() {
            assert!((0.040..0.045).contains(&(m * diameter)), "frame {i}: {m}");
        }
        // No vertex of a moving object travels further than the bound.
        for obj in scene.objects.iter().filter(|o| o.is_moving()) {
            for (i, w) in times.windows(2).enumerate() {
                let (a, b) = (obj.to_world(w[0]), obj.to_world(w[1]));
                for v in obj.polygons.iter().flat_map(|p| &p.vertices) {
                    let d = a.transform_point3(*v).distance(b.transform_point3(*v));
                    assert!(d <= motion[i] * diameter * (1.0 + 1e-12), "frame {i}: {d}");
                }
            }
        }
        // The same motion played twice as slowly: half the motion a frame, so the
        // same keyframes in motion, twice as far apart in frames.
        let mut slow = scene.clone();
        slow.time.end *= 2.0;
        for obj in &mut slow.objects {
            for k in obj.motion.iter_mut().flat_map(|m| m.keys.iter_mut()) {
                k.t *= 2.0;
            }
        }
        let slow_times = instants(0.0, 6.0, 25.0);
        let slow_motion = frame_motion(&slow, &slow_times, diameter);
        let st = SpaceTimeOptions::default();
        let fast = time_layout(&times, &motion, &st);
        let slow = time_layout(&slow_times, &slow_motion, &st);
        let count = |p: &[WindowPlan]| (p.len(), p.iter().map(|w| w.keys.len()).sum::<usize>());
        assert_eq!(count(&fast), (1, 11));
        assert_eq!(count(&slow), count(&fast));
        assert_eq!(fast[0].keys, [0, 8, 16, 24, 32, 40, 48, 56, 64, 72, 75]);
        assert_eq!(
            slow[0].keys,
            [0, 16, 32, 48, 64, 80, 96, 112, 128, 144, 150]
        );
    }

    #[test]
    fn keyframes_come_before_the_frames_between_them() {
        let key_frames = |n: usize, stride: u32| {
            let (_, mut keys) = layout(n, 0.0, Some(n as f64 / 25.0), Some(stride));
            keys.pop().unwrap_or_default()
        };
        assert_eq!(key_frames(26, 4), [0, 4, 8, 12, 16, 20, 24, 25]);
        assert_eq!(key_frames(25, 4), [0, 4, 8, 12, 16, 20, 24]);
        assert_eq!(key_frames(3, 1), [0, 1, 2]);
        assert_eq!(key_frames(1, 4), [0]);
        assert_eq!(key_frames(0, 4), Vec::<usize>::new());
        // Bisection: the midpoint between the keyframes first, then each half's.
        let frames = |o: &[Step]| o.iter().map(|s| s.frame).collect::<Vec<_>>();
        assert_eq!(
            frames(&solve_order(&[0, 4, 8])),
            [0, 4, 2, 1, 3, 8, 6, 5, 7]
        );
        assert_eq!(frames(&solve_order(&[0, 8])), [0, 8, 4, 2, 1, 3, 6, 5, 7]);
        assert_eq!(before(4, 6), Some(2));
        assert_eq!(before(0, 4), None);
        for (n, stride) in [(26, 4), (25, 8), (5, 2), (1, 3), (7, 1), (26, 7), (40, 16)] {
            let keys = key_frames(n, stride);
            let order = solve_order(&keys);
            // Every frame once.
            let mut sorted = frames(&order);
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "n {n}, stride {stride}");
            let at = |f: usize| {
                order
                    .iter()
                    .position(|s| s.frame == f)
                    .unwrap_or(usize::MAX)
            };
            for (i, step) in order.iter().enumerate() {
                let f = step.frame;
                match (keys.binary_search(&f), step.brackets) {
                    (Ok(_), None) => {}
                    (Err(k), Some((lo, hi))) => {
                        // Between the keyframes of its interval, after both...
                        assert!(keys[k - 1] <= lo && lo < f && f < hi && hi <= keys[k]);
                        assert!(at(lo) < i && at(hi) < i, "n {n}, stride {stride}: {f}");
                        // ...and the nearest frames solved so far on either side.
                        assert!(
                            order[..i].iter().all(|s| s.frame <= lo || s.frame >= hi),
                            "n {n}, stride {stride}: {f} in ({lo}, {hi})"
                        );
                        // Its look-back frame is solved before it too.
                        if let Some(p) = before(lo, hi) {
                            assert!(at(p) < i, "n {n}, stride {stride}: {p} before {f}");
                        }
                        // Solved before the next keyframe.
                        if let Some(&next) = keys.get(k + 1) {
                            assert!(i < at(next), "n {n}, stride {stride}: {f} before {next}");
                        }
                    }
                    other => panic!("n {n}, stride {stride}: frame {f} is {other:?}"),
                }
            }
        }
    }
}
