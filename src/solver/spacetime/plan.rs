//! The plan of a space-time solve: how far the moving objects travel between frames
//! ([`frame_motion`]), the windows and their keyframes spaced by that motion
//! ([`time_layout`]), the order a window's frames are solved in (each keyframe, then
//! the frames between by bisection, [`solve_order`]; Damez & Sillion, paper 001,
//! §4.3), and the boxes the moving objects sweep over a time range
//! ([`swept_boxes`]), which a window classifies its links against (§7 item 1).
//!
//! What it does not do: solve anything. It reads the scene's motion only.

use glam::DVec3;

use super::SpaceTimeOptions;
use crate::scene::Scene;

/// Key intervals per window when `--window` is not given ([`time_layout`]).
///
/// A window's start costs more than a keyframe (the window before ends on a
/// keyframe, this one starts on the next frame, and its first frame gathers every
/// point afresh), while a longer window sweeps larger boxes, so more of
/// its links vary; on ACTOR and LIGHT the starts saved outweigh that, at the same
/// peak memory (BENCHMARKS.md, "Longer windows; hull planes made one at a time"). At
/// most `WINDOW_KEYS · MAX_KEY_FRAMES + 1` frames are lost when a solve is
/// interrupted.
pub const WINDOW_KEYS: usize = 12;

/// Most frames from one keyframe to the next when keyframes are spaced by motion
/// ([`time_layout`]): where nothing moves, a window still ends every
/// `WINDOW_KEYS · MAX_KEY_FRAMES + 1` frames, so an interrupted solve loses at most
/// that many and a bisection looks back over at most five levels.
pub const MAX_KEY_FRAMES: usize = 32;

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
/// they allow it ([`FrameBetween`](crate::solver::FrameBetween)), so a point gathered at the midpoint because a
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
/// line through time ([`FrameBetween::before`](crate::solver::FrameBetween::before)): as far before `lo` as `hi` is after.
pub(super) fn before(lo: usize, hi: usize) -> Option<usize> {
    lo.checked_sub(hi - lo)
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
pub(in crate::solver) fn sweep_times(
    track: Option<&crate::scene::MotionTrack>,
    t0: f64,
    t1: f64,
) -> Vec<f64> {
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
