//! # rhier — radiosity for scenes that move
//!
//! rhier computes diffuse global illumination (radiosity, `B = E + rho * H`) with
//! hierarchical radiosity and keeps the answer on disk so that it can be played back,
//! probed and inspected later. This file is the tour; `DESIGN.md`-level detail lives in
//! each module's `//!` header.
//!
//! Data flows one way:
//!
//! ```text
//! scene file ─▶ scene::Scene ─▶ geometry (patches, form factors, obvhs visibility)
//!            ─▶ pools (element / link arenas on RAM or mmap storage)
//!            ─▶ solver (refine with the oracle → GMRES on leaf rows, in rounds;
//!               then a final gather at reconstruction-cell corners)
//!            ─▶ store (.rhier) ─▶ playback (frames, probes), inspect
//! ```
//!
//! | module | concept |
//! |---|---|
//! | [`scene`] | the input model (objects, polygons, materials, motion) and its loaders |
//! | [`geometry`] | patches in world space, form-factor kernels, ray visibility (the only obvhs user) |
//! | [`pools`] | storage backends (RAM, mmap) and struct-of-arrays arenas with `u32` ids |
//! | [`oracle`] | refinement decisions: keep a link, split receiver, split source |
//! | [`solver`] | hierarchical radiosity: clusters, refinement, GMRES, reconstruction; animations in time windows ([`solver::spacetime`]) or frame by frame ([`solver::per_frame`]) |
//! | [`interactive`] | interactive updates: moves applied one at a time through the line-space hierarchy, shafts kept under a budget |
//! | [`shafts`] | shafts between elements (Haines & Wallace) for visibility culling |
//! | [`store`] | the `.rhier` file: writer, reader, validation; the journal `solve --resume` continues from |
//! | [`playback`] | evaluation of a stored solution: probes, frames, exports |
//! | [`view`] | `rhier view`'s local web server: the page, frames and probes of one stored solution |
//! | [`flatland`] | exact 2D radiosity with the visibility complex |
//! | [`mod@reference`] | an independent Monte Carlo path tracer used to validate the solver |

pub mod error;
pub mod flatland;
pub mod geometry;
pub mod interactive;
pub mod oracle;
pub mod playback;
pub mod pools;
pub mod reference;
pub mod scene;
pub mod shafts;
pub mod solution;
pub mod solver;
pub mod store;
pub mod view;

pub use error::{Error, Result};
