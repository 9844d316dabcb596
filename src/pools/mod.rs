//! Pools: arenas of plain records stored as columns (struct of arrays), indexed by
//! `u32` newtypes, on a storage backend chosen at run time.
//!
//! - [`Column`]: a growable array of one `Pod` type, in RAM (`Vec`) or in a file
//!   mapped with memmap2 that grows by doubling (the OS pages it in and out). Both
//!   hand out plain slices, so the solver's loops are the same on either backend.
//! - [`ElementPool`], [`LinkPool`]: the hierarchy's element and link columns.
//! - [`Storage`]: which backend new columns use (`--storage ram|mmap --scratch DIR`; the
//!   default from `RHIER_STORAGE`, [`Storage::ENV`]).
//!
//! Nothing here knows about radiosity beyond the record layouts; the solver gives
//! the columns their meaning. Every pool has `validate()`, run by tests and by debug
//! builds after refinement.

mod column;
pub mod elements;
mod ids;
pub mod links;

pub use column::{Column, Storage};
pub use elements::{ElementKind, ElementPool, Emission};
pub use ids::{ElementId, LinkId};
pub use links::{LinkPool, LinkState};
