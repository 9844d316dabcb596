//! The moves of an interactive session, one JSON line each (`formats/interactive.md`):
//! `{"object": NAME, "translation": [x,y,z], "rotation": [x,y,z,w]}` or a list of
//! such objects. A move gives an object's transform relative to its pose in the
//! scene file, as a motion key does (absolute, not a step): the object's world map
//! becomes `T(translation) · R(rotation)` after its scene pose. A missing field keeps
//! its identity value. Parsing checks everything and names the line on failure.

use std::collections::HashMap;
use std::path::Path;

use glam::{DAffine3, DQuat, DVec3};
use serde_json::Value;

use crate::{Error, Result};

const _: () = assert!(std::mem::size_of::<Pose>() == 56);
const _: () = assert!(std::mem::size_of::<ObjectMove>() == 64);

/// How far from 1 a rotation quaternion's length may be.
pub const UNIT_TOLERANCE: f64 = 1e-6;

/// One object's pose in a move. 56 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Translation applied after the rotation.
    pub translation: DVec3,
    /// Unit quaternion.
    pub rotation: DQuat,
}

impl Pose {
    /// The scene pose (no change).
    pub const IDENTITY: Pose = Pose {
        translation: DVec3::ZERO,
        rotation: DQuat::IDENTITY,
    };

    /// The map this pose applies after the object's scene pose.
    pub fn to_affine(&self) -> DAffine3 {
        DAffine3::from_rotation_translation(self.rotation, self.translation)
    }
}

/// One object of a move: its index in the scene and its new pose. 64 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectMove {
    /// Object index in the scene.
    pub object: u32,
    /// Its transform relative to the scene pose.
    pub pose: Pose,
}

/// Parses move line `line` (1-based `number` in `source`) against the object
/// names `names` (name → object index; `movable` says which may move).
pub fn parse_move(
    source: &Path,
    number: usize,
    line: &str,
    names: &HashMap<String, u32>,
    movable: &[bool],
) -> Result<Vec<ObjectMove>> {
    let place = format!("line {number}");
    let bad = |expected: &str, found: String| Error::invalid(source, &place, expected, found);
    let v: Value = serde_json::from_str(line).map_err(|e| {
        bad(
            "a JSON object {\"object\": NAME, ...} or a list of them",
            format!("malformed JSON ({e})"),
        )
    })?;
    let items: Vec<&Value> = match &v {
        Value::Array(a) => a.iter().collect(),
        other => vec![other],
    };
    if items.is_empty() {
        return Err(bad("at least one object", "an empty list".into()));
    }
    let mut out: Vec<ObjectMove> = Vec::with_capacity(items.len());
    for item in items {
        let Value::Object(map) = item else {
            return Err(bad("a JSON object", item.to_string()));
        };
        if let Some(k) = map
            .keys()
            .find(|k| !matches!(k.as_str(), "object" | "translation" | "rotation"))
        {
            return Err(bad(
                "only the keys object, translation, rotation",
                format!("key \"{k}\""),
            ));
        }
        let name = match map.get("object") {
            Some(Value::String(s)) => s,
            Some(other) => return Err(bad("\"object\": a name (string)", other.to_string())),
            None => return Err(bad("an \"object\" key", "none".into())),
        };
        let &object = names
            .get(name)
            .ok_or_else(|| bad("the name of an object of the scene", format!("\"{name}\"")))?;
        if !movable.get(object as usize).copied().unwrap_or(false) {
            return Err(bad(
                "an object named by --movable",
                format!("\"{name}\", which is held static"),
            ));
        }
        let translation = match map.get("translation") {
            None => DVec3::ZERO,
            Some(t) => DVec3::from_array(
                numbers::<3>(t)
                    .ok_or_else(|| bad("\"translation\": 3 finite numbers", t.to_string()))?,
            ),
        };
        let rotation = match map.get("rotation") {
            None => DQuat::IDENTITY,
            Some(r) => {
                let q = numbers::<4>(r).ok_or_else(|| {
                    bad("\"rotation\": 4 finite numbers [x,y,z,w]", r.to_string())
                })?;
                let q = DQuat::from_array(q);
                if (q.length() - 1.0).abs() > UNIT_TOLERANCE {
                    return Err(bad(
                        "\"rotation\": a unit quaternion",
                        format!("length {}", q.length()),
                    ));
                }
                q.normalize()
            }
        };
        if out.iter().any(|m| m.object == object) {
            return Err(bad("each object once", format!("\"{name}\" twice")));
        }
        out.push(ObjectMove {
            object,
            pose: Pose {
                translation,
                rotation,
            },
        });
    }
    Ok(out)
}

/// `N` finite numbers from a JSON array, or `None`.
fn numbers<const N: usize>(v: &Value) -> Option<[f64; N]> {
    let a = v.as_array().filter(|a| a.len() == N)?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x.as_f64().filter(|x| x.is_finite())?;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> HashMap<String, u32> {
        [("box".to_string(), 0), ("wall".to_string(), 1)].into()
    }

    fn parse(line: &str) -> Result<Vec<ObjectMove>> {
        parse_move(Path::new("m.jsonl"), 3, line, &names(), &[true, false])
    }

    #[test]
    fn a_move_reads_its_fields_and_identity_for_the_missing() {
        let m = parse(r#"{"object": "box", "translation": [1, 2, 3]}"#).unwrap();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].pose.translation, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(m[0].pose.rotation, DQuat::IDENTITY);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let m = parse(&format!(
            r#"[{{"object": "box", "rotation": [0, {h}, 0, {h}]}}]"#
        ))
        .unwrap();
        assert_eq!(m[0].pose.translation, DVec3::ZERO);
        assert!((m[0].pose.rotation.y - h).abs() < 1e-15);
    }

    #[test]
    fn bad_moves_name_the_line_and_what_was_wrong() {
        for (line, says) in [
            (r#"{"object": "chair"}"#, "\"chair\""),
            (r#"{"object": "box", "rotation": [0, 0, 0, 2]}"#, "length 2"),
            (r#"{"object": "box", "translation": [0, 1]}"#, "translation"),
            (
                r#"{"object": "box", "translation": [0, 1, NaN]}"#,
                "malformed",
            ),
            (
                r#"{"object": "box", "translation": [0, 1, 1e999]}"#,
                "line 3",
            ),
            (r#"{"object": "wall"}"#, "held static"),
            (r#"{"object": "box""#, "malformed"),
            (r#"{"object": "box", "scale": [1, 1, 1]}"#, "scale"),
            ("[]", "empty"),
        ] {
            let e = parse(line).unwrap_err().to_string();
            assert!(e.contains("line 3") && e.contains(says), "{line}: {e}");
        }
    }
}
