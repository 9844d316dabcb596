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

/// Exact unoccluded form factor from the differential area at `x` with unit normal
/// `n` to the one-sided polygon `src` (counter-clockwise seen from its front).
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
    // One-sided source: x must be strictly in front of its plane.
    let ns = src.area_vector();
    let h = ns.dot(x - src.v[0]);
    if h <= 0.0 {
        return 0.0;
    }
    // A twin: facing the point's own plane (normals within 25°) from a height
    // under `TWIN_GAP` × its size (`|ns|` is twice its area).
    let l2 = ns.length_squared();
    if n.dot(ns) < -0.9 * l2.sqrt() && h * h <= TWIN_GAP * TWIN_GAP * l2 * l2.sqrt() {
        return 0.0;
    }
    // Keep the part of the source above x's tangent plane.
    let clipped = src.clip_front(x, n);
    contour_integral(x, n, clipped.corners())
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
    use std::f64::consts::PI;

    #[test]
    fn edge_angle_is_atan2_to_an_ulp() {
        // Inputs over twelve decades on both sides of the three branches
        // (t = y/|x| below 0.66, up to tan 3π/8, above), both signs of x, and the
        // ends: x = 0, y = 0, infinite ratios.
        let mut h = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = || {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            (h >> 11) as f64 / (1u64 << 53) as f64
        };
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
