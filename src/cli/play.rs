//! `rhier play`: not yet implemented.

/// Arguments of `rhier play`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `rhier play`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("rhier play is not implemented yet")
}
