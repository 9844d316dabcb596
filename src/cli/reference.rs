//! `rhier reference`: not yet implemented.

/// Arguments of `rhier reference`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `rhier reference`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("rhier reference is not implemented yet")
}
