//! A static scene (`rhier solve` without motion): refine-and-solve rounds, each
//! reported (and measured against `--reference`, off the emitters first:
//! [`PointError`]), then the reconstruction, probes,
//! the power-balance warning, the reason the solve stopped and the `.rhier` file. A
//! scene with no emitter is not solved: its zero solution is written at once.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use rhier::interactive::{Pose, Stage};
use rhier::playback::{ProbePoint, probe, read_probe_points, write_probe_results};
use rhier::scene::Scene;
use rhier::solution::{PointError, Solution};
use rhier::solver::report;
use rhier::solver::{RoundRecord, SolveOptions, Solver};
use rhier::store::{
    Hierarchy, LinkRecord, MemoryReport, SolutionHeader, WriteOptions, Writer, write_solution,
};

use super::common::OutputArgs;

/// A static solve warns when its leaves absorb more than this fraction beyond the
/// power the scene emits ([`Solver::power_balance`]), or, in a closed scene
/// ([`Solver::is_closed`]), less than it by as much. ACTOR's room reads 1.011 at
/// its own reflectances (0.9% too bright against the path tracer), 1.029 with every
/// reflectance 0.9 (4–5%) and 1.40 at 0.99 (45%; BENCHMARKS.md, "Stiff scenes").
/// A closed scene past it is balanced ([`Solver::rows_balanced`]) and then absorbs
/// what it emits but for what the rows balancing leaves unscaled miss (0.97–1.0
/// in ACTOR's room up to `ρ = 0.99`), so the warning is left for open scenes and
/// for what balancing leaves; it is the level that turns balancing on.
const POWER_ERROR_WARNING: f64 = rhier::solver::BALANCE_TRIGGER;

/// Reads reference points `{"p","n","B"}`.
fn read_reference(path: &Path) -> anyhow::Result<(Vec<ProbePoint>, Vec<[f64; 3]>)> {
    let points = read_probe_points(path)?;
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let mut b = Vec::with_capacity(points.len());
    for (i, v) in value.as_array().into_iter().flatten().enumerate() {
        let arr = v
            .get("B")
            .and_then(|x| x.as_array())
            .filter(|a| a.len() == 3);
        let vals: Option<Vec<f64>> = arr.map(|a| a.iter().filter_map(|x| x.as_f64()).collect());
        match vals {
            Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => {
                b.push([v[0], v[1], v[2]])
            }
            _ => anyhow::bail!(
                "{}: point {i}, \"B\": expected an array of 3 finite numbers, found {}",
                path.display(),
                v.get("B")
                    .map_or("no such field".to_string(), |x| x.to_string())
            ),
        }
    }
    Ok((points, b))
}

/// Solves the static `scene` with the checked settings `opts` and writes its
/// `.rhier` file as `output` asks; `start` is when the command started (the
/// reported time).
pub fn run(
    output: &OutputArgs,
    scene: &Scene,
    stem: &str,
    opts: SolveOptions,
    start: Instant,
) -> anyhow::Result<()> {
    let reference = output
        .reference
        .as_deref()
        .map(read_reference)
        .transpose()?;
    let probes = output.probe.as_deref().map(read_probe_points).transpose()?;
    let t = scene.time.start;
    if !scene.has_emitter() {
        return super::common::write_zero(output, scene, stem, start, |path| {
            Ok(report::write_csv(path, &[])?)
        });
    }

    let bar = output.progress("refining");
    let mut solver = Solver::new(scene, opts)?;
    // Points on an emitting patch are left out of the headline error.
    let on_emitter = reference.as_ref().map_or_else(Vec::new, |(pts, _)| {
        let pn: Vec<_> = pts.iter().map(|q| (q.p, q.n)).collect();
        rhier::geometry::on_emitters(&solver.patches, &pn)
    });
    let quiet = output.quiet;
    let mut true_error_failure = None;
    let records: Vec<RoundRecord> = solver.run(|rec, s| {
        if let Some((pts, b_ref)) = &reference {
            let sol = s.solution();
            match probe(&sol, pts, t) {
                Ok(b) => rec.true_error = Some(PointError::measure(&b, b_ref, &on_emitter)),
                Err(e) => true_error_failure = Some(e),
            }
        }
        let line = rec.summary();
        match &bar {
            Some(b) => b.println(line),
            None if !quiet => eprintln!("{line}"),
            None => {}
        }
    })?;
    if let Some(e) = true_error_failure {
        return Err(e).context("measuring the true error against the reference");
    }
    if let Some(b) = &bar {
        b.set_message("reconstructing");
    }
    // Read off the rows before they are freed for the final gather.
    let balance = solver.power_balance();
    solver.release_rows();
    let mut solution = solver.solution();
    solution.stats.seconds = start.elapsed().as_secs_f64();
    solution.stats.iterations = records.len() as u32;
    if let Some(last) = records.last() {
        solution.stats.residual = last.residual;
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(path) = &output.report {
        report::write_csv(path, &records)?;
    }
    if let (Some(points), Some(out)) = (&probes, &output.probe_out) {
        let values = probe(&solution, points, t)?;
        write_probe_results(out, &values)?;
    }
    let out = output.out_path(stem);
    let write_opts = WriteOptions {
        keep_links: output.keep_links,
        ..WriteOptions::default()
    };
    if output.keep_links {
        write_with_links(&out, &solution, &solver, None)?;
    } else {
        write_solution(&out, &solution, write_opts)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    if balance > 1.0 + POWER_ERROR_WARNING {
        eprintln!(
            "rhier: warning: the solution absorbs {:.1}% more power than the scene emits: its form factors sum above 1 somewhere (cluster estimates, quadrature), and the answer is too bright by about as much; reflectance near 1 amplifies this (a finer --eps may help; BENCHMARKS.md, \"Stiff scenes\")",
            100.0 * (balance - 1.0)
        );
    } else if balance < 1.0 - POWER_ERROR_WARNING && solver.is_closed() == Some(true) {
        eprintln!(
            "rhier: warning: the scene is closed (no ray from the error samples escapes) but the solution absorbs {:.1}% less power than it emits: its form factors sum below 1 somewhere, and the answer is too dark by about as much; reflectance near 1 amplifies this (BENCHMARKS.md, \"Stiff scenes\")",
            100.0 * (1.0 - balance)
        );
    }
    if !output.quiet {
        eprintln!(
            "solved {} patches{} in {:.3} s: {} stored cells, {} elements, {} active / {} passive links, estimated error {}, absorbs {} of the emitted power{}; stopped: {}; wrote {}",
            solution.patches.len(),
            match solver.dark_patch_count() {
                0 => String::new(),
                n => format!(" ({n} sealed off from every emitter: black, not solved)"),
            },
            solution.stats.seconds,
            solution.leaves.len(),
            solution.stats.elements,
            solution.stats.links_active,
            solution.stats.links_passive,
            report::estimate_text(solution.stats.estimated_error),
            if balance.is_nan() {
                "n/a".to_string()
            } else {
                format!("{balance:.3}")
            },
            if solver.rows_balanced() {
                " (leaf system balanced)"
            } else {
                ""
            },
            solver.stop_reason().text(),
            out.display()
        );
    }
    if output.stats {
        let mut m = MemoryReport::for_run(stem);
        m.add_pool(
            "elements",
            solver.elems.len() as u64,
            solver.elems.bytes() as u64,
        );
        m.add_pool(
            "links",
            solver.links.len() as u64,
            solver.links.bytes() as u64,
        );
        m.add_pool(
            "bvh",
            solver.bvh.triangle_count() as u64,
            solver.bvh.resident_bytes() as u64,
        );
        m.add_pool(
            "stored cells",
            solution.leaves.len() as u64,
            (solution.leaves.len() * std::mem::size_of::<rhier::solution::Leaf>()) as u64,
        );
        println!("{m}");
    }
    Ok(())
}

/// `rhier solve --keep-links --movable NAMES`: solves `scene` as an interactive
/// session stages it ([`Stage`]: the named objects movable) and writes the file
/// with its links and its hierarchy section, for `rhier interact --from`.
pub fn run_staged(
    output: &OutputArgs,
    scene: &Scene,
    stem: &str,
    opts: SolveOptions,
    start: Instant,
    movable: &[String],
) -> anyhow::Result<()> {
    let stage = Stage::new(scene, Some(movable))?;
    if !stage.scene.has_emitter() {
        return super::common::write_zero(output, scene, stem, start, |path| {
            Ok(report::write_csv(path, &[])?)
        });
    }
    // As `rhier interact` solves it: a move may open a shell, so no patch is dark.
    let opts = SolveOptions {
        sealed_regions: false,
        ..opts
    };
    let mut solver = Solver::new(&stage.scene, opts)?;
    solver.keep_restore_point();
    let quiet = output.quiet;
    let records: Vec<RoundRecord> = solver.run(|rec, _| {
        if !quiet {
            eprintln!("{}", rec.summary());
        }
    })?;
    let hierarchy = solver
        .hierarchy(stage.movable_names())
        .context("the solve kept no hierarchy")?;
    let mut solution = solver.solution();
    solution.scene = stage.posed(&vec![Pose::IDENTITY; stage.scene.objects.len()]);
    solution.stats.seconds = start.elapsed().as_secs_f64();
    solution.stats.iterations = records.len() as u32;
    if let Some(last) = records.last() {
        solution.stats.residual = last.residual;
    }
    if let Some(path) = &output.report {
        report::write_csv(path, &records)?;
    }
    let t = solution.scene.time.start;
    if let (Some(points), Some(out)) = (
        output.probe.as_deref().map(read_probe_points).transpose()?,
        &output.probe_out,
    ) {
        write_probe_results(out, &probe(&solution, &points, t)?)?;
    }
    let out = output.out_path(stem);
    write_with_links(&out, &solution, &solver, Some(&hierarchy))?;
    if !quiet {
        eprintln!(
            "solved {} patches for `rhier interact --movable {}` in {:.3} s: {} elements, {} active / {} passive links; wrote {} with its hierarchy",
            solution.patches.len(),
            movable.join(","),
            solution.stats.seconds,
            solution.stats.elements,
            solution.stats.links_active,
            solution.stats.links_passive,
            out.display()
        );
    }
    Ok(())
}

/// Writes `solution` to `out` with the links of `solver` (`--keep-links`) and, for
/// `--movable`, its hierarchy section.
fn write_with_links(
    out: &Path,
    solution: &Solution,
    solver: &Solver,
    hierarchy: Option<&Hierarchy>,
) -> anyhow::Result<()> {
    let write_opts = WriteOptions {
        keep_links: true,
        ..WriteOptions::default()
    };
    let mut w = Writer::create(out, &SolutionHeader::of(solution), write_opts)?;
    w.write_chunk(
        solution.scene.time.start,
        solution.scene.time.end,
        &solution.leaves,
    )?;
    w.write_links(&link_records(solver));
    if let Some(h) = hierarchy {
        w.write_hierarchy(h);
    }
    w.finish(&solution.stats)
        .with_context(|| format!("writing {}", out.display()))
}

/// The solver's links (active and passive) as the store records them: element ids in
/// solver numbering, coefficient `ρ_receiver · F` per channel (clusters use 1), the
/// link's spread as its error bound.
fn link_records(solver: &Solver) -> Vec<LinkRecord> {
    let geoms = solver.elems.geoms.as_slice();
    let times = solver.elems.times.as_slice();
    solver
        .links
        .ends
        .as_slice()
        .iter()
        .zip(solver.links.transports.as_slice())
        .map(|(e, t)| {
            let g = &geoms[e.receiver as usize];
            let rho = if g.patch == u32::MAX {
                [1.0; 3]
            } else {
                solver.patches.rhos[g.patch as usize]
            };
            LinkRecord {
                receiver: e.receiver as u64,
                source: e.source as u64,
                time: times[e.receiver as usize],
                coefficient: [
                    (rho[0] * t.f as f64) as f32,
                    (rho[1] * t.f as f64) as f32,
                    (rho[2] * t.f as f64) as f32,
                ],
                error: t.spread,
                active: (t.state() == rhier::pools::LinkState::Active) as u32,
                reserved: 0,
            }
        })
        .collect()
}
