//! Hierarchical radiosity: clusters, refinement, gather, push-pull, iteration.

pub mod solution;

pub use solution::{Leaf, PatchGeometry, Shape, Solution, SolveStats};
