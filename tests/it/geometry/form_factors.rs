//! Area-to-area form factors against their closed forms (Howell's catalogue), by
//! integrating the exact point-to-polygon factor over the receiver. Tolerance 1%
//! (the bar); the midpoint rule on 64×64 points converges well inside it.

use std::f64::consts::PI;

use glam::DVec3;
use rhier::geometry::formfactor_contour as contour;
use rhier::geometry::{Poly, point_to_polygon};

/// The midpoint of cell `(i, j)` of a `k` × `k` grid over the bilinear quad `q`.
fn grid_point(q: &[DVec3; 4], i: usize, j: usize, k: usize) -> DVec3 {
    let (u, v) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
    (1.0 - u) * (1.0 - v) * q[0] + u * (1.0 - v) * q[1] + u * v * q[2] + (1.0 - u) * v * q[3]
}

fn area_factor(recv: [DVec3; 4], n: DVec3, src: &Poly, k: usize) -> f64 {
    let mut s = 0.0;
    for i in 0..k {
        for j in 0..k {
            s += point_to_polygon(grid_point(&recv, i, j, k), n, src);
        }
    }
    s / (k * k) as f64
}

#[test]
fn parallel_opposed_rectangles_match_howell_c11() {
    // a × b rectangles at distance c: Howell C-11.
    let (a, b, c) = (1.0f64, 2.0f64, 0.7f64);
    let (x, y) = (a / c, b / c);
    let exact = 2.0 / (PI * x * y)
        * (((1.0 + x * x) * (1.0 + y * y) / (1.0 + x * x + y * y))
            .sqrt()
            .ln()
            + x * (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan()
            + y * (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
            - x * x.atan()
            - y * y.atan());
    let recv = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(a, 0.0, 0.0),
        DVec3::new(a, b, 0.0),
        DVec3::new(0.0, b, 0.0),
    ];
    // Source facing down: counter-clockwise seen from below.
    let src = Poly::new(&[
        DVec3::new(0.0, 0.0, c),
        DVec3::new(0.0, b, c),
        DVec3::new(a, b, c),
        DVec3::new(a, 0.0, c),
    ]);
    let f = area_factor(recv, DVec3::Z, &src, 64);
    assert!((f - exact).abs() / exact < 0.01, "{f} vs {exact}");
}

#[test]
fn perpendicular_rectangles_sharing_an_edge_match_howell_c14() {
    // Receiver w (along x) × l (along y) on z = 0; source h (along z) × l on x = 0.
    let (w, h, l) = (1.0f64, 1.0f64, 1.0f64);
    let (hh, ww) = (h / l, w / l);
    let a = (1.0 + hh * hh) * (1.0 + ww * ww) / (1.0 + hh * hh + ww * ww);
    let b = ww * ww * (1.0 + hh * hh + ww * ww) / ((1.0 + ww * ww) * (ww * ww + hh * hh));
    let c = hh * hh * (1.0 + hh * hh + ww * ww) / ((1.0 + hh * hh) * (hh * hh + ww * ww));
    // Howell C-14, factor from the w × l rectangle to the h × l one.
    let exact = 1.0 / (PI * ww)
        * (ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan()
            - (hh * hh + ww * ww).sqrt() * (1.0 / (hh * hh + ww * ww).sqrt()).atan()
            + 0.25 * (a * b.powf(ww * ww) * c.powf(hh * hh)).ln());
    let recv = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(w, 0.0, 0.0),
        DVec3::new(w, l, 0.0),
        DVec3::new(0.0, l, 0.0),
    ];
    // Source on x = 0 facing +x: counter-clockwise seen from +x.
    let src = Poly::new(&[
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(0.0, l, 0.0),
        DVec3::new(0.0, l, h),
        DVec3::new(0.0, 0.0, h),
    ]);
    assert!(src.normal().dot(DVec3::X) > 0.99);
    let f = area_factor(recv, DVec3::Z, &src, 64);
    assert!((exact - 0.200044).abs() < 1e-5, "closed form {exact}");
    assert!((f - exact).abs() / exact < 0.01, "{f} vs {exact}");
}

#[test]
fn coaxial_parallel_disks_match_howell_c40() {
    // Disk radius r1 to coaxial disk radius r2 at distance h: Howell C-40.
    let (r1, r2, h) = (0.5f64, 0.8f64, 1.0f64);
    let (x1, x2) = (r1 / h, r2 / h);
    let s = 1.0 + (1.0 + x2 * x2) / (x1 * x1);
    let exact = 0.5 * (s - (s * s - 4.0 * (x2 / x1).powi(2)).sqrt());
    let m = 512;
    // Source disk facing down as an inscribed 512-gon (area ratio 1 − 2.5e-5).
    let corners: Vec<DVec3> = (0..m)
        .map(|i| {
            let a = -2.0 * PI * i as f64 / m as f64;
            DVec3::new(r2 * a.cos(), r2 * a.sin(), h)
        })
        .collect();
    // By symmetry the point factor depends on the radius only: Gauss–Legendre in r².
    let nodes = 32;
    let mut f = 0.0;
    for k in 0..nodes {
        let t = (k as f64 + 0.5) / nodes as f64; // midpoint in r², uniform area weight
        let r = r1 * t.sqrt();
        f += contour(DVec3::new(r, 0.0, 0.0), DVec3::Z, &corners) / nodes as f64;
    }
    assert!((f - exact).abs() / exact < 0.01, "{f} vs {exact}");
}

/// A two-sided surface's twin (its polygon reversed) is not in front of the
/// surface's own points, however round-off or a quad's slight non-planarity puts
/// them: a point a hair in front of its twin's plane took the twin's factor, about
/// 1 (the twin covering its whole hemisphere), and the rows of Blender's two-sided
/// Suzanne summed up to 2.06. Checked on a quad bent out of plane by 5·10⁻⁵ of
/// its size (within the scene's planarity tolerance), at its points and 10⁻⁵ in front of
/// its twin, and on its two triangles
/// (the tessellated twin) with points 10⁻⁹ in front of the twin; a real surface
/// facing the point from 1% of its size above still counts (factor near 1).
#[test]
fn a_twin_is_not_in_front_of_its_own_surface() {
    let bent = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 1.0, 5e-5),
        DVec3::new(0.0, 1.0, 0.0),
    ];
    let twin = |v: &[DVec3]| Poly::new(&v.iter().rev().copied().collect::<Vec<_>>());
    let n = DVec3::Z;
    let k = 16;
    for i in 0..k {
        for j in 0..k {
            let x = grid_point(&bent, i, j, k);
            // The bent quad's points, and the same 1e-5 in front of its twin.
            let t = twin(&bent);
            let m = t.area_vector().normalize();
            for x in [x, x + 1e-5 * m] {
                let f = point_to_polygon(x, n, &t);
                assert!(
                    f == 0.0,
                    "point {x} of the bent quad takes {f} from its twin"
                );
            }
            // The two triangles, the point 1e-9 in front of each twin.
            for tri in [[bent[0], bent[1], bent[2]], [bent[0], bent[2], bent[3]]] {
                let t = twin(&tri);
                let m = t.area_vector().normalize();
                let f = point_to_polygon(x + 1e-9 * m, n, &t);
                assert!(f == 0.0, "point {x} takes {f} from a triangle's twin");
            }
        }
    }
    // A real square 1% of its size above the centre of another, facing it.
    let above = twin(&[
        DVec3::new(0.0, 0.0, 0.01),
        DVec3::new(1.0, 0.0, 0.01),
        DVec3::new(1.0, 1.0, 0.01),
        DVec3::new(0.0, 1.0, 0.01),
    ]);
    let f = point_to_polygon(DVec3::new(0.5, 0.5, 0.0), n, &above);
    assert!(f > 0.99, "a square 1% above takes {f}");
}
