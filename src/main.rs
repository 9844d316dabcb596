//! The `rhier` command: `main → run(parse()) → match subcommand`.
//!
//! Exit codes: 0 success, 1 failure of the job (bad input, corrupt file, I/O), 2 wrong
//! usage (clap's own exit code). Every failure prints one message on stderr.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("rhier: error: {err:#}");
            ExitCode::from(1)
        }
    }
}
