//! `rhier probe FILE.rhier --points P.json [--time T] [-o OUT.json]`: radiosity at
//! points from a stored solution, the same contract and code as `solve --probe`
//! (DESIGN.md): prints a JSON array of `{"B":[r,g,b]}` in the points' order.

use std::path::PathBuf;

use anyhow::Context;
use rhier::playback::{probe, probe::probe_results_json, read_probe_points, write_probe_results};
use rhier::store::Reader;

/// Arguments of `rhier probe`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The `.rhier` file.
    pub file: PathBuf,
    /// Probe points: a JSON array of `{"p":[x,y,z],"n":[x,y,z]}`.
    #[arg(long)]
    pub points: PathBuf,
    /// Time in seconds (default: the scene's start).
    #[arg(long)]
    pub time: Option<f64>,
    /// Write the JSON results to this file instead of standard output.
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
}

/// Runs `rhier probe`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let reader = Reader::open(&args.file)?;
    let points = read_probe_points(&args.points)?;
    let t = args.time.unwrap_or(reader.time_domain().start);
    let values = probe(&reader, &points, t)
        .with_context(|| format!("probing {} at time {t}", args.file.display()))?;
    match &args.out {
        Some(out) => write_probe_results(out, &values)?,
        None => print_stdout(&probe_results_json(&values))?,
    }
    Ok(())
}

/// Writes `text` to standard output; a closed pipe (`rhier ... | head`) ends quietly
/// instead of panicking as `print!` would.
pub(crate) fn print_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => Ok(r.context("writing to standard output")?),
    }
}
