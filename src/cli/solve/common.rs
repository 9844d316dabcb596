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
    /// Which shard of a farm solve to solve.
    #[command(flatten)]
    pub farm: ShardArgs,
}

/// One shard of a space-time solve split for a job scheduler (`rhier plan
/// --shards N`): its index `0..count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Index, `0..count`.
    pub index: usize,
    /// Shards the windows are split into.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let expected = || format!("K/N with 0 <= K < N (e.g. 0/4), not {s:?}");
        let (k, n) = s.split_once('/').ok_or_else(expected)?;
        let (index, count) = (
            k.trim().parse().map_err(|_| expected())?,
            n.trim().parse().map_err(|_| expected())?,
        );
        Shard::new(index, count).ok_or_else(expected)
    }
}

impl Shard {
    /// Shard `index` of `count`, if `index < count`.
    pub fn new(index: usize, count: usize) -> Option<Shard> {
        (index < count).then_some(Shard { index, count })
    }
}

/// Which shard of a farm solve `rhier solve` solves.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Farm")]
pub struct ShardArgs {
    /// Solve only shard K of N of a space-time solve's windows (`rhier plan --shards
    /// N` shows them) and write them as a part for `rhier merge`.
    ///
    /// The windows are split into N contiguous runs of about equal estimated cost;
    /// the split depends on the scene and the settings alone, so every task of a job
    /// array finds the same one. The shard solves the shared part, then its own
    /// windows. A window depends on no other, so the merged parts hold the leaves a
    /// solve on one machine writes, bit for bit, whatever N.
    /// The part records the solve's fingerprint and the windows and times it holds;
    /// `--resume` continues an interrupted shard. A shard with no window (more
    /// shards than windows) writes a part that holds none.
    #[arg(long, conflicts_with_all = ["shards", "shard_index_env"])]
    pub shard: Option<Shard>,
    /// With `--shard-index-env`: the number of shards N.
    #[arg(long, requires = "shard_index_env")]
    pub shards: Option<usize>,
    /// Read the shard index K of `--shards N` from this environment variable, so that
    /// one command line serves every task of a job array (`SLURM_ARRAY_TASK_ID`,
    /// Kubernetes' `JOB_COMPLETION_INDEX`).
    #[arg(long, requires = "shards")]
    pub shard_index_env: Option<String>,
}

impl ShardArgs {
    /// The shard asked for, if any: `--shard K/N`, or `--shards N` with K from
    /// the environment variable `--shard-index-env` names.
    pub fn shard(&self) -> anyhow::Result<Option<Shard>> {
        if let Some(s) = self.shard {
            return Ok(Some(s));
        }
        let (Some(n), Some(var)) = (self.shards, &self.shard_index_env) else {
            return Ok(None);
        };
        let value = std::env::var(var).map_err(|_| {
            anyhow::anyhow!("--shard-index-env {var}: the environment variable {var} is not set")
        })?;
        let k: usize = value.trim().parse().map_err(|_| {
            anyhow::anyhow!("--shard-index-env {var}: expected a shard index, found {value:?}")
        })?;
        Shard::new(k, n).map(Some).ok_or_else(|| {
            anyhow::anyhow!("--shard-index-env {var} = {k}: expected an index below --shards {n}")
        })
    }
}

/// The scene to solve.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Scene")]
pub struct SceneArgs {
    /// Scene file (.json native, .gltf/.glb, .obj); none = the embedded Cornell box.
    ///
    /// The native JSON format is specified in formats/scene.md; a glTF file's node
    /// animations (translation, rotation, scale) become motion tracks; an OBJ file is
    /// static. A scene with motion is solved over its whole time domain: in time
    /// windows by default (space-time), or frame by frame with `--per-frame`.
    // Listed under "Arguments", where a positional argument is looked for.
    #[arg(help_heading = None::<&str>)]
    pub scene: Option<PathBuf>,
    /// Solve the Cornell box with the two published blocks (embedded scene only).
    #[arg(long, conflicts_with = "builtin")]
    pub blocks: bool,
    /// Solve an embedded scene instead of a file: the Cornell box, or the animated
    /// ACTOR / LIGHT scenes of 75 (3 s), 150 or 750 frames at 25 fps.
    ///
    /// ACTOR and LIGHT follow Damez & Sillion (section 3.1). ACTOR is a furnished
    /// 5 × 4 × 2.7 m room with a ceiling light and a window, two human-sized boxes
    /// walking across it; LIGHT is the same room with a ceiling light and a lower wall
    /// lamp that a sliding board hides mid-shot. The 150- and 750-frame versions walk
    /// the same motion back and forth. The same scenes are in formats/examples/.
    #[arg(long, value_enum, conflicts_with = "scene")]
    pub builtin: Option<Builtin>,
    /// Make every surface reflect and emit on both of its sides.
    ///
    /// Polygons are one-sided: the side their vertices turn counter-clockwise
    /// around reflects and emits, the back absorbs and stays black. Formats with no
    /// side flag (OBJ, native JSON) often hold surfaces that are lit from behind (a
    /// floor modelled facing down, a lamp facing into its fixture); this gives every
    /// polygon a twin facing the other way, at twice the patches. glTF materials
    /// marked `doubleSided` are two-sided without it.
    #[arg(long)]
    pub two_sided: bool,
}

/// Where the answer, the reports and the probes go.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Output")]
pub struct OutputArgs {
    /// Output `.rhier` file (default: `<scene stem>.rhier` in the working directory).
    ///
    /// A device or FIFO (`-o /dev/null` to time a solve and keep nothing) is written
    /// in place at the end, and gets no resume journal.
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// Write one CSV row per round (error against run time).
    ///
    /// A static solve writes a row per refine-and-solve round, as it prints a line:
    /// elapsed seconds, elements, leaves, active and passive links, bytes per pool,
    /// rays cast, links settled by shafts, the estimated error and the linear solve's
    /// residual (and the true error with `--reference`). A space-time solve writes a
    /// row per frame, in time order: cells, points gathered and interpolated,
    /// elements, links, varying links, rays, pool bytes, the bytes of final-gather
    /// terms the window keeps and the residual. `--per-frame` writes a row per frame.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Reference points with known radiosity (`rhier reference` output, or any JSON
    /// array of `{"p":..,"n":..,"B":[r,g,b]}`): adds the true error per round.
    ///
    /// The true error is the relative RMS error, at those points, of what `rhier
    /// probe` would return after the round. A static solve only: for an animation,
    /// compare probes at every frame (tools/spacetime_bench.py).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Probe points to evaluate after the solve (JSON array of `{"p":..,"n":..}`).
    ///
    /// Each point gets the radiosity of the surface nearest `p` whose normal faces
    /// along `n`, at the scene's start: the interpolant of the stored cell holding
    /// the point (bilinear on quads, linear on triangles), not an element average;
    /// the same answer as `rhier probe`. Not with `--per-frame`: probe its output
    /// with `rhier probe FILE --time T`.
    #[arg(long, requires = "probe_out")]
    pub probe: Option<PathBuf>,
    /// Where to write the probe results.
    #[arg(long, requires = "probe")]
    pub probe_out: Option<PathBuf>,
    /// Keep the links in the output file.
    ///
    /// Every link, active and passive, with its coefficient and error bound. A
    /// static solve only: `--per-frame` refuses it, and a space-time solve releases
    /// each window's links when the window is written.
    #[arg(long)]
    pub keep_links: bool,
    /// With --keep-links: solve the scene as `rhier interact --movable` stages it,
    /// and keep its hierarchy for `rhier interact --from`.
    ///
    /// The objects named (comma-separated) are the ones an interactive session
    /// may move: their patches are kept apart from the others' (contact meshing
    /// cuts along static objects only) and the solve is the one a session makes
    /// at start-up. The file then also holds the hierarchy section (every element
    /// and link of the solve, formats/rhier.md), from which `rhier interact
    /// --from FILE` starts without solving again. A static scene only.
    #[arg(
        long,
        value_delimiter = ',',
        requires = "keep_links",
        value_name = "NAMES"
    )]
    pub movable: Option<Vec<String>>,
    /// Print the memory counters of the run.
    ///
    /// Elements, links, the BVH and the stored cells, with the bytes each holds (a
    /// space-time solve: the shared part's and the largest window's pools;
    /// `--per-frame`: the counts of its largest frame).
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
    ///
    /// Smaller refines the hierarchy further: more elements and links, a smaller
    /// error, more time. A static solve refines in levels: up to two rounds at
    /// `2 eps`, then rounds at `eps`; the estimated error it prints is the change of
    /// the answer between the two levels (see `--target-error`). Without
    /// `--target-error`, `eps` promises an estimated error of `eps/20`: a static
    /// solve whose estimate is still above it once every link is under `eps` halves
    /// `eps` until it is not, within `--max-rounds` (a one-quad-per-wall room whose
    /// coarse links miss its lamp's light). In a space-time
    /// solve the room's error often follows `--recon-tol` more than `--eps`.
    #[arg(long, default_value_t = SolveOptions::default().eps)]
    pub eps: f64,
    /// Smallest element edge as a fraction of the scene's diameter, or of the
    /// object's when that is smaller.
    ///
    /// A link above `--eps` whose ends are both at this floor stays whole; the last
    /// line of the solve says so when that stopped it. The floor of an element is
    /// taken relative to its object's diameter (bounding-box diagonal) as well as to
    /// the scene's, the finer of the two, but no finer than 1/16 of the scene's: a
    /// car in a long tunnel is meshed to the car's scale, and so is its shadow on the
    /// tunnel. The default, 1/64, leaves the point values to the final gather: a
    /// finer floor refined the Cornell box's corners for the same error against the
    /// path tracer at 1.5–1.9× the time (BENCHMARKS.md). A solve that refines below
    /// `--eps` because its estimate is above what `--eps` promises lowers the floor's
    /// edge with `eps` (half the edge at `eps/2`).
    #[arg(long, default_value_t = SolveOptions::default().min_size)]
    pub min_size: f64,
    /// Reconstruction tolerance, relative to the RMS reflected radiosity.
    ///
    /// The stored answer is a mesh of cells whose corners carry a final gather
    /// through the links of the cell's leaf and its ancestors, with exact
    /// point-to-polygon form factors. A cell splits while the gather at its centre
    /// differs from its corners' interpolant by more than this, so the mesh follows
    /// room edges, contact lines and shadows. Smaller: finer cells, more gathers.
    ///
    /// Default: `--eps` / 10, between 0.002 and 0.02 (0.02 at the default `--eps`),
    /// so that the stored answer's error keeps falling with `--eps`: a cell's
    /// bilinear interpolant reads low where the radiosity is concave, by about
    /// this tolerance (BENCHMARKS.md, "Static solver: error against run time").
    #[arg(long)]
    pub recon_tol: Option<f64>,
    /// Reconstruction tolerance on the surfaces of moving objects (default:
    /// `--recon-tol`).
    ///
    /// The actors of a space-time solve at the tolerance best for the room come out
    /// coarser than the room; half of it on them costs little.
    #[arg(long)]
    pub recon_tol_moving: Option<f64>,
    /// Receivers smaller than the square of this fraction of the scene's diameter
    /// are refined on the power their links may get wrong, not on their radiosity
    /// (0: never).
    ///
    /// A small face is then refined for what it hands on to the rest of the scene,
    /// and the final gather gives its own values; this keeps the links of a room of
    /// a hundred thousand polygons bounded. Smaller refines the small faces of
    /// cluttered rooms further: slower, more memory and, there, more accurate
    /// (BENCHMARKS.md, "Scale").
    #[arg(long, default_value_t = SolveOptions::default().power_size)]
    pub power_size: f64,
    /// After the last round of a static solve, split the small leaves whose
    /// radiosity varies across them by more than this fraction of the RMS reflected
    /// radiosity, and solve again (0: never).
    ///
    /// Small: below the power area of `--power-size`; the spread is over the leaf's
    /// own quadrature points. It mends narrow slots in clutter, whose faces the power
    /// criterion leaves whole though their radiosity varies several-fold over their
    /// height, for more time and memory, and does not help every scene (BENCHMARKS.md,
    /// "Scale"). Static scenes and the frames of `--per-frame` only: a space-time
    /// solve refuses it.
    #[arg(long, default_value_t = SolveOptions::default().split_spread)]
    pub split_spread: f64,
    /// After the last round of a static solve, gather from the small leaves whose
    /// radiosity strays from their mean by more than this fraction of it quadrant by
    /// quadrant, not at their mean (0: never).
    ///
    /// Small: below the power area of `--power-size`. It mends the same narrow slots
    /// as `--split-spread` in the final gather only: no leaf is added and nothing is
    /// solved again, so it costs less time and no memory, and, as the split, does not
    /// help every scene (BENCHMARKS.md, "Scale"). Static scenes and the frames of
    /// `--per-frame` only: a space-time solve refuses it.
    #[arg(long, default_value_t = SolveOptions::default().leaf_shapes)]
    pub leaf_shapes: f64,
    /// Reconstruct a static solve twice, the second final gather seeing every leaf
    /// source by the first one's field instead of its constant radiosity.
    ///
    /// A point near a big leaf (a ceiling point by a wall) gathers most from the
    /// part of it nearest, whose radiosity the leaf's mean misses. The second gather
    /// takes each leaf source cell by cell from the first reconstruction where it
    /// looks large from the point, by quadrants elsewhere: on the empty Cornell box
    /// about a fifth less error off the lamp at eps 0.5 (1.26% → 0.97% when it was
    /// measured, build 1114711), for about twice the time
    /// (BENCHMARKS.md, "Static solver: error against run time"). It replaces
    /// `--leaf-shapes` on the leaves it shapes.
    #[arg(long)]
    pub source_field: bool,
    /// Mend the final gather's near sources from the reconstruction's own field
    /// (static solves).
    ///
    /// A point that sees a source large (the floor beside a block sees the
    /// block's side, a ceiling point by a wall the wall) then takes that source's
    /// light from the reconstruction's cells over it, each cell seen by a ray, at
    /// its own radiosity and exact factor, not from the source's mean radiosity,
    /// wherever that moves the point by more than a share of the reconstruction
    /// tolerance. It mends the contacts and concave edges, where the mean of a
    /// coarse source misses the dark or bright strip the point sees most: the
    /// Cornell box with blocks 1.66% → 1.01% off the lamp at the default eps, its
    /// contact points 3.5% → 1.9%, for about 25% more time there and 40% on the
    /// empty box (BENCHMARKS.md, "The near field").
    ///
    /// Off by default because the answer then depends more on how a wall is
    /// tiled: where a large source's field has few cells, the point is mended
    /// from their bilinear values, and a room with one quad per wall and the same
    /// room tiled differ by up to 1.17% at a point by a concave edge (1% is the
    /// bar the default holds). Space-time windows that span time do without it.
    #[arg(long)]
    pub near_field: bool,
    /// Take a cluster whose patches face a few ways (a box, a group of boxes)
    /// whole in the leaf rows and final gathers wherever each of its orientations
    /// is wholly in front of or behind the point, each orientation at its own
    /// radiosity, instead of opening it down to its faces.
    ///
    /// Faster and leaner in rooms cluttered with boxes, and as accurate at
    /// `gen_cubes 20` (107 CPU s against 197, 2.67% off the emitters against
    /// 2.85%), but at `gen_cubes 65` a facet counts boxes of its cluster that hide
    /// each other and the solve is refused (its leaf system makes 12% more light than
    /// is emitted; BENCHMARKS.md, "Scale"). Static scenes; a scene with motion
    /// ignores it.
    #[arg(long, default_value_t = SolveOptions::default().cluster_facets,
          num_args = 0..=1, default_missing_value = "true", action = clap::ArgAction::Set)]
    pub cluster_facets: bool,
    /// Solve a reconstruction point that faces a surface across a gap narrower than
    /// this fraction of the square root of the surface's area together with its foot
    /// on that surface (0: never).
    ///
    /// A face hovering close over another (a box's bottom hung just over the floor,
    /// as ACTOR's actors are) is not a contact, and light leaks into the gap from
    /// the coarse mean of the leaf a point there faces. With this on, such a point
    /// and its foot on the facing surface are solved together instead of gathering
    /// that mean, for more time. It works in every kind of solve (BENCHMARKS.md, "Two
    /// surfaces across a narrow gap").
    #[arg(long, default_value_t = SolveOptions::default().near_gap)]
    pub near_gap: f64,
    /// Do not cut patches along the lines where other polygons rest on them (see
    /// geometry::contact): faster in cluttered scenes, less accurate near contacts.
    ///
    /// By default, patches are cut along contact lines (a block resting on the
    /// floor) and the pieces hidden underneath are dropped, so no element straddles
    /// a contact; a patch is also cut along the outline of a polygon hanging
    /// parallel just in front of it (a lamp just under a ceiling). In a cluttered
    /// scene the cuts multiply the patches. A face hovering close over another is
    /// not a contact: see `--near-gap`. Moving objects cut nothing; the pieces of
    /// a static patch inside a moving object where it stands at the scene's start
    /// are dropped for the whole animation (every frame gets the same patches), so
    /// the floor under where a sliding block starts stays missing after it leaves.
    #[arg(long)]
    pub no_contact_meshing: bool,
    /// Solve every patch, also those no emitter's light can reach.
    ///
    /// By default a static solve first finds the closed shells of the scene
    /// (polygons whose edges pair up exactly, in one object or several: a crate, a
    /// box, a room of six walls, two rooms as two objects sharing a wall, a closed
    /// tessellated mesh; two-sided surfaces are left out)
    /// and the patches that lie on the other side of one from every emitter (what a
    /// sealed crate holds, a closed room with no lamp beside the lit one, a box's
    /// bottom resting on the floor). Their radiosity is exactly zero: they get no
    /// link, no row and no gather, are stored black (a probe there reads 0), and the
    /// lit part is solved at the scale it would have alone. A shell with a gap or a
    /// T-junction is not a shell; what is unsure is solved. Scenes with motion and
    /// `rhier interact` solve every patch (a move may open a shell). This flag turns
    /// the analysis off, to compare.
    #[arg(long)]
    pub no_sealed: bool,
    /// Most refine-and-solve rounds.
    #[arg(long, default_value_t = SolveOptions::default().max_rounds)]
    pub max_rounds: u32,
    /// Refine (halving `--eps` as needed) until the estimated relative error, the
    /// final gather's change between levels, is below this (static scenes)
    ///
    /// The estimate is the answer's own: the relative RMS change of the final gather
    /// (what `rhier probe` returns) at 128 points spread over the surfaces by area,
    /// between the last round at `2 eps` and this one, relative to the reflected
    /// radiosity there (the first level has none: `n/a` on the terminal, NaN in the
    /// CSV). It overestimates at a coarse `--eps`, where the change is mostly the
    /// coarser level's own error, and is blind to a bias that halving `--eps` does
    /// not change, as in rooms cluttered with boxes, where it reads low. Space-time
    /// solves report none; `--per-frame` reports each frame's.
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
    ///
    /// Frame `i` is at `t = start + i/F` and holds over the times nearest to it, so
    /// `rhier probe OUT --time T` plays any time back. Each frame is solved as the
    /// static scene it is. Prints one line per frame unless `-q`; `--report` writes
    /// one row per frame. Not with `--reference`, `--probe` or `--keep-links`.
    #[arg(long)]
    pub per_frame: bool,
    /// Frames per second at which a moving scene is solved (space-time, or
    /// `--per-frame`).
    #[arg(long, default_value_t = 25.0)]
    pub fps: f64,
    /// Seconds of animation per space-time window: frames are solved window by
    /// window; each finished window is written and its memory released.
    ///
    /// Default: twelve key intervals (see `--key-motion`), as long in motion as they
    /// are. Memory does not grow with the animation's length; a shorter window holds
    /// less at once. A window takes from the one before only the final-gather terms
    /// that still hold over it.
    #[arg(long)]
    pub window: Option<f64>,
    /// A stored cell keeps one value over consecutive frames while its corners stay
    /// within this fraction of the RMS reflected radiosity of their mean.
    ///
    /// Such a cell is stored once, with the longer time range.
    #[arg(long, default_value_t = 0.01)]
    pub merge_tol: f64,
    /// Space-time: every N-th frame of a window (and its first and last) is a
    /// keyframe gathered at every reconstruction point (1: gather every frame).
    ///
    /// The frames between, taken by bisection, interpolate the points where the two
    /// nearest solved frames agree, or follow a line with the frame as far before,
    /// and gather the rest (see `--interp-tol`). Default: keyframes spaced by motion
    /// (`--key-motion`).
    #[arg(long)]
    pub key_stride: Option<u32>,
    /// Space-time, without `--key-stride`: the next keyframe is the last frame
    /// before some point of a moving object has moved more than this fraction of the
    /// scene's diameter since the keyframe before (at most 32 frames on).
    ///
    /// Keyframes follow the motion, not the frame count: the same motion played over
    /// more frames makes as many keyframes and windows, and only the frames between
    /// multiply. Further apart is faster; too far, and moving shadows leave stains
    /// the frames between cannot mend.
    #[arg(long, default_value_t = SpaceTimeOptions::default().key_motion)]
    pub key_motion: f64,
    /// Space-time: how far (a fraction of the RMS reflected radiosity) a point's
    /// values at the solved frames around may stray from agreeing, or from a line,
    /// for a frame between to interpolate it.
    ///
    /// The frames between two keyframes come by bisection: the midpoint first, then
    /// each half's midpoint between its two ends, and so on. A point within this of
    /// agreeing at both ends, or of the line through the frame as far before, is
    /// interpolated in time instead of gathered; the rest (where a moving shadow's
    /// edge passed) is gathered at the frame, so a change is chased down only in the
    /// half it happened in.
    #[arg(long, default_value_t = SpaceTimeOptions::default().interp_tol)]
    pub interp_tol: f64,
    /// Space-time: a frame between two solved frames over which no moving object
    /// travels more than this fraction of the scene's diameter takes the line
    /// between them at every point both hold, and skips its leaf solve (0: never).
    ///
    /// Below this motion the bisection stops testing points, so the same motion
    /// played over more frames costs little more; a moving shadow's edge fades over
    /// that distance instead of stepping.
    #[arg(long, default_value_t = SpaceTimeOptions::default().interp_motion)]
    pub interp_motion: f64,
    /// Space-time: a frame between two solved frames skips its leaf solve (the
    /// radiosity of what every frame shares taken on the line between them) when no
    /// moving surface's power changes between them by more than this fraction of
    /// the moving surfaces' total.
    ///
    /// The moving objects are still placed at the frame, and its points gather from
    /// the last solved hierarchy. Otherwise the frame is solved and becomes an end
    /// for the halves below it. Walking actors change the light they hand on little
    /// between keyframes, and the frames between skip the solve; a panel sliding
    /// over a lamp changes it much, and they are solved.
    #[arg(long, default_value_t = SpaceTimeOptions::default().moving_power_tol)]
    pub moving_power_tol: f64,
    /// Space-time: take the line between two solved frames over the whole light of
    /// the points on moving surfaces.
    ///
    /// By default their direct light is computed anew at every frame between, and
    /// the line is over the rest of their light only (in scenes with at most 16
    /// emitting patches: exact factors to each lamp, with rays). A panel sliding past a lamp is lit
    /// along a curve the line cannot follow; its inter-reflections with what it
    /// passes follow it less steeply. This flag saves the rays of the direct light
    /// and is less accurate on such surfaces (BENCHMARKS.md, "The direct light of
    /// moving surfaces").
    #[arg(long)]
    pub whole_light_between: bool,
    /// Continue an interrupted space-time solve from its last finished window (kept
    /// in OUT.rhier.partial/).
    ///
    /// Every finished window but the last is kept in the journal directory
    /// `OUT.rhier.partial/` (checksummed; removed when the file is complete), with
    /// the final-gather terms it hands the next window, so the resumed file has the
    /// same leaves as an uninterrupted solve; an interrupted solve leaves no
    /// `.rhier` file. A journal made with another scene or another setting that
    /// changes the result is refused, and the error names the first that differs;
    /// what changes no result (`--storage`, `--scratch`, `--threads`, the output
    /// flags) may change.
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
    ///
    /// Without `--storage`, the environment variable `RHIER_STORAGE` sets the
    /// default of a static or per-frame solve: `ram` (unset), `mmap` (the system temp
    /// directory) or `mmap:DIR`. On memory-mapped files the leaves are the same as in
    /// RAM and the solve is a little slower.
    #[arg(long, value_enum)]
    pub storage: Option<StorageKind>,
    /// Directory for memory-mapped pool files, created if missing (default: a
    /// space-time solve's journal directory, else the system temp directory).
    #[arg(long)]
    pub scratch: Option<PathBuf>,
    /// Memory budget in bytes: the pools live in memory-mapped files (`--scratch`)
    /// and a window that exceeds it is reported.
    ///
    /// A space-time solve also keeps at most this many bytes of final-gather terms
    /// and leaf rows per window: over it, the points the last frame did not use are
    /// dropped first and new ones are gathered afresh at every frame (slower; the
    /// result moves very little, where a frame has opened a source into finer
    /// children than when its terms were kept).
    #[arg(long)]
    pub budget: Option<u64>,
    /// Worker threads (default: all cores).
    ///
    /// Results are deterministic for a given seed and thread count.
    ///
    /// The occlusion rays are cast through a 4-wide BVH built by obvhs;
    /// `RHIER_RAYS=cwbvh` casts them through obvhs' CWBVH (the default before), and
    /// `RHIER_RAYS=embree` through Embree 3, its library opened at run time
    /// (Debian: `apt-get install libembree3-3`, or `libembree-dev`), all with the
    /// same f64 decisions (`obvhs`, unset: the default).
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
        let mut opts = self
            .accuracy
            .solve_options(self.resources.storage(false, None))?;
        // `--keep-links` writes every link, the passive ones too.
        opts.keep_passive = self.output.keep_links;
        Ok(opts)
    }

    /// The time settings the arguments ask for, checked
    /// ([`SpaceTimeOptions::validate`]).
    pub fn space_time_options(&self) -> anyhow::Result<SpaceTimeOptions> {
        self.animation.space_time_options(&self.resources)
    }
}

impl AnimationArgs {
    /// The time settings these and `resources` (`--budget`) ask for, checked
    /// ([`SpaceTimeOptions::validate`]).
    pub fn space_time_options(&self, resources: &ResourceArgs) -> anyhow::Result<SpaceTimeOptions> {
        let a = self;
        let st = SpaceTimeOptions {
            fps: a.fps,
            window: a.window,
            merge_tol: a.merge_tol,
            kept_budget: resources.budget,
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

/// The reconstruction tolerance when `--recon-tol` is not given: `eps / 10`,
/// between 0.002 and [`SolveOptions::default`]'s (0.02).
pub fn default_recon_tol(eps: f64) -> f64 {
    let coarsest = SolveOptions::default().recon_tol;
    (eps / 10.0).clamp(0.002, coarsest)
}

impl AccuracyArgs {
    /// The solve's settings these flags give, with the pools in `storage`; checked.
    pub fn solve_options(&self, storage: Storage) -> anyhow::Result<SolveOptions> {
        let a = self;
        let opts = SolveOptions {
            storage,
            eps: a.eps,
            min_size: a.min_size,
            recon_tol: a.recon_tol.unwrap_or_else(|| default_recon_tol(a.eps)),
            recon_tol_moving: a.recon_tol_moving,
            power_size: a.power_size,
            split_spread: a.split_spread,
            leaf_shapes: a.leaf_shapes,
            source_field: a.source_field,
            near_field: a.near_field,
            cluster_facets: a.cluster_facets,
            near_gap: a.near_gap,
            max_rounds: a.max_rounds,
            target_error: a.target_error,
            time_budget: a.time_budget,
            seed: a.seed,
            contact_meshing: !a.no_contact_meshing,
            sealed_regions: !a.no_sealed,
            ..SolveOptions::default()
        };
        opts.validate()?;
        Ok(opts)
    }
}

impl SceneArgs {
    /// The scene to solve and the stem of the default output name.
    pub fn load(&self) -> anyhow::Result<(Scene, String)> {
        let (mut scene, stem) = self.load_as_is()?;
        if self.two_sided {
            rhier::scene::two_sided(&mut scene);
        }
        Ok((scene, stem))
    }

    fn load_as_is(&self) -> anyhow::Result<(Scene, String)> {
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

/// Writes the answer of a scene with no emitter, zero everywhere over its time
/// domain, without solving: one leaf per patch in one chunk (a static file, and a
/// space-time one whose leaves all hold over the whole animation), the probes' zeros,
/// and the report of no round or frame `empty_report` writes.
pub fn write_zero(
    output: &OutputArgs,
    scene: &Scene,
    stem: &str,
    start: std::time::Instant,
    empty_report: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    use rhier::playback::{probe, read_probe_points, write_probe_results};
    let probes = output.probe.as_deref().map(read_probe_points).transpose()?;
    let mut solution = rhier::solution::Solution::zero(scene);
    solution.stats.seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &output.report {
        empty_report(path)?;
    }
    if let (Some(points), Some(out)) = (&probes, &output.probe_out) {
        let values = probe(&solution, points, scene.time.start)?;
        write_probe_results(out, &values)?;
    }
    let out = output.out_path(stem);
    rhier::store::write_solution(&out, &solution, rhier::store::WriteOptions::default())
        .with_context(|| format!("writing {}", out.display()))?;
    if !output.quiet {
        eprintln!(
            "solved {} patches in {:.3} s: no emitter, so the radiosity is zero everywhere{} (written without solving); wrote {}",
            solution.patches.len(),
            solution.stats.seconds,
            if scene.has_motion() {
                format!(
                    " at every time in [{}, {}]",
                    scene.time.start, scene.time.end
                )
            } else {
                String::new()
            },
            out.display()
        );
    }
    Ok(())
}
