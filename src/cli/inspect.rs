//! `rhier inspect`: not yet implemented.

/// Arguments of `rhier inspect`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `rhier inspect`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("rhier inspect is not implemented yet")
}
