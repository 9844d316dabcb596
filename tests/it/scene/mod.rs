//! Scenes: every loader and its validation rules, the JSON writer's round trip, the
//! embedded animated scenes, and no panic on any input.

mod animated;
mod fuzz;
mod loaders;
mod roundtrip;
mod validation;
