//! Nearest point on a patch: the location rule of `probe` ("the surface point nearest
//! `p` whose normal faces along `n`").

use glam::DVec3;

use super::polygon::Poly;

/// Closest point to `p` on the convex polygon `poly` (in its plane, clamped to its
/// boundary).
pub fn closest_point_on_polygon(poly: &Poly, p: DVec3) -> DVec3 {
    let n = poly.normal();
    let c = poly.corners();
    let q = p - n * n.dot(p - c[0]);
    // Inside every edge (counter-clockwise around n)? Then the projection is it.
    let k = c.len();
    let mut inside = true;
    for i in 0..k {
        let (a, b) = (c[i], c[(i + 1) % k]);
        if (b - a).cross(q - a).dot(n) < 0.0 {
            inside = false;
            break;
        }
    }
    if inside {
        return q;
    }
    let mut best = c[0];
    let mut bd = f64::INFINITY;
    for i in 0..k {
        let (a, b) = (c[i], c[(i + 1) % k]);
        let ab = b - a;
        let t = if ab.length_squared() > 0.0 {
            ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = a + t * ab;
        let d = x.distance_squared(q);
        if d < bd {
            bd = d;
            best = x;
        }
    }
    best
}

/// The patch nearest `p` among those whose normal has a positive dot product with
/// `n`, and the point on it; brute force over `polys` (callers with many patches
/// use an index).
pub fn nearest_facing(
    polys: &[Poly],
    normals: &[DVec3],
    p: DVec3,
    n: DVec3,
) -> Option<(usize, DVec3)> {
    let mut best = None;
    let mut bd = f64::INFINITY;
    for (i, poly) in polys.iter().enumerate() {
        if normals[i].dot(n) <= 0.0 {
            continue;
        }
        let x = closest_point_on_polygon(poly, p);
        let d = x.distance_squared(p);
        if d < bd {
            bd = d;
            best = Some((i, x));
        }
    }
    best
}

/// For each probe point `(p, n)`, whether the patch `probe` finds for it
/// ([`nearest_facing`]) emits: the points an error report leaves out
/// ([`crate::solution::PointError`]).
pub fn on_emitters(patches: &super::Patches, points: &[(DVec3, DVec3)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(p, n)| {
            nearest_facing(&patches.polys, &patches.normals, p, n)
                .is_some_and(|(i, _)| patches.emits(i))
        })
        .collect()
}
