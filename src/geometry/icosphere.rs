//! The icosphere: the regular icosahedron with each triangle cut into four
//! `level` times, the new corners pushed out onto the sphere (`20 · 4^level`
//! triangles). The closed curved mesh the tests and benchmarks of curved
//! enclosures and curved-mesh occlusion are built on (issue 45 part 1: exactly
//! `B = E/(1 − ρ)` inside; `wide`'s slabs).

use glam::DVec3;

/// The triangles of an icosphere of radius `r` about `c`, `level` times
/// subdivided, each counter-clockwise seen from outside.
pub fn icosphere(c: DVec3, r: f64, level: u32) -> Vec<[DVec3; 3]> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let v = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .map(|(a, b, c)| DVec3::new(a, b, c).normalize());
    let f: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[DVec3; 3]> = f.iter().map(|t| t.map(|i| v[i])).collect();
    for _ in 0..level {
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    (a + b).normalize(),
                    (b + c).normalize(),
                    (c + a).normalize(),
                );
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    tris.iter().map(|t| t.map(|p| c + r * p)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `20 · 4^level` triangles, every corner on the sphere, each facing out.
    #[test]
    fn corners_on_the_sphere_and_faces_out() {
        let c = DVec3::new(0.5, -1.0, 2.0);
        for level in 0..3 {
            let tris = icosphere(c, 2.0, level);
            assert_eq!(tris.len(), 20 * 4usize.pow(level));
            for [a, b, d] in &tris {
                for p in [a, b, d] {
                    assert!(((*p - c).length() - 2.0).abs() < 1e-12, "{p}");
                }
                let out = (*b - *a).cross(*d - *a).dot((*a + *b + *d) / 3.0 - c);
                assert!(out > 0.0, "{a} {b} {d}");
            }
        }
    }
}
