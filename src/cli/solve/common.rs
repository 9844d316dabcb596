//! What the three ways of `rhier solve` share: the arguments, in groups that
//! `--help` shows under their own headings, and what is made of them (the scene,
//! the storage of the pools, the solver's and the time settings, the output path,
//! the progress line). It imports no sibling module, so the modes import it and
//! nothing imports them back.
//!
//! Every flag's doc comment is its help: the first paragraph is the line `-h`
//! shows, the rest what `--help` adds (what the flag does and when to use it;
//! measurements live in BENCHMARKS.md).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::Context;
use rhier::pools::Storage;
use rhier::scene::Scene;
use rhier::solver::SolveOptions;
use rhier::solver::spacetime::SpaceTimeOptions;

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

/// Arguments of `rhier solve`, by group.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// What to solve.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Where the answer and the reports go.
    #[command(flatten)]
    pub output: OutputArgs,
    /// How finely the scene is refined and reconstructed.
    #[command(flatten)]
    pub accuracy: AccuracyArgs,
    /// How a moving scene is solved over time.
    #[command(flatten)]
    pub animation: AnimationArgs,
    /// Memory, files and threads.
    #[command(flatten)]
    pub resources: ResourceArgs,
}

/// The scene to solve.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Scene")]
pub struct SceneArgs {
    /// Scene file (.json native, .gltf/.glb, .obj); none = the embedded Cornell box.
    // Listed under "Arguments", where a positional argument is looked for.
    #[arg(help_heading = None::<&str>)]
    pub scene: Option<PathBuf>,
    /// Solve the Cornell box with the two published blocks (embedded scene only).
    #[arg(long, conflicts_with = "builtin")]
    pub blocks: bool,
    /// Solve an embedded scene instead of a file: the Cornell box, or the animated
    /// ACTOR / LIGHT scenes of 75 (3 s), 150 or 750 frames at 25 fps.
    #[arg(long, value_enum, conflicts_with = "scene")]
    pub builtin: Option<Builtin>,
}

/// Where the answer, the reports and the probes go.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Output")]
pub struct OutputArgs {
    /// Output `.rhier` file (default: `<scene stem>.rhier` in the working directory).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
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
    /// Print the memory counters of the run.
    #[arg(long)]
    pub stats: bool,
    /// Print nothing but errors and warnings.
    #[arg(short, long)]
    pub quiet: bool,
}

/// How finely the scene is refined, solved and reconstructed.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Accuracy")]
pub struct AccuracyArgs {
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
    /// Do not cut patches along the lines where other polygons rest on them (see
    /// geometry::contact): faster in cluttered scenes, less accurate near contacts.
    #[arg(long)]
    pub no_contact_meshing: bool,
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
    /// Seed of the ray jitter.
    #[arg(long, default_value_t = SolveOptions::default().seed)]
    pub seed: u64,
}

/// How a moving scene is solved over time.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Animation")]
pub struct AnimationArgs {
    /// Solve every frame independently (the frame-by-frame baseline) at `--fps`,
    /// streaming one chunk per frame into the output file.
    #[arg(long)]
    pub per_frame: bool,
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
    /// Stop with an error after this many windows (to test --resume).
    #[arg(long, hide = true)]
    pub stop_after_windows: Option<u32>,
}

/// Memory, files and threads.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Resources")]
pub struct ResourceArgs {
    /// Where the element and link pools (and a space-time window's kept final-gather
    /// terms and leaves) live [default: mmap for a space-time solve, out of core in
    /// the journal directory `OUT.rhier.partial/` beside the output; ram otherwise]
    #[arg(long, value_enum)]
    pub storage: Option<StorageKind>,
    /// Directory for memory-mapped pool files, created if missing (default: a
    /// space-time solve's journal directory, else the system temp directory).
    #[arg(long)]
    pub scratch: Option<PathBuf>,
    /// Memory budget in bytes: the pools live in memory-mapped files (`--scratch`)
    /// and a window that exceeds it is reported; a space-time solve also keeps at
    /// most this many bytes of final-gather terms per window (over it, points are
    /// gathered afresh each frame: slower, same result).
    #[arg(long)]
    pub budget: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
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

    /// The solver settings the arguments ask for (shared by every mode of `solve`),
    /// checked against their domains ([`SolveOptions::validate`]).
    pub fn solve_options(&self) -> anyhow::Result<SolveOptions> {
        let a = &self.accuracy;
        let opts = SolveOptions {
            storage: self.resources.storage(false, None),
            eps: a.eps,
            min_size: a.min_size,
            recon_tol: a.recon_tol,
            recon_tol_moving: a.recon_tol_moving,
            power_size: a.power_size,
            split_spread: a.split_spread,
            leaf_shapes: a.leaf_shapes,
            near_gap: a.near_gap,
            max_rounds: a.max_rounds,
            target_error: a.target_error,
            time_budget: a.time_budget,
            seed: a.seed,
            contact_meshing: !a.no_contact_meshing,
            ..SolveOptions::default()
        };
        opts.validate()?;
        Ok(opts)
    }

    /// The time settings the arguments ask for, checked
    /// ([`SpaceTimeOptions::validate`]).
    pub fn space_time_options(&self) -> anyhow::Result<SpaceTimeOptions> {
        let a = &self.animation;
        let st = SpaceTimeOptions {
            fps: a.fps,
            window: a.window,
            merge_tol: a.merge_tol,
            kept_budget: self.resources.budget,
            key_stride: a.key_stride,
            key_motion: a.key_motion,
            interp_tol: a.interp_tol,
            interp_motion: a.interp_motion,
            moving_power_tol: a.moving_power_tol,
            direct_apart: !a.whole_light_between,
        };
        st.validate()?;
        Ok(st)
    }
}

impl SceneArgs {
    /// The scene to solve and the stem of the default output name.
    pub fn load(&self) -> anyhow::Result<(Scene, String)> {
        if let Some(b) = self.builtin {
            use clap::ValueEnum;
            let name = b
                .to_possible_value()
                .map_or_else(String::new, |v| v.get_name().to_string());
            let scene = rhier::scene::builtin(&name)
                .with_context(|| format!("no embedded scene called {name:?}"))?;
            return Ok((scene, name.replace('-', "_")));
        }
        match &self.scene {
            Some(path) => {
                let scene = rhier::scene::load(path)?;
                let stem = path
                    .file_stem()
                    .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
                Ok((scene, stem))
            }
            None => {
                let name = if self.blocks {
                    "cornell_blocks"
                } else {
                    "cornell"
                };
                Ok((rhier::scene::cornell_box(self.blocks), name.to_string()))
            }
        }
    }
}

impl OutputArgs {
    /// The output file: `--out`, else `<stem>.rhier` in the working directory.
    pub fn out_path(&self, stem: &str) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| PathBuf::from(format!("{stem}.rhier")))
    }

    /// A spinner on stderr showing `message`, unless `-q`, stderr is no terminal or
    /// `CI` is set.
    pub fn progress(&self, message: &'static str) -> Option<indicatif::ProgressBar> {
        let show =
            !self.quiet && std::io::stderr().is_terminal() && std::env::var_os("CI").is_none();
        show.then(|| {
            let b = indicatif::ProgressBar::new_spinner();
            b.set_message(message);
            b.enable_steady_tick(std::time::Duration::from_millis(120));
            b
        })
    }
}

impl ResourceArgs {
    /// Where the pools live: `--storage`, else memory-mapped if `out_of_core` (a
    /// space-time solve) and the library's default otherwise (RAM unless
    /// `RHIER_STORAGE` says otherwise, [`Storage::ENV`]); `--budget` always maps.
    /// Mapped files go in `--scratch`, else `dir` (a space-time solve's journal
    /// directory), else the directory `RHIER_STORAGE` names, else the system temp
    /// directory.
    pub fn storage(&self, out_of_core: bool, dir: Option<&Path>) -> Storage {
        let env_dir = match Storage::from_env().unwrap_or_default() {
            Storage::Mmap(d) => Some(d),
            Storage::Ram => None,
        };
        let mapped = self.budget.is_some()
            || match self.storage {
                Some(kind) => kind == StorageKind::Mmap,
                None => out_of_core || env_dir.is_some(),
            };
        if !mapped {
            return Storage::Ram;
        }
        Storage::Mmap(
            self.scratch
                .clone()
                .or_else(|| dir.map(Path::to_path_buf))
                .or(env_dir)
                .unwrap_or_else(std::env::temp_dir),
        )
    }
}
