//! Which side of a polygon lights and is lit: two-sided surfaces and emitters that
//! face something too close.
//!
//! Polygons are one-sided: the side their vertices turn counter-clockwise around
//! reflects and emits, the other absorbs. [`two_sided`] gives every polygon a reversed
//! twin, so that a scene from a format with no side flag (OBJ, native) reflects and
//! emits both ways (`--two-sided`; glTF's `doubleSided` does the same per material at
//! load). [`emitters_facing_close`] warns about an emitter whose front looks into a
//! surface nearer than [`EMITTER_CLEARANCE`] × its size, the usual sign of a lamp
//! modelled facing into its own fixture: one ray from each emitter polygon's centroid
//! along its normal, tested against every polygon (the largest
//! [`MAX_EMITTERS_CHECKED`] emitter polygons only, to keep the test linear in the
//! scene).

use glam::DVec3;

use super::model::{Polygon, Scene};

/// An emitter facing a surface nearer than this fraction of its diameter gets a
/// warning.
pub const EMITTER_CLEARANCE: f64 = 0.25;

/// Emitter polygons tested by [`emitters_facing_close`], largest first.
pub const MAX_EMITTERS_CHECKED: usize = 256;

/// Gives every polygon a twin with its vertices reversed (facing the other way), so
/// that every surface reflects and emits on both sides. Returns the twins added.
pub fn two_sided(scene: &mut Scene) -> usize {
    let mut added = 0;
    for o in &mut scene.objects {
        let twins: Vec<Polygon> = o
            .polygons
            .iter()
            .map(|p| Polygon {
                vertices: p.vertices.iter().rev().copied().collect(),
                material: p.material,
            })
            .collect();
        added += twins.len();
        o.polygons.extend(twins);
    }
    added
}

/// Distance along `d` (unit) from `o` to the convex polygon `v` with vector area `m`,
/// if the ray hits it.
fn ray_hit(o: DVec3, d: DVec3, v: &[DVec3], m: DVec3) -> Option<f64> {
    let denom = m.dot(d);
    if denom.abs() <= 1e-12 * m.length() {
        return None;
    }
    let t = m.dot(v[0] - o) / denom;
    let x = o + t * d;
    let n = v.len();
    let inside = (0..n).all(|k| (v[(k + 1) % n] - v[k]).cross(x - v[k]).dot(m) >= 0.0);
    inside.then_some(t)
}

/// One warning per emitter polygon (at most five, then a count) whose front faces a
/// surface nearer than [`EMITTER_CLEARANCE`] × its diameter, at the scene's start.
pub fn emitters_facing_close(scene: &Scene) -> Vec<String> {
    let t0 = scene.time.start;
    // World-space polygons: (object, index, vertices, vector area).
    let mut world: Vec<(usize, usize, Vec<DVec3>, DVec3)> = Vec::new();
    for (oi, o) in scene.objects.iter().enumerate() {
        let m = o.to_world(t0);
        for (i, p) in o.polygons.iter().enumerate() {
            let v: Vec<DVec3> = p.vertices.iter().map(|x| m.transform_point3(*x)).collect();
            let a = Polygon {
                vertices: v.clone(),
                material: p.material,
            }
            .area_vector();
            world.push((oi, i, v, a));
        }
    }
    let mut emitters: Vec<usize> = (0..world.len())
        .filter(|&k| {
            let (oi, i, ..) = world[k];
            let mat = scene.objects[oi].polygons[i].material.0 as usize;
            scene.materials.get(mat).is_some_and(|m| m.is_emitter())
        })
        .collect();
    emitters.sort_by(|&a, &b| world[b].3.length().total_cmp(&world[a].3.length()));
    emitters.truncate(MAX_EMITTERS_CHECKED);
    let mut found = Vec::new();
    for &e in &emitters {
        let (eo, ei, ref ev, ea) = world[e];
        let n = ea.normalize_or_zero();
        let c = ev.iter().copied().sum::<DVec3>() / ev.len() as f64;
        let size = Polygon {
            vertices: ev.clone(),
            material: scene.objects[eo].polygons[ei].material,
        }
        .diameter();
        let reach = EMITTER_CLEARANCE * size;
        let nearest = world
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != e)
            .filter_map(|(k, (_, _, v, a))| {
                ray_hit(c, n, v, *a)
                    .filter(|&t| t > 1e-9 * size && t < reach)
                    .map(|t| (k, t))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((k, t)) = nearest {
            let (oo, oi, ..) = world[k];
            found.push(format!(
                "emitter object \"{}\" polygon {ei} faces object \"{}\" polygon {oi} at {t:.3e}, under {EMITTER_CLEARANCE} x its size {size:.3e}: most of its light goes into that surface; if it should light the room, reverse its vertex order, or make it two-sided (glTF doubleSided, solve --two-sided)",
                scene.objects[eo].name, scene.objects[oo].name
            ));
        }
    }
    if found.len() > 5 {
        let more = found.len() - 5;
        found.truncate(5);
        found.push(format!(
            "{more} more emitter polygon(s) face a surface that close"
        ));
    }
    found
}
