//! Splitting a face the solver cannot take (a non-planar or concave quad, a polygon
//! of five or more vertices) into triangles, as other renderers do.
//!
//! How it works: the face's Newell normal (its vector area) gives its plane; the
//! vertices are projected on it and cut by ear clipping (Eberly, "Triangulation by
//! ear clipping", 2002): repeatedly cut the first corner that turns the polygon's way
//! and holds no other vertex, skipping corners of no area (collinear vertices). A quad
//! is cut along its shorter diagonal when both cuts are valid, so that a bent quad
//! keeps the fold nearest its surface. Each triangle keeps the face's winding.
//!
//! It refuses only what has no triangulation: a face of zero vector area
//! (all vertices on a line or a point) and one that crosses itself in projection.

use glam::{DVec2, DVec3};

/// Why a face could not be triangulated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Degenerate {
    /// Zero vector area: every vertex on one line, or repeated points.
    ZeroArea,
    /// No ear left: the outline crosses itself.
    SelfIntersecting,
}

impl Degenerate {
    /// What the face is, for messages.
    pub(crate) fn describe(self) -> &'static str {
        match self {
            Degenerate::ZeroArea => "degenerate (zero area: its vertices are on one line)",
            Degenerate::SelfIntersecting => {
                "self-intersecting (no triangulation keeps its outline)"
            }
        }
    }
}

/// Triangles (indices into `v`, counter-clockwise about the face's normal) covering the
/// face `v` of 3 or more vertices.
pub(crate) fn triangulate(v: &[DVec3]) -> Result<Vec<[usize; 3]>, Degenerate> {
    let n = v.len();
    let normal: DVec3 = (0..n).map(|k| v[k].cross(v[(k + 1) % n])).sum();
    let scale = v.iter().map(|p| p.distance(v[0])).fold(0.0, f64::max);
    if normal.length() <= 1e-12 * scale * scale || scale == 0.0 {
        return Err(Degenerate::ZeroArea);
    }
    // A frame of the face's plane: (u, w, normal) right-handed.
    let nz = normal.normalize();
    let u = nz.any_orthonormal_vector();
    let w = nz.cross(u);
    let p: Vec<DVec2> = v
        .iter()
        .map(|x| DVec2::new((*x - v[0]).dot(u), (*x - v[0]).dot(w)))
        .collect();
    let eps = 1e-12 * scale * scale;
    let cross = |a: usize, b: usize, c: usize| (p[b] - p[a]).perp_dot(p[c] - p[a]);
    if n == 4 {
        // Both diagonals' cuts, shorter first; a cut is valid if both halves turn the
        // face's way.
        let mut cuts = [[[0, 1, 2], [0, 2, 3]], [[1, 2, 3], [1, 3, 0]]];
        if v[1].distance(v[3]) < v[0].distance(v[2]) {
            cuts.swap(0, 1);
        }
        for cut in cuts {
            if cut.iter().all(|t| cross(t[0], t[1], t[2]) > eps) {
                return Ok(cut.to_vec());
            }
        }
    }
    let inside = |a: usize, b: usize, c: usize, q: usize| {
        cross(a, b, q) >= -eps && cross(b, c, q) >= -eps && cross(c, a, q) >= -eps
    };
    let mut ring: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while ring.len() > 3 {
        let m = ring.len();
        let mut cut = None;
        for k in 0..m {
            let (a, b, c) = (ring[(k + m - 1) % m], ring[k], ring[(k + 1) % m]);
            let turn = cross(a, b, c);
            if turn.abs() <= eps {
                // A collinear corner: remove it, no triangle.
                cut = Some((k, None));
                break;
            }
            if turn > 0.0
                && !ring.iter().any(|&q| {
                    q != a
                        && q != b
                        && q != c
                        && p[q] != p[a]
                        && p[q] != p[b]
                        && p[q] != p[c]
                        && inside(a, b, c, q)
                })
            {
                cut = Some((k, Some([a, b, c])));
                break;
            }
        }
        let Some((k, tri)) = cut else {
            return Err(Degenerate::SelfIntersecting);
        };
        out.extend(tri);
        ring.remove(k);
    }
    if cross(ring[0], ring[1], ring[2]) > eps {
        out.push([ring[0], ring[1], ring[2]]);
    } else if cross(ring[0], ring[1], ring[2]) < -eps {
        return Err(Degenerate::SelfIntersecting);
    }
    if out.is_empty() {
        return Err(Degenerate::ZeroArea);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(v: &[DVec3], tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|t| 0.5 * (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]).length())
            .sum()
    }

    #[test]
    fn concave_l_shape_is_cut_into_four_triangles_of_its_area() {
        // An L of area 3 (a 2 x 2 square less a 1 x 1 corner), counter-clockwise.
        let v: Vec<DVec3> = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
            .iter()
            .map(|a| DVec3::new(a[0] as f64, a[1] as f64, 0.0))
            .collect();
        let t = triangulate(&v).unwrap();
        assert_eq!(t.len(), 4);
        assert!((area(&v, &t) - 3.0).abs() < 1e-12);
        // Every triangle faces +z, as the face does.
        for tri in &t {
            let n = (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]);
            assert!(n.z > 0.0, "{tri:?}");
        }
    }

    #[test]
    fn concave_quad_takes_the_diagonal_through_its_reflex_corner() {
        // A dart: vertex 3 is reflex, so only the cut 1-3 is valid.
        let v: Vec<DVec3> = [[0.0, 0.0], [2.0, -1.0], [1.0, 0.0], [2.0, 1.0]]
            .iter()
            .map(|a| DVec3::new(a[0], a[1], 0.0))
            .collect();
        let v: Vec<DVec3> = v.into_iter().rev().collect();
        let t = triangulate(&v).unwrap();
        assert_eq!(t.len(), 2);
        assert!((area(&v, &t) - 1.0).abs() < 1e-12, "{t:?}");
    }

    #[test]
    fn collinear_and_self_crossing_faces_are_refused() {
        let line: Vec<DVec3> = (0..4).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
        assert_eq!(triangulate(&line), Err(Degenerate::ZeroArea));
        // A bow tie of two triangles of opposite turn: zero vector area.
        let bow: Vec<DVec3> = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]
            .iter()
            .map(|a| DVec3::new(a[0], a[1], 0.0))
            .collect();
        assert!(triangulate(&bow).is_err());
    }
}
