//! Scene records: [`Scene`], [`Object`], [`Polygon`], [`Material`], [`MotionTrack`].
//!
//! Geometry is kept in `f64` so that scenes in millimetres and in kilometres solve to
//! the same answer (the form-factor kernel is scale-free; only round-off differs).
//! Reflectance `rho` is per channel in `[0, 1)`, emission is exitance `E >= 0` in the
//! units the radiosity is reported in (`B = E + rho * H`).

use glam::{DAffine3, DQuat, DVec3};

/// Index of a material in [`Scene::materials`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);

/// Index of an object in [`Scene::objects`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObjectId(pub u32);

/// The animation's time range, in seconds. A static scene has `start == end`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeDomain {
    /// First instant.
    pub start: f64,
    /// Last instant (`>= start`).
    pub end: f64,
}

impl Default for TimeDomain {
    fn default() -> Self {
        TimeDomain {
            start: 0.0,
            end: 0.0,
        }
    }
}

/// A diffuse material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name as written in the source file.
    pub name: String,
    /// Diffuse reflectance per RGB channel, each in `[0, 1)`.
    pub rho: [f64; 3],
    /// Exitance `E` per RGB channel, `>= 0` (0 for non-emitters).
    pub emission: [f64; 3],
}

impl Material {
    /// A material that reflects `rho` and emits nothing.
    pub fn diffuse(name: impl Into<String>, rho: [f64; 3]) -> Material {
        Material {
            name: name.into(),
            rho,
            emission: [0.0; 3],
        }
    }

    /// True if any channel emits.
    pub fn is_emitter(&self) -> bool {
        self.emission.iter().any(|&e| e > 0.0)
    }
}

/// One planar polygon (triangle or quad) in object space, counter-clockwise seen from
/// its lit side. Quads are planar within the tolerance the loaders check.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// 3 or 4 vertices.
    pub vertices: Vec<DVec3>,
    /// The polygon's material.
    pub material: MaterialId,
}

impl Polygon {
    /// Vector area: `sum (v[i] - v[0]) x (v[i+1] - v[0]) / 2`. Its length is the area of
    /// a planar polygon, its direction the normal of the lit side (counter-clockwise
    /// winding seen from that side).
    pub fn area_vector(&self) -> DVec3 {
        let Some(&v0) = self.vertices.first() else {
            return DVec3::ZERO;
        };
        let mut sum = DVec3::ZERO;
        for w in self.vertices.windows(2).skip(1) {
            sum += (w[0] - v0).cross(w[1] - v0);
        }
        0.5 * sum
    }

    /// Area (length of [`Polygon::area_vector`]).
    pub fn area(&self) -> f64 {
        self.area_vector().length()
    }

    /// Unit normal pointing to the lit side (zero for a degenerate polygon).
    pub fn normal(&self) -> DVec3 {
        self.area_vector().normalize_or_zero()
    }

    /// Mean of the vertices.
    pub fn centroid(&self) -> DVec3 {
        if self.vertices.is_empty() {
            return DVec3::ZERO;
        }
        self.vertices.iter().copied().sum::<DVec3>() / self.vertices.len() as f64
    }

    /// Largest distance between two vertices.
    pub fn diameter(&self) -> f64 {
        let v = &self.vertices;
        let mut d: f64 = 0.0;
        for i in 0..v.len() {
            for j in i + 1..v.len() {
                d = d.max(v[i].distance(v[j]));
            }
        }
        d
    }
}

/// One keyframe of a rigid-plus-scale motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionKey {
    /// Time of the key, in seconds.
    pub t: f64,
    /// Translation applied last.
    pub translation: DVec3,
    /// Unit quaternion, applied after scale.
    pub rotation: DQuat,
    /// Per-axis scale, applied first.
    pub scale: DVec3,
}

impl MotionKey {
    /// The identity key at time `t`.
    pub fn identity(t: f64) -> Self {
        MotionKey {
            t,
            translation: DVec3::ZERO,
            rotation: DQuat::IDENTITY,
            scale: DVec3::ONE,
        }
    }

    /// The affine map object space → world space of this key.
    pub fn to_affine(&self) -> DAffine3 {
        DAffine3::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// Keyframes sorted by time; linear interpolation of translation and scale, slerp of
/// rotation; held constant before the first and after the last key.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionTrack {
    /// Keys, strictly increasing in `t`, at least one.
    pub keys: Vec<MotionKey>,
}

impl MotionTrack {
    /// The interpolated key at time `t`.
    pub fn key_at(&self, t: f64) -> MotionKey {
        let keys = &self.keys;
        let Some(first) = keys.first() else {
            return MotionKey::identity(t);
        };
        if keys.len() == 1 || t <= first.t {
            return MotionKey { t, ..*first };
        }
        let last = keys[keys.len() - 1];
        if t >= last.t {
            return MotionKey { t, ..last };
        }
        // Keys are sorted: find the segment [k0, k1] holding t.
        let i = keys.partition_point(|k| k.t <= t).max(1);
        let (k0, k1) = (keys[i - 1], keys[i]);
        let s = (t - k0.t) / (k1.t - k0.t);
        MotionKey {
            t,
            translation: k0.translation.lerp(k1.translation, s),
            rotation: k0.rotation.slerp(k1.rotation, s).normalize(),
            scale: k0.scale.lerp(k1.scale, s),
        }
    }

    /// Object → world map at time `t`.
    pub fn at(&self, t: f64) -> DAffine3 {
        self.key_at(t).to_affine()
    }

    /// True if the track moves the object at some time (keys differ).
    pub fn is_moving(&self) -> bool {
        self.keys.windows(2).any(|w| {
            w[0].translation != w[1].translation
                || w[0].rotation != w[1].rotation
                || w[0].scale != w[1].scale
        })
    }
}

/// A named group of polygons that moves as one.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name from the source file (used in error messages).
    pub name: String,
    /// Polygons in object space.
    pub polygons: Vec<Polygon>,
    /// Motion; `None` = static (identity placement).
    pub motion: Option<MotionTrack>,
}

impl Object {
    /// An object that does not move: its polygons are in world space.
    pub fn still(name: impl Into<String>, polygons: Vec<Polygon>) -> Object {
        Object {
            name: name.into(),
            polygons,
            motion: None,
        }
    }

    /// Object → world map at time `t` (identity when static).
    pub fn to_world(&self, t: f64) -> DAffine3 {
        self.motion.as_ref().map_or(DAffine3::IDENTITY, |m| m.at(t))
    }

    /// True if the object has a track that actually moves it.
    pub fn is_moving(&self) -> bool {
        self.motion.as_ref().is_some_and(MotionTrack::is_moving)
    }
}

/// A pinhole camera for playback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (world).
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up vector.
    pub up: DVec3,
    /// Vertical field of view in radians.
    pub fov_y: f64,
}

/// The whole input: what every loader returns after validation.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Scene {
    /// Time domain; static scenes have `start == end`.
    pub time: TimeDomain,
    /// Materials, referenced by [`MaterialId`].
    pub materials: Vec<Material>,
    /// Objects, referenced by [`ObjectId`].
    pub objects: Vec<Object>,
    /// Optional camera (glTF camera or the native `camera` field).
    pub camera: Option<Camera>,
    /// Warnings raised while loading (dropped zero-area polygons, no emitter…).
    pub warnings: Vec<String>,
}

impl Scene {
    /// True if any object moves.
    pub fn has_motion(&self) -> bool {
        self.objects.iter().any(Object::is_moving)
    }

    /// True if any material emits and is used by a polygon.
    pub fn has_emitter(&self) -> bool {
        self.objects
            .iter()
            .flat_map(|o| &o.polygons)
            .any(|p| self.materials[p.material.0 as usize].is_emitter())
    }

    /// Number of polygons over all objects.
    pub fn polygon_count(&self) -> usize {
        self.objects.iter().map(|o| o.polygons.len()).sum()
    }
}
