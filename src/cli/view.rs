//! `rhier view FILE.rhier [--port P] [--host H] [--open]`: validates the file as
//! `rhier inspect` does (every chunk), then serves a page that draws it in a browser
//! ([`rhier::view`]), prints its address and runs until interrupted.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use rhier::store::Reader;
use rhier::view::Viewer;

/// Arguments of `rhier view`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The `.rhier` file.
    pub file: PathBuf,
    /// Port to listen on (0: any free port; the address printed says which).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Address to listen on.
    ///
    /// The default, 127.0.0.1, is reachable from this machine only. Any other
    /// address (0.0.0.0 = every interface) lets every machine that reaches it read
    /// the whole solution, with no password: a warning says so.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Open the page in the desktop's browser (`xdg-open`) once it is served.
    #[arg(long)]
    pub open: bool,
}

/// Runs `rhier view`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let reader = Reader::open(&args.file)?;
    let report = super::inspect::report(&args.file, &reader, true)?;
    let inspect = serde_json::json!({
        "json": serde_json::to_value(&report)?,
        "text": super::inspect::text(&report, reader.chunks().len())?,
    });
    let viewer = Viewer::new(reader, inspect)?;
    let server = tiny_http::Server::http((args.host.as_str(), args.port))
        .map_err(|e| anyhow::anyhow!("listening on {}:{}: {e}", args.host, args.port))?;
    let addr = server
        .server_addr()
        .to_ip()
        .context("the server has no IP address")?;
    if !addr.ip().is_loopback() {
        eprintln!(
            "rhier: warning: --host {}: listening on {addr}, reachable from other machines; anyone who reaches it can read {}",
            args.host,
            args.file.display()
        );
    }
    let url = format!("http://{addr}/");
    super::probe::print_stdout(&format!(
        "rhier view: serving {} at {url} (Ctrl-C to stop)\n",
        args.file.display()
    ))?;
    if args.open
        && let Err(e) = std::process::Command::new("xdg-open").arg(&url).spawn()
    {
        eprintln!("rhier: warning: --open: could not start xdg-open ({e}); open {url} by hand");
    }
    rhier::view::serve(Arc::new(viewer), server);
    Ok(())
}
