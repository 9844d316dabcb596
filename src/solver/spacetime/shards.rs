//! A space-time solve cut into shards for a job scheduler: the whole solve's plan
//! ([`Plan`]: its windows, their frames, keyframes and time spans, and an estimated
//! cost per window from the motion), and its split into `N` contiguous runs of
//! windows of about equal cost ([`Plan::shards`]).
//!
//! A window depends on no other (`Solver::release_window`), so a shard solves the
//! shared part (which every window starts from, the same in every shard) and then
//! its own windows, and writes the leaves a solve on one machine writes for them.
//! The plan is a function of the scene and the settings
//! alone (the solver's own [`frame_motion`] and [`time_layout`], with the scene's
//! diameter as the solver computes it), so every array task of a farm finds the same
//! windows and the same shards without talking to the others.
//!
//! **Cost.** A window costs its start, its keyframes (a final gather at every point)
//! and its frames between: those whose brackets lie within `interp_motion` of each
//! other in motion take the line at every point and skip their solve (cheap), the
//! others test their points and may solve ([`FrameBetween`](crate::solver::FrameBetween)). The weights are
//! in keyframes ([`START_COST`], [`TESTED_COST`], [`FREE_COST`]), set by hand (a
//! window's start costs about a keyframe, BENCHMARKS.md, "Longer windows"), not
//! fitted; how even the shards come out is measured in BENCHMARKS.md, "Farm". The
//! split minimises the costliest shard over every contiguous split (a dynamic
//! programme over the windows).

use std::ops::Range;

use super::{SpaceTimeOptions, WindowPlan, frame_motion, solve_order, time_layout};
use crate::Result;
use crate::scene::Scene;
use crate::solver::SolveOptions;
use crate::solver::frames::{frame_instants, frame_range};

/// Estimated cost of a window's start (re-classifying the links, refining those
/// constant in the window), in keyframes.
pub const START_COST: f64 = 1.0;
/// Estimated cost of a frame between two solved frames that tests its points, in
/// keyframes.
pub const TESTED_COST: f64 = 0.3;
/// Estimated cost of a frame between two solved frames close enough in motion to
/// take the line at every point (`interp_motion`), in keyframes.
pub const FREE_COST: f64 = 0.05;

/// The windows of a whole space-time solve and their estimated costs.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Frame times and keyframes of each window, earliest first (what
    /// [`super::SpaceTime`] solves).
    pub windows: Vec<WindowPlan>,
    /// Index in the animation of each window's first frame.
    pub first_frames: Vec<usize>,
    /// Time range of each window: its first frame's start to its last frame's end.
    pub spans: Vec<[f64; 2]>,
    /// Estimated cost of each window, in keyframes.
    pub costs: Vec<f64>,
    /// Frames in the animation.
    pub frames: usize,
}

/// The plan of the space-time solve of `scene` with `opts` and `st`: the windows
/// [`super::SpaceTime::new`] makes, without solving anything (the patches are
/// placed at the start time, and cut at contacts when the solver cuts them, for the
/// scene's diameter).
pub fn plan(scene: &Scene, opts: &SolveOptions, st: &SpaceTimeOptions) -> Result<Plan> {
    st.validate()?;
    opts.validate()?;
    let diameter = plan_patches(scene, opts).diameter;
    let times = frame_instants(scene.time, st.fps)?;
    let motion = frame_motion(scene, &times, diameter);
    let windows = time_layout(&times, &motion, st);
    Ok(Plan::of(scene, windows, &motion, st))
}

/// The patches the solver starts from (placed at the start time, cut at contacts
/// unless `--no-contact-meshing`): what a shard with no window writes as its file's
/// patches, and the diameter keyframes are spaced by.
pub fn plan_patches(scene: &Scene, opts: &SolveOptions) -> crate::geometry::Patches {
    let patches = crate::geometry::Patches::at_time(scene, scene.time.start);
    if opts.contact_meshing {
        crate::geometry::split_at_contacts(scene, &patches, scene.time.start).0
    } else {
        patches
    }
}

impl Plan {
    /// The plan of `windows` (from [`time_layout`]) with `motion` from
    /// [`frame_motion`]: spans and costs.
    pub fn of(
        scene: &Scene,
        windows: Vec<WindowPlan>,
        motion: &[f64],
        st: &SpaceTimeOptions,
    ) -> Plan {
        let frames: usize = windows.iter().map(|w| w.times.len()).sum();
        let mut first_frames = Vec::with_capacity(windows.len());
        let mut at = 0;
        for w in &windows {
            first_frames.push(at);
            at += w.times.len();
        }
        let spans = windows
            .iter()
            .zip(&first_frames)
            .map(|(w, &f)| {
                let last = f + w.times.len() - 1;
                [
                    frame_range(f, frames, scene.time, st.fps)[0],
                    frame_range(last, frames, scene.time, st.fps)[1],
                ]
            })
            .collect();
        let costs = windows
            .iter()
            .zip(&first_frames)
            .map(|(w, &f)| window_cost(w, &motion[f.min(motion.len())..], st))
            .collect();
        Plan {
            windows,
            first_frames,
            spans,
            costs,
            frames,
        }
    }

    /// The windows of each of `n` shards: contiguous runs, in order, covering every
    /// window, of about equal estimated cost (the costliest as cheap as any
    /// contiguous split makes it). With more shards than windows, the last shards
    /// hold none.
    pub fn shards(&self, n: usize) -> Vec<Range<usize>> {
        let bounds = split_bounds(&self.costs, n.max(1));
        bounds.windows(2).map(|b| b[0]..b[1]).collect()
    }

    /// Time range of the windows `r` (`[t, t]` at the start of the next window, or
    /// the end of the animation, when `r` is empty).
    pub fn span_of(&self, r: &Range<usize>) -> [f64; 2] {
        if r.is_empty() {
            let t = self
                .spans
                .get(r.start)
                .map_or_else(|| self.spans.last().map_or(0.0, |s| s[1]), |s| s[0]);
            return [t, t];
        }
        [self.spans[r.start][0], self.spans[r.end - 1][1]]
    }
}

/// Estimated cost of window `w` whose frames move `motion` (from its first frame
/// on), in keyframes (module docs).
fn window_cost(w: &WindowPlan, motion: &[f64], st: &SpaceTimeOptions) -> f64 {
    let mut cost = START_COST;
    for step in solve_order(&w.keys) {
        cost += match step.brackets {
            None => 1.0,
            Some((lo, hi)) => {
                let travel: f64 = motion[lo.min(motion.len())..hi.min(motion.len())]
                    .iter()
                    .sum();
                if st.interp_motion > 0.0 && travel <= st.interp_motion {
                    FREE_COST
                } else {
                    TESTED_COST
                }
            }
        };
    }
    cost
}

/// Bounds `0 = b_0 <= b_1 <= … <= b_n = costs.len()` of the contiguous split of
/// `costs` into `n` runs whose largest sum is smallest (the first such split in
/// the order the programme finds it, so the same costs always give the same
/// bounds); with `n` at least the number of windows, one window a run and empty
/// runs after.
pub fn split_bounds(costs: &[f64], n: usize) -> Vec<usize> {
    let w = costs.len();
    if n >= w {
        return (0..=n).map(|k| k.min(w)).collect();
    }
    let mut prefix = vec![0.0; w + 1];
    for (i, c) in costs.iter().enumerate() {
        prefix[i + 1] = prefix[i] + c;
    }
    // best[k][j]: smallest largest run splitting the first j windows into k runs
    // (each non-empty); cut[k][j]: where the last of them starts.
    let mut best = vec![vec![f64::INFINITY; w + 1]; n + 1];
    let mut cut = vec![vec![0usize; w + 1]; n + 1];
    best[0][0] = 0.0;
    for k in 1..=n {
        for j in k..=w {
            for i in (k - 1)..j {
                let v = best[k - 1][i].max(prefix[j] - prefix[i]);
                if v < best[k][j] {
                    best[k][j] = v;
                    cut[k][j] = i;
                }
            }
        }
    }
    let mut bounds = vec![w; n + 1];
    let mut j = w;
    for k in (1..=n).rev() {
        bounds[k] = j;
        j = cut[k][j];
    }
    bounds[0] = 0;
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Largest run of a split.
    fn largest(costs: &[f64], b: &[usize]) -> f64 {
        b.windows(2)
            .map(|r| costs[r[0]..r[1]].iter().sum::<f64>())
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_split_is_the_best_of_every_contiguous_split() {
        let costs = [3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0];
        for n in 1..=costs.len() {
            let b = split_bounds(&costs, n);
            assert_eq!((b[0], b[n], b.len()), (0, costs.len(), n + 1));
            assert!(b.windows(2).all(|r| r[0] < r[1]), "{b:?}");
            // Brute force over every choice of n - 1 cuts among the 7 places.
            let mut brute = f64::INFINITY;
            for mask in 0u32..(1 << (costs.len() - 1)) {
                if mask.count_ones() as usize != n - 1 {
                    continue;
                }
                let mut bb = vec![0];
                bb.extend((1..costs.len()).filter(|i| mask & (1 << (i - 1)) != 0));
                bb.push(costs.len());
                brute = brute.min(largest(&costs, &bb));
            }
            assert_eq!(largest(&costs, &b), brute, "n = {n}: {b:?}");
        }
        // More shards than windows: one each, then empty ones.
        assert_eq!(split_bounds(&[1.0, 2.0], 4), vec![0, 1, 2, 2, 2]);
    }
}
