//! Geometry under the solver: form factors against closed forms, contact meshing,
//! and accelerated visibility (BVH, shafts) against brute force.

mod contact;
mod form_factors;
mod visibility;
