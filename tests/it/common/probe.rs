//! Probe-point grids for the accuracy tests.

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
