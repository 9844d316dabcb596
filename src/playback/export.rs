//! glTF 2.0 export of a frame: one mesh of the frame's triangulated leaves
//! ([`super::raster::FrameMesh`]) with `COLOR_0` vertex colours, in a `.gltf` file with
//! its buffer embedded as a base64 data URI, so that it opens in ordinary viewers.
//!
//! Colours are linear floats after exposure, clamped to `[0, 1]` (glTF vertex colours
//! are linear and multiply the base colour); the material is white and marked
//! `KHR_materials_unlit` so that viewers show the radiosity as is. It does not write
//! textures, normals or animation.

use std::path::Path;

use serde_json::json;

use super::raster::FrameMesh;
use crate::error::{Error, Result};

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding (RFC 4648 §4).
pub fn base64(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(B64[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The glTF JSON document of `mesh` with colours multiplied by `exposure`.
pub fn gltf_document(mesh: &FrameMesh, exposure: f64) -> serde_json::Value {
    let mut buf: Vec<u8> = Vec::new();
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &mesh.positions {
        let p = p.as_vec3().to_array();
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
            buf.extend_from_slice(&p[k].to_le_bytes());
        }
    }
    let pos_len = buf.len();
    for c in &mesh.colors {
        for x in c {
            buf.extend_from_slice(&((x * exposure).clamp(0.0, 1.0) as f32).to_le_bytes());
        }
    }
    let col_len = buf.len() - pos_len;
    for t in &mesh.triangles {
        for i in t {
            buf.extend_from_slice(&i.to_le_bytes());
        }
    }
    let idx_len = buf.len() - pos_len - col_len;
    let n = mesh.positions.len();
    if n == 0 {
        lo = [0.0; 3];
        hi = [0.0; 3];
    }
    json!({
        "asset": { "version": "2.0", "generator": "rhier play --export gltf" },
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": "radiosity" }],
        "materials": [{
            "name": "vertex radiosity",
            "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
            "doubleSided": false,
            "extensions": { "KHR_materials_unlit": {} }
        }],
        "meshes": [{ "primitives": [{
            "attributes": { "POSITION": 0, "COLOR_0": 1 },
            "indices": 2,
            "material": 0,
            "mode": 4
        }]}],
        "buffers": [{
            "byteLength": buf.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&buf))
        }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": pos_len, "target": 34962 },
            { "buffer": 0, "byteOffset": pos_len, "byteLength": col_len, "target": 34962 },
            { "buffer": 0, "byteOffset": pos_len + col_len, "byteLength": idx_len, "target": 34963 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3", "min": lo, "max": hi },
            { "bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3" },
            { "bufferView": 2, "componentType": 5125, "count": mesh.triangles.len() * 3, "type": "SCALAR" }
        ]
    })
}

/// Writes `mesh` as a `.gltf` file.
pub fn write_gltf(path: &Path, mesh: &FrameMesh, exposure: f64) -> Result<()> {
    let doc = gltf_document(mesh, exposure);
    let text =
        serde_json::to_string(&doc).map_err(|e| Error::io(path, std::io::Error::other(e)))?;
    std::fs::write(path, text).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::base64;

    #[test]
    fn base64_known_answers() {
        // RFC 4648 §10 test vectors.
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foob"), "Zm9vYg==");
        assert_eq!(base64(b"fooba"), "Zm9vYmE=");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
    }
}
