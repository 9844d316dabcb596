//! Flatland scenes: the `rhier_flatland` JSON format (`formats/flatland.md`), its
//! validation, and the posed geometry of a scene at a time `t`.
//!
//! How it works: the file is read as a `serde_json::Value` and walked by hand so that
//! every error names the file, the object / segment, what was expected and what was
//! found. Reflectance and emission may be a number (grey) or an RGB triple; a scene
//! whose every value is a number is reported with numbers (`FlatScene::grey`).
//! Motion is rigid: keyframes `(t, translation, rotation)` interpolated linearly, the
//! rotation (radians, counter-clockwise) about the object's pivot (its first vertex
//! unless `pivot` is given), applied before the translation. Times outside the keys
//! clamp to the first / last key.
//!
//! What it does not do: it does not repair input (no snapping of nearly shared
//! vertices, no splitting of crossing segments): crossing segments, zero-length
//! segments and reflectance outside `[0, 1)` are refused.

use std::path::Path;

use serde_json::Value;

use crate::Error;

/// One input segment, lit on its left side (normal `(-(b-a).y, (b-a).x) / |b-a|`).
#[derive(Clone, Debug, PartialEq)]
pub struct FlatSegment {
    /// First endpoint, object space.
    pub a: [f64; 2],
    /// Second endpoint, object space.
    pub b: [f64; 2],
    /// Reflectance per channel, each in `[0, 1)`.
    pub rho: [f64; 3],
    /// Exitance per channel, `>= 0`.
    pub emission: [f64; 3],
}

/// One rigid keyframe. 32 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatKey {
    /// Time of the key.
    pub t: f64,
    /// Translation, applied after the rotation.
    pub translation: [f64; 2],
    /// Counter-clockwise rotation in radians about the object's pivot.
    pub rotation: f64,
}

/// One object: a named set of segments moving together.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatObject {
    /// Name as written in the file.
    pub name: String,
    /// Segments in file order.
    pub segments: Vec<FlatSegment>,
    /// Rotation pivot (object space): `pivot` from the file or the first vertex.
    pub pivot: [f64; 2],
    /// Keyframes sorted by time (strictly increasing); empty = static.
    pub motion: Vec<FlatKey>,
}

/// A flatland scene as loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct FlatScene {
    /// Objects in file order; segments are numbered across objects in this order.
    pub objects: Vec<FlatObject>,
    /// True if every reflectance and emission in the file was a plain number.
    pub grey: bool,
}

/// A posed segment (world space at one time) with its derived quantities. 64 bytes
/// (60 + padding).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosedSegment {
    /// First endpoint.
    pub a: [f64; 2],
    /// Second endpoint.
    pub b: [f64; 2],
    /// Unit normal of the lit side.
    pub n: [f64; 2],
    /// Length.
    pub len: f64,
    /// Index of the owning object.
    pub object: u32,
}

const _: () = assert!(std::mem::size_of::<FlatKey>() == 32);
const _: () = assert!(std::mem::size_of::<PosedSegment>() == 64);

impl FlatScene {
    /// Number of segments over all objects.
    pub fn segment_count(&self) -> usize {
        self.objects.iter().map(|o| o.segments.len()).sum()
    }

    /// The segments in global order with their object index.
    pub fn segments(&self) -> impl Iterator<Item = (u32, &FlatSegment)> {
        self.objects
            .iter()
            .enumerate()
            .flat_map(|(i, o)| o.segments.iter().map(move |s| (i as u32, s)))
    }

    /// The time range covered by the keyframes (`(0, 0)` if nothing moves).
    pub fn time_range(&self) -> (f64, f64) {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for o in &self.objects {
            for k in &o.motion {
                lo = lo.min(k.t);
                hi = hi.max(k.t);
            }
        }
        if lo > hi { (0.0, 0.0) } else { (lo, hi) }
    }

    /// Objects whose pose differs between times `t0` and `t1`.
    pub fn moving_between(&self, t0: f64, t1: f64) -> Vec<u32> {
        (0..self.objects.len() as u32)
            .filter(|&i| {
                let o = &self.objects[i as usize];
                let k0 = o.pose_at(t0);
                let k1 = o.pose_at(t1);
                k0.translation != k1.translation || k0.rotation != k1.rotation
            })
            .collect()
    }

    /// All segments posed at time `t`, in global order.
    pub fn posed(&self, t: f64) -> Vec<PosedSegment> {
        let mut out = Vec::with_capacity(self.segment_count());
        for (oi, o) in self.objects.iter().enumerate() {
            let key = o.pose_at(t);
            let (s, c) = key.rotation.sin_cos();
            let place = |p: [f64; 2]| {
                let dx = p[0] - o.pivot[0];
                let dy = p[1] - o.pivot[1];
                [
                    o.pivot[0] + c * dx - s * dy + key.translation[0],
                    o.pivot[1] + s * dx + c * dy + key.translation[1],
                ]
            };
            for seg in &o.segments {
                let a = place(seg.a);
                let b = place(seg.b);
                out.push(PosedSegment::new(a, b, oi as u32));
            }
        }
        out
    }

    /// Checks the posed scene at `t` for crossing segments (the check `load` runs at
    /// every keyframe time), naming `path` in the error.
    pub fn check_at(&self, path: &Path, t: f64) -> Result<(), Error> {
        let posed = self.posed(t);
        let names = self.segment_names();
        if let Some((i, j)) = first_crossing(&posed) {
            return Err(Error::invalid(
                path,
                format!("{} and {} at t = {t}", names[i], names[j]),
                "segments that do not cross (they may share endpoints)",
                "crossing segments",
            ));
        }
        Ok(())
    }

    /// `object "name", segment k` for every global segment index.
    pub fn segment_names(&self) -> Vec<String> {
        let mut out = Vec::new();
        for o in &self.objects {
            for k in 0..o.segments.len() {
                out.push(format!("object \"{}\", segment {k}", o.name));
            }
        }
        out
    }
}

impl PosedSegment {
    /// A posed segment from its endpoints (`a != b`).
    pub fn new(a: [f64; 2], b: [f64; 2], object: u32) -> Self {
        let dx = b[0] - a[0];
        let dy = b[1] - a[1];
        let len = dx.hypot(dy);
        PosedSegment {
            a,
            b,
            n: [-dy / len, dx / len],
            len,
            object,
        }
    }

    /// The point at parameter `t` in `[0, 1]`.
    pub fn at(&self, t: f64) -> [f64; 2] {
        [
            self.a[0] + t * (self.b[0] - self.a[0]),
            self.a[1] + t * (self.b[1] - self.a[1]),
        ]
    }
}

impl FlatObject {
    /// The interpolated key at time `t` (identity if the object does not move).
    pub fn pose_at(&self, t: f64) -> FlatKey {
        let identity = FlatKey {
            t,
            translation: [0.0, 0.0],
            rotation: 0.0,
        };
        let (Some(first), Some(last)) = (self.motion.first(), self.motion.last()) else {
            return identity;
        };
        if t <= first.t {
            return *first;
        }
        if t >= last.t {
            return *last;
        }
        let k = self.motion.partition_point(|k| k.t <= t);
        let (k0, k1) = (self.motion[k - 1], self.motion[k]);
        let s = (t - k0.t) / (k1.t - k0.t);
        FlatKey {
            t,
            translation: [
                k0.translation[0] + s * (k1.translation[0] - k0.translation[0]),
                k0.translation[1] + s * (k1.translation[1] - k0.translation[1]),
            ],
            rotation: k0.rotation + s * (k1.rotation - k0.rotation),
        }
    }
}

/// Orientation of `c` against the line `a -> b` (twice the signed triangle area).
pub fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// The first pair of posed segments that cross (interiors meet, or collinear overlap);
/// shared endpoints and an endpoint touching another segment are allowed.
pub fn first_crossing(segs: &[PosedSegment]) -> Option<(usize, usize)> {
    for i in 0..segs.len() {
        for j in i + 1..segs.len() {
            if segments_cross(&segs[i], &segs[j]) {
                return Some((i, j));
            }
        }
    }
    None
}

fn segments_cross(s: &PosedSegment, u: &PosedSegment) -> bool {
    let d1 = orient(s.a, s.b, u.a);
    let d2 = orient(s.a, s.b, u.b);
    let d3 = orient(u.a, u.b, s.a);
    let d4 = orient(u.a, u.b, s.b);
    if d1 == 0.0 && d2 == 0.0 {
        // Collinear: overlap of positive length?
        let dir = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
        let proj = |p: [f64; 2]| (p[0] - s.a[0]) * dir[0] + (p[1] - s.a[1]) * dir[1];
        let l2 = dir[0] * dir[0] + dir[1] * dir[1];
        let (p0, p1) = (proj(u.a), proj(u.b));
        let (lo, hi) = (p0.min(p1), p0.max(p1));
        return lo.max(0.0) < hi.min(l2);
    }
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// Loads and validates a flatland scene file.
pub fn load(path: &Path) -> Result<FlatScene, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(path, &text)
}

/// Parses and validates flatland scene text; `path` only names the source in errors.
pub fn parse(path: &Path, text: &str) -> Result<FlatScene, Error> {
    let root: Value = serde_json::from_str(text).map_err(|e| {
        Error::invalid(
            path,
            format!("line {}, column {}", e.line(), e.column()),
            "JSON",
            e.to_string(),
        )
    })?;
    let bad = |place: &str, expected: &str, found: String| {
        Error::invalid(path, place.to_string(), expected.to_string(), found)
    };
    let Some(top) = root.as_object() else {
        return Err(bad("top level", "a JSON object", kind(&root)));
    };
    match top.get("rhier_flatland") {
        Some(v) if v.as_u64() == Some(1) => {}
        Some(v) => return Err(bad("\"rhier_flatland\"", "version 1", v.to_string())),
        None => {
            return Err(bad(
                "top level",
                "the key \"rhier_flatland\": 1",
                "no such key".into(),
            ));
        }
    }
    let Some(objs) = top.get("objects").and_then(Value::as_array) else {
        return Err(bad(
            "\"objects\"",
            "an array of objects",
            top.get("objects").map_or("nothing".into(), kind),
        ));
    };
    if objs.is_empty() {
        return Err(bad("\"objects\"", "at least one object", "[]".into()));
    }
    let mut grey = true;
    let mut objects = Vec::with_capacity(objs.len());
    for (oi, ov) in objs.iter().enumerate() {
        let Some(o) = ov.as_object() else {
            return Err(bad(&format!("object {oi}"), "a JSON object", kind(ov)));
        };
        let name = match o.get("name") {
            None => format!("#{oi}"),
            Some(Value::String(s)) => s.clone(),
            Some(v) => return Err(bad(&format!("object {oi}, \"name\""), "a string", kind(v))),
        };
        let oplace = format!("object \"{name}\"");
        let Some(segs) = o.get("segments").and_then(Value::as_array) else {
            return Err(bad(
                &format!("{oplace}, \"segments\""),
                "an array of segments",
                o.get("segments").map_or("nothing".into(), kind),
            ));
        };
        if segs.is_empty() {
            return Err(bad(
                &format!("{oplace}, \"segments\""),
                "at least one segment",
                "[]".into(),
            ));
        }
        let mut segments = Vec::with_capacity(segs.len());
        for (si, sv) in segs.iter().enumerate() {
            let place = format!("{oplace}, segment {si}");
            let Some(s) = sv.as_object() else {
                return Err(bad(&place, "a JSON object", kind(sv)));
            };
            let a = point(path, &place, "a", s.get("a"))?;
            let b = point(path, &place, "b", s.get("b"))?;
            if a == b {
                return Err(bad(
                    &place,
                    "a segment of non-zero length",
                    format!("a = b = [{}, {}]", a[0], a[1]),
                ));
            }
            let (rho, g1) = colour(path, &place, "reflectance", s.get("reflectance"), Some(0.0))?;
            let (emission, g2) = colour(path, &place, "emission", s.get("emission"), Some(0.0))?;
            grey &= g1 && g2;
            if let Some(r) = rho.iter().find(|r| !(0.0..1.0).contains(*r)) {
                return Err(bad(
                    &format!("{place}, \"reflectance\""),
                    "values in [0, 1)",
                    r.to_string(),
                ));
            }
            if let Some(e) = emission.iter().find(|e| **e < 0.0) {
                return Err(bad(
                    &format!("{place}, \"emission\""),
                    "values >= 0",
                    e.to_string(),
                ));
            }
            segments.push(FlatSegment {
                a,
                b,
                rho,
                emission,
            });
        }
        let pivot = match o.get("pivot") {
            None => segments[0].a,
            Some(v) => point(path, &oplace, "pivot", Some(v))?,
        };
        let mut motion = Vec::new();
        if let Some(mv) = o.get("motion") {
            let Some(keys) = mv.as_array() else {
                return Err(bad(
                    &format!("{oplace}, \"motion\""),
                    "an array of keys",
                    kind(mv),
                ));
            };
            for (ki, kv) in keys.iter().enumerate() {
                let place = format!("{oplace}, motion key {ki}");
                let Some(k) = kv.as_object() else {
                    return Err(bad(&place, "a JSON object", kind(kv)));
                };
                let t = number(path, &place, "t", k.get("t"))?;
                let translation = match k.get("translation") {
                    None => [0.0, 0.0],
                    v => point(path, &place, "translation", v)?,
                };
                let rotation = match k.get("rotation") {
                    None => 0.0,
                    v => number(path, &place, "rotation", v)?,
                };
                if let Some(prev) = motion.last().map(|k: &FlatKey| k.t)
                    && t <= prev
                {
                    return Err(bad(
                        &format!("{place}, \"t\""),
                        &format!("a time greater than the previous key's {prev}"),
                        t.to_string(),
                    ));
                }
                motion.push(FlatKey {
                    t,
                    translation,
                    rotation,
                });
            }
        }
        objects.push(FlatObject {
            name,
            segments,
            pivot,
            motion,
        });
    }
    let scene = FlatScene { objects, grey };
    // Crossing segments are checked at every keyframe time (and at 0 for static scenes).
    let mut times: Vec<f64> = scene
        .objects
        .iter()
        .flat_map(|o| o.motion.iter().map(|k| k.t))
        .collect();
    if times.is_empty() {
        times.push(0.0);
    }
    times.sort_by(f64::total_cmp);
    times.dedup();
    for t in times {
        scene.check_at(path, t)?;
    }
    Ok(scene)
}

fn kind(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("the boolean {b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) => format!("the string {s:?}"),
        Value::Array(a) => format!("an array of {} items", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

fn number(path: &Path, place: &str, key: &str, v: Option<&Value>) -> Result<f64, Error> {
    match v.and_then(Value::as_f64) {
        Some(x) if x.is_finite() => Ok(x),
        _ => Err(Error::invalid(
            path,
            format!("{place}, \"{key}\""),
            "a finite number",
            v.map_or("nothing".into(), kind),
        )),
    }
}

fn point(path: &Path, place: &str, key: &str, v: Option<&Value>) -> Result<[f64; 2], Error> {
    let err = || {
        Error::invalid(
            path,
            format!("{place}, \"{key}\""),
            "a point [x, y] of finite numbers",
            v.map_or("nothing".into(), kind),
        )
    };
    let arr = v.and_then(Value::as_array).ok_or_else(err)?;
    if arr.len() != 2 {
        return Err(err());
    }
    let x = arr[0].as_f64().filter(|x| x.is_finite()).ok_or_else(err)?;
    let y = arr[1].as_f64().filter(|y| y.is_finite()).ok_or_else(err)?;
    Ok([x, y])
}

/// A number or an RGB triple; returns the triple and whether it was a number.
fn colour(
    path: &Path,
    place: &str,
    key: &str,
    v: Option<&Value>,
    default: Option<f64>,
) -> Result<([f64; 3], bool), Error> {
    let err = || {
        Error::invalid(
            path,
            format!("{place}, \"{key}\""),
            "a finite number or an RGB triple [r, g, b]",
            v.map_or("nothing".into(), kind),
        )
    };
    match v {
        None => default.map(|d| ([d; 3], true)).ok_or_else(err),
        Some(Value::Number(n)) => {
            let x = n.as_f64().filter(|x| x.is_finite()).ok_or_else(err)?;
            Ok(([x; 3], true))
        }
        Some(Value::Array(a)) if a.len() == 3 => {
            let mut c = [0.0; 3];
            for (ci, x) in c.iter_mut().zip(a) {
                *ci = x.as_f64().filter(|x| x.is_finite()).ok_or_else(err)?;
            }
            Ok((c, false))
        }
        Some(_) => Err(err()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_interpolates_and_rotates_about_pivot() {
        let text = r#"{"rhier_flatland": 1, "objects": [{"name": "box",
            "segments": [{"a": [1, 0], "b": [2, 0], "reflectance": 0.5}],
            "motion": [{"t": 0, "translation": [0, 0], "rotation": 0},
                       {"t": 2, "translation": [2, 0], "rotation": 3.141592653589793}]}]}"#;
        let s = parse(Path::new("mem"), text).unwrap();
        let p = s.posed(1.0);
        // Half way: rotation pi/2 about (1, 0), then translation (1, 0).
        assert!((p[0].a[0] - 2.0).abs() < 1e-12 && p[0].a[1].abs() < 1e-12);
        assert!((p[0].b[0] - 2.0).abs() < 1e-12 && (p[0].b[1] - 1.0).abs() < 1e-12);
        // Clamped after the last key.
        let q = s.posed(5.0);
        assert!((q[0].b[0] - 2.0).abs() < 1e-12 && q[0].b[1].abs() < 1e-12);
        assert_eq!(s.moving_between(0.0, 1.0), vec![0]);
        assert!(s.moving_between(3.0, 4.0).is_empty());
    }
}
