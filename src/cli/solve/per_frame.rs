//! `rhier solve --per-frame --fps F`: the frame-by-frame baseline
//! ([`rhier::solver::per_frame`]): one independent static solve per frame, each
//! frame's solution handed back and written here into the output `.rhier` file, one
//! chunk per frame, in time order, through the store's [`Writer`] (the file appears
//! when every frame is written). Prints one line per frame and a last line that
//! says why the frames' solves stopped (unless `-q`), and with `--report CSV`
//! writes one row per frame. A scene with no emitter is not solved: every frame is
//! written zero at once.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use rhier::Error;
use rhier::scene::Scene;
use rhier::solution::Solution;
use rhier::solver::SolveOptions;
use rhier::solver::per_frame::{FrameReport, PerFrameStats, solve_per_frame, zero_per_frame};
use rhier::store::{FrameWriter, WriteOptions};

use super::common::Args;

/// Runs `rhier solve --per-frame` with the checked settings `opts`.
pub fn run(args: &Args, opts: SolveOptions) -> anyhow::Result<()> {
    let output = &args.output;
    let unsupported = [
        (output.reference.is_some(), "--reference"),
        (output.probe.is_some(), "--probe"),
        (output.keep_links, "--keep-links"),
    ];
    if let Some((_, flag)) = unsupported.iter().find(|(on, _)| *on) {
        anyhow::bail!(
            "{flag} is not available with --per-frame (probe the output with `rhier probe FILE --time T`)"
        );
    }
    let start = std::time::Instant::now();
    let (scene, stem) = args.scene.load()?;
    for w in &scene.warnings {
        eprintln!("rhier: warning: {w}");
    }
    let out = output.out_path(&stem);
    let fps = args.animation.fps;
    let mut csv = match &output.report {
        Some(path) => {
            let file = std::fs::File::create(path)
                .with_context(|| format!("creating {}", path.display()))?;
            let mut w = std::io::BufWriter::new(file);
            writeln!(w, "{}", FrameReport::CSV_HEADER)
                .with_context(|| format!("writing {}", path.display()))?;
            Some((w, path.clone()))
        }
        None => None,
    };
    let quiet = output.quiet;
    let lit = scene.has_emitter();
    let mut stops = Vec::new();
    let stats = write_frames(&out, &scene, &opts, fps, |report| {
        stops.push(report.stop);
        if !quiet && lit {
            eprintln!("{}", report.summary());
        }
        if let Some((w, path)) = &mut csv {
            writeln!(w, "{}", report.csv_row())
                .and_then(|()| w.flush())
                .map_err(|e| Error::io(path.clone(), e))?;
        }
        Ok(())
    })
    .with_context(|| format!("per-frame solve into {}", out.display()))?;
    if !quiet && !lit {
        eprintln!(
            "solved {} frames at {} fps in {:.3} s: no emitter, so the radiosity is zero everywhere at every frame (written without solving); wrote {}",
            stats.frames,
            fps,
            start.elapsed().as_secs_f64(),
            out.display()
        );
    } else if !quiet {
        eprintln!(
            "solved {} frames at {} fps in {:.3} s ({:.3} s per frame): {} stored cells; stopped: {}; wrote {}",
            stats.frames,
            fps,
            start.elapsed().as_secs_f64(),
            stats.stats.seconds / stats.frames.max(1) as f64,
            stats.leaves,
            rhier::solver::report::stop_tally(&stops),
            out.display()
        );
    }
    if output.stats {
        println!(
            "frames {}\nleaves {}\nlargest frame: elements {}, links {} active / {} passive",
            stats.frames,
            stats.leaves,
            stats.stats.elements,
            stats.stats.links_active,
            stats.stats.links_passive
        );
    }
    Ok(())
}

/// Solves every frame of `scene` at `fps` ([`solve_per_frame`]; a scene with no
/// emitter is not solved, its frames are zero, [`zero_per_frame`]) and writes each
/// frame's leaves into the `.rhier` file `path` as one chunk over the frame's
/// interval, in time order; `on_frame` sees each frame's report after its chunk is
/// written. Memory holds one frame whatever the animation's length.
fn write_frames(
    path: &Path,
    scene: &Scene,
    opts: &SolveOptions,
    fps: f64,
    mut on_frame: impl FnMut(&FrameReport) -> rhier::Result<()>,
) -> rhier::Result<PerFrameStats> {
    let mut file = FrameWriter::new(path, WriteOptions::default());
    let frame = |r: &FrameReport, solution: &Solution| {
        file.push(scene, (r.index, r.t, r.range), solution)?;
        on_frame(r)
    };
    let stats = if scene.has_emitter() {
        solve_per_frame(scene, opts, fps, frame)?
    } else {
        zero_per_frame(scene, fps, frame)?
    };
    file.finish(&stats.stats)?;
    Ok(stats)
}
