//! Error against run time: one [`RoundRecord`] per refine-and-solve round, printed by
//! `solve` and written as CSV by `--report`, and the [`StopReason`] the last line says.

use std::io::Write;
use std::path::Path;

use crate::{Error, Result};

/// What one round cost and reached.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct RoundRecord {
    /// Round number (0 = first refinement of the root link).
    pub round: u32,
    /// Seconds since the solve started (after loading).
    pub seconds: f64,
    /// Elements (all levels, clusters included).
    pub elements: u64,
    /// Leaves (the unknowns).
    pub leaves: u64,
    /// Active links.
    pub links_active: u64,
    /// Passive (refined) links.
    pub links_passive: u64,
    /// Bytes in the element pool.
    pub bytes_elements: u64,
    /// Bytes in the link pool.
    pub bytes_links: u64,
    /// Bytes in the BVHs.
    pub bytes_bvh: u64,
    /// Occlusion rays cast this round.
    pub rays: u64,
    /// Links settled by a shaft without rays this round.
    pub shaft_clear: u64,
    /// Estimated relative RMS error from the active links' error bounds.
    pub estimated_error: f64,
    /// Relative residual of the linear solve.
    pub residual: f64,
    /// True error at the reference points (with `--reference`): off the emitters,
    /// over all points and the worst point.
    pub true_error: Option<crate::solution::PointError>,
}

impl RoundRecord {
    /// CSV header matching [`RoundRecord::csv_row`].
    pub const CSV_HEADER: &'static str = "round,seconds,elements,leaves,links_active,links_passive,bytes_elements,bytes_links,bytes_bvh,rays,shaft_clear,estimated_error,residual,true_error,true_error_all,worst_point,worst_error";

    /// One CSV row.
    pub fn csv_row(&self) -> String {
        format!(
            "{},{:.6},{},{},{},{},{},{},{},{},{},{:.6e},{:.3e},{}",
            self.round,
            self.seconds,
            self.elements,
            self.leaves,
            self.links_active,
            self.links_passive,
            self.bytes_elements,
            self.bytes_links,
            self.bytes_bvh,
            self.rays,
            self.shaft_clear,
            self.estimated_error,
            self.residual,
            self.true_error.map_or(",,,".to_string(), |e| {
                let worst = if e.worst == usize::MAX {
                    ",".to_string()
                } else {
                    format!("{},{:.6e}", e.worst, e.worst_error)
                };
                format!("{:.6e},{:.6e},{worst}", e.off_emitters, e.all)
            })
        )
    }

    /// A one-line human summary.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "round {:>2}  {:>8.3} s  {:>8} elements  {:>8} leaves  {:>9} links ({} passive)  {:>7.1} MiB  est. error {}  residual {:.1e}",
            self.round,
            self.seconds,
            self.elements,
            self.leaves,
            self.links_active,
            self.links_passive,
            (self.bytes_elements + self.bytes_links + self.bytes_bvh) as f64 / (1024.0 * 1024.0),
            estimate_text(self.estimated_error),
            self.residual
        );
        if let Some(e) = self.true_error {
            s.push_str(&format!("  true error {}", e.text()));
        }
        s
    }
}

/// An estimated error for people: `n/a` where there is none (NaN: a first round,
/// or a solve that estimates nothing).
pub fn estimate_text(e: f64) -> String {
    if e.is_nan() {
        "n/a".to_string()
    } else {
        format!("{e:.3e}")
    }
}

/// Writes the records as CSV to `path`.
pub fn write_csv(path: &Path, records: &[RoundRecord]) -> Result<()> {
    let mut out = String::from(RoundRecord::CSV_HEADER);
    out.push('\n');
    for r in records {
        out.push_str(&r.csv_row());
        out.push('\n');
    }
    let mut f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    f.write_all(out.as_bytes()).map_err(|e| Error::io(path, e))
}

/// Why a static solve stopped refining, said on its last line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum StopReason {
    /// No run yet (or a scene with no surface).
    #[default]
    NotRun,
    /// The estimated error reached `--target-error`.
    TargetMet,
    /// No link is left above the refinement threshold `--eps`.
    Refined,
    /// The links left above `--eps` cannot split: their elements are at the
    /// `--min-size` floor.
    MinSize {
        /// Links above the threshold that stayed whole.
        links: u64,
    },
    /// No link is left above a finer `eps` that the error estimate asked for:
    /// with no `--target-error`, the estimate was still above what `--eps`
    /// promises ([`crate::solver::SolveOptions::promised_error`]) once every link
    /// was under `--eps`, and `eps` was halved `halvings` times.
    PromiseMet {
        /// Times `eps` was halved below `--eps`.
        halvings: u32,
    },
    /// `--time-budget` ran out.
    TimeBudget,
    /// `--max-rounds` rounds were solved.
    RoundLimit,
}

impl StopReason {
    /// The reason in words, for the last line of a solve.
    pub fn text(self) -> String {
        match self {
            StopReason::NotRun => "nothing to refine".into(),
            StopReason::TargetMet => "target error met (--target-error)".into(),
            StopReason::Refined => "no link left above --eps".into(),
            StopReason::MinSize { links } => format!(
                "no link left to refine: {links} link(s) above --eps have both ends at the --min-size floor (a smaller --min-size refines further)"
            ),
            StopReason::PromiseMet { halvings } => format!(
                "estimated error under what --eps promises (eps/20), after refining to eps/{}",
                1u64 << halvings.min(63)
            ),
            StopReason::TimeBudget => "time budget spent (--time-budget)".into(),
            StopReason::RoundLimit => "round limit reached (--max-rounds)".into(),
        }
    }
}

/// Why the solves of several frames stopped, in words for the last line of a
/// per-frame solve: the reason "in every frame" when all agree, else each reason
/// with its number of frames, in order of first appearance ("round limit reached
/// (--max-rounds) in 3 frames, no link left above --eps in 73 frames"). Frames that
/// stopped at the `--min-size` floor count as one reason, said with the largest
/// number of links any of them left.
pub fn stop_tally(reasons: &[StopReason]) -> String {
    let same =
        |a: &StopReason, b: &StopReason| std::mem::discriminant(a) == std::mem::discriminant(b);
    let mut kinds: Vec<(StopReason, usize)> = Vec::new();
    for r in reasons {
        match kinds.iter_mut().find(|(k, _)| same(k, r)) {
            Some((k, n)) => {
                *n += 1;
                if let (StopReason::MinSize { links }, StopReason::MinSize { links: more }) = (k, r)
                {
                    *links = (*links).max(*more);
                }
            }
            None => kinds.push((*r, 1)),
        }
    }
    match kinds.as_slice() {
        [] => StopReason::NotRun.text(),
        [(k, _)] => format!("{} in every frame", k.text()),
        _ => kinds
            .iter()
            .map(|(k, n)| {
                format!(
                    "{} in {n} frame{}",
                    k.text(),
                    if *n == 1 { "" } else { "s" }
                )
            })
            .collect::<Vec<_>>()
            .join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stop_tally_counts_frames_by_reason() {
        use StopReason::*;
        assert_eq!(stop_tally(&[]), "nothing to refine");
        assert_eq!(
            stop_tally(&[Refined, Refined]),
            "no link left above --eps in every frame"
        );
        assert_eq!(
            stop_tally(&[RoundLimit, Refined, RoundLimit]),
            "round limit reached (--max-rounds) in 2 frames, no link left above --eps in 1 frame"
        );
        let t = stop_tally(&[MinSize { links: 3 }, MinSize { links: 7 }]);
        assert!(t.starts_with("no link left to refine: 7 link(s)"), "{t}");
        assert!(t.ends_with(") in every frame"), "{t}");
    }
}
