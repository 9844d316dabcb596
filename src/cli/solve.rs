//! `rhier solve`: load a scene (or the embedded Cornell box), solve, report, probe,
//! write the `.rhier` file.

use std::path::PathBuf;

/// Arguments of `rhier solve`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (.json native, .gltf/.glb, .obj); none = the embedded Cornell box.
    pub scene: Option<PathBuf>,
    /// Output `.rhier` file.
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
}

impl Args {
    /// The job `rhier` runs with no subcommand: the embedded scene, default output.
    pub fn default_job() -> Self {
        Args {
            scene: None,
            out: None,
        }
    }
}

/// Runs `rhier solve`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("rhier solve is not implemented yet")
}
