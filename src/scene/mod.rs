//! The input model: objects made of planar polygons, materials, motion tracks and the
//! time domain, plus the loaders that fill it (native JSON, glTF 2.0, Wavefront OBJ)
//! and the validation every loader runs.
//!
//! A [`Scene`] is what every loader produces and what the solver consumes. It is a
//! plain description: world-space geometry at time `t` is computed by
//! [`crate::geometry`] from each object's [`MotionTrack`].

mod model;

pub use model::{
    Camera, Material, MaterialId, MotionKey, MotionTrack, Object, ObjectId, Polygon, Scene,
    TimeDomain,
};
