//! The input model: objects made of planar polygons, materials, motion tracks and the
//! time domain, plus the loaders that fill it (native JSON, glTF 2.0, Wavefront OBJ)
//! and the validation every loader runs.
//!
//! A [`Scene`] is what every loader produces and what the solver consumes. It is a
//! plain description: world-space geometry at time `t` is computed by
//! [`crate::geometry`] from each object's [`MotionTrack`].
//!
//! How it works: [`load`] picks the reader from the file extension (`json.rs`,
//! `gltf.rs`, `obj.rs`); each reader maps its format onto the model (the mappings are
//! specified in `formats/scene.md`) and then calls [`validate::validate`], which
//! refuses bad input with an error naming the file, object, polygon, what was expected
//! and what was found, and records repairs as [`Scene::warnings`]. Beside the readers:
//! `triangulate.rs` (faces other tools accept), `texture.rs` (a texture's mean colour)
//! and `sides.rs` ([`two_sided`], emitters facing a close surface). [`cornell_box`] is
//! the embedded default scene; [`actor_scene`] and [`light_scene`] the embedded
//! animated scenes (after Damez & Sillion), [`builtin`] finds any of them by name.
//! This module does not place geometry in world space and does not compute anything
//! about light.

mod animated;
mod cornell;
mod gltf;
mod json;
mod model;
mod obj;
mod sides;
mod texture;
mod triangulate;
pub mod validate;

use std::path::Path;

pub use animated::{BUILTIN_NAMES, LEG_SECONDS, SCENE_FPS, actor_scene, builtin, light_scene};
pub use cornell::cornell_box;
pub use json::{FORMAT_VERSION, to_json_string};
pub use model::{
    Camera, Material, MaterialId, MotionKey, MotionTrack, Object, ObjectId, Polygon, Scene,
    TimeDomain,
};
pub use sides::{EMITTER_CLEARANCE, MAX_EMITTERS_CHECKED, emitters_facing_close, two_sided};

use crate::{Error, Result};

/// File extensions [`load`] understands.
pub const SUPPORTED_EXTENSIONS: &str = ".json (native rhier scene), .gltf, .glb, .obj";

/// Loads and validates the scene in `path`, choosing the reader by extension
/// (case-insensitive): `.json` native (`formats/scene.md`), `.gltf` / `.glb` glTF 2.0,
/// `.obj` Wavefront OBJ with its MTL.
pub fn load(path: &Path) -> Result<Scene> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("json") => {
            let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
            load_json_str(&text, path)
        }
        Some("gltf") | Some("glb") => gltf::load(path),
        Some("obj") => obj::load(path),
        other => Err(Error::invalid(
            path,
            "file name",
            format!("a scene file with extension {SUPPORTED_EXTENSIONS}"),
            match other {
                Some(e) => format!("extension .{e}"),
                None => "no extension".to_string(),
            },
        )),
    }
}

/// The perspective cameras of the glTF file at `path` by name, for `play --camera`;
/// other formats have at most the one camera [`load`] gives.
pub fn cameras(path: &Path) -> Result<Vec<(String, Camera)>> {
    gltf::cameras(path)
}

/// Parses and validates native JSON scene `text`; `path` names it in messages.
pub fn load_json_str(text: &str, path: &Path) -> Result<Scene> {
    validate::validate(json::parse(text, path)?, path)
}

/// Loads and validates a glTF 2.0 scene from bytes (`.gltf` JSON or `.glb`), resolving
/// external buffers relative to `base` (none: only embedded data is allowed); `path`
/// names the source in messages.
pub fn load_gltf_slice(bytes: &[u8], base: Option<&Path>, path: &Path) -> Result<Scene> {
    gltf::load_slice(bytes, base, path)
}
