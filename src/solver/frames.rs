//! The frames of an animation, one definition for the per-frame baseline and the
//! space-time windows: frame `i` at `t_i = start + i/F`, `i = 0 ..= floor((end −
//! start)·F)`, holding the interval of the times nearer to it than to any other
//! frame, `[t_i − 1/(2F), t_i + 1/(2F)]` clipped to the time domain. The first frame's
//! interval starts at the domain's start and the last's reaches its end, so every time
//! of the domain is covered by exactly one frame; consecutive intervals share their
//! bounds, computed once from the index, so that [`crate::solution::Leaf::is_live`]
//! picks exactly one frame at a bound.

use crate::scene::TimeDomain;
use crate::{Error, Result};

/// How many frames `time` has at `fps` frames per second. An error if `fps` is not a
/// positive finite number, the domain is not finite, or the count does not fit a
/// `u32`.
pub fn frame_count(time: TimeDomain, fps: f64) -> Result<usize> {
    let (start, end) = (time.start, time.end);
    if !(fps.is_finite() && fps > 0.0) {
        return Err(Error::Usage(format!(
            "--fps: expected a positive number of frames per second, found {fps}"
        )));
    }
    if !(start.is_finite() && end.is_finite() && end >= start) {
        return Err(Error::Usage(format!(
            "expected a finite time domain with start <= end, found [{start}, {end}]"
        )));
    }
    // Tolerate round-off in (end - start) * fps (0.3 s at 10 fps is 4 frames, not 3).
    let last = ((end - start) * fps + 1e-9).floor();
    if last > u32::MAX as f64 - 1.0 {
        return Err(Error::Usage(format!(
            "{last} frames at {fps} fps is too many"
        )));
    }
    Ok(last as usize + 1)
}

/// The interval frame `i` of `n` holds for (module docs).
pub fn frame_range(i: usize, n: usize, time: TimeDomain, fps: f64) -> [f64; 2] {
    let (start, end) = (time.start, time.end);
    // Bound between frame k and k + 1.
    let bound = |k: usize| (start + (k as f64 + 0.5) / fps).clamp(start, end);
    let t0 = if i == 0 { start } else { bound(i - 1) };
    let t1 = if i + 1 >= n { end } else { bound(i) };
    [t0, t1]
}

/// Every frame's instant and interval (module docs); a static domain (`start ==
/// end`) has the single frame `start` over `[start, start]`. Errors as
/// [`frame_count`].
pub fn frame_times(time: TimeDomain, fps: f64) -> Result<Vec<(f64, [f64; 2])>> {
    let n = frame_count(time, fps)?;
    Ok((0..n)
        .map(|i| {
            let t = (time.start + i as f64 / fps).min(time.end);
            (t, frame_range(i, n, time, fps))
        })
        .collect())
}

/// Every frame's instant (module docs). Errors as [`frame_count`].
pub fn frame_instants(time: TimeDomain, fps: f64) -> Result<Vec<f64>> {
    Ok(frame_times(time, fps)?.into_iter().map(|f| f.0).collect())
}
