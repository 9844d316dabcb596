//! Geometry: patches in world space, polygon clipping, the form-factor kernels and ray
//! visibility.
//!
//! - [`Poly`]: a small convex polygon (≤ 8 corners, `f64`) with area, normal, clipping.
//! - [`point_to_polygon`]: the unoccluded form factor from a differential area to a
//!   polygon (Lambert's contour integral, clipped to the receiver's hemisphere; a far
//!   source wholly above it by Gauss quadrature within 3e-5 of the exact value).
//! - [`Patches`]: every input polygon placed in world space at a time `t`.
//! - [`Shells`]: the closed shells of a scene and the patches they seal off from
//!   every emitter ([`dark_patches`]).
//! - [`SceneBvh`]: occlusion rays and closest hits through obvhs CWBVHs: one BVH in
//!   world space for all static objects, one in object space per moving object placed
//!   by its motion at time `t`. This module is the only user of obvhs. Occlusion rays
//!   go through a 4-wide BVH collapsed from obvhs' PLOC tree (`wide`); obvhs' CWBVH
//!   or Embree 3 (its library opened at run time, `embree`) may find their
//!   candidates instead ([`Rays`], chosen by `RHIER_RAYS`), with the same f64
//!   decisions.
//!
//! Geometry is `f64` everywhere except inside the BVHs (`f32`, as obvhs stores it);
//! ray end points are offset relative to the segment length, so results do not depend
//! on the scene's scale.

mod contact;
mod embree;
mod formfactor;
mod icosphere;
mod nearest;
mod patches;
mod polygon;
mod sealed;
mod visibility;
mod wide;

pub use contact::{ContactStats, split_at_contacts, split_at_contacts_but};
pub use formfactor::{
    FAR_RATIO, TWIN_GAP, contour_integral as formfactor_contour, cosine_direction,
    point_to_point_kernel, point_to_polygon, point_to_polygon_exact,
};
pub use icosphere::icosphere;
pub use nearest::{closest_point_on_polygon, nearest_facing, on_emitters};
pub use patches::{PatchGeometry, PatchId, Patches, param_point};
pub use polygon::{MAX_CORNERS, Poly, centroid_of, clip_to_half_space};
pub use sealed::{Sealed, Shells, dark_patches};
pub use visibility::{
    FRONT_FIRST_TIE, Hit, LastHit, PLANE_GAP, Parts, Rays, SEGMENT_TRIM, SURFACE_TRIM, SceneBvh,
    twin_patches,
};
