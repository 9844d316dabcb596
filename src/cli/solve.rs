//! `rhier solve`: load a scene (or the embedded Cornell box), solve, report error
//! against run time, probe, write the `.rhier` file.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::Context;
use rhier::playback::{ProbePoint, probe, read_probe_points, write_probe_results};
use rhier::pools::Storage;
use rhier::scene::Scene;
use rhier::solver::report::{self, relative_rms};
use rhier::solver::spacetime::SpaceTimeOptions;
use rhier::solver::{RoundRecord, SolveOptions, Solver};
use rhier::store::{
    LinkRecord, MemoryReport, SolutionHeader, WriteOptions, Writer, write_solution,
};

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

/// Storage backend of the pools.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum StorageKind {
    /// Heap memory.
    Ram,
    /// Memory-mapped files in `--scratch`.
    Mmap,
}

/// The embedded scenes of `--builtin` (see `rhier::scene::builtin`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Builtin {
    /// The Cornell box.
    #[value(name = "cornell")]
    Cornell,
    /// The Cornell box with its two blocks.
    #[value(name = "cornell-blocks")]
    CornellBlocks,
    /// ACTOR, 75 frames (3 s).
    #[value(name = "actor")]
    Actor,
    /// ACTOR, 150 frames (6 s).
    #[value(name = "actor150")]
    Actor150,
    /// ACTOR, 750 frames (30 s).
    #[value(name = "actor750")]
    Actor750,
    /// LIGHT, 75 frames (3 s).
    #[value(name = "light")]
    Light,
    /// LIGHT, 150 frames (6 s).
    #[value(name = "light150")]
    Light150,
    /// LIGHT, 750 frames (30 s).
    #[value(name = "light750")]
    Light750,
}

/// Arguments of `rhier solve`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (.json native, .gltf/.glb, .obj); none = the embedded Cornell box.
    pub scene: Option<PathBuf>,
    /// Output `.rhier` file (default: `<scene stem>.rhier` in the working directory).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// Solve the Cornell box with the two published blocks (embedded scene only).
    #[arg(long, conflicts_with = "builtin")]
    pub blocks: bool,
    /// Solve an embedded scene instead of a file: the Cornell box, or the animated
    /// ACTOR / LIGHT scenes of 75 (3 s), 150 or 750 frames at 25 fps.
    #[arg(long, value_enum, conflicts_with = "scene")]
    pub builtin: Option<Builtin>,
    /// Solve every frame independently (the frame-by-frame baseline) at `--fps`,
    /// streaming one chunk per frame into the output file.
    #[arg(long)]
    pub per_frame: bool,
    /// Where the element and link pools (and a space-time window's kept final-gather
    /// terms and leaves) live [default: mmap for a space-time solve, out of core in
    /// the journal directory `OUT.rhier.partial/` beside the output; ram otherwise]
    #[arg(long, value_enum)]
    pub storage: Option<StorageKind>,
    /// Directory for memory-mapped pool files, created if missing (default: a
    /// space-time solve's journal directory, else the system temp directory).
    #[arg(long)]
    pub scratch: Option<PathBuf>,
    /// Refinement threshold, relative to the RMS reflected radiosity.
    #[arg(long, default_value_t = SolveOptions::default().eps)]
    pub eps: f64,
    /// Smallest element edge as a fraction of the scene's diameter.
    #[arg(long, default_value_t = SolveOptions::default().min_size)]
    pub min_size: f64,
    /// Reconstruction tolerance, relative to the RMS reflected radiosity.
    #[arg(long, default_value_t = SolveOptions::default().recon_tol)]
    pub recon_tol: f64,
    /// Reconstruction tolerance on the surfaces of moving objects (default:
    /// `--recon-tol`). The actors of a space-time solve at the tolerance best for the
    /// room come out coarser than the room; half of it there costs little.
    #[arg(long)]
    pub recon_tol_moving: Option<f64>,
    /// Receivers smaller than the square of this fraction of the scene's diameter
    /// are refined on the power their links may get wrong, not on their radiosity
    /// (0: never). Smaller is slower and, in cluttered scenes, more accurate
    /// (BENCHMARKS.md, "Scale").
    #[arg(long, default_value_t = SolveOptions::default().power_size)]
    pub power_size: f64,
    /// After the last round of a static solve, split the leaves below the power area
    /// whose radiosity differs across their own quadrature points by more than this
    /// fraction of the RMS reflected radiosity, and solve again (0: never). Mends
    /// narrow slots in clutter; 0.15 measured (BENCHMARKS.md, "Scale"). Static
    /// scenes and `--per-frame` frames only: refused by a space-time solve.
    #[arg(long, default_value_t = SolveOptions::default().split_spread)]
    pub split_spread: f64,
    /// After the last round of a static solve, a leaf below the power area whose
    /// radiosity across its quadrants strays from its mean by more than this
    /// fraction of it is gathered quadrant by quadrant, not at its mean (0: never).
    /// Mends narrow slots in clutter for about 14% more time; 0.1 measured
    /// (BENCHMARKS.md, "Scale"). Static scenes and `--per-frame` frames only:
    /// refused by a space-time solve.
    #[arg(long, default_value_t = SolveOptions::default().leaf_shapes)]
    pub leaf_shapes: f64,
    /// A reconstruction point facing a surface across a gap narrower than this
    /// fraction of the square root of the surface's area (a box's bottom hung just over the
    /// floor, and the floor under it) is solved together with its foot on that
    /// surface instead of gathering the element's mean (0: never). ACTOR's actors at
    /// 0.1: their error 6.4% → 2.9% in a space-time solve for 25–45% more time,
    /// per-frame's 4.5% → 3.5% for about 15% (BENCHMARKS.md, "Two surfaces across
    /// a narrow gap").
    #[arg(long, default_value_t = SolveOptions::default().near_gap)]
    pub near_gap: f64,
    /// Most refine-and-solve rounds.
    #[arg(long, default_value_t = SolveOptions::default().max_rounds)]
    pub max_rounds: u32,
    /// Refine (halving `--eps` as needed) until the estimated relative error, the
    /// final gather's change between levels, is below this (static scenes)
    #[arg(long)]
    pub target_error: Option<f64>,
    /// Start no new round after this many seconds.
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Write one CSV row per round (error against run time).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Reference points with known radiosity (`rhier reference` output, or any JSON
    /// array of `{"p":..,"n":..,"B":[r,g,b]}`): adds the true error per round.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Probe points to evaluate after the solve (JSON array of `{"p":..,"n":..}`).
    #[arg(long, requires = "probe_out")]
    pub probe: Option<PathBuf>,
    /// Where to write the probe results.
    #[arg(long, requires = "probe")]
    pub probe_out: Option<PathBuf>,
    /// Keep the links in the output file.
    #[arg(long)]
    pub keep_links: bool,
    /// Do not cut patches along the lines where other polygons rest on them (see
    /// geometry::contact): faster in cluttered scenes, less accurate near contacts.
    #[arg(long)]
    pub no_contact_meshing: bool,
    /// Print the memory counters of the run.
    #[arg(long)]
    pub stats: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the ray jitter.
    #[arg(long, default_value_t = SolveOptions::default().seed)]
    pub seed: u64,
    /// Print nothing but errors and warnings.
    #[arg(short, long)]
    pub quiet: bool,
    /// Frames per second at which a moving scene is solved (space-time, or
    /// `--per-frame`).
    #[arg(long, default_value_t = 25.0)]
    pub fps: f64,
    /// Seconds of animation per space-time window: frames are solved window by
    /// window; each finished window is written and its memory released. Default:
    /// twelve key intervals (see `--key-motion`), as long in motion as they are.
    #[arg(long)]
    pub window: Option<f64>,
    /// A stored cell keeps one value over consecutive frames while its corners stay
    /// within this fraction of the RMS reflected radiosity of their mean.
    #[arg(long, default_value_t = 0.01)]
    pub merge_tol: f64,
    /// Space-time: every N-th frame of a window (and its first and last) is a
    /// keyframe gathered at every reconstruction point; the frames between, taken
    /// by bisection, interpolate the points where the two nearest solved frames
    /// agree, or follow a line with the frame as far before, and gather the rest
    /// (1: gather every frame). Default: keyframes spaced by motion (`--key-motion`).
    #[arg(long)]
    pub key_stride: Option<u32>,
    /// Space-time, without `--key-stride`: the next keyframe is the last frame
    /// before some point of a moving object has moved more than this fraction of the
    /// scene's diameter since the keyframe before (at most 32 frames on). The same
    /// motion played over more frames makes as many keyframes.
    #[arg(long, default_value_t = SpaceTimeOptions::default().key_motion)]
    pub key_motion: f64,
    /// Space-time: how far (a fraction of the RMS reflected radiosity) a point's
    /// values at the solved frames around may stray from agreeing, or from a line,
    /// for a frame between to interpolate it.
    #[arg(long, default_value_t = SpaceTimeOptions::default().interp_tol)]
    pub interp_tol: f64,
    /// Space-time: a frame between two solved frames over which no moving object
    /// travels more than this fraction of the scene's diameter takes the line
    /// between them at every point both hold, and skips its leaf solve (0: never).
    /// The same motion played over more frames then costs little more.
    #[arg(long, default_value_t = SpaceTimeOptions::default().interp_motion)]
    pub interp_motion: f64,
    /// Space-time: a frame between two solved frames skips its leaf solve (the
    /// radiosity of what every frame shares taken on the line between them) when no
    /// moving surface's power changes between them by more than this fraction of
    /// the moving surfaces' total.
    #[arg(long, default_value_t = SpaceTimeOptions::default().moving_power_tol)]
    pub moving_power_tol: f64,
    /// Space-time: take the line between two solved frames over the whole light of
    /// the points on moving surfaces. By default their direct light is computed
    /// anew at every frame between, and the line is over the rest of their light.
    #[arg(long)]
    pub whole_light_between: bool,
    /// Continue an interrupted space-time solve from its last finished window (kept
    /// in OUT.rhier.partial/).
    #[arg(long)]
    pub resume: bool,
    /// Memory budget in bytes: the pools live in memory-mapped files (`--scratch`)
    /// and a window that exceeds it is reported; a space-time solve also keeps at
    /// most this many bytes of final-gather terms per window (over it, points are
    /// gathered afresh each frame: slower, same result).
    #[arg(long)]
    pub budget: Option<u64>,
    /// Stop with an error after this many windows (to test --resume).
    #[arg(long, hide = true)]
    pub stop_after_windows: Option<u32>,
}

impl Args {
    /// The job `rhier` runs with no subcommand: the embedded scene, default output.
    pub fn default_job() -> Self {
        use clap::FromArgMatches;
        let cmd = <Args as clap::Args>::augment_args(clap::Command::new("solve"));
        let matches = cmd.get_matches_from(["solve"]);
        match Args::from_arg_matches(&matches) {
            Ok(a) => a,
            Err(e) => e.exit(),
        }
    }
}

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

/// The scene to solve and the stem of the default output name.
pub(super) fn load(args: &Args) -> anyhow::Result<(Scene, String)> {
    if let Some(b) = args.builtin {
        use clap::ValueEnum;
        let name = b
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_string());
        let scene = rhier::scene::builtin(&name)
            .with_context(|| format!("no embedded scene called {name:?}"))?;
        return Ok((scene, name.replace('-', "_")));
    }
    match &args.scene {
        Some(path) => {
            let scene = rhier::scene::load(path)?;
            let stem = path
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            Ok((scene, stem))
        }
        None => {
            let name = if args.blocks {
                "cornell_blocks"
            } else {
                "cornell"
            };
            Ok((rhier::scene::cornell_box(args.blocks), name.to_string()))
        }
    }
}

/// Where the pools live: `--storage`, else memory-mapped if `out_of_core` (a
/// space-time solve) and the library's default otherwise (RAM unless
/// `RHIER_STORAGE` says otherwise, [`Storage::ENV`]); `--budget` always maps. Mapped
/// files go in `--scratch`, else `dir` (a space-time solve's journal directory),
/// else the directory `RHIER_STORAGE` names, else the system temp directory.
pub(super) fn storage(args: &Args, out_of_core: bool, dir: Option<&Path>) -> Storage {
    let env_dir = match Storage::from_env().unwrap_or_default() {
        Storage::Mmap(d) => Some(d),
        Storage::Ram => None,
    };
    let mapped = args.budget.is_some()
        || match args.storage {
            Some(kind) => kind == StorageKind::Mmap,
            None => out_of_core || env_dir.is_some(),
        };
    if !mapped {
        return Storage::Ram;
    }
    Storage::Mmap(
        args.scratch
            .clone()
            .or_else(|| dir.map(Path::to_path_buf))
            .or(env_dir)
            .unwrap_or_else(std::env::temp_dir),
    )
}

/// The solver settings the arguments ask for (shared by every mode of `solve`),
/// checked against their domains ([`SolveOptions::validate`]).
pub(super) fn solve_options(args: &Args) -> anyhow::Result<SolveOptions> {
    let opts = SolveOptions {
        storage: storage(args, false, None),
        eps: args.eps,
        min_size: args.min_size,
        recon_tol: args.recon_tol,
        recon_tol_moving: args.recon_tol_moving,
        power_size: args.power_size,
        split_spread: args.split_spread,
        leaf_shapes: args.leaf_shapes,
        near_gap: args.near_gap,
        max_rounds: args.max_rounds,
        target_error: args.target_error,
        time_budget: args.time_budget,
        seed: args.seed,
        contact_meshing: !args.no_contact_meshing,
        ..SolveOptions::default()
    };
    opts.validate()?;
    Ok(opts)
}

/// Runs `rhier solve`.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(n) = args.threads {
        // Only fails if a pool exists already, which cannot happen this early.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global();
    }
    if let Some(dir) = &args.scratch {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--scratch {}: cannot create the directory", dir.display()))?;
    }
    let opts = solve_options(&args)?;
    if args.per_frame {
        return super::per_frame::run(&args, opts);
    }
    let start = std::time::Instant::now();
    let (scene, stem) = load(&args)?;
    for w in &scene.warnings {
        eprintln!("rhier: warning: {w}");
    }
    if scene.has_motion() {
        return super::spacetime::run(&args, &scene, &stem, opts, start);
    }
    let reference = args.reference.as_deref().map(read_reference).transpose()?;
    let probes = args.probe.as_deref().map(read_probe_points).transpose()?;
    let t = scene.time.start;

    let show_progress =
        !args.quiet && std::io::stderr().is_terminal() && std::env::var_os("CI").is_none();
    let bar = show_progress.then(|| {
        let b = indicatif::ProgressBar::new_spinner();
        b.set_message("refining");
        b.enable_steady_tick(std::time::Duration::from_millis(120));
        b
    });
    let mut solver = Solver::new(&scene, opts)?;
    let quiet = args.quiet;
    let mut true_error_failure = None;
    let records: Vec<RoundRecord> = solver.run(|rec, s| {
        if let Some((pts, b_ref)) = &reference {
            let sol = s.solution();
            match probe(&sol, pts, t) {
                Ok(b) => rec.true_error = Some(relative_rms(&b, b_ref)),
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
    let mut solution = solver.solution();
    solution.stats.seconds = start.elapsed().as_secs_f64();
    solution.stats.iterations = records.len() as u32;
    if let Some(last) = records.last() {
        solution.stats.residual = last.residual;
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(path) = &args.report {
        report::write_csv(path, &records)?;
    }
    if let (Some(points), Some(out)) = (&probes, &args.probe_out) {
        let values = probe(&solution, points, t)?;
        write_probe_results(out, &values)?;
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{stem}.rhier")));
    let write_opts = WriteOptions {
        keep_links: args.keep_links,
        ..WriteOptions::default()
    };
    if args.keep_links {
        let mut w = Writer::create(&out, &SolutionHeader::of(&solution), write_opts)?;
        w.write_chunk(
            solution.scene.time.start,
            solution.scene.time.end,
            &solution.leaves,
        )?;
        w.write_links(&link_records(&solver));
        w.finish(&solution.stats)
            .with_context(|| format!("writing {}", out.display()))?;
    } else {
        write_solution(&out, &solution, write_opts)
            .with_context(|| format!("writing {}", out.display()))?;
    }
    let balance = solver.power_balance();
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
    if !args.quiet {
        eprintln!(
            "solved {} patches in {:.3} s: {} stored cells, {} elements, {} active / {} passive links, estimated error {}, absorbs {} of the emitted power{}; wrote {}",
            solution.patches.len(),
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
            out.display()
        );
    }
    if args.stats {
        let mut m = MemoryReport::for_run(&stem);
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
            (solution.leaves.len() * std::mem::size_of::<rhier::solver::Leaf>()) as u64,
        );
        println!("{m}");
    }
    Ok(())
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
