//! Form-factor kernels.
//!
//! [`point_to_polygon`] is the exact unoccluded form factor from a differential area
//! at `x` (unit normal `n`) to a planar polygon, by Lambert's contour integral
//! (Nusselt / Hottel & Sarofim; the form used in every radiosity text):
//!
//! ```text
//! F(dA_x → A) = 1/(2π) · Σ_i  n · (r_i × r_{i+1}) / |r_i × r_{i+1}| · γ_i ,
//! r_i = v_i − x,   γ_i = angle between r_i and r_{i+1}
//! ```
//!
//! valid for a polygon entirely in front of `x`'s tangent plane, so the polygon is
//! first clipped to that half-space (the contour integral of the clipped polygon is
//! the exact factor to the visible part). Sources are one-sided: a receiver behind
//! the source's plane gets 0. Angles use `atan2(|a×b|, a·b)`, accurate at every
//! scale and for nearly collinear corners, evaluated by [`edge_angle`] (Moshier's
//! Cephes arctangent, within an ulp of the C library's and about 1.7× faster: it was
//! a tenth of LIGHT's space-time profile). Visibility is not part of these kernels.
//!
//! A source small against its distance and wholly above `x`'s horizon is integrated
//! instead by Gauss–Legendre quadrature of the point kernel over its bilinear
//! parametrisation (`far_factor`): with no clipping the integrand
//! `(n · (y − x)) · h / (π |y − x|⁴)` is smooth (the first factor linear, `h` the
//! height of `x` over the source's plane), and the rule's relative error falls as
//! the sixth power of `radius / distance` (3 × 3 points). Measured against the
//! contour integral over random convex quads and triangles and all orientations of
//! `n` that keep the source above the horizon (test
//! `far_sources_take_the_quadrature_within_its_bound`): at most 2.1e-5 for quads and
//! 3.7e-6 for triangles up to the rule's limit [`FAR_RATIO`]. The 2 × 2 rule was
//! 7e-5 off for skewed quads at a third of that distance, where few sources are.

use glam::DVec3;

use super::polygon::Poly;

/// Point-to-point kernel `cos θx cos θy / (π r²)` between `x` (normal `nx`) and `y`
/// (normal `ny`), zero when either faces away.
pub fn point_to_point_kernel(x: DVec3, nx: DVec3, y: DVec3, ny: DVec3) -> f64 {
    let d = y - x;
    let r2 = d.length_squared();
    if r2 <= 0.0 {
        return 0.0;
    }
    let cx = nx.dot(d);
    let cy = -ny.dot(d);
    if cx <= 0.0 || cy <= 0.0 {
        return 0.0;
    }
    cx * cy / (std::f64::consts::PI * r2 * r2)
}

/// The direction about unit normal `n` for unit-square numbers `(u1, u2)`, cosine
/// distributed (density `cos θ / π`: the point kernel's, so the fraction of such
/// directions that meet a surface is that surface's form factor). `rhier
/// reference` continues its paths along these, and a solve's closure test casts
/// them from its error samples.
pub fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let a = if n.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let t = n.cross(a).normalize();
    let b = n.cross(t);
    let (r, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
    t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()
}

/// Height over a source's plane, relative to the source's size (square root of
/// its area), under which a source facing a point back to back is its twin and
/// not in front of it ([`point_to_polygon`]): the planarity a quad is held to
/// (`scene::validate::PLANARITY_TOLERANCE`), since a surface is only known to
/// that. On Blender's Suzanne (`tests/data/blender/cornell-box.glb`), two-sided,
/// a quarter of the head's leaves summed their rows above 1 (up to 2.06) from
/// their own twin's factor of 1; at `ρ = 0.999` that made `ρK` expand.
pub const TWIN_GAP: f64 = 1e-4;

/// Unoccluded form factor from the differential area at `x` with unit normal `n` to
/// the one-sided polygon `src` (counter-clockwise seen from its front): exact (the
/// contour integral, [`point_to_polygon_exact`]) unless the source is far and wholly
/// above the horizon, where a Gauss quadrature (`far_factor`) is within 3e-5 of it.
///
/// A source facing the point from within [`TWIN_GAP`] of the point's plane is not
/// in front of it: it is the point's own surface seen from the other side (a
/// two-sided polygon's back-to-back twin), which round-off or a merged quad's
/// slight non-planarity puts a hair in front of some of its points, where it
/// would cover their whole hemisphere (factor 1).
pub fn point_to_polygon(x: DVec3, n: DVec3, src: &Poly) -> f64 {
    if src.n < 3 {
        return 0.0;
    }
    let Some((ns, h)) = in_front(x, n, src) else {
        return 0.0;
    };
    let c = src.corners();
    let above = c.iter().all(|&v| n.dot(v - x) > 0.0);
    if above && c.len() <= 4 {
        if let Some(f) = far_factor(x, n, c, ns, h) {
            return f;
        }
    }
    if above {
        // Nothing to clip.
        return contour_integral(x, n, c);
    }
    // Keep the part of the source above x's tangent plane.
    let clipped = src.clip_front(x, n);
    contour_integral(x, n, clipped.corners())
}

/// [`point_to_polygon`] by the contour integral always: exact to rounding.
pub fn point_to_polygon_exact(x: DVec3, n: DVec3, src: &Poly) -> f64 {
    if src.n < 3 || in_front(x, n, src).is_none() {
        return 0.0;
    }
    contour_integral(x, n, src.clip_front(x, n).corners())
}

/// The source's Newell vector `ns` and `h = ns · (x − v₀)` when `x` (normal `n`) is
/// strictly in front of the one-sided `src` and `src` is not its twin
/// ([`TWIN_GAP`]); `None` otherwise.
fn in_front(x: DVec3, n: DVec3, src: &Poly) -> Option<(DVec3, f64)> {
    let ns = src.area_vector();
    let h = ns.dot(x - src.v[0]);
    if h <= 0.0 {
        return None;
    }
    // A twin: facing the point's own plane (normals within 25°) from a height
    // under `TWIN_GAP` × its size (`|ns|` is twice its area).
    let l2 = ns.length_squared();
    if n.dot(ns) < -0.9 * l2.sqrt() && h * h <= TWIN_GAP * TWIN_GAP * l2 * l2.sqrt() {
        return None;
    }
    Some((ns, h))
}

/// Largest `radius / distance` (the source's corners about their mean, over that
/// mean's distance from `x`) at which [`point_to_polygon`] integrates by the 3 × 3
/// Gauss rule (`far_factor`).
pub const FAR_RATIO: f64 = 0.1;

/// The form factor from `x` (normal `n`) to the triangle or planar quad `c`
/// (Newell vector `ns`, `h = ns · (x − c₀) > 0`), every corner above `x`'s tangent
/// plane, by Gauss–Legendre quadrature of the point kernel where the source is far
/// enough for the 3 × 3 rule's bound (module docs); `None` where it is not.
///
/// The quad is `y(s, t) = c₀ + s e₁ + t e₂ + s t e₃` on the unit square (a
/// triangle: `c₃ = c₂`), whose Jacobian along the unit normal `ns/|ns|` is
/// `J/|ns|` with `J = (e₁ + t e₃) × (e₂ + s e₃) · ns`, linear in `s` and `t` for a
/// planar quad; the kernel's cosine at the source is `h / (|ns| r)`, so
/// `F = h / (π |ns|²) · Σ w J (n · d) / r⁴` with `d = y − x`, `r = |d|`.
fn far_factor(x: DVec3, n: DVec3, c: &[DVec3], ns: DVec3, h: f64) -> Option<f64> {
    let (p0, p1, p2) = (c[0], c[1], c[2]);
    let p3 = if c.len() == 4 { c[3] } else { p2 };
    let m = c.iter().sum::<DVec3>() / c.len() as f64;
    let rad2 = c.iter().fold(0.0f64, |r, v| r.max(v.distance_squared(m)));
    let d2 = x.distance_squared(m);
    let ratio2 = rad2 / d2;
    // NaN (the point on the source's centroid) is near too.
    if ratio2.is_nan() || ratio2 > FAR_RATIO * FAR_RATIO {
        return None;
    }
    let (e1, e2, e3) = (p1 - p0, p3 - p0, p2 - p1 - p3 + p0);
    let (j0, js, jt) = (
        e1.cross(e2).dot(ns),
        e1.cross(e3).dot(ns),
        e3.cross(e2).dot(ns),
    );
    let o = p0 - x;
    let (no, n1, n2, n3) = (n.dot(o), n.dot(e1), n.dot(e2), n.dot(e3));
    let point = |s: f64, t: f64| {
        let d = o + s * e1 + t * e2 + (s * t) * e3;
        let r2 = d.length_squared();
        let nd = no + s * n1 + t * n2 + (s * t) * n3;
        (j0 + s * js + t * jt) * nd / (r2 * r2)
    };
    // 0.5 ∓ 0.5 √(3/5), 0.5; weights 5/18, 8/18, 5/18.
    const G: [f64; 3] = [0.112_701_665_379_258_3, 0.5, 0.887_298_334_620_741_7];
    const W: [f64; 3] = [5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0];
    let mut sum = 0.0;
    for (&s, &ws) in G.iter().zip(&W) {
        for (&t, &wt) in G.iter().zip(&W) {
            sum += ws * wt * point(s, t);
        }
    }
    Some((h / (std::f64::consts::PI * ns.length_squared()) * sum).max(0.0))
}

/// Lambert's contour sum over `corners` (any count), no clipping, no side test.
/// Exposed for polygons with more corners than [`Poly`] holds (tests use a 256-gon).
pub fn contour_integral(x: DVec3, n: DVec3, corners: &[DVec3]) -> f64 {
    let k = corners.len();
    if k < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..k {
        let a = corners[i] - x;
        let b = corners[(i + 1) % k] - x;
        let c = a.cross(b);
        let cl = c.length();
        if cl <= 0.0 {
            continue; // edge through x or degenerate: contributes nothing
        }
        let gamma = edge_angle(cl, a.dot(b));
        sum += n.dot(c) / cl * gamma;
    }
    // The corners run counter-clockwise seen from the source's front, i.e. clockwise
    // seen from x: the sum is negative for a visible polygon.
    (-sum / (2.0 * std::f64::consts::PI)).max(0.0)
}

/// `atan2(y, x)` for `y ≥ 0` (the angle in `[0, π]` between two vectors from
/// `|a × b|` and `a · b`), by the arctangent of S. L. Moshier's Cephes library
/// (`atan.c`): reduced to `|t| ≤ 0.66` through `π/2 − atan(1/t)` or
/// `π/4 + atan((t − 1)/(t + 1))`, then `t + t³ P(t²)/Q(t²)` with the library's
/// rational coefficients. Within 2.3e-16 relative of `f64::atan2` over inputs
/// spanning twelve decades (tests), with no table and no slow path.
#[inline]
pub fn edge_angle(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    if x > 0.0 {
        atan_nonneg(y / x)
    } else if x < 0.0 {
        PI - atan_nonneg(y / -x)
    } else if y > 0.0 {
        FRAC_PI_2
    } else {
        0.0
    }
}

/// Cephes `atan` for `t ≥ 0` (see [`edge_angle`]).
#[inline]
fn atan_nonneg(t: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    const P: [f64; 5] = [
        -8.750_608_600_031_904E-1,
        -1.615_753_718_733_365_2E1,
        -7.500_855_792_314_705E1,
        -1.228_866_684_490_136_1E2,
        -6.485_021_904_942_025E1,
    ];
    const Q: [f64; 5] = [
        2.485_846_490_142_306_2E1,
        1.650_270_098_316_988_5E2,
        4.328_810_604_912_902_7E2,
        4.853_903_996_359_137E2,
        1.945_506_571_482_614E2,
    ];
    /// tan(3π/8).
    const T3P8: f64 = 2.414_213_562_373_095;
    /// The part of π/2 an f64 misses.
    const MOREBITS: f64 = 6.123_233_995_736_766E-17;
    let (base, t, more) = if t > T3P8 {
        (FRAC_PI_2, -1.0 / t, MOREBITS)
    } else if t <= 0.66 {
        (0.0, t, 0.0)
    } else {
        (FRAC_PI_4, (t - 1.0) / (t + 1.0), 0.5 * MOREBITS)
    };
    let z = t * t;
    let p = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    let q = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    base + (t * (z * p / q) + t + more)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle::xorshift;
    use std::f64::consts::PI;

    #[test]
    fn edge_angle_is_atan2_to_an_ulp() {
        // Inputs over twelve decades on both sides of the three branches
        // (t = y/|x| below 0.66, up to tan 3π/8, above), both signs of x, and the
        // ends: x = 0, y = 0, infinite ratios.
        let mut rnd = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut worst = 0.0f64;
        for _ in 0..200_000 {
            let y = rnd() * 10f64.powf(12.0 * rnd() - 6.0);
            let x = (rnd() - 0.5) * 10f64.powf(12.0 * rnd() - 6.0);
            let (a, b) = (y.atan2(x), edge_angle(y, x));
            worst = worst.max((a - b).abs() / a.abs().max(f64::MIN_POSITIVE));
        }
        assert!(worst <= 4.5e-16, "worst relative error {worst:e}");
        for (y, x) in [
            (0.0f64, 1.0f64),
            (0.0, -1.0),
            (1.0, 0.0),
            (0.0, 0.0),
            (1.0, 1.0),
            (1.0, -1.0),
            (0.66, 1.0),
            (2.414_213_562_373_095, 1.0),
            (1e300, 1e-300),
            (1e-300, -1e300),
        ] {
            let (a, b) = (y.atan2(x), edge_angle(y, x));
            assert!(
                (a - b).abs() <= 4.5e-16 * a.abs(),
                "atan2({y}, {x}) = {a}, got {b}"
            );
        }
    }

    fn quad(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> Poly {
        Poly::new(&[a.into(), b.into(), c.into(), d.into()])
    }

    /// dA on the axis of a coaxial parallel disk: F = R² / (R² + h²).
    #[test]
    fn point_to_coaxial_disk() {
        let (r, h) = (0.7, 1.3);
        let m = 256;
        // Disk at height h facing down (-z): counter-clockwise seen from below.
        let corners: Vec<DVec3> = (0..m)
            .map(|i| {
                let a = -2.0 * PI * i as f64 / m as f64;
                DVec3::new(r * a.cos(), r * a.sin(), h)
            })
            .collect();
        let f = contour_integral(DVec3::ZERO, DVec3::Z, &corners);
        // Inscribed 256-gon: area ratio sin(2π/m)/(2π/m), well under 1e-4.
        let exact = r * r / (r * r + h * h);
        assert!((f - exact).abs() / exact < 2e-4, "{f} vs {exact}");
    }

    /// Corner of a square at unit distance, parallel: F = (1/2π)(atan… ) closed form
    /// for dA below one corner of a w×l rectangle at height h.
    #[test]
    fn point_below_rectangle_corner() {
        let (w, l, h) = (1.0f64, 2.0f64, 0.5f64);
        let src = quad([0.0, 0.0, h], [0.0, l, h], [w, l, h], [w, 0.0, h]);
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &src);
        let (a, b) = (w / h, l / h);
        let exact = 1.0 / (2.0 * PI)
            * (a / (1.0 + a * a).sqrt() * (b / (1.0 + a * a).sqrt()).atan()
                + b / (1.0 + b * b).sqrt() * (a / (1.0 + b * b).sqrt()).atan());
        assert!((f - exact).abs() < 1e-12, "{f} vs {exact}");
    }

    /// Far sources (any convex quad or triangle, any receiver orientation that
    /// keeps the source above the horizon, `radius/distance` up to [`FAR_RATIO`]):
    /// the quadrature against the contour integral, within the bound the module
    /// docs give; and a source across the horizon or nearer is the exact value.
    #[test]
    fn far_sources_take_the_quadrature_within_its_bound() {
        let mut rnd = xorshift(0x2545_f491_4f6c_dd1d);
        let unit = |rnd: &mut dyn FnMut() -> f64| loop {
            let v = DVec3::new(2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0);
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        };
        let (mut worst_quad, mut worst_tri, mut taken) = (0.0f64, 0.0f64, 0);
        for i in 0..20_000 {
            let k = if i % 2 == 0 { 4 } else { 3 };
            // A convex polygon: k angles sorted around a point, random radii.
            let mut ang: Vec<f64> = (0..k).map(|_| rnd() * 2.0 * PI).collect();
            ang.sort_by(f64::total_cmp);
            let e1 = unit(&mut rnd);
            let e2 = e1.cross(unit(&mut rnd)).normalize();
            let ns = e1.cross(e2);
            let corners: Vec<DVec3> = ang
                .iter()
                .map(|a| (0.5 + rnd()) * (a.cos() * e1 + a.sin() * e2))
                .collect();
            let src = Poly::new(&corners);
            if src.area_vector().dot(ns) <= 0.0 || src.area() < 0.05 {
                continue; // not convex and counter-clockwise, or a sliver
            }
            let m = corners.iter().sum::<DVec3>() / k as f64;
            let rad = corners.iter().fold(0.0f64, |r, v| r.max(v.distance(m)));
            let ratio = FAR_RATIO * (0.2 + 1.3 * rnd());
            let mut dir = unit(&mut rnd);
            if dir.dot(ns) < 0.0 {
                dir = -dir;
            }
            let x = m + dir * (rad / ratio);
            let mut n = unit(&mut rnd);
            if n.dot(m - x) < 0.0 {
                n = -n;
            }
            let exact = point_to_polygon_exact(x, n, &src);
            let f = point_to_polygon(x, n, &src);
            let err = (f - exact).abs() / exact.max(f64::MIN_POSITIVE);
            let above = corners.iter().all(|&v| n.dot(v - x) > 0.0);
            if !above || ratio > FAR_RATIO * 1.001 {
                assert_eq!(f, exact, "exact where the rule does not hold");
                continue;
            }
            if ratio > FAR_RATIO * 0.999 {
                continue; // either side of the limit, by rounding
            }
            taken += 1;
            if k == 4 {
                worst_quad = worst_quad.max(err);
            } else {
                worst_tri = worst_tri.max(err);
            }
        }
        assert!(taken > 5_000, "{taken}");
        assert!(worst_quad < 3e-5, "quads: {worst_quad:e}");
        assert!(worst_tri < 1e-5, "triangles: {worst_tri:e}");
    }

    #[test]
    fn back_facing_and_behind_are_zero() {
        // Facing up (away from a receiver below).
        let up = quad(
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        );
        assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &up), 0.0);
        // Facing down but behind the receiver's plane.
        let below = quad(
            [0.0, 0.0, -1.0],
            [0.0, 1.0, -1.0],
            [1.0, 1.0, -1.0],
            [1.0, 0.0, -1.0],
        );
        assert_eq!(point_to_polygon(DVec3::ZERO, DVec3::Z, &below), 0.0);
    }

    #[test]
    fn hemisphere_closure_of_a_cube_is_one() {
        // Centre of the floor of a unit cube: the other five faces fill the hemisphere.
        let x = DVec3::new(0.5, 0.5, 0.0);
        let faces = [
            quad(
                [0.0, 0.0, 1.0],
                [0.0, 1.0, 1.0],
                [1.0, 1.0, 1.0],
                [1.0, 0.0, 1.0],
            ), // top, facing -z
            quad(
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 1.0],
                [1.0, 0.0, 0.0],
            ), // y=0, +y
            quad(
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
                [1.0, 1.0, 1.0],
                [0.0, 1.0, 1.0],
            ), // y=1, -y
            quad(
                [0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 1.0, 1.0],
                [0.0, 0.0, 1.0],
            ), // x=0, +x
            quad(
                [1.0, 0.0, 0.0],
                [1.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
                [1.0, 1.0, 0.0],
            ), // x=1, -x
        ];
        for f in &faces {
            assert!(f.normal().dot(DVec3::new(0.5, 0.5, 0.5) - f.centroid()) > 0.0);
        }
        let total: f64 = faces.iter().map(|f| point_to_polygon(x, DVec3::Z, f)).sum();
        assert!((total - 1.0).abs() < 1e-13, "{total}");
        // Approaching an edge of the floor the hemisphere stays closed…
        let e = DVec3::new(1e-9, 0.3, 0.0);
        let total: f64 = faces.iter().map(|f| point_to_polygon(e, DVec3::Z, f)).sum();
        assert!((total - 1.0).abs() < 1e-8, "{total}");
        // …but on the edge itself the wall x = 0 is seen edge-on and gives 0: the jump
        // the reconstruction avoids by evaluating corners a hair inside their cell.
        let on = DVec3::new(0.0, 0.3, 0.0);
        assert_eq!(point_to_polygon(on, DVec3::Z, &faces[3]), 0.0);
    }

    #[test]
    fn kernel_is_symmetric_and_scale_free() {
        let (x, nx) = (DVec3::ZERO, DVec3::Z);
        let (y, ny) = (DVec3::new(0.3, 0.1, 1.0), DVec3::new(0.0, 0.0, -1.0));
        let k = point_to_point_kernel(x, nx, y, ny);
        assert_eq!(k, point_to_point_kernel(y, ny, x, nx));
        let s = 1e3;
        let ks = point_to_point_kernel(x * s, nx, y * s, ny);
        assert!((ks * s * s - k).abs() / k < 1e-12);
    }
}
