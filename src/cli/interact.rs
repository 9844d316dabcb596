//! `rhier interact`: a solved scene whose objects move one move at a time
//! ([`rhier::interactive`]). Reads one move line, applies it, writes its statistics
//! (and probes), and only then reads the next line, so an editor can drive it
//! through a pipe. The session file (`-o`) is written when the moves end, and after
//! the last good move when a move fails (exit 1, naming the line).

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

use anyhow::Context;
use rhier::interactive::predict::Method;
use rhier::interactive::record::Recorder;
use rhier::interactive::store::{Keep, Policy};
use rhier::interactive::{MoveStats, Session, Settings, Stage, Traversal, Update, parse_move};
use rhier::playback::probe::{ProbePoint, probe, read_probe_points};
use rhier::pools::Storage;
use rhier::scene::Scene;
use rhier::store::{Hierarchy, Reader};

use super::solve::common::{AccuracyArgs, SceneArgs};

/// Where evicted shafts go.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ShaftStoreKind {
    /// Dropped, rebuilt when needed (the paper's way).
    None,
    /// zstd-compressed in memory, restored bit for bit.
    Zstd,
}

/// How a move finds the links it affects.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum UpdateKind {
    Local,
    Full,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum TraversalKind {
    /// Shafts and boxes: only the links the move can affect.
    Shafts,
    /// Every link evaluated again (the brute force, to check the other).
    Every,
}

/// Arguments of `rhier interact`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The scene and how it is loaded.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Start from a stored hierarchy instead of solving at start-up.
    ///
    /// The file must come from `rhier solve SCENE --keep-links --movable NAMES`:
    /// it holds every element and link of the solve a session makes at start-up,
    /// and the session takes them up (checked against the scene, the leaf system
    /// solved once, no refinement). The scene is SCENE when given, else the one
    /// stored in the file. `--movable` (default: the file's objects) and the
    /// accuracy flags must be those of the solve; a difference is refused, naming
    /// it. A file without links, or with the links of a plain static solve, is
    /// refused too.
    #[arg(long, value_name = "SOLVED.rhier")]
    pub from: Option<PathBuf>,
    /// The moves, one JSON line each (`-`: standard input); formats/interactive.md.
    #[arg(long, value_name = "MOVES.jsonl")]
    pub moves: PathBuf,
    /// Record the session as an animation (move i at time i / fps).
    #[arg(short = 'o', long = "out", value_name = "SESSION.rhier")]
    pub out: Option<PathBuf>,
    /// Frames per second of the recorded session.
    #[arg(long, default_value_t = 25.0)]
    pub fps: f64,
    /// One JSON line of statistics per move.
    #[arg(long, value_name = "S.jsonl")]
    pub stats: Option<PathBuf>,
    /// Probe points (a JSON array of {"p":[x,y,z],"n":[x,y,z]}), probed after each move.
    #[arg(long, value_name = "P.json", requires = "probe_out")]
    pub probe: Option<PathBuf>,
    /// Where the probes go: one line per move, {"move": i, "B": [[r,g,b], ...]}.
    #[arg(long, value_name = "OUT.jsonl", requires = "probe")]
    pub probe_out: Option<PathBuf>,
    /// The objects moves may place, comma-separated (default: every object).
    ///
    /// The others stay static: contact meshing cuts along them and their triangles
    /// share one BVH. A move of an object not named here is refused.
    #[arg(long, value_delimiter = ',')]
    pub movable: Option<Vec<String>>,
    /// Resident shaft bytes held within one block (64 shafts) of this ceiling.
    #[arg(long, value_name = "BYTES")]
    pub shaft_budget: Option<u64>,
    /// The paper's T_shafts: collect only while the fraction of links with a stored
    /// shaft is above it (with --t-min).
    #[arg(long, requires = "t_min")]
    pub t_shafts: Option<f64>,
    /// The paper's T_min: the collector stops when the fraction falls to it.
    #[arg(long, requires = "t_shafts")]
    pub t_min: Option<f64>,
    /// A shaft unused for more moves than this is collected.
    #[arg(long, default_value_t = 8)]
    pub max_age: u32,
    /// Where collected shafts go.
    #[arg(long, value_enum, default_value = "zstd")]
    pub shaft_store: ShaftStoreKind,
    /// Movement prediction: none, linear (eq. 1), mean:M (eq. 2), matrix (eq. 3).
    #[arg(long, default_value = "linear")]
    pub predict: String,
    /// Moves predicted ahead.
    #[arg(long, default_value_t = 1)]
    pub predict_ahead: u32,
    /// Scale of the predicted boxes about their centres.
    #[arg(long, default_value_t = 1.1)]
    pub predict_scale: f64,
    /// How a move finds the links it affects.
    #[arg(long, value_enum, default_value = "shafts")]
    pub traversal: TraversalKind,
    /// How a move brings the leaf system up to date: local or full.
    ///
    /// local: only the rows of the leaves under the links the move evaluated
    /// again, added or split are computed again; every other row is kept from the
    /// move before, and the leaf system is solved warm-started from the last
    /// radiosity.
    ///
    /// full: every leaf row is computed again at every refine-and-solve pass (as
    /// slow as solving again; kept to measure the local update against).
    #[arg(long, value_enum, default_value = "local")]
    pub update: UpdateKind,
    /// Do not prime the session before the first move.
    ///
    /// By default, once the scene is solved or restored, the session moves each
    /// movable object to where it already stands before reading the first move:
    /// the rows near the objects are computed again as a move computes them,
    /// keeping which of their rays static geometry blocks, and the shafts around
    /// the objects are built. The first move then costs what later moves cost;
    /// the start-up costs about what the first move would have. The radiosity is
    /// the solve's either way. With --no-prime the first move does that work.
    #[arg(long)]
    pub no_prime: bool,
    /// No progress lines on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// How finely the scene is refined and reconstructed.
    #[command(flatten)]
    pub accuracy: AccuracyArgs,
}

/// An output file written line by line, flushed after each.
struct Lines {
    path: PathBuf,
    w: std::io::BufWriter<std::fs::File>,
}

impl Lines {
    fn create(path: &Path) -> anyhow::Result<Lines> {
        let f =
            std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        Ok(Lines {
            path: path.to_path_buf(),
            w: std::io::BufWriter::new(f),
        })
    }

    fn line(&mut self, s: &str) -> anyhow::Result<()> {
        writeln!(self.w, "{s}")
            .and_then(|()| self.w.flush())
            .with_context(|| format!("writing {}", self.path.display()))
    }
}

/// Runs `rhier interact`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let settings = settings(&args)?;
    let (scene, hierarchy) = match &args.from {
        Some(from) => {
            let (scene, h) = read_from(&args, from)?;
            (scene, Some((h, from)))
        }
        None => (args.scene.load()?.0, None),
    };
    // The solver's pools on the backend `RHIER_STORAGE` names (RAM by default), as
    // a static solve without `--storage` places them.
    let storage = Storage::from_env().with_context(|| format!("reading {}", Storage::ENV))?;
    let opts = args.accuracy.solve_options(storage)?;
    let movable = match (&args.movable, &hierarchy) {
        (Some(m), _) => Some(m.clone()),
        (None, Some((h, _))) => Some(h.movable.clone()),
        (None, None) => None,
    };
    let stage = Stage::new(&scene, movable.as_deref())?;
    let points = match &args.probe {
        Some(p) => Some(read_probe_points(p)?),
        None => None,
    };
    let mut stats_out = args.stats.as_deref().map(Lines::create).transpose()?;
    let mut probe_out = args.probe_out.as_deref().map(Lines::create).transpose()?;
    let mut recorder = args.out.as_ref().map(|_| Recorder::new(args.fps));
    let start = std::time::Instant::now();
    let restored = hierarchy.is_some();
    // The stored columns are dropped once the session's pools hold them.
    let mut session = match hierarchy {
        Some((h, from)) => Session::restore(&stage, opts, settings, &h, from)
            .with_context(|| format!("starting from {}", from.display()))?,
        None => Session::start(&stage, opts, settings).context("solving the scene")?,
    };
    if !args.quiet {
        let (active, passive) = session.solver().links.counts();
        eprintln!(
            "{} in {:.3} s: {} elements, {active} active / {passive} passive links; reading moves",
            if restored {
                "restored the stored hierarchy"
            } else {
                "solved"
            },
            start.elapsed().as_secs_f64(),
            session.solver().elems.len()
        );
    }
    if !args.no_prime {
        let t = std::time::Instant::now();
        if let Some(p) = session.prime().context("priming the session")? {
            if !args.quiet {
                eprintln!(
                    "primed in {:.3} s: {} rows, {} shafts built",
                    t.elapsed().as_secs_f64(),
                    p.rows_recomputed,
                    p.shafts_built
                );
            }
        }
    }
    let mut io = Outputs {
        points: points.as_deref(),
        probe_out: probe_out.as_mut(),
        recorder: recorder.as_mut(),
    };
    io.after(&session, 0)?;
    let result = apply_moves(&args, &stage, &mut session, &mut stats_out, &mut io);
    if let (Some(rec), Some(path)) = (&recorder, &args.out) {
        rec.write(path, &stage)
            .with_context(|| format!("writing {}", path.display()))?;
        if !args.quiet {
            eprintln!("wrote {} ({} frames)", path.display(), rec.len());
        }
    }
    result
}

/// The scene and the persisted hierarchy of `--from`: the links section must be
/// there (`--keep-links`), and the hierarchy section (`--movable`). The scene is
/// SCENE when given, else the file's.
fn read_from(args: &Args, from: &Path) -> anyhow::Result<(Scene, Hierarchy)> {
    let r = Reader::open(from).with_context(|| format!("reading {}", from.display()))?;
    // Only the sections a session uses are read and validated: the hierarchy (which
    // holds the links in pool form) and the scene's tables. The links section is only
    // counted, and the leaves are not read (`rhier inspect` checks those).
    if r.link_count() == 0 {
        anyhow::bail!(
            "{}: the file holds no links; solve the scene with `rhier solve --keep-links --movable NAMES` to interact from it",
            from.display()
        );
    }
    let Some(h) = r
        .hierarchy()
        .with_context(|| format!("reading {}", from.display()))?
    else {
        anyhow::bail!(
            "{}: the file holds the links of a static solve but no hierarchy section; solve the scene with `rhier solve --keep-links --movable NAMES` (the objects the session moves) to interact from it",
            from.display()
        );
    };
    let given = args.scene.scene.is_some() || args.scene.builtin.is_some() || args.scene.blocks;
    let scene = if given {
        args.scene.load()?.0
    } else {
        r.scene()
    };
    Ok((scene, h))
}

/// The per-move outputs that need the final gather.
struct Outputs<'a> {
    points: Option<&'a [ProbePoint]>,
    probe_out: Option<&'a mut Lines>,
    recorder: Option<&'a mut Recorder>,
}

impl Outputs<'_> {
    /// Probes and records the session after move `i` (0: before the first).
    fn after(&mut self, session: &Session, i: u32) -> anyhow::Result<()> {
        if self.probe_out.is_none() && self.recorder.is_none() {
            return Ok(());
        }
        let sol = session.solution();
        if let (Some(pts), Some(out)) = (self.points, self.probe_out.as_mut()) {
            let b = probe(&sol, pts, 0.0)?;
            let line = serde_json::json!({"move": i, "B": b});
            out.line(&line.to_string())?;
        }
        if let Some(rec) = self.recorder.as_mut() {
            rec.push(session.poses(), &sol)?;
        }
        Ok(())
    }
}

/// Reads and applies the moves, one line at a time.
fn apply_moves(
    args: &Args,
    stage: &Stage,
    session: &mut Session,
    stats_out: &mut Option<Lines>,
    io: &mut Outputs,
) -> anyhow::Result<()> {
    let (name, input): (PathBuf, Box<dyn BufRead>) = if args.moves.as_os_str() == "-" {
        (
            PathBuf::from("<standard input>"),
            Box::new(BufReader::new(std::io::stdin())),
        )
    } else {
        let f = std::fs::File::open(&args.moves)
            .with_context(|| format!("opening {}", args.moves.display()))?;
        (args.moves.clone(), Box::new(BufReader::new(f)))
    };
    let mut count = 0u32;
    for (i, line) in input.lines().enumerate() {
        let line = line.with_context(|| format!("reading {}", name.display()))?;
        if line.trim().is_empty() {
            continue;
        }
        let moves = parse_move(&name, i + 1, &line, &stage.names, &stage.movable)?;
        let stats: MoveStats = session
            .apply(&moves)
            .with_context(|| format!("{}: line {}", name.display(), i + 1))?;
        count += 1;
        io.after(session, count)?;
        if let Some(out) = stats_out.as_mut() {
            out.line(&stats.json())?;
        }
        if !args.quiet {
            eprintln!("{}", stats.summary());
        }
    }
    Ok(())
}

/// The session's settings from the flags; a bad value names its flag.
fn settings(args: &Args) -> anyhow::Result<Settings> {
    let predict: Method = args.predict.parse()?;
    if !(args.predict_scale.is_finite() && args.predict_scale >= 1.0) {
        anyhow::bail!(
            "--predict-scale: expected a finite number >= 1, found {}",
            args.predict_scale
        );
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        anyhow::bail!("--fps: expected a finite number > 0, found {}", args.fps);
    }
    let thresholds = match (args.t_shafts, args.t_min) {
        (Some(t), Some(m)) => {
            if !(0.0..=1.0).contains(&t) || !(0.0..=t).contains(&m) {
                anyhow::bail!(
                    "--t-shafts / --t-min: expected 0 <= T_min <= T_shafts <= 1, found {t} and {m}"
                );
            }
            Some((t, m))
        }
        _ => None,
    };
    Ok(Settings {
        traversal: match args.traversal {
            TraversalKind::Shafts => Traversal::Affected,
            TraversalKind::Every => Traversal::Every,
        },
        policy: Policy {
            budget: args.shaft_budget,
            thresholds,
            max_age: args.max_age,
            keep: match args.shaft_store {
                ShaftStoreKind::None => Keep::Drop,
                ShaftStoreKind::Zstd => Keep::Zstd,
            },
        },
        predict,
        ahead: args.predict_ahead,
        scale: args.predict_scale,
        update: match args.update {
            UpdateKind::Local => Update::Local,
            UpdateKind::Full => Update::Full,
        },
    })
}
