//! `rhier solve`: load a scene (a file, an embedded scene, or the Cornell box), solve
//! it and write the `.rhier` file, reporting error against run time.
//!
//! Three ways, one module each: a static scene ([`static_scene`]), a moving scene
//! in time windows ([`spacetime`]) or frame by frame with `--per-frame`
//! ([`per_frame`]). What they share (the arguments, loading the scene, the storage
//! and settings made of the arguments) is in [`common`], which imports none of
//! them; this module reads the arguments once and hands them to the way that fits.
//! `rhier plan` ([`plan`]) reads the same arguments to show the windows a
//! space-time solve makes and their split into shards.

pub(super) mod common;
mod per_frame;
pub mod plan;
mod spacetime;
mod static_scene;

pub use common::Args;

/// Runs `rhier solve`.
pub fn run(args: Args) -> anyhow::Result<()> {
    use anyhow::Context;
    if let Some(n) = args.resources.threads {
        // Only fails if a pool exists already, which cannot happen this early.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global();
    }
    if let Some(dir) = &args.resources.scratch {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--scratch {}: cannot create the directory", dir.display()))?;
    }
    let opts = args.solve_options()?;
    let sharded = args.farm.shard()?.is_some();
    if sharded && args.animation.per_frame {
        anyhow::bail!("--shard splits a space-time solve's windows; --per-frame has none");
    }
    if args.animation.per_frame {
        return per_frame::run(&args, opts);
    }
    let start = std::time::Instant::now();
    let (scene, stem) = args.scene.load()?;
    for w in &scene.warnings {
        eprintln!("rhier: warning: {w}");
    }
    if let Some(movable) = &args.output.movable {
        if scene.has_motion() || sharded {
            anyhow::bail!(
                "--movable: solves a static scene for `rhier interact`; {stem} has motion or is sharded"
            );
        }
        static_scene::run_staged(&args.output, &scene, &stem, opts, start, movable)
    } else if scene.has_motion() {
        spacetime::run(&args, &scene, &stem, opts, start)
    } else if sharded {
        anyhow::bail!(
            "--shard splits a space-time solve's windows; {stem} does not move, so it is solved whole"
        )
    } else {
        static_scene::run(&args.output, &scene, &stem, opts, start)
    }
}
