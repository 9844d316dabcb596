//! The shaft between two boxes (Haines & Wallace 1991's box-to-box shaft): what a
//! link with a cluster end is tested by when an object moves (paper 000, section 2:
//! a link is affected only if the moved object enters the volume of its segments).
//!
//! How it works: every segment between a point of box `a` and a point of box `c`
//! lies in the convex hull of the two boxes, and that hull lies inside each of the
//! three prisms that project it onto a coordinate plane (the 2D hull of two
//! rectangles, extruded along the third axis). A 2D hull of two axis-aligned
//! rectangles is bounded by the coordinate lines of their joint box and by, at
//! most, four lines each through the same corner of both rectangles. So a box `x`
//! misses every segment if it misses the joint box, or if for one coordinate plane
//! and one corner the line through both rectangles' corners keeps all eight
//! corners on one side and `x`'s projection wholly on the other. Conservative
//! (the prisms' intersection is larger than the hull): "misses" is a proof.

use glam::DVec3;

/// An axis-aligned box `(lo, hi)`.
pub type Aabb = (DVec3, DVec3);

/// True if no point of box `x` lies on a segment between a point of box `a` and a
/// point of box `c` (module docs); `false` does not prove that one does.
pub fn box_shaft_misses(a: Aabb, c: Aabb, x: Aabb) -> bool {
    box_shaft_misses_all(a, c, std::slice::from_ref(&x))
}

/// True if [`box_shaft_misses`] holds for `a`, `c` and every box of `xs`, the
/// shaft's lines set up once for all the boxes (an interactive move's rows test
/// each shaft against the moved objects' boxes before and after): a box is
/// proved missed by the joint box or by one line, as the module docs say.
pub fn box_shaft_misses_all(a: Aabb, c: Aabb, xs: &[Aabb]) -> bool {
    if xs.len() > 64 {
        return xs.chunks(64).all(|xs| box_shaft_misses_all(a, c, xs));
    }
    let (lo, hi) = (a.0.min(c.0), a.1.max(c.1));
    let eps = (hi - lo).length() * 1e-9;
    // The boxes not proved missed yet (bit k: xs[k]).
    let mut left = 0u64;
    for (k, x) in xs.iter().enumerate() {
        if !((x.0 - DVec3::splat(eps)).cmpgt(hi).any() || (x.1 + DVec3::splat(eps)).cmplt(lo).any())
        {
            left |= 1 << k;
        }
    }
    if left == 0 {
        return true;
    }
    for (i, j) in [(0usize, 1usize), (1, 2), (0, 2)] {
        for (si, sj) in [(false, false), (true, false), (false, true), (true, true)] {
            let corner = |b: Aabb| {
                let pick = |k: usize, hi_side: bool| if hi_side { b.1[k] } else { b.0[k] };
                (pick(i, si), pick(j, sj))
            };
            let (p, q) = (corner(a), corner(c));
            // The line's normal, pointing away from the rectangles' far corners.
            let (dx, dy) = (q.0 - p.0, q.1 - p.1);
            let mut n = (dy, -dx);
            let out = (if si { 1.0 } else { -1.0 }, if sj { 1.0 } else { -1.0 });
            if n.0 * out.0 + n.1 * out.1 < 0.0 {
                n = (-n.0, -n.1);
            }
            if n.0 == 0.0 && n.1 == 0.0 {
                continue;
            }
            let d = n.0 * p.0 + n.1 * p.1;
            let tol = eps * (n.0.abs() + n.1.abs());
            // Largest and smallest of n · corner over a rectangle.
            let extent = |b: Aabb, max: bool| {
                let pick = |k: usize, w: f64| {
                    if (w >= 0.0) == max {
                        b.1[k] * w
                    } else {
                        b.0[k] * w
                    }
                };
                pick(i, n.0) + pick(j, n.1)
            };
            if extent(a, true) > d + tol || extent(c, true) > d + tol {
                continue; // not a side of the hull: some corner lies beyond
            }
            let mut rest = left;
            while rest != 0 {
                let k = rest.trailing_zeros();
                rest &= rest - 1;
                if extent(xs[k as usize], false) > d + tol {
                    left &= !(1 << k);
                }
            }
            if left == 0 {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(lo: [f64; 3], hi: [f64; 3]) -> Aabb {
        (DVec3::from_array(lo), DVec3::from_array(hi))
    }

    /// Brute force: sample segments between the boxes and check whether any
    /// passes through `x`.
    fn some_segment_meets(a: Aabb, c: Aabb, x: Aabb) -> bool {
        let at = |bx: Aabb, u: [f64; 3]| bx.0 + (bx.1 - bx.0) * DVec3::from_array(u);
        let g = [0.0, 0.25, 0.5, 0.75, 1.0];
        for &ux in &g {
            for &uy in &g {
                for &uz in &g {
                    for &vx in &g {
                        for &vy in &g {
                            for &vz in &g {
                                let (p, q) = (at(a, [ux, uy, uz]), at(c, [vx, vy, vz]));
                                for k in 0..=40 {
                                    let s = p + (q - p) * (k as f64 / 40.0);
                                    if s.cmpge(x.0).all() && s.cmple(x.1).all() {
                                        return true;
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        false
    }

    #[test]
    fn a_box_between_is_met_one_beside_is_missed() {
        let a = b([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        let c = b([4.0, 3.0, 0.0], [5.0, 4.0, 1.0]);
        // On the diagonal between them.
        let mid = b([2.2, 1.7, 0.2], [2.6, 2.1, 0.4]);
        assert!(!box_shaft_misses(a, c, mid));
        assert!(some_segment_meets(a, c, mid));
        // In the joint box, off the diagonal band (its corner below the line
        // through the boxes' (hi x, lo y) corners).
        let off = b([3.6, 0.0, 0.2], [4.0, 0.4, 0.4]);
        assert!(box_shaft_misses(a, c, off));
        assert!(!some_segment_meets(a, c, off));
        // Outside the joint box.
        assert!(box_shaft_misses(a, c, b([6.0, 0.0, 0.0], [7.0, 1.0, 1.0])));
    }

    /// The shaft set up once for several boxes answers as each box alone: over
    /// pairs of boxes and lists of boxes about them (in the joint box, beside it,
    /// across the diagonal band), `box_shaft_misses_all` is `all` of
    /// `box_shaft_misses`, and both answers occur.
    #[test]
    fn all_boxes_at_once_answer_as_each_box_alone() {
        let mut h = 0x9e37_79b9_7f4a_7c15u64;
        let mut r = || {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            (h >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut rbox = |scale: f64, size: f64| {
            let lo = DVec3::new(r(), r(), r()) * scale;
            (lo, lo + DVec3::new(r(), r(), r()) * size)
        };
        let (mut yes, mut no) = (0, 0);
        for _ in 0..2000 {
            let (a, c) = (rbox(4.0, 1.0), rbox(4.0, 1.0));
            let n = 1 + (rbox(1.0, 1.0).0.x * 4.0) as usize;
            let xs: Vec<Aabb> = (0..n).map(|_| rbox(4.0, 0.4)).collect();
            let each = xs.iter().all(|&x| box_shaft_misses(a, c, x));
            assert_eq!(box_shaft_misses_all(a, c, &xs), each, "{a:?} {c:?} {xs:?}");
            if each { yes += 1 } else { no += 1 }
        }
        assert!(yes > 100 && no > 100, "{yes} {no}");
    }

    #[test]
    fn never_misses_a_box_a_segment_meets() {
        // A grid of small boxes around two boxes placed at random-looking offsets:
        // a "misses" answer is never wrong, and the test culls a good share.
        let pairs = [
            (
                b([0.0, 0.0, 0.0], [1.0, 0.5, 2.0]),
                b([3.0, 2.0, -1.0], [3.5, 3.0, 0.0]),
            ),
            (
                b([0.0, 0.0, 0.0], [0.2, 2.0, 0.2]),
                b([2.0, 0.5, 2.0], [2.1, 0.7, 2.5]),
            ),
            (
                b([-1.0, 0.0, 0.0], [0.0, 0.1, 1.0]),
                b([1.0, 0.0, 3.0], [2.0, 0.1, 4.0]),
            ),
        ];
        let mut missed = 0;
        let mut total = 0;
        for (a, c) in pairs {
            let (lo, hi) = (a.0.min(c.0), a.1.max(c.1));
            let step = (hi - lo) / 6.0;
            for ix in 0..6 {
                for iy in 0..6 {
                    for iz in 0..6 {
                        let l = lo + step * DVec3::new(ix as f64, iy as f64, iz as f64);
                        let x = (l + step * 0.3, l + step * 0.7);
                        total += 1;
                        if box_shaft_misses(a, c, x) {
                            missed += 1;
                            assert!(!some_segment_meets(a, c, x), "{a:?} {c:?} {x:?}");
                        }
                    }
                }
            }
        }
        assert!(missed * 5 > total, "{missed} of {total} culled");
    }
}
