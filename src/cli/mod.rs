//! Command-line interface: clap derive, one module per subcommand (`solve` is a
//! folder: its three ways of solving share one module of arguments, see
//! [`solve`]). Modules import in one direction: `inspect` and `play` use `probe`'s
//! printing, `view` `inspect`'s report, `solve`'s modes its `common`, and nothing imports back. Error context
//! (anyhow) is added here and only here; the library returns [`rhier::Error`].

mod flatland;
mod inspect;
mod interact;
mod merge;
mod play;
mod probe;
mod reference;
mod solve;
mod view;

use clap::{Parser, Subcommand};

/// rhier: hierarchical radiosity for scenes that move, kept on disk.
#[derive(Debug, Parser)]
#[command(name = "rhier", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Solve a scene (native JSON, glTF, OBJ; none = the embedded Cornell box).
    ///
    /// A static scene is refined and solved in rounds, each printed with its cost
    /// and estimated error, then reconstructed as a mesh of cells whose corners carry
    /// a final gather. A scene with motion is solved over its whole time domain, in
    /// time windows that share what does not move (space-time), or frame by frame
    /// with `--per-frame`. The answer goes to a `.rhier` file that `rhier probe`,
    /// `play` and `inspect` read back. Patches that no emitter's light can reach
    /// (sealed off by a closed shell) are stored black without being solved
    /// (`--no-sealed`).
    ///
    /// The last line of a static solve says how much of the emitted power the
    /// solution absorbs: no exact answer absorbs more, and a closed scene absorbs all
    /// of it. A closed scene whose leaf system is off by more than 2% is balanced
    /// (`leaf system balanced`); what stays off by more than that is warned about. A
    /// setting outside its domain (`--eps 0`, a NaN) exits with status 1, naming the
    /// flag, before any work starts. `-h` lists the flags, `--help` explains them.
    // Boxed: its arguments are many times the size of the others'.
    Solve(Box<solve::Args>),
    /// Radiosity at points from a stored `.rhier` solution.
    Probe(probe::Args),
    /// Render frames of a stored solution to PNG (or glTF).
    Play(play::Args),
    /// What a `.rhier` file holds and what it costs in memory.
    Inspect(inspect::Args),
    /// Move objects of a solved scene one move at a time (moves as JSON lines).
    ///
    /// The scene is solved, then each line of `--moves` (or standard input with
    /// `-`) moves objects; the radiosity is brought up to date by the links the move
    /// affects only (line-space hierarchy, shafts stored near the moving objects
    /// under a budget). One statistics line per move (`--stats`), probes after each
    /// move (`--probe`), and the session as an animation (`-o`). formats/interactive.md.
    Interact(Box<interact::Args>),
    /// Exact 2D radiosity with the visibility complex.
    Flatland(flatland::Args),
    /// Independent Monte Carlo reference radiosity at probe points.
    Reference(reference::Args),
    /// The windows of a space-time solve, their estimated costs and their split
    /// into shards for a job scheduler (`rhier solve --shard K/N`).
    ///
    /// Takes the scene and the settings of `rhier solve` and solves nothing: every
    /// window's frames, keyframes and time span, its estimated cost (in keyframes,
    /// from the motion), and the contiguous runs of windows of about equal cost
    /// that `--shards N` splits them into.
    Plan(Box<solve::plan::Args>),
    /// Join the parts of a space-time solve's shards into one `.rhier` file.
    ///
    /// The parts must come from the same scene and settings (the fingerprint each
    /// holds), and their windows must cover the animation with no gap and no
    /// overlap, every shard once; otherwise the merge fails naming the part, or the
    /// missing shard. Chunks are copied as stored, not re-encoded; the file appears
    /// only once whole.
    Merge(merge::Args),
    /// Serve a stored solution to a web browser: orbit, scrub time, click to probe.
    ///
    /// Validates the file as `rhier inspect` does (a corrupt one is refused, status
    /// 1), then serves a page on http://127.0.0.1:8080/ (`--host`, `--port`) and
    /// prints its address. The page draws the solution with WebGL2 as `rhier play`
    /// does (smooth vertex radiosity or flat per leaf, the same exposure and sRGB
    /// curve, the same start camera), a time slider with play/pause for a moving
    /// scene, the `rhier probe` answer of a clicked surface with its patch and leaf,
    /// and the `inspect` report. Everything is in the binary: no network needed.
    View(view::Args),
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        None => solve::run(solve::Args::default_job()),
        Some(Command::Solve(a)) => solve::run(*a),
        Some(Command::Probe(a)) => probe::run(a),
        Some(Command::Play(a)) => play::run(a),
        Some(Command::Inspect(a)) => inspect::run(a),
        Some(Command::Interact(a)) => interact::run(*a),
        Some(Command::Flatland(a)) => flatland::run(a),
        Some(Command::Reference(a)) => reference::run(a),
        Some(Command::Plan(a)) => solve::plan::run(*a),
        Some(Command::Merge(a)) => merge::run(a),
        Some(Command::View(a)) => view::run(a),
    }
}
