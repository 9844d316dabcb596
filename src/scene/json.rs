//! The native JSON scene format (`formats/scene.md`): reader and writer.
//!
//! Reading is two steps: serde parses the text into the `*Json` records below (wrong
//! types and malformed JSON are reported with serde's line and column; unknown keys are
//! ignored so that newer files still load), then [`to_scene`] resolves material names
//! to [`MaterialId`]s and fills the defaults. [`super::validate`] runs afterwards.
//!
//! Writing ([`to_json_string`]) emits the same format with numbers in Rust's shortest
//! round-trip form. Reading it back gives the same structure with every number within
//! 1 ulp: serde_json's default number parser is not correctly rounded for 17-digit
//! mantissas (its `float_roundtrip` feature is; with it the round trip is exact).
//! Materials are kept in a JSON object, so they read back sorted by name.
//! It does not read any other format.

use std::collections::BTreeMap;
use std::path::Path;

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::model::{
    Camera, Material, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, TimeDomain,
};
use crate::{Error, Result};

/// The version this reader understands (`"rhier_scene": 1`).
pub const FORMAT_VERSION: u64 = 1;

#[derive(Deserialize, Serialize)]
struct SceneJson {
    rhier_scene: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    time: Option<TimeJson>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    camera: Option<CameraJson>,
    #[serde(default)]
    materials: BTreeMap<String, MaterialJson>,
    #[serde(default)]
    objects: Vec<ObjectJson>,
}

#[derive(Deserialize, Serialize)]
struct TimeJson {
    start: f64,
    end: f64,
}

#[derive(Deserialize, Serialize)]
struct CameraJson {
    eye: [f64; 3],
    target: [f64; 3],
    #[serde(default = "default_up")]
    up: [f64; 3],
    fov_y_degrees: f64,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

#[derive(Deserialize, Serialize)]
struct MaterialJson {
    reflectance: [f64; 3],
    #[serde(default, skip_serializing_if = "is_zero3")]
    emission: [f64; 3],
}

fn is_zero3(v: &[f64; 3]) -> bool {
    *v == [0.0; 3]
}

#[derive(Deserialize, Serialize)]
struct ObjectJson {
    #[serde(default)]
    name: Option<String>,
    polygons: Vec<PolygonJson>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    motion: Option<Vec<KeyJson>>,
}

#[derive(Deserialize, Serialize)]
struct PolygonJson {
    vertices: Vec<[f64; 3]>,
    material: String,
}

#[derive(Deserialize, Serialize)]
struct KeyJson {
    t: f64,
    #[serde(default)]
    translation: Option<[f64; 3]>,
    #[serde(default)]
    rotation: Option<[f64; 4]>,
    #[serde(default)]
    scale: Option<[f64; 3]>,
}

/// Parses native JSON `text` (read from `path`, used in messages) into an unvalidated
/// [`Scene`].
pub(crate) fn parse(text: &str, path: &Path) -> Result<Scene> {
    let file: SceneJson = serde_json::from_str(text).map_err(|e| {
        Error::invalid(
            path,
            format!("line {} column {}", e.line(), e.column()),
            "a native rhier scene (formats/scene.md)",
            e.to_string(),
        )
    })?;
    to_scene(file, path)
}

fn to_scene(file: SceneJson, path: &Path) -> Result<Scene> {
    match file.rhier_scene {
        Some(FORMAT_VERSION) => {}
        Some(v) => {
            return Err(Error::invalid(
                path,
                "\"rhier_scene\"",
                format!("format version {FORMAT_VERSION}"),
                format!("version {v}"),
            ));
        }
        None => {
            return Err(Error::invalid(
                path,
                "top level",
                format!("the key \"rhier_scene\": {FORMAT_VERSION}"),
                "no \"rhier_scene\" key",
            ));
        }
    }
    let mut ids = BTreeMap::new();
    let mut materials = Vec::with_capacity(file.materials.len());
    for (i, (name, m)) in file.materials.into_iter().enumerate() {
        ids.insert(name.clone(), MaterialId(i as u32));
        materials.push(Material {
            name,
            rho: m.reflectance,
            emission: m.emission,
        });
    }
    let known = || {
        let names: Vec<&str> = ids.keys().map(String::as_str).collect();
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    };
    let mut objects = Vec::with_capacity(file.objects.len());
    let (mut t_min, mut t_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for (oi, o) in file.objects.into_iter().enumerate() {
        let name = o.name.unwrap_or_else(|| format!("object {oi}"));
        let mut polygons = Vec::with_capacity(o.polygons.len());
        for (pi, p) in o.polygons.into_iter().enumerate() {
            let Some(&material) = ids.get(&p.material) else {
                return Err(Error::invalid(
                    path,
                    format!("object \"{name}\", polygon {pi}"),
                    format!("a material defined in \"materials\" (defined: {})", known()),
                    format!("material \"{}\"", p.material),
                ));
            };
            polygons.push(Polygon {
                vertices: p.vertices.iter().map(|v| DVec3::from_array(*v)).collect(),
                material,
            });
        }
        let motion = o.motion.map(|keys| MotionTrack {
            keys: keys
                .iter()
                .map(|k| {
                    t_min = t_min.min(k.t);
                    t_max = t_max.max(k.t);
                    MotionKey {
                        t: k.t,
                        translation: DVec3::from_array(k.translation.unwrap_or([0.0; 3])),
                        rotation: DQuat::from_array(k.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0])),
                        scale: DVec3::from_array(k.scale.unwrap_or([1.0; 3])),
                    }
                })
                .collect(),
        });
        objects.push(Object {
            name,
            polygons,
            motion,
        });
    }
    let time = match file.time {
        Some(t) => TimeDomain {
            start: t.start,
            end: t.end,
        },
        None if t_min <= t_max => TimeDomain {
            start: t_min,
            end: t_max,
        },
        None => TimeDomain::default(),
    };
    let camera = file.camera.map(|c| Camera {
        eye: DVec3::from_array(c.eye),
        target: DVec3::from_array(c.target),
        up: DVec3::from_array(c.up),
        fov_y: c.fov_y_degrees.to_radians(),
    });
    Ok(Scene {
        time,
        materials,
        objects,
        camera,
        warnings: Vec::new(),
    })
}

/// The native JSON text of `scene` (format version 1), laid out one polygon and one
/// motion key per line. Material names must be unique (they are JSON keys).
pub fn to_json_string(scene: &Scene) -> String {
    let file = SceneJson {
        rhier_scene: Some(FORMAT_VERSION),
        time: Some(TimeJson {
            start: scene.time.start,
            end: scene.time.end,
        }),
        camera: scene.camera.map(|c| CameraJson {
            eye: c.eye.to_array(),
            target: c.target.to_array(),
            up: c.up.to_array(),
            fov_y_degrees: c.fov_y.to_degrees(),
        }),
        materials: scene
            .materials
            .iter()
            .map(|m| {
                (
                    m.name.clone(),
                    MaterialJson {
                        reflectance: m.rho,
                        emission: m.emission,
                    },
                )
            })
            .collect(),
        objects: scene
            .objects
            .iter()
            .map(|o| ObjectJson {
                name: Some(o.name.clone()),
                polygons: o
                    .polygons
                    .iter()
                    .map(|p| PolygonJson {
                        vertices: p.vertices.iter().map(|v| v.to_array()).collect(),
                        material: scene
                            .materials
                            .get(p.material.0 as usize)
                            .map_or_else(String::new, |m| m.name.clone()),
                    })
                    .collect(),
                motion: o.motion.as_ref().map(|m| {
                    m.keys
                        .iter()
                        .map(|k| KeyJson {
                            t: k.t,
                            translation: Some(k.translation.to_array()),
                            rotation: Some(k.rotation.to_array()),
                            scale: Some(k.scale.to_array()),
                        })
                        .collect()
                }),
            })
            .collect(),
    };
    // Serialising plain records of numbers and strings to a Value cannot fail; an
    // empty Value would only appear if serde_json changed that.
    let value = serde_json::to_value(&file).unwrap_or(Value::Null);
    let mut out = String::new();
    write_value(&value, 0, &mut out);
    out.push('\n');
    out
}

/// Key order in written files (serde_json's map is sorted alphabetically otherwise).
const KEY_ORDER: [&str; 22] = [
    "rhier_scene",
    "time",
    "start",
    "end",
    "camera",
    "eye",
    "target",
    "up",
    "fov_y_degrees",
    "materials",
    "reflectance",
    "emission",
    "objects",
    "name",
    "polygons",
    "vertices",
    "material",
    "motion",
    "t",
    "translation",
    "rotation",
    "scale",
];

fn ordered(map: &serde_json::Map<String, Value>) -> Vec<(&String, &Value)> {
    let mut items: Vec<_> = map.iter().collect();
    items.sort_by_key(|(k, _)| {
        KEY_ORDER
            .iter()
            .position(|o| o == k)
            .unwrap_or(KEY_ORDER.len())
    });
    items
}

/// Pretty printer that keeps "leaf" arrays (numbers, arrays of numbers) and objects
/// holding only such values on one line.
fn write_value(v: &Value, indent: usize, out: &mut String) {
    let flat = is_flat(v);
    let (open, sep, close) = if flat {
        (String::new(), ", ".to_string(), String::new())
    } else {
        (
            format!("\n{}", "  ".repeat(indent + 1)),
            format!(",\n{}", "  ".repeat(indent + 1)),
            format!("\n{}", "  ".repeat(indent)),
        )
    };
    match v {
        Value::Array(items) if !items.is_empty() => {
            out.push('[');
            out.push_str(&open);
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push_str(if flat && !item.is_array() { "," } else { &sep });
                }
                write_value(item, indent + 1, out);
            }
            out.push_str(&close);
            out.push(']');
        }
        Value::Object(map) if !map.is_empty() => {
            out.push('{');
            out.push_str(&open);
            for (i, (k, item)) in ordered(map).into_iter().enumerate() {
                if i > 0 {
                    out.push_str(&sep);
                }
                out.push_str(&Value::String(k.clone()).to_string());
                out.push_str(": ");
                write_value(item, indent + 1, out);
            }
            out.push_str(&close);
            out.push('}');
        }
        other => out.push_str(&other.to_string()),
    }
}

/// True for values printed on one line: scalars, arrays of scalars or of arrays of
/// scalars, and objects whose values are all of those kinds (a polygon, a key).
fn is_flat(v: &Value) -> bool {
    fn scalar_array(v: &Value) -> bool {
        match v {
            Value::Array(a) => a.iter().all(|x| !x.is_array() && !x.is_object()),
            _ => !v.is_object(),
        }
    }
    match v {
        Value::Array(a) => a.iter().all(scalar_array),
        Value::Object(m) => m.values().all(|x| match x {
            Value::Array(a) => a.iter().all(scalar_array),
            Value::Object(_) => false,
            _ => true,
        }),
        _ => true,
    }
}
