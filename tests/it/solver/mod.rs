//! The hierarchical solver: known answers, invariants, accuracy against the path
//! tracer, cluster links, scale, the `--min-size` floor per object, and the
//! frame-by-frame baseline.

mod accuracy;
mod cluster_links;
mod enclosures;
mod exported;
mod floor;
mod invariants;
mod known;
mod l_room_lit;
mod per_frame;
mod scale;
mod scale_free;
mod shadow_edge;
mod tiled_lamp;
