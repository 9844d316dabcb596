//! glTF 2.0 reader (`.gltf` with embedded `data:` or external buffers, and `.glb`).
//!
//! How it works (the mapping is specified in `formats/scene.md`, section "glTF 2.0"):
//!
//! 1. The `gltf` crate parses and validates the document; buffers are loaded without
//!    images. Every accessor read here is checked first (type, component type, count,
//!    byte range inside its buffer) so that a malformed file gives an error, never a
//!    panic inside the `gltf` crate.
//! 2. The default scene (else the first) is walked from its roots; each node with a
//!    mesh becomes one [`Object`] named after the node (else its mesh, else
//!    `node N`). Primitives must be `TRIANGLES` (indexed or not); consecutive
//!    triangles `(a, b, c)`, `(a, c, d)` forming a planar convex quad are merged back
//!    into that quad.
//! 3. A node whose chain of ancestors has no animation channel is static: its world
//!    matrix (product of the parent chain) is baked into the vertices, exactly. A node
//!    with animated ancestors (or itself animated) keeps mesh-space vertices and gets
//!    a [`MotionTrack`] with keys at the union of the key times of every channel on its
//!    chain (plus 3 interior samples per segment of a `CUBICSPLINE` channel); at each
//!    key every channel is sampled with its own interpolation, the chain composed and
//!    the world matrix decomposed into translation, rotation, scale (shear, which a
//!    TRS key cannot hold, is lost).
//! 4. Winding: glTF's front face is counter-clockwise when the world matrix has a
//!    positive determinant and clockwise otherwise; triangles of mirrored nodes are
//!    reversed so that every polygon is counter-clockwise seen from its lit side.
//! 5. Materials: `baseColorFactor` (linear RGB, alpha ignored) = reflectance,
//!    `emissiveFactor` × `KHR_materials_emissive_strength` = radiance `L`, exitance
//!    `E = pi L`. A `baseColorTexture` multiplies the factor by its mean linear
//!    colour ([`super::texture`]). A reflectance channel of exactly 1.0 (the
//!    format's default white) is clamped to 0.999 with a warning. Primitives without
//!    a material use `default` (reflectance 0.8, no emission). A `doubleSided`
//!    material's polygons get a reversed twin, so they reflect and emit both ways.
//! 6. Camera: the first node (depth-first from the roots) with a perspective camera,
//!    placed at the scene's start time; [`cameras`] lists them all by name.
//!
//! Not read: morph targets and skins (ignored), sparse accessors (refused), lights
//! (`KHR_lights_punctual`: a warning says how to model them as emissive surfaces),
//! emissive textures (a warning), texture coordinates (a texture counts by its mean).

use std::collections::BTreeSet;
use std::f64::consts::PI;
use std::path::Path;

use ::gltf as gl;
use gl::accessor::{DataType, Dimensions};
use gl::animation::{Interpolation, Property};
use glam::{DAffine3, DMat4, DQuat, DVec3};

use super::model::{
    Camera, Material, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, TimeDomain,
};
use super::{texture, validate};
use crate::{Error, Result};

/// Reflectance of primitives without a material.
const DEFAULT_RHO: f64 = 0.8;
/// What an exactly-1.0 reflectance channel becomes.
pub(crate) const CLAMPED_WHITE: f64 = 0.999;
/// Interior samples added per segment of a cubic-spline channel.
const CUBIC_SUBSAMPLES: usize = 3;

/// Loads and validates the glTF file at `path` (`.gltf` or `.glb`).
pub(crate) fn load(path: &Path) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    load_slice(&bytes, path.parent(), path)
}

/// Loads and validates glTF `bytes`; external buffers are resolved against `base`.
pub(crate) fn load_slice(bytes: &[u8], base: Option<&Path>, path: &Path) -> Result<Scene> {
    let (scene, _) = read(bytes, base.unwrap_or(Path::new(".")), path)?;
    validate::validate(scene, path)
}

/// The perspective cameras of the glTF file at `path`, by name (the camera's, else
/// its node's, else `camera N`), placed at the scene's start time, in node order.
pub(crate) fn cameras(path: &Path) -> Result<Vec<(String, Camera)>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let (_, cameras) = read(&bytes, path.parent().unwrap_or(Path::new(".")), path)?;
    Ok(cameras)
}

/// The scene (not yet validated) and the cameras of glTF `bytes`, external buffers
/// resolved against `base`; errors name `path`.
fn read(bytes: &[u8], base: &Path, path: &Path) -> Result<(Scene, Vec<(String, Camera)>)> {
    let invalid =
        |found: String| Error::invalid(path, "glTF document", "a valid glTF 2.0 file", found);
    let gltf =
        gl::Gltf::from_slice_without_validation(bytes).map_err(|e| invalid(e.to_string()))?;
    check_document(gltf.document.as_json()).map_err(invalid)?;
    let buffers = gl::import_buffers(&gltf.document, Some(base), gltf.blob.clone())
        .map_err(|e| Error::invalid(path, "glTF buffers", "readable buffer data", e.to_string()))?;
    let data: Vec<&[u8]> = buffers.iter().map(|b| &b.0[..]).collect();
    Reader {
        doc: &gltf.document,
        data,
        buffers: &buffers,
        base,
        path,
    }
    .read()
}

/// Validates the raw document: first what the `gltf` crate's own validation indexes
/// without checking (a primitive's `POSITION` accessor) or does not check at all
/// (animation channel targets), then the crate's validation. `Err` describes the
/// first problems found.
fn check_document(root: &gl::json::Root) -> std::result::Result<(), String> {
    use gl::json::validation::{Checked, Validate};
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = prim
                .attributes
                .get(&Checked::Valid(gl::Semantic::Positions));
            if let Some(i) = position.filter(|i| i.value() >= root.accessors.len()) {
                return Err(format!(
                    "mesh {m}, primitive {p}: POSITION accessor {} of {}",
                    i.value(),
                    root.accessors.len()
                ));
            }
        }
    }
    for (a, anim) in root.animations.iter().enumerate() {
        for (c, ch) in anim.channels.iter().enumerate() {
            if ch.target.node.value() >= root.nodes.len()
                || !matches!(ch.target.path, Checked::Valid(_))
            {
                return Err(format!(
                    "animation {a}, channel {c}: target node {} of {} or an unknown path",
                    ch.target.node.value(),
                    root.nodes.len()
                ));
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, gl::json::Path::new, &mut |place, error| {
        if errors.len() < 5 {
            errors.push(format!("{}: {error}", place()));
        }
    });
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors.join("; "))
    }
}

/// One animation channel, read into `f64`.
struct Channel {
    property: Property,
    interpolation: Interpolation,
    times: Vec<f64>,
    /// Output values (3 or 4 components); for `CUBICSPLINE` 3 per key: in-tangent,
    /// value, out-tangent.
    values: Vec<[f64; 4]>,
}

impl Channel {
    fn value(&self, k: usize) -> [f64; 4] {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The channel's value at `t` (held constant outside its key range).
    fn sample(&self, t: f64) -> [f64; 4] {
        let n = self.times.len();
        if t <= self.times[0] {
            return self.value(0);
        }
        if t >= self.times[n - 1] {
            return self.value(n - 1);
        }
        let i = self.times.partition_point(|&x| x <= t).clamp(1, n - 1) - 1;
        let (t0, t1) = (self.times[i], self.times[i + 1]);
        let s = (t - t0) / (t1 - t0);
        let rotation = self.property == Property::Rotation;
        match self.interpolation {
            Interpolation::Step => self.value(i),
            Interpolation::Linear if rotation => {
                let q0 = DQuat::from_array(self.value(i));
                let q1 = DQuat::from_array(self.value(i + 1));
                q0.slerp(q1, s).normalize().to_array()
            }
            Interpolation::Linear => {
                let (a, b) = (self.value(i), self.value(i + 1));
                std::array::from_fn(|c| a[c] + s * (b[c] - a[c]))
            }
            Interpolation::CubicSpline => {
                // glTF 2.0 spec, Appendix C: Hermite spline with tangents scaled by the
                // segment duration.
                let td = t1 - t0;
                let (v0, b0) = (self.values[3 * i + 1], self.values[3 * i + 2]);
                let (a1, v1) = (self.values[3 * i + 3], self.values[3 * i + 4]);
                let (s2, s3) = (s * s, s * s * s);
                let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                let h10 = s3 - 2.0 * s2 + s;
                let h01 = -2.0 * s3 + 3.0 * s2;
                let h11 = s3 - s2;
                let out: [f64; 4] = std::array::from_fn(|c| {
                    h00 * v0[c] + h10 * td * b0[c] + h01 * v1[c] + h11 * td * a1[c]
                });
                if rotation {
                    DQuat::from_array(out).normalize().to_array()
                } else {
                    out
                }
            }
        }
    }
}

/// Rest pose of a node: exact matrix plus its TRS (used when channels override parts).
struct NodeRest {
    matrix: DAffine3,
    translation: DVec3,
    rotation: DQuat,
    scale: DVec3,
}

struct Reader<'a> {
    doc: &'a gl::Document,
    data: Vec<&'a [u8]>,
    /// The same buffers as `data`, as the `gltf` crate's image decoder takes them.
    buffers: &'a [gl::buffer::Data],
    /// Where external images are looked for.
    base: &'a Path,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn err(
        &self,
        place: impl Into<String>,
        expected: impl Into<String>,
        found: impl Into<String>,
    ) -> Error {
        Error::invalid(self.path, place, expected, found)
    }

    /// Checks that `acc` can be read as `dims` of one of `types`, inside its buffer.
    fn check_accessor(
        &self,
        acc: &gl::Accessor<'_>,
        dims: Dimensions,
        types: &[DataType],
        place: &str,
    ) -> Result<()> {
        let here = || format!("{place}, accessor {}", acc.index());
        if acc.sparse().is_some() {
            return Err(self.err(here(), "a non-sparse accessor", "a sparse accessor"));
        }
        if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
            return Err(self.err(
                here(),
                format!("{dims:?} of {types:?}"),
                format!("{:?} of {:?}", acc.dimensions(), acc.data_type()),
            ));
        }
        if acc.count() == 0 {
            return Err(self.err(here(), "at least one element", "count 0"));
        }
        let Some(view) = acc.view() else {
            return Err(self.err(here(), "a buffer view", "none"));
        };
        let size = acc.size();
        let stride = view.stride().unwrap_or(size);
        let buffer_len = self.data.get(view.buffer().index()).map_or(0, |d| d.len());
        let view_end = view.offset().checked_add(view.length());
        let acc_end = stride
            .checked_mul(acc.count() - 1)
            .and_then(|x| x.checked_add(size))
            .and_then(|x| x.checked_add(acc.offset()));
        let fits = stride >= size
            && view_end.is_some_and(|e| e <= buffer_len)
            && acc_end.is_some_and(|e| e <= view.length());
        if !fits {
            return Err(self.err(
                here(),
                format!("{} elements of {size} bytes (stride {stride}) inside buffer view {} ({} bytes at offset {}) and buffer {} ({buffer_len} bytes)", acc.count(), view.index(), view.length(), view.offset(), view.buffer().index()),
                "an accessor that does not fit",
            ));
        }
        Ok(())
    }

    fn buffer(&self) -> impl Clone + Fn(gl::Buffer<'_>) -> Option<&'a [u8]> + '_ {
        move |b: gl::Buffer<'_>| self.data.get(b.index()).copied()
    }

    /// The scene, and every perspective camera by name.
    fn read(&self) -> Result<(Scene, Vec<(String, Camera)>)> {
        let doc = self.doc;
        let Some(root) = doc.default_scene().or_else(|| doc.scenes().next()) else {
            return Err(self.err("glTF document", "a scene", "no scene"));
        };

        // Step 1: the node tree (parents), checked to be a tree.
        let node_count = doc.nodes().len();
        let mut parent: Vec<Option<usize>> = vec![None; node_count];
        let mut order = Vec::new(); // depth-first, parents before children
        let mut seen = vec![false; node_count];
        let mut stack: Vec<(gl::Node<'_>, Option<usize>)> =
            root.nodes().map(|n| (n, None)).collect();
        stack.reverse();
        while let Some((node, p)) = stack.pop() {
            let i = node.index();
            if seen[i] {
                return Err(self.err(
                    format!("node {i}"),
                    "a node tree (each node reachable once)",
                    "a node with two parents or a cycle",
                ));
            }
            seen[i] = true;
            parent[i] = p;
            order.push(node.clone());
            let mut children: Vec<_> = node.children().map(|c| (c, Some(i))).collect();
            children.reverse();
            stack.extend(children);
        }
        let rests: Vec<NodeRest> = doc.nodes().map(|n| rest_of(&n)).collect();

        // Step 2: animation channels per node, and the time domain.
        let mut channels: Vec<Vec<Channel>> = (0..node_count).map(|_| Vec::new()).collect();
        let (mut t_min, mut t_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for anim in doc.animations() {
            for ch in anim.channels() {
                let place = format!("animation {}, channel {}", anim.index(), ch.index());
                let Some(c) = self.read_channel(&ch, &place)? else {
                    continue;
                };
                t_min = t_min.min(c.times[0]);
                t_max = t_max.max(c.times[c.times.len() - 1]);
                channels[ch.target().node().index()].push(c);
            }
        }
        let time = if t_min <= t_max {
            TimeDomain {
                start: t_min,
                end: t_max,
            }
        } else {
            TimeDomain::default()
        };
        let chain = |mut i: usize| {
            let mut c = vec![i];
            while let Some(p) = parent[i] {
                c.push(p);
                i = p;
            }
            c.reverse();
            c
        };
        let world_at = |node: usize, t: f64| {
            chain(node).iter().fold(DAffine3::IDENTITY, |w, &i| {
                w * local_at(&rests[i], &channels[i], t)
            })
        };

        // Step 3: materials (every document material, in order; `default` on demand).
        let mut warnings = Vec::new();
        if self
            .doc
            .extensions_used()
            .any(|e| e == "KHR_lights_punctual")
        {
            warnings.push(format!(
                "{}: KHR_lights_punctual lights are not read (only surfaces emit): model each lamp as a small mesh whose material has an emissiveFactor (times KHR_materials_emissive_strength), placed where the lamp is",
                self.path.display()
            ));
        }
        let mut materials = self.materials(&mut warnings);
        let mut default_material = None;

        // Step 4: objects.
        let mut objects = Vec::new();
        let mut cameras: Vec<(String, Camera)> = Vec::new();
        let mut double_sided = 0usize;
        for node in &order {
            let i = node.index();
            let perspective = node.camera().and_then(|cam| {
                let yfov = match cam.projection() {
                    gl::camera::Projection::Perspective(p) => Some(p.yfov()),
                    gl::camera::Projection::Orthographic(_) => None,
                };
                yfov.map(|y| (cam, y))
            });
            if let Some((cam, yfov)) = perspective {
                let w = world_at(i, time.start);
                let eye = w.transform_point3(DVec3::ZERO);
                let name = cam
                    .name()
                    .or(node.name())
                    .map_or_else(|| format!("camera {}", cam.index()), str::to_string);
                cameras.push((
                    name,
                    Camera {
                        eye,
                        target: eye + w.transform_vector3(DVec3::NEG_Z).normalize_or_zero(),
                        up: w.transform_vector3(DVec3::Y).normalize_or_zero(),
                        fov_y: f64::from(yfov),
                    },
                ));
            }
            let Some(mesh) = node.mesh() else {
                continue;
            };
            let name = node
                .name()
                .or(mesh.name())
                .map_or_else(|| format!("node {i}"), str::to_string);
            let nodes = chain(i);
            let mut times: Vec<f64> = Vec::new();
            for &n in &nodes {
                for c in &channels[n] {
                    times.extend(&c.times);
                    if c.interpolation == Interpolation::CubicSpline {
                        for w in c.times.windows(2) {
                            for k in 1..=CUBIC_SUBSAMPLES {
                                let s = k as f64 / (CUBIC_SUBSAMPLES + 1) as f64;
                                times.push(w[0] + s * (w[1] - w[0]));
                            }
                        }
                    }
                }
            }
            times.sort_by(f64::total_cmp);
            times.dedup();
            let (vertex_map, motion) = if times.is_empty() {
                (world_at(i, 0.0), None)
            } else {
                let keys = times
                    .iter()
                    .map(|&t| {
                        let (scale, rotation, translation) =
                            world_at(i, t).to_scale_rotation_translation();
                        MotionKey {
                            t,
                            translation,
                            rotation,
                            scale,
                        }
                    })
                    .collect();
                (DAffine3::IDENTITY, Some(MotionTrack { keys }))
            };
            let mirrored = match &motion {
                Some(m) => m.keys[0].to_affine().matrix3.determinant() < 0.0,
                None => vertex_map.matrix3.determinant() < 0.0,
            };
            let mut polygons = Vec::new();
            for prim in mesh.primitives() {
                let place = format!(
                    "mesh \"{}\", primitive {}",
                    mesh.name()
                        .map_or_else(|| mesh.index().to_string(), str::to_string),
                    prim.index()
                );
                if prim.mode() != gl::mesh::Mode::Triangles {
                    return Err(self.err(
                        place,
                        "mode TRIANGLES",
                        format!("mode {:?}", prim.mode()),
                    ));
                }
                let material = match prim.material().index() {
                    Some(m) => MaterialId(m as u32),
                    None => *default_material.get_or_insert_with(|| {
                        materials.push(Material::diffuse(
                            unique_name("default", &materials),
                            [DEFAULT_RHO; 3],
                        ));
                        MaterialId(materials.len() as u32 - 1)
                    }),
                };
                // A double-sided material reflects and emits on both sides: each
                // polygon gets a twin facing the other way.
                let twins = prim.material().double_sided();
                for poly in merge_quads(&self.triangles(&prim, &place)?) {
                    let mut v: Vec<DVec3> = poly
                        .iter()
                        .map(|p| vertex_map.transform_point3(*p))
                        .collect();
                    if mirrored {
                        v.reverse();
                    }
                    if twins {
                        double_sided += 1;
                        polygons.push(Polygon {
                            vertices: v.iter().rev().copied().collect(),
                            material,
                        });
                    }
                    polygons.push(Polygon {
                        vertices: v,
                        material,
                    });
                }
            }
            objects.push(Object {
                name,
                polygons,
                motion,
            });
        }
        if double_sided > 0 {
            warnings.push(format!(
                "{double_sided} polygon(s) of doubleSided materials reflect and emit on both sides (each is solved as two back-to-back polygons)"
            ));
        }
        let camera = cameras.first().map(|c| c.1);
        let scene = Scene {
            time,
            materials,
            objects,
            camera,
            warnings,
        };
        Ok((scene, cameras))
    }

    fn materials(&self, warnings: &mut Vec<String>) -> Vec<Material> {
        let mut out: Vec<Material> = Vec::new();
        for m in self.doc.materials() {
            let Some(i) = m.index() else { continue };
            let base = m
                .name()
                .map_or_else(|| format!("material {i}"), str::to_string);
            let name = unique_name(&base, &out);
            let pbr = m.pbr_metallic_roughness();
            let [r, g, b, _] = pbr.base_color_factor().map(f64::from);
            let mut rho = [r, g, b];
            if let Some(info) = pbr.base_color_texture() {
                let image = info.texture().source();
                let what = match image.source() {
                    gl::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                        uri.to_string()
                    }
                    _ => format!("image {}", image.index()),
                };
                match self.texture_mean(&image) {
                    Ok(mean) => {
                        warnings.push(texture::note(&name, &what, mean, rho));
                        rho = std::array::from_fn(|c| mean[c] * rho[c]);
                    }
                    Err(e) => warnings.push(format!(
                        "material \"{name}\": baseColorTexture {what} not read ({e}); the reflectance is baseColorFactor {}",
                        texture::fmt(rho)
                    )),
                }
            }
            let rho = clamp_white(rho, &name, warnings);
            let strength = f64::from(m.emissive_strength().unwrap_or(1.0));
            let emission = m.emissive_factor().map(|l| PI * f64::from(l) * strength);
            if m.emissive_texture().is_some() {
                warnings.push(format!(
                    "material \"{name}\": emissiveTexture is ignored (only emissiveFactor is read)"
                ));
            }
            out.push(Material {
                name,
                rho,
                emission,
            });
        }
        out
    }

    /// Mean linear colour of a glTF image (PNG or JPEG, embedded or external).
    fn texture_mean(&self, image: &gl::Image<'_>) -> std::result::Result<[f64; 3], String> {
        use gl::image::Format;
        let data = gl::image::Data::from_source(image.source(), Some(self.base), self.buffers)
            .map_err(|e| e.to_string())?;
        let (channels, bytes) = match data.format {
            Format::R8 => (1, 1),
            Format::R8G8 => (2, 1),
            Format::R8G8B8 => (3, 1),
            Format::R8G8B8A8 => (4, 1),
            Format::R16 => (1, 2),
            Format::R16G16 => (2, 2),
            Format::R16G16B16 => (3, 2),
            Format::R16G16B16A16 => (4, 2),
            other => return Err(format!("pixel format {other:?}")),
        };
        // Luminance-alpha counts as grey: only the first channel of two is colour.
        let colour = if channels == 2 { 1 } else { channels.min(3) };
        let values = data
            .pixels
            .chunks_exact(bytes)
            .enumerate()
            .filter(|(k, _)| k % channels < colour)
            .map(|(_, b)| match b {
                [x] => f64::from(*x) / 255.0,
                [x, y] => f64::from(u16::from_ne_bytes([*x, *y])) / 65535.0,
                _ => 0.0,
            });
        let values: Vec<f64> = values.collect();
        texture::mean_linear(values.into_iter(), colour).ok_or_else(|| "an empty image".to_string())
    }

    /// Reads one channel; `None` for morph-target weights (ignored).
    fn read_channel(
        &self,
        ch: &gl::animation::Channel<'_>,
        place: &str,
    ) -> Result<Option<Channel>> {
        let property = ch.target().property();
        let dims = match property {
            Property::MorphTargetWeights => return Ok(None),
            Property::Rotation => Dimensions::Vec4,
            _ => Dimensions::Vec3,
        };
        let sampler = ch.sampler();
        let interpolation = sampler.interpolation();
        self.check_accessor(
            &sampler.input(),
            Dimensions::Scalar,
            &[DataType::F32],
            &format!("{place}, input"),
        )?;
        let out_types: &[DataType] = if property == Property::Rotation {
            &[
                DataType::F32,
                DataType::I8,
                DataType::U8,
                DataType::I16,
                DataType::U16,
            ]
        } else {
            &[DataType::F32]
        };
        self.check_accessor(
            &sampler.output(),
            dims,
            out_types,
            &format!("{place}, output"),
        )?;
        let reader = ch.reader(self.buffer());
        let times: Vec<f64> = reader
            .read_inputs()
            .map(|it| it.map(f64::from).collect())
            .unwrap_or_default();
        let values: Vec<[f64; 4]> = match reader.read_outputs() {
            Some(gl::animation::util::ReadOutputs::Translations(it))
            | Some(gl::animation::util::ReadOutputs::Scales(it)) => it
                .map(|v| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2]), 0.0])
                .collect(),
            Some(gl::animation::util::ReadOutputs::Rotations(r)) => {
                r.into_f32().map(|v| v.map(f64::from)).collect()
            }
            _ => Vec::new(),
        };
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        if times.is_empty() || values.len() != per_key * times.len() {
            return Err(self.err(
                place,
                format!("{per_key} output value(s) per input time ({interpolation:?})"),
                format!("{} inputs, {} outputs", times.len(), values.len()),
            ));
        }
        if let Some(k) = times
            .iter()
            .position(|t| !t.is_finite())
            .or_else(|| times.windows(2).position(|w| w[1] <= w[0]).map(|k| k + 1))
        {
            return Err(self.err(
                format!("{place}, key {k}"),
                "finite input times, strictly increasing",
                match k.checked_sub(1) {
                    Some(j) => format!("t = {} after t = {}", times[k], times[j]),
                    None => format!("t = {}", times[k]),
                },
            ));
        }
        if let Some(k) = values.iter().position(|v| v.iter().any(|x| !x.is_finite())) {
            return Err(self.err(
                format!("{place}, output {k}"),
                "finite values",
                format!("{:?}", values[k]),
            ));
        }
        Ok(Some(Channel {
            property,
            interpolation,
            times,
            values,
        }))
    }

    /// The primitive's triangles in mesh space.
    fn triangles(&self, prim: &gl::Primitive<'_>, place: &str) -> Result<Vec<[DVec3; 3]>> {
        let Some(acc) = prim.get(&gl::Semantic::Positions) else {
            return Err(self.err(place, "a POSITION attribute", "none"));
        };
        self.check_accessor(
            &acc,
            Dimensions::Vec3,
            &[DataType::F32],
            &format!("{place}, POSITION"),
        )?;
        let reader = prim.reader(self.buffer());
        let positions: Vec<DVec3> = reader
            .read_positions()
            .map(|it| {
                it.map(|p| DVec3::new(p[0].into(), p[1].into(), p[2].into()))
                    .collect()
            })
            .unwrap_or_default();
        let indices: Vec<u32> = match prim.indices() {
            Some(ia) => {
                self.check_accessor(
                    &ia,
                    Dimensions::Scalar,
                    &[DataType::U8, DataType::U16, DataType::U32],
                    &format!("{place}, indices"),
                )?;
                reader
                    .read_indices()
                    .map(|r| r.into_u32().collect())
                    .unwrap_or_default()
            }
            None => (0..positions.len() as u32).collect(),
        };
        if indices.len() % 3 != 0 {
            return Err(self.err(
                place,
                "a multiple of 3 indices (TRIANGLES)",
                format!("{} indices", indices.len()),
            ));
        }
        let mut out = Vec::with_capacity(indices.len() / 3);
        for (t, idx) in indices.chunks_exact(3).enumerate() {
            let mut tri = [DVec3::ZERO; 3];
            for (k, &ix) in idx.iter().enumerate() {
                let Some(p) = positions.get(ix as usize) else {
                    return Err(self.err(
                        format!("{place}, triangle {t}"),
                        format!("vertex indices < {}", positions.len()),
                        format!("index {ix}"),
                    ));
                };
                tri[k] = *p;
            }
            out.push(tri);
        }
        Ok(out)
    }
}

/// Merges each pair of consecutive triangles `(a, b, c)`, `(a, c, d)` (the second in
/// any rotation) that share the diagonal `a-c`, both have non-zero area and form a
/// planar convex quad (the validation tolerances) into the quad `(a, b, c, d)`; this
/// undoes the usual export of quads as triangle pairs. Other triangles are kept.
fn merge_quads(tris: &[[DVec3; 3]]) -> Vec<Vec<DVec3>> {
    let mut out = Vec::with_capacity(tris.len());
    let mut i = 0;
    while i < tris.len() {
        let [a, b, c] = tris[i];
        let quad = tris.get(i + 1).and_then(|t| {
            let d = (0..3).find_map(|r| {
                let (x, y, z) = (t[r], t[(r + 1) % 3], t[(r + 2) % 3]);
                (x == a && y == c).then_some(z)
            })?;
            let q = [a, b, c, d];
            let nonzero =
                (b - a).cross(c - a) != DVec3::ZERO && (c - a).cross(d - a) != DVec3::ZERO;
            (nonzero && validate::quad_problem(&q).is_none()).then(|| q.to_vec())
        });
        match quad {
            Some(q) => {
                out.push(q);
                i += 2;
            }
            None => {
                out.push(tris[i].to_vec());
                i += 1;
            }
        }
    }
    out
}

/// Node rest pose: exact matrix and its TRS decomposition.
fn rest_of(node: &gl::Node<'_>) -> NodeRest {
    match node.transform() {
        gl::scene::Transform::Matrix { matrix } => {
            let m = DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)));
            let matrix = DAffine3::from_mat4(m);
            let (scale, rotation, translation) = matrix.to_scale_rotation_translation();
            NodeRest {
                matrix,
                translation,
                rotation,
                scale,
            }
        }
        gl::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let translation = DVec3::from_array(translation.map(f64::from));
            // glTF allows slightly non-unit quaternions; normalise (identity if zero).
            let rotation = DQuat::from_array(rotation.map(f64::from));
            let rotation = if rotation.length_squared() > 0.0 {
                rotation.normalize()
            } else {
                DQuat::IDENTITY
            };
            let scale = DVec3::from_array(scale.map(f64::from));
            NodeRest {
                matrix: DAffine3::from_scale_rotation_translation(scale, rotation, translation),
                translation,
                rotation,
                scale,
            }
        }
    }
}

/// A node's local matrix at `t`: the rest matrix if not animated, else its rest TRS
/// with the animated properties replaced by the channels' samples.
fn local_at(rest: &NodeRest, channels: &[Channel], t: f64) -> DAffine3 {
    if channels.is_empty() {
        return rest.matrix;
    }
    let (mut tr, mut rot, mut sc) = (rest.translation, rest.rotation, rest.scale);
    for c in channels {
        let v = c.sample(t);
        match c.property {
            Property::Translation => tr = DVec3::new(v[0], v[1], v[2]),
            Property::Rotation => {
                let q = DQuat::from_array(v);
                if q.length_squared() > 0.0 {
                    rot = q.normalize();
                }
            }
            Property::Scale => sc = DVec3::new(v[0], v[1], v[2]),
            Property::MorphTargetWeights => {}
        }
    }
    DAffine3::from_scale_rotation_translation(sc, rot, tr)
}

/// Clamps channels equal to exactly 1.0 to [`CLAMPED_WHITE`], with a warning naming
/// the material; other values are left for validation.
pub(crate) fn clamp_white(rho: [f64; 3], name: &str, warnings: &mut Vec<String>) -> [f64; 3] {
    if rho.contains(&1.0) {
        warnings.push(format!(
            "material \"{name}\": reflectance 1.0 clamped to {CLAMPED_WHITE} (radiosity needs rho < 1)"
        ));
        rho.map(|r| if r == 1.0 { CLAMPED_WHITE } else { r })
    } else {
        rho
    }
}

/// `base`, or `base#k` with the smallest k making it unique among `materials`.
pub(crate) fn unique_name(base: &str, materials: &[Material]) -> String {
    let taken: BTreeSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    if !taken.contains(base) {
        return base.to_string();
    }
    (2..)
        .map(|k| format!("{base}#{k}"))
        .find(|n| !taken.contains(n.as_str()))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(property: Property, interpolation: Interpolation, values: &[[f64; 4]]) -> Channel {
        Channel {
            property,
            interpolation,
            times: vec![1.0, 3.0],
            values: values.to_vec(),
        }
    }

    #[test]
    fn triangle_pairs_merge_into_quads_only_when_planar_and_convex() {
        let (a, b, c, d) = (DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y);
        // (a, b, c) + (a, c, d), and the second written as (c, d, a).
        assert_eq!(merge_quads(&[[a, b, c], [a, c, d]]), vec![vec![a, b, c, d]]);
        assert_eq!(merge_quads(&[[a, b, c], [c, d, a]]), vec![vec![a, b, c, d]]);
        // Not sharing the diagonal a-c in the same direction: kept.
        assert_eq!(merge_quads(&[[a, b, c], [c, a, d]]).len(), 2);
        // Bent out of plane: kept as two triangles.
        let lifted = DVec3::new(0.0, 1.0, 0.1);
        assert_eq!(merge_quads(&[[a, b, c], [a, c, lifted]]).len(), 2);
        // Concave union (reflex corner at c; both triangles counter-clockwise): kept.
        let dent = DVec3::new(2.0, 3.0, 0.0);
        assert_eq!(merge_quads(&[[a, b, c], [a, c, dent]]).len(), 2);
        // Third triangle alone stays a triangle.
        assert_eq!(
            merge_quads(&[[a, b, c], [a, c, d], [a, b, d]]),
            vec![vec![a, b, c, d], vec![a, b, d]]
        );
    }

    #[test]
    fn step_holds_the_previous_key() {
        let c = channel(
            Property::Translation,
            Interpolation::Step,
            &[[1.0; 4], [5.0; 4]],
        );
        assert_eq!(c.sample(0.0)[0], 1.0);
        assert_eq!(c.sample(2.999)[0], 1.0);
        assert_eq!(c.sample(3.0)[0], 5.0);
        assert_eq!(c.sample(9.0)[0], 5.0);
    }

    #[test]
    fn linear_lerps_and_slerps() {
        let c = channel(
            Property::Translation,
            Interpolation::Linear,
            &[[0.0; 4], [4.0; 4]],
        );
        assert_eq!(c.sample(1.5)[1], 1.0);
        let q1 = DQuat::from_rotation_x(1.2).to_array();
        let c = channel(
            Property::Rotation,
            Interpolation::Linear,
            &[[0.0, 0.0, 0.0, 1.0], q1],
        );
        let q = DQuat::from_array(c.sample(2.5));
        // Three quarters of the way: 0.9 rad about x.
        assert!(q.angle_between(DQuat::from_rotation_x(0.9)) < 1e-12);
    }

    #[test]
    fn cubic_spline_is_hermite_with_scaled_tangents() {
        // Keys (in-tangent, value, out-tangent): v0 = 0 with out-tangent 1, v1 = 1 with
        // in-tangent 0; segment length 2. At s = 1/2: h00 = h01 = 1/2, h10 = 1/8,
        // h11 = -1/8, so p = 0.5 * 1 + 0.125 * 2 * 1 = 0.75.
        let z = [0.0; 4];
        let c = channel(
            Property::Translation,
            Interpolation::CubicSpline,
            &[z, z, [1.0; 4], z, [1.0; 4], z],
        );
        assert!((c.sample(2.0)[0] - 0.75).abs() < 1e-15);
        assert_eq!(c.sample(1.0)[0], 0.0);
        assert_eq!(c.sample(3.0)[0], 1.0);
        assert_eq!(c.sample(0.0)[0], 0.0);
    }
}
