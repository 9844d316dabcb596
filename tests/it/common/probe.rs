//! Probe-point sets and the error measure for accuracy tests.
#![allow(dead_code)]

use glam::DVec3;
use rhier::geometry::Patches;

/// A grid of probe points on every patch of a scene, `k × k` per patch, inset.
pub fn grid_points(patches: &Patches, k: usize) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for i in 0..patches.len() {
        for a in 0..k {
            for b in 0..k {
                let (u, v) = ((a as f64 + 0.5) / k as f64, (b as f64 + 0.5) / k as f64);
                // Square to triangle strictly inside (folding at `u + v = 1` would put
                // points on the long edge, in the corner of two walls).
                let (u, v) = if patches.polys[i].n == 3 {
                    (1.0 - u.sqrt(), u.sqrt() * v)
                } else {
                    (u, v)
                };
                out.push((patches.point(i, u, v), patches.normals[i]));
            }
        }
    }
    out
}

/// Points near contact edges: for every patch with an edge on the plane `y = 0`
/// (a block side resting on the floor), points on the floor at distances `ds` from
/// the middle of that edge, outside, and on the side itself at heights `ds`.
pub fn contact_points(patches: &Patches, ds: &[f64]) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for i in 0..patches.len() {
        let n = patches.normals[i];
        if n.y.abs() > 0.1 {
            continue; // only vertical faces
        }
        let c = patches.polys[i].corners();
        for k in 0..c.len() {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            if a.y.abs() < 1e-6 && b.y.abs() < 1e-6 {
                let m = (a + b) * 0.5;
                let out_dir = DVec3::new(n.x, 0.0, n.z).normalize();
                for &d in ds {
                    out.push((m + out_dir * d, DVec3::Y));
                    out.push((m + DVec3::Y * d, n));
                }
            }
        }
    }
    out
}
