//! The `rhier` command: `main → run(parse()) → match subcommand`.
//!
//! Exit codes: 0 success, 1 failure of the job (bad input, corrupt file, I/O), 2 wrong
//! usage (clap's own exit code). Every failure prints one message on stderr.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    large_blocks_from_the_system();
    let cli = cli::Cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("rhier: error: {err:#}");
            ExitCode::from(1)
        }
    }
}

/// Serves every heap block of 1 MiB or more straight from the system (its own
/// mapping, resized in place by `mremap` and unmapped when freed) instead of
/// glibc's dynamic threshold, which rises to 32 MiB after the first large free: the
/// arenas a space-time window grows by a quarter at a time (kept final-gather
/// terms, tens of MB) would otherwise leave holes in the heap that the next window
/// cannot reuse, and the resident size would grow window after window.
fn large_blocks_from_the_system() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only changes the allocator's thresholds; called first thing
    // in `main`, before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}
