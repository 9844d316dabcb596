//! Playback of solutions: the probe contract, pictures and exports of known scenes,
//! and the `probe`, `play` and `inspect` commands.

mod probe;
mod render;
