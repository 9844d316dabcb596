//! `rhier merge PART... -o FILE`: the parts a space-time solve's shards wrote
//! (`rhier solve --shard K/N`) joined into one file, as [`rhier::store::merge`]
//! checks and copies them.

use std::path::PathBuf;

/// Arguments of `rhier merge`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The parts, in any order (`part-*.rhier`).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged `.rhier` file.
    #[arg(short = 'o', long = "out")]
    pub out: PathBuf,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `rhier merge`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let start = std::time::Instant::now();
    let r = rhier::store::merge::merge(&args.parts, &args.out)?;
    if !args.quiet {
        eprintln!(
            "merged {} parts ({} windows, {} chunks copied) in {:.3} s; wrote {} ({} bytes)",
            r.parts.len(),
            r.windows,
            r.chunks,
            start.elapsed().as_secs_f64(),
            args.out.display(),
            r.bytes
        );
    }
    Ok(())
}
