//! Interactive updates (`rhier interact`): a solved scene whose objects a user
//! moves one move at a time, the radiosity brought up to date after each move by
//! touching only the links the move affects — the line-space hierarchy of
//! Drettakis & Sillion as Schöffel & Pomi manage its shafts (paper 000).
//!
//! | module | concept |
//! |---|---|
//! | [`moves`] | the move lines (`formats/interactive.md`) and their checks |
//! | [`stage`] | the scene as a session solves it: movable objects kept apart |
//! | [`session`] | one move: place, traverse the links, evaluate, refine, solve |
//! | [`store`] | the shaft store: ages, the collector (Fig. 2), budget, zstd eviction |
//! | [`predict`] | movement prediction (eq. 1–3) and the predicted boxes |
//! | [`stats`] | one move's statistics (Table 2's columns) |
//! | [`record`] | the session as a `.rhier` animation |
//!
//! Data flow: a move line → [`moves::parse_move`] → [`session::Session::apply`]
//! (solver pools updated in place) → [`stats::MoveStats`], and when asked the final
//! gather ([`session::Session::solution`]) for probes and the session file.
//! A static or space-time solve uses none of this.

pub mod moves;
pub mod predict;
pub mod record;
pub mod session;
pub mod stage;
pub mod stats;
pub mod store;

pub use moves::{ObjectMove, Pose, parse_move};
pub use session::{Session, Settings, Traversal, Update};
pub use stage::Stage;
pub use stats::MoveStats;
