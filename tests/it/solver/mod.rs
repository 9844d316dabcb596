//! The hierarchical solver: known answers, invariants, accuracy against the path
//! tracer, cluster links, scale, and the frame-by-frame baseline.

mod accuracy;
mod cluster_links;
mod enclosures;
mod invariants;
mod known;
mod per_frame;
mod scale;
mod scale_free;
