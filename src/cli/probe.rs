//! `rhier probe`: not yet implemented.

/// Arguments of `rhier probe`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `rhier probe`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("rhier probe is not implemented yet")
}
