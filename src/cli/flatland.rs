//! `rhier flatland`: not yet implemented.

/// Arguments of `rhier flatland`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `rhier flatland`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("rhier flatland is not implemented yet")
}
