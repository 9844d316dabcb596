//! The scene a session solves: the input scene placed at its start, each movable
//! object's polygons baked at its scene pose and given a marker track, so that the
//! solver keeps its patches apart (contact meshing cuts along static objects only)
//! and its triangles in a BVH part of their own that a move places without a rebuild
//! ([`crate::geometry::SceneBvh::place_with`]). The marker track is never evaluated
//! after the start: the session places objects by the poses its moves give.
//!
//! [`Stage::posed`] is the scene as a move left it (each moved object with one key
//! at its pose): what a solution of that move is played back and probed with.

use std::collections::HashMap;

use glam::DVec3;

use super::moves::Pose;
use crate::scene::{MotionKey, MotionTrack, Scene, TimeDomain};
use crate::{Error, Result};

/// A scene prepared for interactive moves.
#[derive(Clone, Debug)]
pub struct Stage {
    /// The scene the solver sees (movable objects baked and marked).
    pub scene: Scene,
    /// Per object: whether moves may place it.
    pub movable: Vec<bool>,
    /// Object names → index (the first object of a name).
    pub names: HashMap<String, u32>,
}

impl Stage {
    /// Prepares `scene` (placed at its start time). `movable`: the names of the
    /// objects moves may place (`None`: every object); an unknown name is an error.
    pub fn new(scene: &Scene, movable: Option<&[String]>) -> Result<Stage> {
        let mut names = HashMap::new();
        for (i, o) in scene.objects.iter().enumerate() {
            names.entry(o.name.clone()).or_insert(i as u32);
        }
        let mut flags = vec![movable.is_none(); scene.objects.len()];
        for name in movable.unwrap_or(&[]) {
            let &i = names.get(name).ok_or_else(|| {
                Error::Usage(format!(
                    "--movable: no object named \"{name}\" in the scene (objects: {})",
                    scene
                        .objects
                        .iter()
                        .map(|o| o.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?;
            flags[i as usize] = true;
        }
        let t0 = scene.time.start;
        let mut staged = scene.clone();
        staged.time = TimeDomain {
            start: 0.0,
            end: 0.0,
        };
        for (o, &m) in staged.objects.iter_mut().zip(&flags) {
            let world = o.to_world(t0);
            for p in &mut o.polygons {
                for v in &mut p.vertices {
                    *v = world.transform_point3(*v);
                }
            }
            o.motion = m.then(marker_track);
        }
        Ok(Stage {
            scene: staged,
            movable: flags,
            names,
        })
    }

    /// The names of the objects moves may place, in scene order (what a persisted
    /// hierarchy records: [`crate::store::Hierarchy::movable`]).
    pub fn movable_names(&self) -> Vec<String> {
        self.scene
            .objects
            .iter()
            .zip(&self.movable)
            .filter(|(_, m)| **m)
            .map(|(o, _)| o.name.clone())
            .collect()
    }

    /// The scene with each object of `poses` (object index → pose) held at that
    /// pose by a one-key track: the scene a move's solution belongs to.
    pub fn posed(&self, poses: &[Pose]) -> Scene {
        let mut s = self.scene.clone();
        for (o, p) in s.objects.iter_mut().zip(poses) {
            o.motion = o.motion.as_ref().map(|_| MotionTrack {
                keys: vec![key(0.0, p)],
            });
        }
        s
    }
}

/// The motion key of `pose` at time `t`.
pub fn key(t: f64, pose: &Pose) -> MotionKey {
    MotionKey {
        t,
        translation: pose.translation,
        rotation: pose.rotation,
        scale: DVec3::ONE,
    }
}

/// A track that marks an object as moving for the solver ([`MotionTrack::is_moving`])
/// and places it at its scene pose at the start (time 0).
fn marker_track() -> MotionTrack {
    let mut second = MotionKey::identity(1.0);
    second.translation = DVec3::new(0.0, 0.0, f64::MIN_POSITIVE);
    MotionTrack {
        keys: vec![MotionKey::identity(0.0), second],
    }
}
