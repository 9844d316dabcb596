//! Wavefront OBJ reader (with its MTL materials), static scenes only.
//!
//! How it works (mapping specified in `formats/scene.md`, section "Wavefront OBJ"):
//! `tobj` parses the file with faces kept as written; models with the same name (tobj
//! splits an `o`/`g` group at each `usemtl`) are merged into one [`Object`] per OBJ
//! object/group, in order of first appearance. Triangles and planar convex quads are
//! kept as they are; bent or concave quads and faces of more vertices are cut into
//! triangles ([`super::triangulate`]), with one warning counting them. The k-th face
//! tobj returns is the k-th `f` line of the text, so every message about a face names
//! `file.obj:LINE` (validation too, through [`validate::validate_sourced`]). `Kd` =
//! reflectance, times the mean colour of `map_Kd` ([`super::texture`]; a channel of
//! exactly 1.0 is clamped to 0.999 with a warning), `Ke` = exitance (not multiplied
//! by pi: OBJ has no radiometric convention, so `Ke` is taken in the units of the
//! result, like native `emission`); a `Ka` above 1 without `Ke` is warned of as a
//! light that does not emit. Faces with no material use `default` (reflectance 0.8).
//! Before `tobj` runs, the text is scanned for `usemtl` names missing from the MTL
//! (tobj would silently drop them), so that they are reported with their line.
//!
//! Not read: normals, texture coordinates, other textures, smoothing groups, lines,
//! points, curves. OBJ has no animation: the scene is static.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::gltf::{clamp_white, unique_name};
use super::model::{Material, MaterialId, Object, Polygon, Scene, TimeDomain};
use super::texture;
use super::triangulate::triangulate;
use super::validate::{self, PLANARITY_TOLERANCE, QuadProblem};
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
    let base = path.parent().unwrap_or(Path::new("."));
    for m in &mtl {
        let name = unique_name(&m.name, &materials);
        let factor = m.diffuse.map(|d| d.map(f64::from));
        let mut rho = factor.unwrap_or([DEFAULT_RHO; 3]);
        if let Some(tex) = &m.diffuse_texture {
            // `map_Kd [-options] file`: the file is the last word.
            let file = tex.split_whitespace().last().unwrap_or_default();
            let factor = factor.unwrap_or([1.0; 3]);
            match texture::mean_of_file(&base.join(file)) {
                Ok(mean) => {
                    warnings.push(texture::note(&name, file, mean, factor));
                    rho = std::array::from_fn(|c| mean[c] * factor[c]);
                }
                Err(e) => warnings.push(format!(
                    "material \"{name}\": texture map_Kd {file} not read ({e}); the reflectance is Kd {}",
                    texture::fmt(rho)
                )),
            }
        }
        let rho = clamp_white(rho, &name, &mut warnings);
        let emission = m.emissive.unwrap_or([0.0; 3]).map(f64::from);
        if let Some(ka) = m.ambient.map(|a| a.map(f64::from))
            && !emission.iter().any(|&e| e > 0.0)
            && ka.iter().any(|&a| a > 1.0)
        {
            warnings.push(format!(
                "material \"{name}\": Ka {} looks like a light but Ka (ambient colour) does not emit here; to make it a light give it `Ke {} {} {}` (exitance, in the units of the result)",
                validate::fmt3(ka),
                ka[0],
                ka[1],
                ka[2]
            ));
        }
        materials.push(Material {
            name,
            rho,
            emission,
        });
    }
    check_usemtl(&text, &mtl, path)?;

    let lines = face_lines(&text);
    let total: usize = models
        .iter()
        .map(|m| {
            let mesh = &m.mesh;
            if mesh.face_arities.is_empty() {
                mesh.indices.len() / 3
            } else {
                mesh.face_arities.len()
            }
        })
        .sum();
    // The k-th face tobj returns is the k-th `f` line, unless tobj skipped one.
    let lines = (lines.len() == total).then_some(lines);
    let file = path.file_name().map_or_else(
        || path.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    let mut default_material = None;
    let mut by_name: BTreeMap<String, usize> = BTreeMap::new();
    let mut objects: Vec<Object> = Vec::new();
    // Source line of each polygon, per object (unused when lines are unknown).
    let mut sources: Vec<Vec<usize>> = Vec::new();
    let mut split = Split::default();
    let mut face = 0usize;
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id {
            Some(m) if m < materials.len() => MaterialId(m as u32),
            _ => *default_material.get_or_insert_with(|| {
                materials.push(Material::diffuse(
                    unique_name("default", &materials),
                    [DEFAULT_RHO; 3],
                ));
                MaterialId(materials.len() as u32 - 1)
            }),
        };
        let o = *by_name.entry(model.name.clone()).or_insert_with(|| {
            objects.push(Object::still(model.name.clone(), Vec::new()));
            sources.push(Vec::new());
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
            let line = lines.as_ref().map(|l| l[face]);
            face += 1;
            let object = &mut objects[o];
            let (at, place) = at_line(path, line, &object.name, object.polygons.len());
            let Some(idx) = mesh.indices.get(start..start + arity) else {
                return Err(Error::invalid(
                    at,
                    place,
                    "face indices",
                    "a truncated face",
                ));
            };
            start += arity;
            let mut vertices = Vec::with_capacity(arity);
            for &i in idx {
                let Some(v) = positions.get(i as usize) else {
                    return Err(Error::invalid(
                        at,
                        place,
                        format!("vertex indices < {}", positions.len()),
                        format!("index {i}"),
                    ));
                };
                vertices.push(*v);
            }
            let kind = match arity {
                3 => None,
                4 => validate::quad_problem(&vertices).map(|q| match q {
                    QuadProblem::NotPlanar { .. } => SplitKind::NonPlanarQuad,
                    QuadProblem::Concave { .. } => SplitKind::ConcaveQuad,
                }),
                _ => Some(SplitKind::Polygon),
            };
            let Some(kind) = kind else {
                object.polygons.push(Polygon { vertices, material });
                sources[o].extend(line);
                continue;
            };
            let triangles = triangulate(&vertices).map_err(|d| {
                Error::invalid(
                    at.clone(),
                    place.clone(),
                    "a face that can be cut into triangles",
                    format!("a {arity}-vertex face that is {}", d.describe()),
                )
            })?;
            split.count(kind, line.map(|l| format!("{file}:{l}")));
            for t in triangles {
                object.polygons.push(Polygon {
                    vertices: t.iter().map(|&k| vertices[k]).collect(),
                    material,
                });
                sources[o].extend(line);
            }
        }
    }
    if let Some(w) = split.warning(&file) {
        warnings.push(w);
    }
    let scene = Scene {
        time: TimeDomain::default(),
        materials,
        objects,
        camera: None,
        warnings,
    };
    let sources = if lines.is_some() { sources } else { Vec::new() };
    validate::validate_sourced(scene, path, &sources)
}

/// The error path (`room.obj:12` when the line is known) and the place of polygon
/// `polygon` of `object`.
fn at_line(path: &Path, line: Option<usize>, object: &str, polygon: usize) -> (PathBuf, String) {
    let at = match line {
        Some(l) => PathBuf::from(format!("{}:{l}", path.display())),
        None => path.to_path_buf(),
    };
    (at, format!("object \"{object}\", polygon {polygon}"))
}

/// Line numbers (1-based) of the face statements (`f` with 3 or more vertices) in
/// file order, the order tobj returns faces in.
fn face_lines(text: &str) -> Vec<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| {
            let mut w = l.split_whitespace();
            w.next() == Some("f") && w.count() >= 3
        })
        .map(|(k, _)| k + 1)
        .collect()
}

/// Why a face was split into triangles.
#[derive(Clone, Copy)]
enum SplitKind {
    NonPlanarQuad,
    ConcaveQuad,
    Polygon,
}

/// Faces split into triangles, by kind, and the first one's line.
#[derive(Default)]
struct Split {
    counts: [usize; 3],
    first: Option<String>,
}

impl Split {
    fn count(&mut self, kind: SplitKind, line: Option<String>) {
        self.counts[kind as usize] += 1;
        if self.first.is_none() {
            self.first = line;
        }
    }

    /// The one warning for all split faces, if any.
    fn warning(&self, file: &str) -> Option<String> {
        let [bent, concave, ngons] = self.counts;
        let total = bent + concave + ngons;
        (total > 0).then(|| {
            format!(
                "{}: split {total} face(s) into triangles: {bent} non-planar quad(s) (a vertex off the plane by more than {PLANARITY_TOLERANCE} x diameter), {concave} concave quad(s), {ngons} face(s) of 5 or more vertices{}",
                self.first.as_deref().unwrap_or(file),
                if self.first.is_some() { " (the first here)" } else { "" }
            )
        })
    }
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
