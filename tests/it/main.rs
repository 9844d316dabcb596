//! rhier's integration tests, one binary for all of them (as ripgrep's): a module
//! per concept, each file testing one part of it through the library's public API or
//! the real `rhier` binary (`common::rhier`). Scenes, probe grids and helpers that
//! several modules use live in `common`; committed sample files in `tests/data/`,
//! example scenes in `formats/examples/`.
//!
//! One module or test runs by its path: `cargo test --release --test it store::samples`.
//! The tests share one process and run on parallel threads: a test that measures
//! something process-wide (allocations, the working directory) must measure its own
//! thread only, as `store::fuzz` does.

mod cli;
mod common;
mod farm;
mod flatland;
mod formats;
mod geometry;
mod interactive;
mod playback;
mod reference;
mod scene;
mod solver;
mod spacetime;
mod store;
mod view;
