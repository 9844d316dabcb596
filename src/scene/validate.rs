//! Validation run by every scene loader before a [`Scene`] is handed out.
//!
//! What it checks (rules and tolerances are specified in `formats/scene.md`,
//! section "Validation"):
//!
//! - time domain finite with `end >= start`; camera finite with `0 < fov_y < pi`;
//! - materials: reflectance finite and in `[0, 1)` per channel, emission finite and
//!   `>= 0`, and no emission whose radiosity bound `E / (1 − ρ_max)` exceeds
//!   [`MAX_RADIOSITY`] (a warning when every emission is below
//!   [`MIN_EMISSION_WARNING`]);
//! - polygons: 3 or 4 vertices, finite coordinates, a material that exists; quads
//!   planar within [`PLANARITY_TOLERANCE`] × the quad's diameter and convex;
//! - motion tracks: at least one key, finite values, `t` strictly increasing, rotation
//!   quaternions of length `1 ± `[`QUATERNION_TOLERANCE`] (then normalised), scale
//!   components non-zero with a determinant sign that does not change over time.
//!
//! What it repairs, with a warning in [`Scene::warnings`]: polygons whose area is at
//! most [`ZERO_AREA_TOLERANCE`] × (scene diameter)² are dropped (one warning with the
//! count), so are polygons that repeat an earlier one exactly (same vertices in the
//! same cyclic order, in the same moving object or both static: two coincident
//! faces each receive and each send the light, and a Cornell box with its floor
//! twice came out 22–73% too bright off the floor), objects left with no polygon
//! are dropped, and a scene without an emitter gets the warning
//! [`NO_EMITTER_WARNING`]; an emitter facing a surface too close gets one too
//! ([`super::emitters_facing_close`]).
//!
//! Every error is an [`Error::Invalid`] naming the file, the place (`object "room",
//! polygon 3`, `material "lamp"`, `object "cube", motion key 2`), what was expected and
//! what was found. It does not check format-specific rules (JSON types, glTF
//! primitive modes): the loaders do that before calling [`validate`].

use std::collections::HashSet;
use std::path::Path;

use glam::DVec3;

use super::model::{Scene, TimeDomain};
use crate::{Error, Result};

/// A quad is planar if every vertex lies within this fraction of the quad's diameter
/// (largest vertex-to-vertex distance) from its mean plane (through the centroid,
/// normal along the vector area). 1e-4 accepts round-off of `f32` files (relative
/// error ~6e-8) with a wide margin and refuses visibly bent quads.
pub const PLANARITY_TOLERANCE: f64 = 1e-4;

/// A polygon is zero-area, and dropped, if its area is at most this fraction of the
/// square of the scene diameter (diagonal of the bounding box of all object-space
/// vertices).
pub const ZERO_AREA_TOLERANCE: f64 = 1e-12;

/// Rotation quaternions must have a length within this distance of 1; they are then
/// normalised.
pub const QUATERNION_TOLERANCE: f64 = 1e-3;

/// Largest coordinate magnitude accepted (vertices, translations), so that
/// diameters and areas stay finite.
pub const MAX_COORDINATE: f64 = 1e100;

fn in_range(v: DVec3) -> bool {
    v.is_finite() && v.abs().max_element() <= MAX_COORDINATE
}

/// The warning given for a scene in which no polygon emits.
pub const NO_EMITTER_WARNING: &str = "scene has no emitter: the solution is zero";

/// Largest radiosity a scene may reach, bounded by `E / (1 − ρ_max)` per material
/// (`ρ_max` the largest reflectance of the scene): radiosities are stored in 32-bit
/// floats (largest 3.4·10³⁸), and this leaves a factor of 300 for light the factors
/// make. A Cornell box with its lamp scaled by 10³⁹ solved for 104 s into 14.7 M
/// links and wrote a file of infinite radiosities, which `probe` refused.
pub const MAX_RADIOSITY: f64 = 1e36;

/// Below this largest emission a scene loads with a warning: radiosities of
/// 32-bit floats lose precision under 1.2·10⁻³⁸ (the Cornell box with its lamp
/// scaled by 10⁻⁴² came out 0.1–1% off its scaled answer).
pub const MIN_EMISSION_WARNING: f64 = 1e-30;

/// Checks `scene` (loaded from `path`) against the rules of `formats/scene.md`,
/// normalises rotations, drops zero-area polygons and empty objects, and appends the
/// warnings. The first violation found is returned as an error.
pub fn validate(scene: Scene, path: &Path) -> Result<Scene> {
    validate_sourced(scene, path, &[])
}

/// [`validate`] for a scene whose polygon `i` of object `o` came from line
/// `lines[o][i]` of `path` (OBJ): messages about a polygon name `file:line`.
pub(crate) fn validate_sourced(
    mut scene: Scene,
    path: &Path,
    lines: &[Vec<usize>],
) -> Result<Scene> {
    let src = Sources { path, lines };
    check_time(&scene.time, path)?;
    check_camera(&scene, path)?;
    check_materials(&scene, path)?;
    check_radiosity_range(&mut scene, path)?;
    check_polygons(&scene, &src)?;
    check_motion(&mut scene, path)?;
    drop_degenerate(&mut scene, &src)?;
    if !scene.has_emitter() {
        scene.warnings.push(NO_EMITTER_WARNING.to_string());
    }
    let close = super::sides::emitters_facing_close(&scene);
    scene.warnings.extend(close);
    Ok(scene)
}

/// A number for messages: shortest round-trip form, in exponent notation when very
/// large or very small.
pub(crate) fn fmt_num(x: f64) -> String {
    if x.is_finite() && x != 0.0 && !(1e-6..1e16).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `[a, b, c]` with full precision, for messages.
pub(crate) fn fmt3(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", fmt_num(v[0]), fmt_num(v[1]), fmt_num(v[2]))
}

fn fmt_vec(v: DVec3) -> String {
    fmt3(v.to_array())
}

fn check_time(time: &TimeDomain, path: &Path) -> Result<()> {
    if !time.start.is_finite() || !time.end.is_finite() || time.end < time.start {
        return Err(Error::invalid(
            path,
            "time",
            "finite start and end with end >= start",
            format!("start = {}, end = {}", time.start, time.end),
        ));
    }
    Ok(())
}

fn check_camera(scene: &Scene, path: &Path) -> Result<()> {
    let Some(c) = &scene.camera else {
        return Ok(());
    };
    let finite = c.eye.is_finite() && c.target.is_finite() && c.up.is_finite();
    if !finite || c.eye == c.target || c.up == DVec3::ZERO {
        return Err(Error::invalid(
            path,
            "camera",
            "finite eye, target != eye and a non-zero up vector",
            format!(
                "eye = {}, target = {}, up = {}",
                fmt_vec(c.eye),
                fmt_vec(c.target),
                fmt_vec(c.up)
            ),
        ));
    }
    if !(c.fov_y > 0.0 && c.fov_y < std::f64::consts::PI) {
        return Err(Error::invalid(
            path,
            "camera",
            "a vertical field of view in (0, 180) degrees",
            format!("{} degrees", c.fov_y.to_degrees()),
        ));
    }
    Ok(())
}

fn check_materials(scene: &Scene, path: &Path) -> Result<()> {
    for m in &scene.materials {
        let place = format!("material \"{}\"", m.name);
        if m.rho.iter().any(|r| !(0.0..1.0).contains(r)) {
            return Err(Error::invalid(
                path,
                place,
                "reflectance in [0, 1) per channel",
                fmt3(m.rho),
            ));
        }
        if m.emission.iter().any(|e| !(e.is_finite() && *e >= 0.0)) {
            return Err(Error::invalid(
                path,
                place,
                "finite emission >= 0 per channel",
                fmt3(m.emission),
            ));
        }
    }
    Ok(())
}

/// The radiosity the scene can reach must fit the 32-bit floats it is stored in
/// ([`MAX_RADIOSITY`]); a scene whose emission is all below
/// [`MIN_EMISSION_WARNING`] gets a warning.
fn check_radiosity_range(scene: &mut Scene, path: &Path) -> Result<()> {
    let rho_max = scene
        .materials
        .iter()
        .flat_map(|m| m.rho)
        .fold(0.0, f64::max);
    let gain = 1.0 / (1.0 - rho_max);
    for m in &scene.materials {
        let e = m.emission.iter().copied().fold(0.0, f64::max);
        if e * gain > MAX_RADIOSITY {
            return Err(Error::invalid(
                path,
                format!("material \"{}\"", m.name),
                format!(
                    "emission / (1 - largest reflectance, {}) <= {} (radiosity is stored in 32-bit floats)",
                    fmt_num(rho_max),
                    fmt_num(MAX_RADIOSITY)
                ),
                fmt3(m.emission),
            ));
        }
    }
    let e_max = scene
        .materials
        .iter()
        .flat_map(|m| m.emission)
        .fold(0.0, f64::max);
    if e_max > 0.0 && e_max < MIN_EMISSION_WARNING {
        scene.warnings.push(format!(
            "largest emission {} is below {}: radiosity is stored in 32-bit floats, which lose precision under 1.2e-38; scale the emission up (the solution is linear in it)",
            fmt_num(e_max),
            fmt_num(MIN_EMISSION_WARNING)
        ));
    }
    Ok(())
}

/// The file a scene came from and, for OBJ, each polygon's source line.
struct Sources<'a> {
    path: &'a Path,
    lines: &'a [Vec<usize>],
}

impl Sources<'_> {
    fn line(&self, o: usize, i: usize) -> Option<usize> {
        self.lines.get(o).and_then(|l| l.get(i)).copied()
    }

    /// The path for an error about polygon `i` of object `o`: `room.obj:12` when its
    /// line is known.
    fn at(&self, o: usize, i: usize) -> std::path::PathBuf {
        match self.line(o, i) {
            Some(l) => format!("{}:{l}", self.path.display()).into(),
            None => self.path.to_path_buf(),
        }
    }

    /// Polygon `i` of object `name` in a warning, with `room.obj:12` when known.
    fn name(&self, o: usize, i: usize, name: &str) -> String {
        match (self.line(o, i), self.path.file_name()) {
            (Some(l), Some(f)) => format!(
                "{}:{l} (object \"{name}\" polygon {i})",
                f.to_string_lossy()
            ),
            _ => format!("object \"{name}\" polygon {i}"),
        }
    }
}

fn check_polygons(scene: &Scene, src: &Sources<'_>) -> Result<()> {
    for (oi, o) in scene.objects.iter().enumerate() {
        for (i, p) in o.polygons.iter().enumerate() {
            let path = src.at(oi, i);
            let path = path.as_path();
            let place = || format!("object \"{}\", polygon {i}", o.name);
            let n = p.vertices.len();
            if n != 3 && n != 4 {
                return Err(Error::invalid(
                    path,
                    place(),
                    "3 or 4 vertices",
                    format!("{n} vertices"),
                ));
            }
            if let Some((k, v)) = p.vertices.iter().enumerate().find(|(_, v)| !in_range(**v)) {
                return Err(Error::invalid(
                    path,
                    place(),
                    format!("finite vertex coordinates of magnitude <= {MAX_COORDINATE:e}"),
                    format!("vertex {k} = {}", fmt_vec(*v)),
                ));
            }
            if p.material.0 as usize >= scene.materials.len() {
                return Err(Error::invalid(
                    path,
                    place(),
                    format!("a material index < {}", scene.materials.len()),
                    format!("material index {}", p.material.0),
                ));
            }
        }
    }
    Ok(())
}

/// What makes a quad (of non-zero area) invalid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum QuadProblem {
    /// `vertex` lies `distance` off the mean plane, beyond `tolerance`.
    NotPlanar {
        vertex: usize,
        distance: f64,
        tolerance: f64,
    },
    /// The corner at `vertex` turns against the normal.
    Concave { vertex: usize },
}

/// Checks planarity (every vertex within [`PLANARITY_TOLERANCE`] × diameter of the
/// plane through the centroid with the quad's normal) and convexity (no corner
/// turning against the normal; collinear corners accepted) of a 4-vertex polygon of
/// non-zero area.
pub(crate) fn quad_problem(v: &[DVec3]) -> Option<QuadProblem> {
    let n =
        ((v[1] - v[0]).cross(v[2] - v[0]) + (v[2] - v[0]).cross(v[3] - v[0])).normalize_or_zero();
    let c = v.iter().copied().sum::<DVec3>() / 4.0;
    let mut diam: f64 = 0.0;
    for i in 0..4 {
        for j in i + 1..4 {
            diam = diam.max(v[i].distance(v[j]));
        }
    }
    let tolerance = PLANARITY_TOLERANCE * diam;
    let (vertex, distance) = (0..4)
        .map(|k| (k, n.dot(v[k] - c).abs()))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    if distance > tolerance {
        return Some(QuadProblem::NotPlanar {
            vertex,
            distance,
            tolerance,
        });
    }
    (0..4)
        .find(|&k| {
            let turn = (v[(k + 1) % 4] - v[k]).cross(v[(k + 2) % 4] - v[(k + 1) % 4]);
            turn.dot(n) < -1e-9 * diam * diam
        })
        .map(|k| QuadProblem::Concave {
            vertex: (k + 1) % 4,
        })
}

/// Planarity and convexity of a quad with non-zero area, as an error.
fn check_quad(v: &[DVec3], place: impl Fn() -> String, path: &Path) -> Result<()> {
    match quad_problem(v) {
        None => Ok(()),
        Some(QuadProblem::NotPlanar {
            vertex,
            distance,
            tolerance,
        }) => Err(Error::invalid(
            path,
            place(),
            format!(
                "a planar quad (every vertex within {PLANARITY_TOLERANCE} x diameter = {tolerance:.3e} of the mean plane)"
            ),
            format!("vertex {vertex} is {distance:.3e} off the plane"),
        )),
        Some(QuadProblem::Concave { vertex }) => Err(Error::invalid(
            path,
            place(),
            "a convex quad, counter-clockwise seen from its lit side",
            format!("a reflex corner at vertex {vertex}"),
        )),
    }
}

fn check_motion(scene: &mut Scene, path: &Path) -> Result<()> {
    for o in &mut scene.objects {
        let Some(track) = &mut o.motion else {
            continue;
        };
        if track.keys.is_empty() {
            return Err(Error::invalid(
                path,
                format!("object \"{}\", motion", o.name),
                "at least one motion key",
                "an empty track",
            ));
        }
        let mut previous: Option<(f64, f64)> = None; // (t, sign of det)
        for (i, key) in track.keys.iter_mut().enumerate() {
            let place = || format!("object \"{}\", motion key {i}", o.name);
            if !key.t.is_finite() {
                return Err(Error::invalid(
                    path,
                    place(),
                    "a finite t",
                    format!("t = {}", key.t),
                ));
            }
            if !in_range(key.translation) {
                return Err(Error::invalid(
                    path,
                    place(),
                    format!("a finite translation of magnitude <= {MAX_COORDINATE:e}"),
                    fmt_vec(key.translation),
                ));
            }
            let s = key.scale;
            if !s.is_finite() || s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
                return Err(Error::invalid(
                    path,
                    place(),
                    "finite non-zero scale components",
                    fmt_vec(s),
                ));
            }
            let q = key.rotation;
            let len = q.length();
            if !q.is_finite() || (len - 1.0).abs() > QUATERNION_TOLERANCE {
                return Err(Error::invalid(
                    path,
                    place(),
                    format!("a unit rotation quaternion (length 1 +- {QUATERNION_TOLERANCE})"),
                    format!("[{}, {}, {}, {}] of length {len}", q.x, q.y, q.z, q.w),
                ));
            }
            // Normalise, leaving quaternions already unit to round-off untouched so
            // that validating twice changes nothing.
            if (len - 1.0).abs() > 4.0 * f64::EPSILON {
                key.rotation = q / len;
            }
            let sign = (s.x * s.y * s.z).signum();
            if let Some((t0, sign0)) = previous {
                if key.t <= t0 {
                    return Err(Error::invalid(
                        path,
                        place(),
                        format!(
                            "t greater than the previous key's t = {t0} (keys strictly increasing)"
                        ),
                        format!("t = {}", key.t),
                    ));
                }
                if sign != sign0 {
                    return Err(Error::invalid(
                        path,
                        place(),
                        "a scale whose sign product (mirroring) is the same at every key",
                        format!("scale {} changes it", fmt_vec(s)),
                    ));
                }
            }
            previous = Some((key.t, sign));
        }
    }
    Ok(())
}

/// Bounding-box diagonal of every object-space vertex.
fn scene_diameter(scene: &Scene) -> f64 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for v in scene
        .objects
        .iter()
        .flat_map(|o| &o.polygons)
        .flat_map(|p| &p.vertices)
    {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    if lo.x > hi.x { 0.0 } else { lo.distance(hi) }
}

/// A polygon's vertices as bits (`-0.0` as `0.0`), rotated to start at the least:
/// equal for two polygons with the same vertices in the same cyclic order, so the
/// same facing.
fn cyclic_key(vertices: &[DVec3]) -> Vec<[u64; 3]> {
    let bits: Vec<[u64; 3]> = vertices
        .iter()
        .map(|v| v.to_array().map(|x| (x + 0.0).to_bits()))
        .collect();
    let start = (0..bits.len()).min_by_key(|&k| bits[k]).unwrap_or(0);
    let mut key = bits[start..].to_vec();
    key.extend_from_slice(&bits[..start]);
    key
}

/// The first five of `places`, comma-separated, then `, ...` if there are more.
fn first_places(places: &[String]) -> String {
    let more = if places.len() > 5 { ", ..." } else { "" };
    format!("{}{more}", places[..places.len().min(5)].join(", "))
}

fn drop_degenerate(scene: &mut Scene, src: &Sources<'_>) -> Result<()> {
    let d = scene_diameter(scene);
    let min_area = ZERO_AREA_TOLERANCE * d * d;
    let mut dropped = Vec::new();
    let mut duplicates = Vec::new();
    // Polygons met so far, by the object they move with (`None`: static) and their
    // vertices in cyclic order from the least.
    let mut seen: HashSet<(Option<usize>, Vec<[u64; 3]>)> = HashSet::new();
    for (oi, o) in scene.objects.iter_mut().enumerate() {
        let group = o.motion.is_some().then_some(oi);
        let mut kept = Vec::with_capacity(o.polygons.len());
        for (i, p) in std::mem::take(&mut o.polygons).into_iter().enumerate() {
            let a = p.area_vector();
            if a.length() <= min_area {
                dropped.push(src.name(oi, i, &o.name));
                continue;
            }
            if !seen.insert((group, cyclic_key(&p.vertices))) {
                duplicates.push(src.name(oi, i, &o.name));
                continue;
            }
            if p.vertices.len() == 4 {
                let place = || format!("object \"{}\", polygon {i}", o.name);
                check_quad(&p.vertices, place, &src.at(oi, i))?;
            }
            kept.push(p);
        }
        o.polygons = kept;
    }
    if !dropped.is_empty() {
        scene.warnings.push(format!(
            "dropped {} zero-area polygon(s) (area <= {ZERO_AREA_TOLERANCE} x scene diameter^2): {}",
            dropped.len(),
            first_places(&dropped)
        ));
    }
    if !duplicates.is_empty() {
        scene.warnings.push(format!(
            "dropped {} polygon(s) repeating an earlier one (same vertices, same order and facing, moving together): {}",
            duplicates.len(),
            first_places(&duplicates)
        ));
    }
    let empty: Vec<String> = scene
        .objects
        .iter()
        .filter(|o| o.polygons.is_empty())
        .map(|o| format!("\"{}\"", o.name))
        .collect();
    if !empty.is_empty() {
        scene.objects.retain(|o| !o.polygons.is_empty());
        scene.warnings.push(format!(
            "dropped {} object(s) with no polygon: {}",
            empty.len(),
            empty.join(", ")
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, MaterialId, MotionKey, MotionTrack, Object, Polygon};
    use glam::DQuat;

    fn quad_scene(v: [[f64; 3]; 4]) -> Scene {
        Scene {
            materials: vec![Material {
                name: "m".into(),
                rho: [0.5; 3],
                emission: [1.0; 3],
            }],
            objects: vec![Object::still(
                "o",
                vec![Polygon {
                    vertices: v.iter().map(|a| DVec3::from_array(*a)).collect(),
                    material: MaterialId(0),
                }],
            )],
            ..Scene::default()
        }
    }

    #[test]
    fn planarity_tolerance_is_relative_to_the_quad() {
        // Diameter sqrt(2) * 1000; a bend of 0.1 is 7e-5 of it: accepted.
        let ok = quad_scene([
            [0.0, 0.0, 0.0],
            [1000.0, 0.0, 0.0],
            [1000.0, 1000.0, 0.1],
            [0.0, 1000.0, 0.0],
        ]);
        assert!(validate(ok, Path::new("t.json")).is_ok());
        // A bend of 1.0 puts each vertex 0.25 off the mean plane (1.8e-4 x diameter).
        let bent = quad_scene([
            [0.0, 0.0, 0.0],
            [1000.0, 0.0, 0.0],
            [1000.0, 1000.0, 1.0],
            [0.0, 1000.0, 0.0],
        ]);
        let e = validate(bent, Path::new("t.json")).unwrap_err().to_string();
        assert!(e.contains("object \"o\", polygon 0"), "{e}");
        assert!(e.contains("planar quad"), "{e}");
        assert!(e.contains("vertex 1 is 2.500e-1 off the plane"), "{e}");
    }

    #[test]
    fn concave_quad_is_refused() {
        let s = quad_scene([
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.0, 2.0, 0.0],
        ]);
        let e = validate(s, Path::new("t.json")).unwrap_err().to_string();
        assert!(e.contains("convex quad") && e.contains("vertex 2"), "{e}");
    }

    #[test]
    fn rotations_are_normalised_and_empty_objects_dropped() {
        let mut s = quad_scene([
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]);
        let mut key = MotionKey::identity(0.0);
        key.rotation = DQuat::from_xyzw(0.0, 0.0, 0.0, 1.0005);
        s.objects[0].motion = Some(MotionTrack { keys: vec![key] });
        s.objects.push(Object::still(
            "flat",
            vec![Polygon {
                vertices: vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0],
                material: MaterialId(0),
            }],
        ));
        let s = validate(s, Path::new("t.json")).unwrap();
        let q = s.objects[0].motion.as_ref().unwrap().keys[0].rotation;
        assert_eq!(q, DQuat::IDENTITY);
        assert_eq!(s.objects.len(), 1);
        assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
        assert!(s.warnings[0].starts_with("dropped 1 zero-area polygon"));
        assert!(s.warnings[1].contains("\"flat\""));
    }
}
