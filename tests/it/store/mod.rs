//! The `.rhier` file: round trips, committed samples of every version and
//! corruption, the real solver's output, and no panic or large allocation on any
//! mutation.

mod fuzz;
mod live;
mod resume_key;
mod roundtrip;
mod samples;
mod solve;
