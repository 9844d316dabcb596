//! The space-time branch of `rhier solve`: a scene with motion is solved window by
//! window ([`rhier::solver::spacetime`]) and streamed into the `.rhier` file, one
//! chunk per window, with a journal (`OUT.rhier.partial/`) that `--resume` continues
//! from. With `--shard K/N` it solves the shard's run of windows only and writes
//! them as a part for `rhier merge`; every file records the solve's fingerprint
//! and the windows it holds (its provenance). A scene with no emitter is not solved: its zero solution is written at
//! once, in one chunk whose leaves hold over the whole animation.

use std::time::Instant;

use anyhow::Context;
use rhier::playback::{probe, read_probe_points, write_probe_results};
use rhier::scene::Scene;
use rhier::solution::SolveStats;
use rhier::solver::SolveOptions;
use rhier::solver::spacetime::{FrameRecord, Plan, SpaceTime, WindowOutput, plan, result_settings};
use rhier::store::journal::{Journal, fingerprint};
use rhier::store::records::ProvenanceRecord;
use rhier::store::{MemoryReport, Reader, SolutionHeader, WriteOptions, Writer};

use super::common::{Args, Shard};

/// Runs the space-time solve of a moving scene (or, with `--shard K/N`, of one
/// shard of its windows).
pub fn run(
    args: &Args,
    scene: &Scene,
    stem: &str,
    opts: SolveOptions,
    start: Instant,
) -> anyhow::Result<()> {
    let (output, animation) = (&args.output, &args.animation);
    let st = args.space_time_options()?;
    refuse_static_only(args, &opts)?;
    let shard = args.farm.shard()?;
    if !scene.has_emitter() {
        if shard.is_some() {
            anyhow::bail!(
                "--shard: {stem} has no emitter, so its answer is zero everywhere and written without solving; solve it whole"
            );
        }
        return super::common::write_zero(output, scene, stem, start, |path| {
            write_report(path, &mut [])
        });
    }
    let out = output.out_path(stem);
    let probes = output.probe.as_deref().map(read_probe_points).transpose()?;
    let key = fingerprint(scene, &result_settings(&opts, &st)?)?;
    // The windows this run solves: every window, or the shard's run of them.
    let plan = shard.map(|_| plan(scene, &opts, &st)).transpose()?;
    let range = match (shard, &plan) {
        (Some(s), Some(p)) => p.shards(s.count)[s.index].clone(),
        _ => 0..0,
    };
    let journal_key = match shard {
        Some(s) => format!(
            "{key}shard {} of {}: windows {}..{}\n",
            s.index, s.count, range.start, range.end
        ),
        None => key.clone(),
    };
    if let (Some(s), Some(p), true) = (shard, &plan, range.is_empty()) {
        return write_empty_shard(args, scene, &opts, p, s, &key, &out, start);
    }
    let (journal, done) = open_journal(&out, &journal_key, animation.resume, range.start)?;
    // Out of core unless asked for RAM: the pools, kept terms and leaves page through
    // files in the journal directory, beside the output on its file system (a
    // system temp directory may be a RAM-backed tmpfs) and removed with it.
    let opts = SolveOptions {
        storage: args
            .resources
            .storage(true, journal.as_ref().map(|j| j.dir())),
        ..opts
    };
    let quiet = output.quiet;
    let bar = output.progress("shared part");
    let say = |line: String| match &bar {
        Some(b) => b.println(line),
        None if !quiet => eprintln!("{line}"),
        None => {}
    };
    let mut run = SpaceTime::new(scene, opts, st, |rec, _| {
        say(format!("shared {}", rec.summary()))
    })?;
    let n_windows = run.window_count();
    let range = match &plan {
        Some(p) if p.windows.as_slice() != run.windows() => anyhow::bail!(
            "--shard: the plan's {} windows differ from the solver's {n_windows} (a bug: please report it)",
            p.windows.len()
        ),
        Some(_) => range,
        None => 0..n_windows,
    };
    check_journaled(done, range.len(), &out)?;
    if done > 0 {
        say(format!(
            "resuming: {done} of {} windows already solved",
            range.len()
        ));
    }
    let header = SolutionHeader {
        scene,
        patches: run.patches(),
    };
    let mut writer = Writer::create(&out, &header, WriteOptions::default())
        .with_context(|| format!("creating {}", out.display()))?;
    let mut frames: Vec<FrameRecord> = Vec::new();
    let (mut stored, mut frame_cells) = (0u64, 0u64);
    if let Some(journal) = &journal {
        (stored, frame_cells) =
            replay_journal(journal, range.start..range.start + done, &mut writer)?;
    }
    let mut last_residual = 0.0;
    for wi in range.start + done..range.end {
        if animation
            .stop_after_windows
            .is_some_and(|k| (wi - range.start) as u32 >= k)
        {
            anyhow::bail!(
                "stopped after {} windows as asked (--stop-after-windows); resume with --resume",
                wi - range.start
            );
        }
        if let Some(b) = &bar {
            b.set_message(format!("window {} of {n_windows}", wi + 1));
        }
        let w = run.solve_window(wi, |f| {
            last_residual = f.residual;
            say(f.summary());
            frames.push(*f);
        })?;
        // The last window is not journaled: the file is finished right after it,
        // and an interrupted solve is finished by solving it again.
        let journal = journal.as_ref().filter(|_| wi + 1 < range.end);
        store_window(&w, &mut writer, journal)?;
        stored += w.leaves.len() as u64;
        frame_cells += w.frame_cells;
        if let Some(budget) = args.resources.budget
            && run.stats.peak_pool_bytes > budget
        {
            say(format!(
                "rhier: warning: window {wi} held {} bytes of pools, over the budget of {budget} (paged from files); use a shorter --window",
                run.stats.peak_pool_bytes
            ));
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let stats = SolveStats {
        seconds: start.elapsed().as_secs_f64(),
        iterations: run.stats.frames,
        elements: run.stats.shared_elements,
        links_active: run.stats.shared_links,
        links_passive: 0,
        estimated_error: run.stats.rounds.last().map_or(0.0, |r| r.estimated_error),
        residual: last_residual,
    };
    let span = match &plan {
        Some(p) => p.span_of(&range),
        None => [scene.time.start, scene.time.end],
    };
    writer.set_provenance(provenance(&key, n_windows, &range, shard, span));
    writer
        .finish(&stats)
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(path) = &output.report {
        write_report(path, &mut frames)?;
    }
    if let (Some(points), Some(path)) = (&probes, &output.probe_out) {
        let reader = Reader::open(&out)?;
        let values = probe(&reader, points, scene.time.start)?;
        write_probe_results(path, &values)?;
    }
    if !quiet {
        let cells = (stored, frame_cells);
        let line = finish_line(&run, done, stats.seconds, cells, &out);
        match shard {
            Some(s) => eprintln!(
                "shard {} of {} (windows {}..{}): {line}",
                s.index, s.count, range.start, range.end
            ),
            None => eprintln!("{line}"),
        }
    }
    if output.stats {
        println!("{}", memory_report(&run, stem, stored));
    }
    // The pools' files live in the journal directory by default: closed first.
    drop(run);
    if let Some(journal) = journal {
        journal.finish()?;
    }
    Ok(())
}

/// The provenance record of a file holding windows `range` of `windows`, keyed by
/// the solve's fingerprint `key`, as `shard` (none: the whole solve, shard 0 of 1).
fn provenance(
    key: &str,
    windows: usize,
    range: &std::ops::Range<usize>,
    shard: Option<Shard>,
    time: [f64; 2],
) -> ProvenanceRecord {
    let s = shard.unwrap_or(Shard { index: 0, count: 1 });
    ProvenanceRecord {
        fingerprint: key.to_string(),
        windows: windows as u32,
        first: range.start as u32,
        end: range.end as u32,
        shard: s.index as u32,
        shards: s.count as u32,
        time,
    }
}

/// Writes the part of a shard that holds no window (more shards than windows):
/// the scene, its patches as the solver would make them, no chunk, and the
/// provenance that tells `rhier merge` it is there. Nothing is solved.
#[allow(clippy::too_many_arguments)]
fn write_empty_shard(
    args: &Args,
    scene: &Scene,
    opts: &SolveOptions,
    plan: &Plan,
    shard: Shard,
    key: &str,
    out: &std::path::Path,
    start: Instant,
) -> anyhow::Result<()> {
    let patches = rhier::solver::spacetime::plan_patches(scene, opts);
    let header = SolutionHeader {
        scene,
        patches: &patches.geometry,
    };
    let mut writer = Writer::create(out, &header, WriteOptions::default())
        .with_context(|| format!("creating {}", out.display()))?;
    let range = plan.shards(shard.count)[shard.index].clone();
    let span = plan.span_of(&range);
    writer.set_provenance(provenance(
        key,
        plan.windows.len(),
        &range,
        Some(shard),
        span,
    ));
    let stats = SolveStats {
        seconds: start.elapsed().as_secs_f64(),
        estimated_error: f64::NAN,
        ..SolveStats::default()
    };
    writer
        .finish(&stats)
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(path) = &args.output.report {
        write_report(path, &mut [])?;
    }
    if !args.output.quiet {
        eprintln!(
            "shard {} of {}: no window ({} windows in all); wrote {} holding none",
            shard.index,
            shard.count,
            plan.windows.len(),
            out.display()
        );
    }
    Ok(())
}

/// Refuses the settings a space-time solve has no use for: those of one static
/// solve (`SpaceTime::new` checks them too, after the shared part; here before any
/// output is made), `--reference` and `--keep-links`.
fn refuse_static_only(args: &Args, opts: &SolveOptions) -> anyhow::Result<()> {
    rhier::solver::spacetime::static_only(opts)?;
    if args.output.reference.is_some() {
        anyhow::bail!(
            "--reference measures one static solve; for an animation compare probes at every frame (tools/spacetime_bench.py)"
        );
    }
    if args.output.keep_links {
        anyhow::bail!(
            "--keep-links: a space-time solve releases each window's links when the window is written; nothing to keep"
        );
    }
    Ok(())
}

/// The journal beside `out` keyed by `key`, fresh or (`resume`) the one an
/// interrupted solve left, with the number of windows it holds; none for a device
/// or FIFO.
fn open_journal(
    out: &std::path::Path,
    key: &str,
    resume: bool,
    first: usize,
) -> anyhow::Result<(Option<Journal>, usize)> {
    // A device or FIFO (`-o /dev/null`) is written in place at the end (see the
    // store's writer): nothing could be resumed into it, so it gets no journal beside
    // it (which, next to /dev/null, a user could not even create).
    if rhier::store::writer::writes_in_place(out) {
        if resume {
            anyhow::bail!(
                "--resume: {} is not a regular file, so no journal was kept for it",
                out.display()
            );
        }
        Ok((None, 0))
    } else if resume {
        let (j, done) = Journal::resume_from(out, key, first as u32)?;
        Ok((Some(j), done as usize))
    } else {
        Ok((Some(Journal::create(out, key)?), 0))
    }
}

/// Writes the windows `done` that `journal` holds to `writer` (the windows after
/// them depend on none of them); returns the stored cells and the frame cells.
fn replay_journal(
    journal: &Journal,
    done: std::ops::Range<usize>,
    writer: &mut Writer,
) -> anyhow::Result<(u64, u64)> {
    let (mut stored, mut frame_cells) = (0u64, 0u64);
    for wi in done {
        let w = journal.read(wi as u32)?;
        writer.write_chunk(w.t0, w.t1, &w.leaves)?;
        stored += w.leaves.len() as u64;
        frame_cells += w.frame_cells;
    }
    Ok((stored, frame_cells))
}

/// Writes the frames' records to the CSV file `path` (`--report`), in time order.
fn write_report(path: &std::path::Path, frames: &mut [FrameRecord]) -> anyhow::Result<()> {
    let mut csv = String::from(
        "frame,window,t,seconds,cells,gathered,interpolated,elements,links,varying_links,rays,bytes_pools,bytes_kept,residual\n",
    );
    // Frames are solved keyframes first; the report lists them in time order.
    frames.sort_by_key(|f| f.frame);
    for f in frames.iter() {
        csv.push_str(&format!(
            "{},{},{},{:.6},{},{},{},{},{},{},{},{},{},{:e}\n",
            f.frame,
            f.window,
            f.t,
            f.seconds,
            f.cells,
            f.gathered,
            f.interpolated,
            f.elements,
            f.links,
            f.varying_links,
            f.rays,
            f.bytes_pools,
            f.bytes_kept,
            f.residual
        ));
    }
    std::fs::write(path, csv).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// What a space-time solve held (`--stats`): the shared part's pools, the peak of a
/// window's, the BVH and the stored cells.
fn memory_report(run: &SpaceTime, stem: &str, stored: u64) -> MemoryReport {
    let mut m = MemoryReport::for_run(stem);
    m.add_pool(
        "shared elements",
        run.stats.shared_elements,
        run.solver().elems.bytes() as u64,
    );
    m.add_pool(
        "shared links",
        run.stats.shared_links,
        run.solver().links.bytes() as u64,
    );
    m.add_pool("peak pools (a window)", 0, run.stats.peak_pool_bytes);
    m.add_pool(
        "bvh",
        run.solver().bvh.triangle_count() as u64,
        run.solver().bvh.resident_bytes() as u64,
    );
    m.add_pool(
        "stored cells",
        stored,
        stored * std::mem::size_of::<rhier::solution::Leaf>() as u64,
    );
    m
}

/// Writes window `w` to `writer` and, with a `journal`, to the journal. Out of
/// core, the leaves are paged in a block at a time and handed back.
fn store_window(
    w: &WindowOutput,
    writer: &mut Writer,
    journal: Option<&Journal>,
) -> anyhow::Result<()> {
    let leaves = &w.leaves;
    writer.write_chunk_paged(w.t0, w.t1, leaves, || leaves.release_resident())?;
    if let Some(journal) = journal {
        journal.append_leaves(w.index, [w.t0, w.t1], w.frame_cells, leaves, || {
            leaves.release_resident()
        })?;
    }
    Ok(())
}

/// Refuses a journal that holds more windows than this solve has.
fn check_journaled(done: usize, n_windows: usize, out: &std::path::Path) -> anyhow::Result<()> {
    if done > n_windows {
        anyhow::bail!(
            "{}: {done} windows journaled, but this solve has {n_windows}",
            rhier::store::journal::journal_dir(out).display(),
        );
    }
    Ok(())
}

/// The last line a solve prints: frames, windows, time, the stored cells against
/// the frame cells (`cells`), and why the shared part's rounds (the refinement
/// every window starts from) stopped.
fn finish_line(
    run: &SpaceTime,
    done: usize,
    seconds: f64,
    (stored, frame_cells): (u64, u64),
    out: &std::path::Path,
) -> String {
    format!(
        "solved {} frames ({} windows from the journal) of {} windows in {:.3} s ({:.3} s shared part): {} stored cells for {} frame cells ({:.1}x fewer); shared part stopped: {}; wrote {}",
        run.stats.frames,
        done,
        run.window_count(),
        seconds,
        run.stats.shared_seconds,
        stored,
        frame_cells,
        frame_cells as f64 / stored.max(1) as f64,
        run.solver().stop_reason().text(),
        out.display()
    )
}
