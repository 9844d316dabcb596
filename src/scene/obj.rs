//! Wavefront OBJ reader (with its MTL materials), static scenes only.
//!
//! How it works (mapping specified in `formats/scene.md`, section "Wavefront OBJ"):
//! `tobj` parses the file with faces kept as written; models with the same name (tobj
//! splits an `o`/`g` group at each `usemtl`) are merged into one [`Object`] per OBJ
//! object/group, in order of first appearance. Faces of 3 or 4 vertices are kept as
//! they are (quads are checked for planarity by validation); faces of more vertices
//! are fan-triangulated from their first vertex when planar and convex, refused
//! otherwise. `Kd` = reflectance (a channel of exactly 1.0 is clamped to 0.999 with a
//! warning), `Ke` = exitance (not multiplied by pi: OBJ has no radiometric convention,
//! so `Ke` is taken in the units of the result, like native `emission`). Faces with no
//! material use `default` (reflectance 0.8). Before `tobj` runs, the text is scanned
//! for `usemtl` names missing from the MTL (tobj would silently drop them), so that
//! they are reported with their object, polygon and line.
//!
//! Not read: normals, texture coordinates, textures, smoothing groups, lines, points,
//! curves. OBJ has no animation: the scene is static.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use glam::DVec3;

use super::gltf::{clamp_white, unique_name};
use super::model::{Material, MaterialId, Object, Polygon, Scene, TimeDomain};
use super::validate::{self, PLANARITY_TOLERANCE};
use crate::{Error, Result};

/// Reflectance of faces without a material.
const DEFAULT_RHO: f64 = 0.8;

/// Loads and validates the OBJ file at `path` and the MTL files it names.
pub(crate) fn load(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, mtl) = tobj::load_obj(path, &options)
        .map_err(|e| Error::invalid(path, "OBJ", "a readable Wavefront OBJ file", e.to_string()))?;
    let mtl = mtl.map_err(|e| {
        let libs: Vec<&str> = text
            .lines()
            .filter_map(|l| l.trim().strip_prefix("mtllib "))
            .map(str::trim)
            .collect();
        Error::invalid(
            path,
            "mtllib",
            "readable MTL material files next to the OBJ file",
            format!("{e} ({})", libs.join(", ")),
        )
    })?;
    let mut warnings = Vec::new();

    // Materials in MTL order; `default` appended when a face has none.
    let mut materials: Vec<Material> = Vec::with_capacity(mtl.len() + 1);
    for m in &mtl {
        let name = unique_name(&m.name, &materials);
        let rho = m.diffuse.unwrap_or([DEFAULT_RHO as f32; 3]).map(f64::from);
        let rho = clamp_white(rho, &name, &mut warnings);
        let emission = m.emissive.unwrap_or([0.0; 3]).map(f64::from);
        materials.push(Material {
            name,
            rho,
            emission,
        });
    }
    check_usemtl(&text, &mtl, path)?;

    let mut default_material = None;
    let mut by_name: BTreeMap<String, usize> = BTreeMap::new();
    let mut objects: Vec<Object> = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id {
            Some(m) if m < materials.len() => MaterialId(m as u32),
            _ => *default_material.get_or_insert_with(|| {
                materials.push(Material {
                    name: unique_name("default", &materials),
                    rho: [DEFAULT_RHO; 3],
                    emission: [0.0; 3],
                });
                MaterialId(materials.len() as u32 - 1)
            }),
        };
        let o = *by_name.entry(model.name.clone()).or_insert_with(|| {
            objects.push(Object {
                name: model.name.clone(),
                polygons: Vec::new(),
                motion: None,
            });
            objects.len() - 1
        });
        let positions: Vec<DVec3> = mesh
            .positions
            .chunks_exact(3)
            .map(|p| DVec3::new(p[0].into(), p[1].into(), p[2].into()))
            .collect();
        let arities: Vec<usize> = if mesh.face_arities.is_empty() {
            vec![3; mesh.indices.len() / 3]
        } else {
            mesh.face_arities.iter().map(|&a| a as usize).collect()
        };
        let mut start = 0;
        for arity in arities {
            let object = &mut objects[o];
            let place = || {
                format!(
                    "object \"{}\", polygon {}",
                    object.name,
                    object.polygons.len()
                )
            };
            let Some(idx) = mesh.indices.get(start..start + arity) else {
                return Err(Error::invalid(
                    path,
                    place(),
                    "face indices",
                    "a truncated face",
                ));
            };
            start += arity;
            let mut vertices = Vec::with_capacity(arity);
            for &i in idx {
                let Some(v) = positions.get(i as usize) else {
                    return Err(Error::invalid(
                        path,
                        place(),
                        format!("vertex indices < {}", positions.len()),
                        format!("index {i}"),
                    ));
                };
                vertices.push(*v);
            }
            if arity <= 4 {
                object.polygons.push(Polygon { vertices, material });
            } else {
                let fan = fan_triangulate(&vertices).map_err(|found| {
                    Error::invalid(
                        path,
                        place(),
                        format!(
                            "a face of 3 or 4 vertices, or a planar (within {PLANARITY_TOLERANCE} x diameter) convex polygon"
                        ),
                        format!("a {arity}-gon that is {found}"),
                    )
                })?;
                object.polygons.extend(
                    fan.into_iter()
                        .map(|vertices| Polygon { vertices, material }),
                );
            }
        }
    }
    let scene = Scene {
        time: TimeDomain::default(),
        materials,
        objects,
        camera: None,
        warnings,
    };
    validate::validate(scene, path)
}

/// Triangles `(v0, v[k], v[k+1])` of a planar convex polygon; `Err` says what it is
/// instead.
fn fan_triangulate(v: &[DVec3]) -> std::result::Result<Vec<Vec<DVec3>>, &'static str> {
    let n = v.len();
    let area: DVec3 = (1..n - 1)
        .map(|k| (v[k] - v[0]).cross(v[k + 1] - v[0]))
        .sum();
    let normal = area.normalize_or_zero();
    let c = v.iter().copied().sum::<DVec3>() / n as f64;
    let diam = v
        .iter()
        .flat_map(|a| v.iter().map(move |b| a.distance(*b)))
        .fold(0.0, f64::max);
    if normal == DVec3::ZERO {
        return Err("degenerate");
    }
    if v.iter()
        .any(|p| normal.dot(*p - c).abs() > PLANARITY_TOLERANCE * diam)
    {
        return Err("not planar");
    }
    for k in 0..n {
        let turn = (v[(k + 1) % n] - v[k]).cross(v[(k + 2) % n] - v[(k + 1) % n]);
        if turn.dot(normal) < -1e-9 * diam * diam {
            return Err("not convex");
        }
    }
    Ok((1..n - 1).map(|k| vec![v[0], v[k], v[k + 1]]).collect())
}

/// Refuses a `usemtl` naming a material that no MTL file defines.
fn check_usemtl(text: &str, mtl: &[tobj::Material], path: &Path) -> Result<()> {
    let known: BTreeSet<&str> = mtl.iter().map(|m| m.name.as_str()).collect();
    let mut object = "unnamed_object".to_string();
    let mut faces: BTreeMap<String, usize> = BTreeMap::new();
    for (line_no, line) in text.lines().enumerate() {
        let line = line.trim();
        let mut words = line.split_whitespace();
        match words.next() {
            Some("o") | Some("g") => {
                let name = line[1..].trim();
                object = if name.is_empty() {
                    "unnamed_object".into()
                } else {
                    name.into()
                };
            }
            Some("f") => *faces.entry(object.clone()).or_default() += 1,
            Some("usemtl") => {
                let name = line["usemtl".len()..].trim();
                if !known.contains(name) {
                    let defined: Vec<&str> = known.iter().copied().collect();
                    return Err(Error::invalid(
                        path,
                        format!(
                            "object \"{object}\", polygon {} (line {})",
                            faces.get(&object).copied().unwrap_or(0),
                            line_no + 1
                        ),
                        format!(
                            "a material defined in the mtllib files (defined: {})",
                            if defined.is_empty() {
                                "none".to_string()
                            } else {
                                defined.join(", ")
                            }
                        ),
                        format!("usemtl \"{name}\""),
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(())
}
