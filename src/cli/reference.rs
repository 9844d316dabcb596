//! `rhier reference SCENE --points P.json --paths N -o REF.json`: independent Monte
//! Carlo radiosity at probe points (diffuse path tracing), written as a JSON array of
//! `{"p","n","B","std_error"}` that `solve --reference` reads.

use std::path::PathBuf;

use anyhow::Context;
use rhier::playback::read_probe_points;

/// Arguments of `rhier reference`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file; none = the embedded Cornell box.
    pub scene: Option<PathBuf>,
    /// Use the Cornell box with its blocks (embedded scene only).
    #[arg(long)]
    pub blocks: bool,
    /// Probe points (JSON array of `{"p":..,"n":..}`).
    #[arg(long)]
    pub points: PathBuf,
    /// Paths per point.
    #[arg(long, default_value_t = 100_000)]
    pub paths: u32,
    /// Seed.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Output file.
    #[arg(short = 'o', long = "out")]
    pub out: PathBuf,
}

/// Runs `rhier reference`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let scene = match &args.scene {
        Some(p) => rhier::scene::load(p)?,
        None => rhier::scene::cornell_box(args.blocks),
    };
    let points = read_probe_points(&args.points)?;
    let pts: Vec<_> = points.iter().map(|p| (p.p, p.n)).collect();
    let est = rhier::reference::radiosity_at(&scene, &pts, args.paths, args.seed);
    let rows: Vec<serde_json::Value> = points
        .iter()
        .zip(&est)
        .map(|(p, e)| serde_json::json!({"p": p.p.to_array(), "n": p.n.to_array(), "B": e.b, "std_error": e.std_error}))
        .collect();
    let text = serde_json::to_string_pretty(&rows)?;
    std::fs::write(&args.out, text).with_context(|| format!("writing {}", args.out.display()))?;
    Ok(())
}
