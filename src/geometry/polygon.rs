//! [`Poly`]: a convex planar polygon of at most 8 corners in `f64`, the shape of every
//! patch, element and clipped source in the form-factor code. Fixed capacity so that
//! kernels never allocate.

use glam::DVec3;

/// Most corners a [`Poly`] holds: a quad clipped by one plane has at most 5, by two 6.
pub const MAX_CORNERS: usize = 8;

/// A convex planar polygon, corners counter-clockwise seen from its front. 200 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Poly {
    /// Corners; only the first `n` are valid.
    pub v: [DVec3; MAX_CORNERS],
    /// Number of valid corners.
    pub n: usize,
}

impl Poly {
    /// A polygon from 3 or 4 (up to 8) corners.
    pub fn new(corners: &[DVec3]) -> Self {
        let mut v = [DVec3::ZERO; MAX_CORNERS];
        let n = corners.len().min(MAX_CORNERS);
        // Corner by corner: `copy_from_slice` of a length only known at run time
        // is a call to `memcpy`, 1.3% of ACTOR's space-time solve for 3 or 4 corners.
        for (d, &c) in v.iter_mut().zip(&corners[..n]) {
            *d = c;
        }
        Poly { v, n }
    }

    /// The valid corners.
    pub fn corners(&self) -> &[DVec3] {
        &self.v[..self.n]
    }

    /// Newell's vector: normal times twice the area (robust for any planar polygon).
    pub fn area_vector(&self) -> DVec3 {
        let mut s = DVec3::ZERO;
        let c = self.corners();
        if c.is_empty() {
            return s;
        }
        let o = c[0];
        for i in 1..c.len().saturating_sub(1) {
            s += (c[i] - o).cross(c[i + 1] - o);
        }
        s
    }

    /// Area.
    pub fn area(&self) -> f64 {
        0.5 * self.area_vector().length()
    }

    /// Unit normal (zero for a degenerate polygon).
    pub fn normal(&self) -> DVec3 {
        self.area_vector().normalize_or_zero()
    }

    /// The box of the corners: `(lo, hi)`, both infinite for no corner.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.corners().iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &c| (lo.min(c), hi.max(c)),
        )
    }

    /// Area-weighted centroid.
    pub fn centroid(&self) -> DVec3 {
        centroid_of(self.corners())
    }

    /// True if `x` (in the plane of the polygon, whose normal is `n`) lies inside it,
    /// more than `tol` inwards from every edge (a negative `tol` admits points that
    /// far outside).
    pub fn contains(&self, n: DVec3, x: DVec3, tol: f64) -> bool {
        let v = self.corners();
        (0..v.len()).all(|k| {
            let e = v[(k + 1) % v.len()] - v[k];
            let len = e.length();
            len > 0.0 && e.cross(x - v[k]).dot(n) / len > tol
        })
    }

    /// Longest distance between two corners.
    pub fn diameter(&self) -> f64 {
        let c = self.corners();
        let mut d: f64 = 0.0;
        for i in 0..c.len() {
            for j in i + 1..c.len() {
                d = d.max(c[i].distance_squared(c[j]));
            }
        }
        d.sqrt()
    }

    /// The part of the polygon on the side `n · (p - x) >= 0` of the plane through `x`
    /// with normal `n` (Sutherland–Hodgman against one plane).
    pub fn clip_front(&self, x: DVec3, n: DVec3) -> Poly {
        self.clip(x, n, |da| da >= 0.0, |da, db| (da >= 0.0) != (db >= 0.0))
    }

    /// [`Poly::clip_front`] with corners within `tol` of the plane taken as on it:
    /// kept, on both sides, and no edge cut next to them. Compared exactly, a
    /// corner a rounding off the plane either stayed alone or came back twice (the
    /// corner and a cut point a rounding away from it): a contact line through a
    /// floor tile's corner made a quad with a repeated corner in metres and a
    /// triangle in millimetres, and the hierarchies differed (issue 45, part 3).
    pub fn clip_front_within(&self, x: DVec3, n: DVec3, tol: f64) -> Poly {
        self.clip(
            x,
            n,
            |da| da >= -tol,
            |da, db| (da > tol && db < -tol) || (da < -tol && db > tol),
        )
    }

    /// Sutherland–Hodgman against the plane through `x` with normal `n`: corner `a`
    /// is kept if `keep(n · (a - x))`, and the edge `a b` is cut if `cuts` of both
    /// ends' distances.
    #[inline]
    fn clip(
        &self,
        x: DVec3,
        n: DVec3,
        keep: impl Fn(f64) -> bool,
        cuts: impl Fn(f64, f64) -> bool,
    ) -> Poly {
        let mut out = Poly {
            v: [DVec3::ZERO; MAX_CORNERS],
            n: 0,
        };
        let c = self.corners();
        let k = c.len();
        for i in 0..k {
            let a = c[i];
            let b = c[(i + 1) % k];
            let da = n.dot(a - x);
            let db = n.dot(b - x);
            if keep(da) && out.n < MAX_CORNERS {
                out.v[out.n] = a;
                out.n += 1;
            }
            if cuts(da, db) && out.n < MAX_CORNERS {
                let s = da / (da - db);
                out.v[out.n] = a + s * (b - a);
                out.n += 1;
            }
        }
        out
    }
}

/// Area-weighted centroid of the convex planar polygon with corners `c` (the mean
/// of the corners if it has no area): [`Poly::centroid`], on any corner slice.
pub fn centroid_of(c: &[DVec3]) -> DVec3 {
    if c.len() < 3 {
        return c.iter().copied().sum::<DVec3>() / (c.len().max(1) as f64);
    }
    let o = c[0];
    let mut acc = DVec3::ZERO;
    let mut w = 0.0;
    for i in 1..c.len() - 1 {
        let a = (c[i] - o).cross(c[i + 1] - o).length();
        acc += a * (o + c[i] + c[i + 1]) / 3.0;
        w += a;
    }
    if w > 0.0 {
        acc / w
    } else {
        c.iter().copied().sum::<DVec3>() / c.len() as f64
    }
}

/// Narrows the parameter range `t = [t0, t1]` of a segment `p + t d` to where
/// `at + t slope >= 0` (one half-space of Cyrus & Beck's clipping: `at` the
/// constraint's value at `p`, `slope` its change along `d`). Returns false where
/// the segment runs parallel to the boundary on its outside; an empty range
/// otherwise shows as `t0 > t1`.
#[inline]
pub fn clip_to_half_space(t: &mut [f64; 2], at: f64, slope: f64) -> bool {
    if slope == 0.0 {
        // Parallel: all or nothing (a NaN `at` excludes nothing).
        return at.partial_cmp(&0.0) != Some(std::cmp::Ordering::Less);
    }
    let cut = -at / slope;
    if slope > 0.0 {
        t[0] = t[0].max(cut);
    } else {
        t[1] = t[1].min(cut);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_square_area_normal_centroid() {
        let p = Poly::new(&[
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ]);
        assert!((p.area() - 1.0).abs() < 1e-15);
        assert_eq!(p.normal(), DVec3::Z);
        assert!((p.centroid() - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-15);
        assert!((p.diameter() - 2f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn clipping_keeps_the_front_half() {
        let p = Poly::new(&[
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
        ]);
        let c = p.clip_front(DVec3::ZERO, DVec3::X);
        assert_eq!(c.n, 4);
        assert!((c.area() - 1.0).abs() < 1e-15);
        let none = p.clip_front(DVec3::new(2.0, 0.0, 0.0), DVec3::X);
        assert_eq!(none.n, 0);
    }

    /// A cut along a diagonal whose corners lie a rounding off the line gives two
    /// triangles, each with the diagonal's corners once, whichever side the
    /// rounding puts them (exactly, one half has a repeated corner).
    #[test]
    fn clipping_within_a_tolerance_keeps_corners_on_the_line_once() {
        let p = Poly::new(&[
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ]);
        let m = DVec3::new(1.0, -1.0, 0.0).normalize();
        for off in [-1e-17, 0.0, 1e-17] {
            let x = DVec3::new(off, 0.0, 0.0);
            for side in [m, -m] {
                let half = p.clip_front_within(x, side, 1e-9);
                assert_eq!(half.n, 3, "{off} {side}: {:?}", half.corners());
                assert!((half.area() - 0.5).abs() < 1e-15);
            }
        }
        // Exactly, each corner on the line comes back as a cut point too.
        let exact = p.clip_front(DVec3::ZERO, -m);
        assert_eq!(exact.n, 5);
        assert_eq!((exact.v[0], exact.v[2]), (exact.v[1], exact.v[3]));
    }
}
