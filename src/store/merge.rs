//! Merging the parts of a space-time solve run as shards (`rhier merge`): the files
//! that `rhier solve --shard K/N` wrote, each holding a contiguous run of the solve's
//! windows, become one file that plays, probes and inspects as a solve on one
//! machine does.
//!
//! How it works: every part is opened and validated ([`super::Reader::open`]) and must
//! carry a provenance record (formats/rhier.md, version 2). The parts must share the
//! fingerprint (the scene and every setting that changes the result, the resume
//! journal's [`super::journal::fingerprint`]), the shard count, the window count and
//! the patches; each shard index `0..N` must be there exactly once, and their windows
//! `first..end` must tile `0..windows` with no gap and no overlap, as must their time
//! ranges tile the scene's. Anything else is refused with an error naming the part
//! (or, for a gap, the missing shard and the windows and times it should hold).
//!
//! The merged file is written as the solver writes one ([`super::Writer`]): through
//! `<out>.tmp`, renamed only once whole, so a merge that fails leaves no file that
//! reads as valid (and an existing `<out>` untouched). The scene, patch and chunk
//! sections are copied as they are stored, their CRCs checked, never decoded or
//! re-encoded; the chunk index is rebuilt (each chunk's `carry_from` over the merged
//! chunks), and the provenance becomes shard 0 of 1 over every window.

use std::path::{Path, PathBuf};

use super::records::ProvenanceRecord;
use super::{Reader, Writer};
use crate::error::{Error, Result};
use crate::solution::SolveStats;

/// What a merge wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct MergeReport {
    /// Parts merged, in window order.
    pub parts: Vec<PathBuf>,
    /// Windows of the solve.
    pub windows: u32,
    /// Chunks copied.
    pub chunks: usize,
    /// Bytes of the merged file.
    pub bytes: u64,
}

/// Merges the `parts` of one space-time solve into `out` (see the module docs).
pub fn merge(parts: &[PathBuf], out: &Path) -> Result<MergeReport> {
    if parts.is_empty() {
        return Err(Error::Usage("merge: no part given".into()));
    }
    for p in parts {
        if same_file(p, out) {
            return Err(Error::Usage(format!(
                "merge: the output {} is one of the parts",
                out.display()
            )));
        }
    }
    let mut opened = Vec::with_capacity(parts.len());
    for p in parts {
        let r = Reader::open(p)?;
        let Some(prov) = r.provenance().cloned() else {
            return Err(Error::invalid(
                p,
                "section table",
                "a provenance section (a part written by `rhier solve --shard K/N`)",
                "none: a static or per-frame solve, or a file older than format version 2",
            ));
        };
        opened.push((r, prov));
    }
    check_same_solve(&opened)?;
    opened.sort_by_key(|(_, p)| (p.first, p.end, p.shard));
    check_shards(&opened)?;
    check_coverage(&opened)?;
    let (first, first_prov) = &opened[0];
    let mut w = Writer::create_copying(out, first)?;
    let mut chunks = 0;
    for (r, p) in &opened {
        for (k, c) in r.chunks().iter().enumerate() {
            if c.t0 < p.time[0] || c.t1 > p.time[1] {
                return Err(Error::invalid(
                    r.path(),
                    format!("chunk {k}"),
                    format!(
                        "a chunk inside the part's time range [{}, {}]",
                        p.time[0], p.time[1]
                    ),
                    format!("[{}, {}]", c.t0, c.t1),
                ));
            }
            w.copy_chunk(r, k)?;
            chunks += 1;
        }
    }
    let td = first.time_domain();
    w.set_provenance(ProvenanceRecord {
        fingerprint: first_prov.fingerprint.clone(),
        windows: first_prov.windows,
        first: 0,
        end: first_prov.windows,
        shard: 0,
        shards: 1,
        time: [td.start, td.end],
    });
    let stats = merged_stats(&opened);
    let windows = first_prov.windows;
    let parts: Vec<PathBuf> = opened.iter().map(|(r, _)| r.path().to_path_buf()).collect();
    drop(opened);
    w.finish(&stats)?;
    let bytes = std::fs::metadata(out).map_or(0, |m| m.len());
    Ok(MergeReport {
        parts,
        windows,
        chunks,
        bytes,
    })
}

/// True if `a` and `b` name the same existing file (or the same path).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// Refuses a part of another solve: another fingerprint (naming the first line that
/// differs), shard count, window count or patches than the first part's.
fn check_same_solve(parts: &[(Reader, ProvenanceRecord)]) -> Result<()> {
    let (r0, p0) = &parts[0];
    let patches0 = r0.patches();
    for (r, p) in &parts[1..] {
        if p.fingerprint != p0.fingerprint {
            let differs = super::journal::first_difference(&p0.fingerprint, &p.fingerprint)
                .map_or_else(String::new, |d| format!(" ({d})"));
            return Err(Error::invalid(
                r.path(),
                "provenance (fingerprint)",
                format!("the scene and settings of {}", r0.path().display()),
                format!("a part of a different solve{differs}"),
            ));
        }
        if (p.shards, p.windows) != (p0.shards, p0.windows) {
            return Err(Error::invalid(
                r.path(),
                "provenance (shards)",
                format!(
                    "a shard of {} over {} windows, as {}",
                    p0.shards,
                    p0.windows,
                    r0.path().display()
                ),
                format!("a shard of {} over {} windows", p.shards, p.windows),
            ));
        }
        if r.patches() != patches0 {
            return Err(Error::invalid(
                r.path(),
                "patches section",
                format!("the patches of {}", r0.path().display()),
                "other patches",
            ));
        }
    }
    Ok(())
}

/// Refuses a shard index given twice, and names every missing one with the windows
/// and times the plan gave it (as far as the parts around it tell).
fn check_shards(parts: &[(Reader, ProvenanceRecord)]) -> Result<()> {
    let n = parts[0].1.shards as usize;
    let mut seen: Vec<Option<&Path>> = vec![None; n];
    for (r, p) in parts {
        if let Some(before) = seen[p.shard as usize] {
            return Err(Error::invalid(
                r.path(),
                "provenance (shard)",
                format!("each of the {n} shards once"),
                format!(
                    "shard {} of {n} again (already in {})",
                    p.shard,
                    before.display()
                ),
            ));
        }
        seen[p.shard as usize] = Some(r.path());
    }
    let missing: Vec<String> = (0..n)
        .filter(|&k| seen[k].is_none())
        .map(|k| {
            // The windows between the parts of the shards around it.
            let lo = parts
                .iter()
                .filter(|(_, p)| (p.shard as usize) < k)
                .map(|(_, p)| p.end)
                .max()
                .unwrap_or(0);
            let hi = parts
                .iter()
                .filter(|(_, p)| (p.shard as usize) > k)
                .map(|(_, p)| p.first)
                .min()
                .unwrap_or(parts[0].1.windows);
            format!("shard {k} (windows {lo}..{hi})")
        })
        .collect();
    if !missing.is_empty() {
        return Err(Error::Usage(format!(
            "merge: {} of the {n} parts missing: {} (failed or not run: re-run that array index, `rhier solve ... --shard K/{n}`)",
            missing.len(),
            missing.join(", ")
        )));
    }
    Ok(())
}

/// Refuses parts (sorted by window) whose windows or times leave a gap or overlap.
fn check_coverage(parts: &[(Reader, ProvenanceRecord)]) -> Result<()> {
    let td = parts[0].0.time_domain();
    let windows = parts[0].1.windows;
    let (mut next, mut t) = (0u32, td.start);
    let mut prev: Option<&Path> = None;
    for (r, p) in parts {
        if p.first == p.end {
            continue;
        }
        let after = prev.map_or_else(|| "the start".to_string(), |q| format!("{}", q.display()));
        if p.first != next || p.time[0] != t {
            let what = if p.first > next || p.time[0] > t {
                "gap"
            } else {
                "overlap"
            };
            return Err(Error::invalid(
                r.path(),
                format!("provenance (windows, {what})"),
                format!("windows from {next} and times from {t} (after {after})"),
                format!(
                    "windows {}..{}, times [{}, {}]",
                    p.first, p.end, p.time[0], p.time[1]
                ),
            ));
        }
        (next, t) = (p.end, p.time[1]);
        prev = Some(r.path());
    }
    if next != windows || t != td.end {
        let last = prev.map_or_else(|| "no part".to_string(), |q| q.display().to_string());
        return Err(Error::Usage(format!(
            "merge: gap at the end: the parts hold windows 0..{next} (to t = {t}, last {last}), the solve has {windows} (to t = {})",
            td.end
        )));
    }
    Ok(())
}

/// The merged file's statistics: the solve's seconds and frames summed over the
/// parts (machine time, not wall time), the shared part's counts and error
/// estimate from the first part (every part solves the same shared part), the
/// last part's residual.
fn merged_stats(parts: &[(Reader, ProvenanceRecord)]) -> SolveStats {
    let first = parts[0].0.stats();
    let last = parts
        .iter()
        .rev()
        .find(|(_, p)| p.first < p.end)
        .map_or(first, |(r, _)| r.stats());
    SolveStats {
        seconds: parts.iter().map(|(r, _)| r.stats().seconds).sum(),
        iterations: parts.iter().map(|(r, _)| r.stats().iterations).sum(),
        residual: last.residual,
        ..first.clone()
    }
}
