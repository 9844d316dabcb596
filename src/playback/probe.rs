//! Probes: radiosity at points, the contract of `rhier probe` and `solve --probe`
//! (DESIGN.md, "Contracts").
//!
//! For each point `p` with normal `n`: among the patches at time `t` that have leaves
//! and whose normal faces along `n` (`normal · n > 0`), take the one nearest `p` (BVH,
//! [`super::nearest`]), the closest point `q` on it, its parameters `(u, v)`
//! ([`patch_params`]: barycentric for triangles, inverse bilinear for quads), the leaf
//! of that patch whose domain contains `(u, v)`, and return that leaf's interpolant
//! [`crate::solution::Leaf::eval`] at `(u, v)` (not an element average). It does not
//! interpolate across patches: the value is the one leaf's.

use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;
use serde_json::Value;

use super::SolutionView;
use super::frame::{Frame, WorldPatch};
use super::nearest::NearestIndex;
use crate::error::{Error, Result};
use crate::solution::leaf_at;

/// One probe: a point and the normal the surface must face along.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbePoint {
    /// Position.
    pub p: DVec3,
    /// Direction the probed surface's normal must face along (need not be unit).
    pub n: DVec3,
}

fn vec3_field(
    path: &Path,
    i: usize,
    obj: &serde_json::Map<String, Value>,
    key: &str,
) -> Result<DVec3> {
    let bad = |found: String| {
        Error::invalid(
            path,
            format!("point {i}, \"{key}\""),
            "an array of 3 finite numbers",
            found,
        )
    };
    let v = obj.get(key).ok_or_else(|| bad("no such field".into()))?;
    let a = v.as_array().ok_or_else(|| bad(v.to_string()))?;
    if a.len() != 3 {
        return Err(bad(v.to_string()));
    }
    let mut out = [0.0; 3];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| bad(v.to_string()))?;
    }
    Ok(DVec3::from_array(out))
}

/// Reads a probe file: a JSON array of `{"p":[x,y,z],"n":[x,y,z]}` (`n` non-zero).
pub fn read_probe_points(path: &Path) -> Result<Vec<ProbePoint>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_probe_points(path, &text)
}

/// Parses the text of a probe file (`path` names it in errors).
pub fn parse_probe_points(path: &Path, text: &str) -> Result<Vec<ProbePoint>> {
    let value: Value = serde_json::from_str(text).map_err(|e| {
        Error::invalid(
            path,
            format!("line {}, column {}", e.line(), e.column()),
            "JSON",
            e.to_string(),
        )
    })?;
    let arr = value.as_array().ok_or_else(|| {
        Error::invalid(
            path,
            "top level",
            "a JSON array of {\"p\":[x,y,z],\"n\":[x,y,z]}",
            kind(&value),
        )
    })?;
    let mut points = Vec::with_capacity(arr.len());
    for (i, v) in arr.iter().enumerate() {
        let obj = v.as_object().ok_or_else(|| {
            Error::invalid(
                path,
                format!("point {i}"),
                "an object {\"p\":[x,y,z],\"n\":[x,y,z]}",
                kind(v),
            )
        })?;
        let p = vec3_field(path, i, obj, "p")?;
        let n = vec3_field(path, i, obj, "n")?;
        if n == DVec3::ZERO {
            return Err(Error::invalid(
                path,
                format!("point {i}, \"n\""),
                "a non-zero normal",
                "[0, 0, 0]",
            ));
        }
        points.push(ProbePoint { p, n });
    }
    Ok(points)
}

fn kind(v: &Value) -> String {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
    .to_string()
}

/// The JSON text of probe results: an array of `{"B":[r,g,b]}`, same order as the
/// points.
pub fn probe_results_json(values: &[[f64; 3]]) -> String {
    let arr: Vec<Value> = values
        .iter()
        .map(|b| serde_json::json!({ "B": b }))
        .collect();
    let mut s = serde_json::to_string_pretty(&Value::Array(arr)).unwrap_or_default();
    s.push('\n');
    s
}

/// Writes probe results to `path` ([`probe_results_json`]).
pub fn write_probe_results(path: &Path, values: &[[f64; 3]]) -> Result<()> {
    std::fs::write(path, probe_results_json(values)).map_err(|e| Error::io(path, e))
}

/// Parameters `(u, v)` of world point `q` on `patch` (`q` assumed on or near its
/// plane): barycentric for a triangle, inverse bilinear for a quad (closed form in the
/// patch's plane, polished by Newton steps), clamped to the patch's domain.
pub fn patch_params(patch: &WorldPatch, q: DVec3) -> (f64, f64) {
    let v = &patch.v;
    if patch.corners == 3 {
        let (e1, e2, h) = (v[1] - v[0], v[2] - v[0], q - v[0]);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (h1, h2) = (h.dot(e1), h.dot(e2));
        let det = d11 * d22 - d12 * d12;
        if det.abs() < 1e-300 {
            return (0.0, 0.0);
        }
        let u = ((d22 * h1 - d12 * h2) / det).max(0.0);
        let w = ((d11 * h2 - d12 * h1) / det).max(0.0);
        let s = (u + w).max(1.0);
        return (u / s, w / s);
    }
    // P(u,v) = a + u e + v f + u v g with a..d = v0..v3.
    let (a, e, f, g) = (v[0], v[1] - v[0], v[3] - v[0], v[0] - v[1] + v[2] - v[3]);
    let n = e.cross(f) + 0.5 * (e.cross(g) + g.cross(f));
    let n = if n.length_squared() > 0.0 {
        n.normalize()
    } else {
        patch.normal
    };
    let h = q - a;
    // 2D cross products in the plane: cross2(x, y) = (x × y) · n.
    let c2 = |x: DVec3, y: DVec3| x.cross(y).dot(n);
    let k2 = c2(g, f);
    let k1 = c2(e, f) + c2(h, g);
    let k0 = c2(h, e);
    let u_of = |w: f64| {
        let den = e + g * w;
        let dd = den.length_squared();
        if dd > 0.0 {
            (h - f * w).dot(den) / dd
        } else {
            0.5
        }
    };
    let scale = k1.abs().max(k0.abs()).max(1e-300);
    let (mut u, mut w) = if k2.abs() <= 1e-12 * scale {
        let w = if k1.abs() > 0.0 { -k0 / k1 } else { 0.5 };
        (u_of(w), w)
    } else {
        let disc = (k1 * k1 - 4.0 * k0 * k2).max(0.0).sqrt();
        let w1 = (-k1 - disc) / (2.0 * k2);
        let w2 = (-k1 + disc) / (2.0 * k2);
        let (u1, u2) = (u_of(w1), u_of(w2));
        let inside =
            |u: f64, w: f64| (-1e-9..=1.0 + 1e-9).contains(&u) && (-1e-9..=1.0 + 1e-9).contains(&w);
        if inside(u1, w1) || !inside(u2, w2) {
            (u1, w1)
        } else {
            (u2, w2)
        }
    };
    // Newton polish on the least-squares system J^T (P - q) = 0.
    for _ in 0..3 {
        let r = a + e * u + f * w + g * (u * w) - q;
        let (pu, pv) = (e + g * w, f + g * u);
        let (j11, j12, j22) = (pu.dot(pu), pu.dot(pv), pv.dot(pv));
        let (b1, b2) = (pu.dot(r), pv.dot(r));
        let det = j11 * j22 - j12 * j12;
        if det.abs() < 1e-300 {
            break;
        }
        u -= (j22 * b1 - j12 * b2) / det;
        w -= (j11 * b2 - j12 * b1) / det;
    }
    (u.clamp(0.0, 1.0), w.clamp(0.0, 1.0))
}

/// What a probe found: the patch, the leaf (an index into [`Frame::leaves`]), the
/// parameters `(u, v)` of the nearest point on the patch, and the radiosity there.
/// 56 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeHit {
    /// Patch probed (index in the view's patches).
    pub patch: u32,
    /// Leaf evaluated, an index into the frame's leaves (`u32::MAX`: the patch's
    /// leaves cover no point, radiosity 0; cannot happen with a valid file).
    pub leaf: u32,
    /// Parameters of the probed point on the patch.
    pub uv: [f64; 2],
    /// Radiosity there ([`crate::solution::Leaf::eval`]).
    pub b: [f64; 3],
}

/// Probes a frame already built.
pub fn probe_frame(name: &Path, frame: &Frame, points: &[ProbePoint]) -> Result<Vec<[f64; 3]>> {
    Ok(probe_frame_hits(name, frame, points)?
        .into_iter()
        .map(|h| h.b)
        .collect())
}

/// Probes a frame already built, saying which patch and leaf answered each point
/// (the one code path of [`probe_frame`] and `rhier view`'s clicks).
pub fn probe_frame_hits(
    name: &Path,
    frame: &Frame,
    points: &[ProbePoint],
) -> Result<Vec<ProbeHit>> {
    let with_leaves: Vec<u32> = (0..frame.patches.len() as u32)
        .filter(|&p| {
            !frame.patch_leaves(p as usize).is_empty()
                && frame.patches[p as usize].normal != DVec3::ZERO
        })
        .collect();
    let index = NearestIndex::build(&frame.patches, with_leaves);
    // Points are independent: evaluate them in parallel, results in input order.
    points
        .par_iter()
        .enumerate()
        .map(|(i, pt)| {
            let facing = |k: u32| frame.patches[k as usize].normal.dot(pt.n) > 0.0;
            let Some((patch, q, _)) = index.nearest(&frame.patches, pt.p, facing) else {
                return Err(Error::invalid(
                    name,
                    format!("probe point {i} at time {}", frame.t),
                    format!(
                        "a surface with leaves whose normal faces along n = {:?}",
                        pt.n.to_array()
                    ),
                    "none",
                ));
            };
            let (u, v) = patch_params(&frame.patches[patch as usize], q);
            let leaves = frame.patch_leaves(patch as usize);
            let first = frame.first_leaf[patch as usize];
            // `with_leaves` guarantees at least one leaf.
            let (leaf, b) = leaf_at(leaves, u, v).map_or((u32::MAX, [0.0; 3]), |l| {
                let k = leaves.iter().position(|x| std::ptr::eq(x, l)).unwrap_or(0);
                (first + k as u32, l.eval(u, v))
            });
            Ok(ProbeHit {
                patch,
                leaf,
                uv: [u, v],
                b,
            })
        })
        .collect()
}

/// Radiosity at `points` at time `t` of any solution view: see the module header.
pub fn probe(view: &impl SolutionView, points: &[ProbePoint], t: f64) -> Result<Vec<[f64; 3]>> {
    let frame = Frame::build(view, t)?;
    probe_frame(view.name(), &frame, points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_bilinear_recovers_parameters() {
        // A planar, non-parallelogram quad tilted in space.
        let rot = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
        let v = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(3.0, 0.2, 0.0),
            DVec3::new(2.5, 2.0, 0.0),
            DVec3::new(-0.4, 1.5, 0.0),
        ]
        .map(|x| rot * x + DVec3::new(5.0, -1.0, 2.0));
        let patch = WorldPatch {
            corners: 4,
            material: 0,
            v,
            normal: rot * DVec3::Z,
        };
        for &(u, w) in &[(0.0, 0.0), (1.0, 1.0), (0.3, 0.8), (0.95, 0.05), (0.5, 0.5)] {
            let (pu, pw) = patch_params(&patch, patch.point(u, w));
            assert!(
                (pu - u).abs() < 1e-10 && (pw - w).abs() < 1e-10,
                "{u} {w} -> {pu} {pw}"
            );
        }
        let tri = WorldPatch {
            corners: 3,
            ..patch
        };
        let (pu, pw) = patch_params(&tri, tri.point(0.2, 0.3));
        assert!((pu - 0.2).abs() < 1e-12 && (pw - 0.3).abs() < 1e-12);
    }

    #[test]
    fn probe_file_errors_name_the_point() {
        let p = Path::new("pts.json");
        let err = parse_probe_points(p, r#"[{"p":[0,0,0],"n":[0,0,1]},{"p":[0,0],"n":[0,0,1]}]"#)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("pts.json") && err.contains("point 1") && err.contains("\"p\""),
            "{err}"
        );
        let ok = parse_probe_points(p, r#"[{"p":[1,2,3],"n":[0,0,1]}]"#).map_err(|e| e.to_string());
        assert_eq!(
            ok,
            Ok(vec![ProbePoint {
                p: DVec3::new(1.0, 2.0, 3.0),
                n: DVec3::Z
            }])
        );
    }
}
