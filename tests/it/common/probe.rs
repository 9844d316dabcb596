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

/// Probe points where boxes meet the floor `y = floor_y`: for every wall patch (normal
/// off the vertical) with an edge on the floor, at each fraction `along` of that edge
/// and each distance `d` of `ds`, a floor point `d` out from the edge (facing up) and a
/// wall point `d` above it (facing the wall's way). Mirrors `contact_points` of
/// `tools/cornell_error_vs_time.py`, along the whole edge instead of its midpoint.
/// Points inside a solid (on a face that another face rests against: the floor
/// under a box, a box's side against its neighbour's) are left out: what a probe
/// finds there is arbitrary.
pub fn contact_points(
    patches: &Patches,
    floor_y: f64,
    ds: &[f64],
    along: &[f64],
) -> Vec<(DVec3, DVec3)> {
    let tol = 1e-9 * patches.diameter;
    // On a polygon facing the other way, in the same plane.
    let covered = |p: DVec3, n: DVec3| {
        (0..patches.len()).any(|j| {
            let (nj, poly) = (patches.normals[j], &patches.polys[j]);
            nj.dot(n) < -0.99 && nj.dot(p - poly.v[0]).abs() <= tol && poly.contains(nj, p, tol)
        })
    };
    let mut out = Vec::new();
    for (poly, &n) in patches.polys.iter().zip(&patches.normals) {
        if n.y.abs() > 0.1 {
            continue;
        }
        let out_dir = DVec3::new(n.x, 0.0, n.z).normalize();
        for k in 0..poly.n {
            let (a, b) = (poly.v[k], poly.v[(k + 1) % poly.n]);
            if (a.y - floor_y).abs() > tol || (b.y - floor_y).abs() > tol {
                continue;
            }
            for &t in along {
                let m = a.lerp(b, t);
                for &d in ds {
                    for (p, pn) in [(m + out_dir * d, DVec3::Y), (m + DVec3::Y * d, n)] {
                        if !covered(p, pn) {
                            out.push((p, pn));
                        }
                    }
                }
            }
        }
    }
    out
}
