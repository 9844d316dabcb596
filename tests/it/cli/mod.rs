//! The real `rhier` binary's `solve`, run in temporary directories: exit codes,
//! settings refused, the storage backend, and space-time solves that stream, are
//! interrupted and resume. (Other commands are tested with their concept:
//! `flatland::cli`, `playback::render`, `store::solve`, `solver::per_frame`.)

mod solve;
mod spacetime;
