//! The frame-by-frame baseline (`rhier solve --per-frame --fps F`): an independent
//! static solve of every frame of an animation with the same spatial parameters —
//! the comparison Damez & Sillion make for space-time radiosity (section 6: "a static
//! radiosity algorithm, for each frame, using the same spatial refinement
//! parameters"), and a reference for it.
//!
//! How it works: [`frame_times`] places the frames and their intervals (the same
//! frames as space-time's, [`super::frames`]). Each frame is
//! placed by [`Solver::at_time`] with its leaves labelled with that interval, frozen
//! ([`Solver::freeze_motion`]: solved as a static scene is, with every shortcut a
//! static solve takes), run to completion and reconstructed; [`solve_per_frame`]
//! hands each frame's [`Solution`] to a callback and drops it, so memory holds one
//! frame whatever the animation's length (`rhier solve --per-frame` hands each to
//! the store's `FrameWriter`, one chunk per frame).
//!
//! What it does not do: share anything between frames (that is the space-time
//! solver's job), or interpolate between frames: playback at `t` shows the frame
//! whose interval holds `t`.

use std::time::Instant;

pub use super::frames::frame_times;
use super::{Solution, SolveOptions, SolveStats, Solver, StopReason};
use crate::Result;
use crate::scene::Scene;

/// One frame of a per-frame solve: its time, interval and what the solve cost.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    /// Frame number, from 0.
    pub index: u32,
    /// The frame's time `t_i`.
    pub t: f64,
    /// The interval the frame's leaves hold over.
    pub range: [f64; 2],
    /// Wall-clock seconds of this frame (solve and reconstruction).
    pub seconds: f64,
    /// Refine-and-solve rounds run.
    pub rounds: u32,
    /// Stored leaves (reconstruction cells) of the frame.
    pub leaves: u64,
    /// Elements of the frame's hierarchy.
    pub elements: u64,
    /// Active links.
    pub links_active: u64,
    /// Passive (refined) links.
    pub links_passive: u64,
    /// Estimated relative error of the last round.
    pub estimated_error: f64,
    /// Why the frame's solve stopped refining ([`StopReason::NotRun`] for a frame
    /// of a scene with no emitter, [`zero_per_frame`]).
    pub stop: StopReason,
}

impl FrameReport {
    /// CSV header matching [`FrameReport::csv_row`].
    pub const CSV_HEADER: &'static str =
        "frame,t,t0,t1,seconds,rounds,leaves,elements,links_active,links_passive,estimated_error";

    /// One CSV row (no newline).
    pub fn csv_row(&self) -> String {
        format!(
            "{},{},{},{},{:.6},{},{},{},{},{},{:.6e}",
            self.index,
            self.t,
            self.range[0],
            self.range[1],
            self.seconds,
            self.rounds,
            self.leaves,
            self.elements,
            self.links_active,
            self.links_passive,
            self.estimated_error
        )
    }

    /// The line `solve --per-frame` prints per frame.
    pub fn summary(&self) -> String {
        format!(
            "frame {:4}  t {:8.4} s  {:8.3} s  {:7} leaves  {:8} links ({} passive)  est. error {:.3e}  stopped: {}",
            self.index,
            self.t,
            self.seconds,
            self.leaves,
            self.links_active + self.links_passive,
            self.links_passive,
            self.estimated_error,
            self.stop.text()
        )
    }
}

/// Totals of a per-frame solve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PerFrameStats {
    /// Frames solved.
    pub frames: u32,
    /// Leaves over all frames.
    pub leaves: u64,
    /// Statistics for the `.rhier` file: `seconds` and `iterations` summed over the
    /// frames, the other counters the largest of any frame (what one frame holds in
    /// memory), errors the worst frame's.
    pub stats: SolveStats,
}

/// Solves every frame of `scene` at `fps` (see the module header) with `opts`,
/// earliest first, and calls `on_frame` with each frame's report and solution before
/// solving the next; an error from `on_frame` stops the loop and is returned.
pub fn solve_per_frame(
    scene: &Scene,
    opts: &SolveOptions,
    fps: f64,
    mut on_frame: impl FnMut(&FrameReport, &Solution) -> Result<()>,
) -> Result<PerFrameStats> {
    let mut total = PerFrameStats::default();
    for (index, (t, range)) in frame_times(scene.time, fps)?.into_iter().enumerate() {
        let start = Instant::now();
        let label = [range[0] as f32, range[1] as f32];
        let mut solver = Solver::at_time(scene, opts.clone(), t, label)?;
        solver.freeze_motion();
        let records = solver.run(|_, _| {})?;
        let mut solution = solver.solution();
        let stop = solver.stop_reason();
        drop(solver);
        let seconds = start.elapsed().as_secs_f64();
        let s = &mut solution.stats;
        s.seconds = seconds;
        s.iterations = records.len() as u32;
        if let Some(last) = records.last() {
            s.estimated_error = last.estimated_error;
            s.residual = last.residual;
        }
        let report = FrameReport {
            index: index as u32,
            t,
            range,
            seconds,
            rounds: s.iterations,
            leaves: solution.leaves.len() as u64,
            elements: s.elements,
            links_active: s.links_active,
            links_passive: s.links_passive,
            estimated_error: s.estimated_error,
            stop,
        };
        let a = &mut total.stats;
        a.seconds += seconds;
        a.iterations += s.iterations;
        a.elements = a.elements.max(s.elements);
        a.links_active = a.links_active.max(s.links_active);
        a.links_passive = a.links_passive.max(s.links_passive);
        a.estimated_error = a.estimated_error.max(s.estimated_error);
        a.residual = a.residual.max(s.residual);
        total.frames += 1;
        total.leaves += report.leaves;
        on_frame(&report, &solution)?;
    }
    Ok(total)
}

/// The frames of a scene with no emitter, known without solving: the frames of
/// [`solve_per_frame`], each the scene's [`Solution::zero`] with its leaves labelled
/// with the frame's interval, handed to `on_frame` with a report of no round.
pub fn zero_per_frame(
    scene: &Scene,
    fps: f64,
    mut on_frame: impl FnMut(&FrameReport, &Solution) -> Result<()>,
) -> Result<PerFrameStats> {
    let mut total = PerFrameStats::default();
    let mut solution = Solution::zero(scene);
    for (index, (t, range)) in frame_times(scene.time, fps)?.into_iter().enumerate() {
        let start = Instant::now();
        let label = [range[0] as f32, range[1] as f32];
        for leaf in &mut solution.leaves {
            leaf.time = label;
        }
        let seconds = start.elapsed().as_secs_f64();
        let report = FrameReport {
            index: index as u32,
            t,
            range,
            seconds,
            rounds: 0,
            leaves: solution.leaves.len() as u64,
            elements: 0,
            links_active: 0,
            links_passive: 0,
            estimated_error: 0.0,
            stop: StopReason::NotRun,
        };
        total.stats.seconds += seconds;
        total.frames += 1;
        total.leaves += report.leaves;
        on_frame(&report, &solution)?;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::TimeDomain;

    fn domain(start: f64, end: f64) -> TimeDomain {
        TimeDomain { start, end }
    }

    #[test]
    fn frames_tile_the_domain() {
        let f = frame_times(domain(0.0, 3.0), 25.0).unwrap();
        assert_eq!(f.len(), 76);
        assert_eq!(f[0], (0.0, [0.0, 0.02]));
        assert_eq!(f[75].0, 3.0);
        assert_eq!(f[75].1, [2.98, 3.0]);
        for w in f.windows(2) {
            assert_eq!(w[0].1[1], w[1].1[0]);
            assert!(w[0].1[0] <= w[0].0 && w[0].0 < w[0].1[1]);
        }
        // Round-off in (end - start) * fps: 0.3 s at 10 fps is frames 0, 0.1, 0.2, 0.3.
        assert_eq!(frame_times(domain(0.0, 0.3), 10.0).unwrap().len(), 4);
        // The last frame reaches the end of a domain that is not a whole number of
        // frames: frames 0 and 0.5 at 2 fps over [0, 0.9], the last over [0.25, 0.9].
        let f = frame_times(domain(0.0, 0.9), 2.0).unwrap();
        assert_eq!(f, vec![(0.0, [0.0, 0.25]), (0.5, [0.25, 0.9])]);
        // A static domain: one frame at its instant.
        assert_eq!(
            frame_times(domain(1.5, 1.5), 25.0).unwrap(),
            vec![(1.5, [1.5, 1.5])]
        );
        assert!(frame_times(domain(0.0, 1.0), 0.0).is_err());
        assert!(frame_times(domain(0.0, 1.0), f64::NAN).is_err());
        assert!(frame_times(domain(0.0, f64::INFINITY), 25.0).is_err());
    }
}
