//! The records stored in `.rhier` sections, as rkyv archives (formats/rhier.md,
//! "Sections").
//!
//! Each section holds one rkyv archive of one root value ([`SceneRecord`],
//! `Vec<PatchRecord>`, `Vec<LeafRecord>`, [`ChunkIndexRecord`], [`StatsRecord`],
//! `Vec<LinkRecord>`, [`ProvenanceRecord`], [`HierarchyRecord`]). rkyv is pinned to little-endian, unaligned, 64-bit relative
//! pointers (Cargo.toml features `little_endian`, `unaligned`, `pointer_width_64`), so
//! an archive is read in place from any byte offset of a mapped file and may exceed
//! 2 GiB. These types are plain mirrors of the in-memory contract
//! ([`crate::solution`], [`crate::scene`]); conversion functions live here and
//! do not validate semantics (the reader does).

use glam::{DAffine3, DQuat, DVec3};
use rkyv::{Archive, Deserialize, Serialize};

use crate::scene::{Camera, Material, MotionKey, MotionTrack};
use crate::solution::{Leaf, PatchGeometry, SolveStats};

/// A material: name, reflectance, exitance.
#[derive(Archive, Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct MaterialRecord {
    /// Name from the source scene.
    pub name: String,
    /// Reflectance per RGB channel.
    pub rho: [f64; 3],
    /// Exitance per RGB channel.
    pub emission: [f64; 3],
}

/// One motion key, 88 bytes archived.
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct MotionKeyRecord {
    /// Time of the key.
    pub t: f64,
    /// Translation.
    pub translation: [f64; 3],
    /// Rotation quaternion `x y z w`.
    pub rotation: [f64; 4],
    /// Scale.
    pub scale: [f64; 3],
}

const _: () = assert!(std::mem::size_of::<ArchivedMotionKeyRecord>() == 88);

/// An object: name, its number of patches, and its motion (only when it moves).
#[derive(Archive, Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ObjectRecord {
    /// Name from the source scene.
    pub name: String,
    /// Motion keys; `None` for objects that do not move (no track stored).
    pub motion: Option<Vec<MotionKeyRecord>>,
}

/// A pinhole camera.
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct CameraRecord {
    /// Eye.
    pub eye: [f64; 3],
    /// Target.
    pub target: [f64; 3],
    /// Up.
    pub up: [f64; 3],
    /// Vertical field of view, radians.
    pub fov_y: f64,
}

/// The scene section's root.
#[derive(Archive, Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct SceneRecord {
    /// Time domain `[start, end]`.
    pub time: [f64; 2],
    /// Materials.
    pub materials: Vec<MaterialRecord>,
    /// Objects.
    pub objects: Vec<ObjectRecord>,
    /// Camera, if the scene had one.
    pub camera: Option<CameraRecord>,
}

/// One patch, 108 bytes archived.
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct PatchRecord {
    /// Owning object.
    pub object: u32,
    /// Material.
    pub material: u32,
    /// 3 or 4.
    pub corners: u32,
    /// Object-space corners.
    pub vertices: [[f64; 3]; 4],
}

const _: () = assert!(std::mem::size_of::<ArchivedPatchRecord>() == 108);

/// One leaf, 96 bytes archived (the same fields as [`Leaf`]).
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct LeafRecord {
    /// Patch index.
    pub patch: u32,
    /// 3 or 4.
    pub corners: u32,
    /// Time range.
    pub time: [f32; 2],
    /// Corners in parameter space.
    pub uv: [[f32; 2]; 4],
    /// Radiosity at the corners.
    pub b: [[f32; 3]; 4],
}

const _: () = assert!(std::mem::size_of::<ArchivedLeafRecord>() == 96);

/// One entry of the chunk index, 36 bytes archived.
///
/// Chunk `i` covers `[t0, t1)` (the last one `[t0, t1]`). A leaf is stored once, in the
/// chunk where its time range starts; `reach` is the largest leaf end time in the
/// chunk and `carry_from` the first chunk `j <= i` with `reach_j >= t0_i`, so that the
/// leaves live at `t` are found in the chunks `carry_from..=i` whose `reach >= t`.
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct ChunkRecord {
    /// Start of the chunk's time range.
    pub t0: f64,
    /// End of the chunk's time range.
    pub t1: f64,
    /// Largest end time of a leaf stored in this chunk.
    pub reach: f64,
    /// Index in the section table of the chunk's section.
    pub section: u32,
    /// Number of leaves stored in the chunk.
    pub leaves: u32,
    /// First chunk whose leaves may still be live at `t0`.
    pub carry_from: u32,
}

const _: () = assert!(std::mem::size_of::<ArchivedChunkRecord>() == 36);

/// The chunk-index section's root.
#[derive(Archive, Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ChunkIndexRecord {
    /// Chunks in time order.
    pub chunks: Vec<ChunkRecord>,
}

/// Where the windows of a space-time file come from (version 2): the solve's
/// fingerprint (`store::journal::fingerprint`: the scene and every setting that
/// changes the result) and the run of windows `first..end` of the solve's `windows`
/// that the file holds, as shard `shard` of `shards` (`0` of `1` for a solve on one
/// machine and for a merged file), covering the times `time`. What `rhier merge`
/// checks parts against. One record of variable length (a string).
#[derive(Archive, Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ProvenanceRecord {
    /// The fingerprint text of the solve (scene and result settings).
    pub fingerprint: String,
    /// Windows in the whole solve's plan.
    pub windows: u32,
    /// First window held.
    pub first: u32,
    /// One past the last window held (`first` when the shard holds none).
    pub end: u32,
    /// Shard index, `0..shards`.
    pub shard: u32,
    /// Shards the plan was split into.
    pub shards: u32,
    /// Time range covered by windows `first..end` (`[t, t]` when none).
    pub time: [f64; 2],
}

/// Solve statistics (mirror of [`SolveStats`]).
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct StatsRecord {
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Iterations.
    pub iterations: u32,
    /// Elements (all levels).
    pub elements: u64,
    /// Active links.
    pub links_active: u64,
    /// Passive links.
    pub links_passive: u64,
    /// Estimated relative error.
    pub estimated_error: f64,
    /// Last residual.
    pub residual: f64,
}

/// One link, kept only with `--keep-links`, 48 bytes archived.
#[derive(Archive, Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct LinkRecord {
    /// Receiver element id (solver numbering).
    pub receiver: u64,
    /// Source element id (solver numbering).
    pub source: u64,
    /// Time range over which the link holds.
    pub time: [f32; 2],
    /// Transport coefficient per channel (form factor times reflectance).
    pub coefficient: [f32; 3],
    /// Error bound of the link.
    pub error: f32,
    /// 1 = active, 0 = passive.
    pub active: u32,
    /// Reserved, 0.
    pub reserved: u32,
}

const _: () = assert!(std::mem::size_of::<ArchivedLinkRecord>() == 48);

/// The persisted hierarchy of an interactive session's start-up solve
/// (`rhier solve --keep-links --movable`; formats/rhier.md, "Hierarchy"): the
/// element pool in pool order and the link pool, each column the little-endian
/// bytes of its `repr(C)` records ([`crate::store::Hierarchy`] holds them typed).
#[derive(Archive, Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct HierarchyRecord {
    /// Names of the objects the session may move, in scene order.
    pub movable: Vec<String>,
    /// The solve settings, as JSON (`SolveOptions` without its storage).
    pub options: String,
    /// Number of elements.
    pub elements: u64,
    /// Number of links.
    pub links: u64,
    /// `Node` records, 16 bytes each.
    pub nodes: Vec<u8>,
    /// `Geom` records, 168 bytes each.
    pub geoms: Vec<u8>,
    /// Time ranges, `[f32; 2]` each.
    pub times: Vec<u8>,
    /// Radiosities the last leaf rows were built at, `[f32; 3]` each.
    pub radiosities: Vec<u8>,
    /// `Emission` records the last leaf rows were built at, 36 bytes each.
    pub directions: Vec<u8>,
    /// Link `Ends` records, 8 bytes each.
    pub ends: Vec<u8>,
    /// Link `Transport` records, 16 bytes each.
    pub transports: Vec<u8>,
    /// Leaf rows: the start of each leaf's entries, `u32` each (leaves + 1; none
    /// when the rows are not kept).
    pub row_start: Vec<u8>,
    /// Leaf rows: each entry's source, `u32` each.
    pub row_sources: Vec<u8>,
    /// Leaf rows: each entry's coefficient, `f64` each.
    pub row_coefs: Vec<u8>,
    /// Each leaf row's entries by chain link: `[leaf, link, first entry, entries]`,
    /// `u32` each, sorted by leaf then link.
    pub row_links: Vec<u8>,
}

fn v3(v: DVec3) -> [f64; 3] {
    v.to_array()
}

impl From<&Material> for MaterialRecord {
    fn from(m: &Material) -> Self {
        MaterialRecord {
            name: m.name.clone(),
            rho: m.rho,
            emission: m.emission,
        }
    }
}

impl From<&MotionKey> for MotionKeyRecord {
    fn from(k: &MotionKey) -> Self {
        MotionKeyRecord {
            t: k.t,
            translation: v3(k.translation),
            rotation: k.rotation.to_array(),
            scale: v3(k.scale),
        }
    }
}

impl From<&ArchivedMotionKeyRecord> for MotionKey {
    fn from(k: &ArchivedMotionKeyRecord) -> Self {
        MotionKey {
            t: k.t.to_native(),
            translation: DVec3::from_array(k.translation.map(|x| x.to_native())),
            rotation: DQuat::from_array(k.rotation.map(|x| x.to_native())),
            scale: DVec3::from_array(k.scale.map(|x| x.to_native())),
        }
    }
}

impl From<&Camera> for CameraRecord {
    fn from(c: &Camera) -> Self {
        CameraRecord {
            eye: v3(c.eye),
            target: v3(c.target),
            up: v3(c.up),
            fov_y: c.fov_y,
        }
    }
}

impl From<&ArchivedCameraRecord> for Camera {
    fn from(c: &ArchivedCameraRecord) -> Self {
        Camera {
            eye: DVec3::from_array(c.eye.map(|x| x.to_native())),
            target: DVec3::from_array(c.target.map(|x| x.to_native())),
            up: DVec3::from_array(c.up.map(|x| x.to_native())),
            fov_y: c.fov_y.to_native(),
        }
    }
}

impl From<&PatchGeometry> for PatchRecord {
    fn from(p: &PatchGeometry) -> Self {
        PatchRecord {
            object: p.object,
            material: p.material,
            corners: p.corners,
            vertices: p.vertices.map(v3),
        }
    }
}

impl From<&ArchivedPatchRecord> for PatchGeometry {
    fn from(p: &ArchivedPatchRecord) -> Self {
        PatchGeometry {
            object: p.object.to_native(),
            material: p.material.to_native(),
            corners: p.corners.to_native(),
            vertices: p
                .vertices
                .each_ref()
                .map(|v| DVec3::from_array(v.map(|x| x.to_native()))),
        }
    }
}

impl From<&Leaf> for LeafRecord {
    fn from(l: &Leaf) -> Self {
        LeafRecord {
            patch: l.patch,
            corners: l.corners,
            time: l.time,
            uv: l.uv,
            b: l.b,
        }
    }
}

impl From<&ArchivedLeafRecord> for Leaf {
    fn from(l: &ArchivedLeafRecord) -> Self {
        Leaf {
            patch: l.patch.to_native(),
            corners: l.corners.to_native(),
            time: l.time.map(|x| x.to_native()),
            uv: l.uv.each_ref().map(|c| c.map(|x| x.to_native())),
            b: l.b.each_ref().map(|c| c.map(|x| x.to_native())),
        }
    }
}

impl From<&SolveStats> for StatsRecord {
    fn from(s: &SolveStats) -> Self {
        StatsRecord {
            seconds: s.seconds,
            iterations: s.iterations,
            elements: s.elements,
            links_active: s.links_active,
            links_passive: s.links_passive,
            estimated_error: s.estimated_error,
            residual: s.residual,
        }
    }
}

impl From<&ArchivedStatsRecord> for SolveStats {
    fn from(s: &ArchivedStatsRecord) -> Self {
        SolveStats {
            seconds: s.seconds.to_native(),
            iterations: s.iterations.to_native(),
            elements: s.elements.to_native(),
            links_active: s.links_active.to_native(),
            links_passive: s.links_passive.to_native(),
            estimated_error: s.estimated_error.to_native(),
            residual: s.residual.to_native(),
        }
    }
}

/// A motion track as stored: its keys.
pub fn track_record(track: &MotionTrack) -> Vec<MotionKeyRecord> {
    track.keys.iter().map(MotionKeyRecord::from).collect()
}

/// What a playback needs of an object's track: every key of a track that moves
/// the object; the one key of a track that only places it (patches are stored in
/// object space, so a placement dropped would draw and probe the object where its
/// file's coordinates put it, not where it was solved); nothing for the identity.
pub fn stored_track(track: &MotionTrack) -> Option<Vec<MotionKeyRecord>> {
    if track.is_moving() {
        return Some(track_record(track));
    }
    let key = track.keys.first()?;
    (key.to_affine() != DAffine3::IDENTITY).then(|| vec![MotionKeyRecord::from(key)])
}
