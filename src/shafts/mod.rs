//! Shafts: the convex volume holding every segment between two convex polygons, used
//! to prove a link unoccluded without casting a ray (Haines & Wallace, "Shaft
//! culling for efficient ray-traced radiosity", 1991; the line-space hierarchy of
//! paper 000 keeps such shafts per link).
//!
//! A [`Shaft`] is the bounding box of both polygons plus the planes of their convex
//! hull that pass through an edge of one polygon and a corner of the other (every hull
//! face other than the two polygons themselves is of that form, since a hull face
//! cannot hold a diagonal of a convex polygon). A triangle is outside the shaft when
//! all its corners lie outside one plane, outside the box, or behind either polygon's
//! own plane (a segment between the two polygons never crosses behind its ends).
//!
//! [`Shaft::is_clear`] asks the scene's BVH for the triangles overlapping the box and
//! stops at the first one it cannot cull: "clear" is a proof, "not clear" only means
//! rays must decide.

use glam::DVec3;

use crate::geometry::SceneBvh;

/// Most planes a shaft keeps (two quads: 8 edges × 4 corners candidates, few survive).
const MAX_PLANES: usize = 16;

/// A shaft between two convex polygons. 432 bytes.
#[derive(Clone, Copy, Debug)]
pub struct Shaft {
    /// Box of both polygons.
    pub lo: DVec3,
    /// Box of both polygons.
    pub hi: DVec3,
    /// Hull planes `(n, d)`: inside is `n · p <= d`.
    planes: [(DVec3, f64); MAX_PLANES],
    count: usize,
    /// Planes of the two polygons `(n, d)`, front is `n · p > d`.
    ends: [(DVec3, f64); 2],
    /// Tolerance in length units.
    eps: f64,
}

impl Shaft {
    /// The shaft between polygons `a` and `b` (corners in order, 3 to 4 each), whose
    /// unit normals are `na`, `nb`.
    pub fn new(a: &[DVec3], na: DVec3, b: &[DVec3], nb: DVec3) -> Shaft {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for &p in a.iter().chain(b) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let eps = (hi - lo).length() * 1e-9;
        let mut s = Shaft {
            lo,
            hi,
            planes: [(DVec3::ZERO, 0.0); MAX_PLANES],
            count: 0,
            ends: [(na, na.dot(a[0])), (nb, nb.dot(b[0]))],
            eps,
        };
        s.add_edge_planes(a, b);
        s.add_edge_planes(b, a);
        s
    }

    fn add_edge_planes(&mut self, edges_of: &[DVec3], corners_of: &[DVec3]) {
        let k = edges_of.len();
        for i in 0..k {
            let (p, q) = (edges_of[i], edges_of[(i + 1) % k]);
            for &c in corners_of {
                if self.count == MAX_PLANES {
                    return;
                }
                let n = (q - p).cross(c - p);
                let len = n.length();
                if len <= self.eps * (q - p).length() {
                    continue;
                }
                let n = n / len;
                let d = n.dot(p);
                // Orient so every corner of both polygons is inside (n·x <= d).
                let (mut above, mut below) = (false, false);
                for &x in edges_of.iter().chain(corners_of) {
                    let s = n.dot(x) - d;
                    above |= s > self.eps;
                    below |= s < -self.eps;
                }
                match (above, below) {
                    (true, true) => continue, // not a hull face
                    (true, false) => self.planes[self.count] = (-n, -d),
                    _ => self.planes[self.count] = (n, d),
                }
                self.count += 1;
            }
        }
    }

    /// True if no point of the box `[lo, hi]` can lie on a segment between the two
    /// polygons (the box is outside the shaft's box, behind an end, or outside a hull
    /// plane). Conservative: `false` does not prove an overlap.
    pub fn misses_box(&self, lo: DVec3, hi: DVec3) -> bool {
        let eps = self.eps;
        if (0..3).any(|a| hi[a] < self.lo[a] - eps || lo[a] > self.hi[a] + eps) {
            return true;
        }
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        });
        for &(n, d) in &self.ends {
            if corners.iter().all(|v| n.dot(*v) - d <= eps) {
                return true;
            }
        }
        for &(n, d) in &self.planes[..self.count] {
            if corners.iter().all(|v| n.dot(*v) - d >= -eps) {
                return true;
            }
        }
        false
    }

    /// True if the triangle `t` cannot meet any segment between the two polygons.
    pub fn culls(&self, t: &[DVec3; 3]) -> bool {
        let eps = self.eps;
        for axis in 0..3 {
            if t.iter().all(|v| v[axis] < self.lo[axis] - eps)
                || t.iter().all(|v| v[axis] > self.hi[axis] + eps)
            {
                return true;
            }
        }
        for &(n, d) in &self.ends {
            if t.iter().all(|v| n.dot(*v) - d <= eps) {
                return true;
            }
        }
        for &(n, d) in &self.planes[..self.count] {
            if t.iter().all(|v| n.dot(*v) - d >= -eps) {
                return true;
            }
        }
        false
    }

    /// True if no triangle of `bvh` other than those of patches `skip` can block a
    /// segment between the two polygons.
    pub fn is_clear(&self, bvh: &SceneBvh, skip: [u32; 2]) -> bool {
        bvh.for_each_triangle_in_box(self.lo, self.hi, |patch, tri| {
            patch == skip[0] || patch == skip[1] || self.culls(&tri)
        })
    }
}

/// How far inside a box (a fraction of the diagonal of the two ends' box) the
/// segment between two ends' centres must run for [`clear_of_boxes`] to decide that
/// the shaft between them meets the box without building it: 1000 times the
/// shaft's own tolerance, so the answer is the shaft's.
const SHORTCUT_MARGIN: f64 = 1e-6;

/// True if the box `[lo, hi]` meets one of `boxes` (closed boxes: touching counts).
pub fn meets_any(lo: DVec3, hi: DVec3, boxes: &[(DVec3, DVec3)]) -> bool {
    boxes
        .iter()
        .any(|&(a, b)| a.cmple(hi).all() && lo.cmple(b).all())
}

/// True if no box of `boxes` can lie on a segment between the polygons `a` and `b`
/// (corners in order, unit normals `na`, `nb`; `a` may be a single point, seen
/// from the side `na` faces). Decided as cheaply as it can be: boxes that miss the
/// box of both ends need nothing more (most of them, for the current boxes of the
/// moving objects); a box on the line between the two centres, in front of both
/// ends, meets the shaft ([`segment_crosses_box`]); only then is the [`Shaft`]
/// built and every box tried against it ([`Shaft::misses_box`]).
pub fn clear_of_boxes(
    a: &[DVec3],
    na: DVec3,
    b: &[DVec3],
    nb: DVec3,
    boxes: &[(DVec3, DVec3)],
) -> bool {
    let (lo, hi) = a
        .iter()
        .chain(b)
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &c| {
            (lo.min(c), hi.max(c))
        });
    if !meets_any(lo, hi, boxes) {
        return true;
    }
    let centre = |p: &[DVec3]| p.iter().sum::<DVec3>() / p.len() as f64;
    let ends = [(na, na.dot(a[0])), (nb, nb.dot(b[0]))];
    let margin = SHORTCUT_MARGIN * (hi - lo).length();
    let (ca, cb) = (centre(a), centre(b));
    if boxes
        .iter()
        .any(|&(l, h)| segment_crosses_box(ca, cb, l, h, ends, margin))
    {
        return false;
    }
    let shaft = Shaft::new(a, na, b, nb);
    boxes.iter().all(|&(l, h)| shaft.misses_box(l, h))
}

/// True if the segment `p q` runs through the box `[lo, hi]` shrunk by `margin` on
/// every side (a slab test), at a place at least `margin` in front of both planes
/// `ends` (`(n, d)`, front is `n · x > d`). When `p` and `q` lie on the two polygons
/// of a shaft (their centroids, say) and `ends` are the polygons' planes, the shaft
/// then meets the box whatever its hull planes, so [`Shaft::misses_box`] is false:
/// a caller that only needs that answer need not build the shaft. (A shaft ignores
/// what lies behind either polygon, hence the planes.) `margin` above the shaft's
/// tolerance (`1e-9` of its box's diagonal) keeps the answer exactly the one
/// `misses_box` gives.
pub fn segment_crosses_box(
    p: DVec3,
    q: DVec3,
    lo: DVec3,
    hi: DVec3,
    ends: [(DVec3, f64); 2],
    margin: f64,
) -> bool {
    let (lo, hi) = (lo + DVec3::splat(margin), hi - DVec3::splat(margin));
    let d = q - p;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    // In front of each end plane by `margin`: n·p + t n·d >= e + margin.
    for (n, e) in ends {
        let (at, slope) = (n.dot(p) - e - margin, n.dot(d));
        if slope == 0.0 {
            if at < 0.0 {
                return false;
            }
        } else if slope > 0.0 {
            t0 = t0.max(-at / slope);
        } else {
            t1 = t1.min(-at / slope);
        }
    }
    if t0 > t1 {
        return false;
    }
    for k in 0..3 {
        if lo[k] > hi[k] {
            return false;
        }
        if d[k] == 0.0 {
            if p[k] < lo[k] || p[k] > hi[k] {
                return false;
            }
            continue;
        }
        let (a, b) = ((lo[k] - p[k]) / d[k], (hi[k] - p[k]) / d[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
        if t0 > t1 {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64, up: bool) -> Vec<DVec3> {
        let mut v = vec![
            DVec3::new(0.0, 0.0, z),
            DVec3::new(1.0, 0.0, z),
            DVec3::new(1.0, 1.0, z),
            DVec3::new(0.0, 1.0, z),
        ];
        if !up {
            v.reverse();
        }
        v
    }

    #[test]
    fn blocker_between_is_not_culled_and_side_walls_are() {
        let (a, b) = (square(0.0, true), square(1.0, false));
        let s = Shaft::new(&a, DVec3::Z, &b, -DVec3::Z);
        // A triangle across the middle blocks.
        let mid = [
            DVec3::new(0.2, 0.2, 0.5),
            DVec3::new(0.8, 0.2, 0.5),
            DVec3::new(0.5, 0.8, 0.5),
        ];
        assert!(!s.culls(&mid));
        // A wall on the side x = 0 plane touches the hull but cannot block.
        let wall = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.5, 1.0),
        ];
        assert!(s.culls(&wall));
        // Outside the box.
        let far = [
            DVec3::new(3.0, 0.0, 0.5),
            DVec3::new(4.0, 0.0, 0.5),
            DVec3::new(3.0, 1.0, 0.5),
        ];
        assert!(s.culls(&far));
    }

    #[test]
    fn hull_planes_cull_inside_the_box_but_outside_the_hull() {
        // Small squares in opposite corners of a big box: the box's middle corner
        // regions are outside the hull.
        let a: Vec<DVec3> = square(0.0, true).iter().map(|p| *p * 0.1).collect();
        let b: Vec<DVec3> = square(0.0, false)
            .iter()
            .map(|p| *p * 0.1 + DVec3::new(0.9, 0.9, 1.0))
            .collect();
        let s = Shaft::new(&a, DVec3::Z, &b, -DVec3::Z);
        let off = [
            DVec3::new(0.9, 0.0, 0.5),
            DVec3::new(1.0, 0.0, 0.5),
            DVec3::new(1.0, 0.1, 0.5),
        ];
        assert!(s.culls(&off));
        let on = [
            DVec3::new(0.45, 0.45, 0.5),
            DVec3::new(0.6, 0.5, 0.5),
            DVec3::new(0.5, 0.6, 0.5),
        ];
        assert!(!s.culls(&on));
    }

    #[test]
    fn a_box_the_centres_segment_crosses_is_never_missed() {
        // Random quads and boxes: wherever the segment between the quads' centroids
        // runs through a box, the shaft must not miss it (the shortcut callers take
        // before building a shaft); and the shortcut must fire on a fair share.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let quad = |z: f64, up: bool, rnd: &mut dyn FnMut() -> f64| {
            let (x, y, w) = (rnd() * 4.0, rnd() * 4.0, 0.2 + rnd());
            let mut q = square(0.0, up);
            for v in &mut q {
                *v = DVec3::new(x + v.x * w, y + v.y * w, z);
            }
            q
        };
        let (mut crossed, mut missed_elsewhere) = (0, 0);
        for i in 0..4000 {
            let a = quad(0.0, true, &mut rnd);
            // Half the pairs face each other; in the other half `b` stands upright
            // beside `a`, partly behind `a`'s plane, where a shaft ignores boxes.
            let (b, nb) = if i % 2 == 0 {
                (quad(2.0 + rnd() * 2.0, false, &mut rnd), -DVec3::Z)
            } else {
                let (x, y, z, w) = (5.0 + rnd(), rnd() * 4.0, rnd() - 0.9, 0.2 + rnd());
                let b = vec![
                    DVec3::new(x, y, z),
                    DVec3::new(x, y, z + w),
                    DVec3::new(x, y + w, z + w),
                    DVec3::new(x, y + w, z),
                ];
                (b, -DVec3::X)
            };
            let s = Shaft::new(&a, DVec3::Z, &b, nb);
            let c = |p: &[DVec3]| p.iter().sum::<DVec3>() / p.len() as f64;
            // Boxes about the segment: some across it, some beside it.
            let on = c(&a).lerp(c(&b), rnd());
            let lo = on - DVec3::new(rnd(), rnd(), rnd()) * 0.8;
            let hi = lo + DVec3::new(0.05 + rnd(), 0.05 + rnd(), 0.05 + rnd());
            let ends = [(DVec3::Z, 0.0), (nb, nb.dot(b[0]))];
            if segment_crosses_box(c(&a), c(&b), lo, hi, ends, 1e-6) {
                crossed += 1;
                assert!(
                    !s.misses_box(lo, hi),
                    "box {lo} {hi} between {a:?} and {b:?}"
                );
            } else {
                missed_elsewhere += s.misses_box(lo, hi) as u32;
            }
        }
        // Measured 1 339 crossed, 1 199 of the rest missed.
        assert!(
            crossed > 1000 && missed_elsewhere > 800,
            "{crossed} crossed, {missed_elsewhere} missed"
        );
        // On the box's face (within the margin) it does not count, nor does a box
        // behind an end.
        let x = DVec3::new(0.0, 0.5, 0.5);
        let open = [(DVec3::X, -1.0), (-DVec3::X, -2.0)];
        let face = DVec3::new(0.0, 0.5, 0.5);
        assert!(!segment_crosses_box(
            x,
            x + DVec3::X,
            face,
            DVec3::ONE,
            open,
            1e-6
        ));
        let inner = DVec3::new(0.0, 0.4, 0.4);
        assert!(segment_crosses_box(
            x,
            x + DVec3::X,
            inner,
            DVec3::ONE,
            open,
            1e-6
        ));
        let behind = [(DVec3::X, 0.99), (-DVec3::X, -2.0)];
        assert!(!segment_crosses_box(
            x,
            x + DVec3::X,
            inner,
            DVec3::new(0.9, 1.0, 1.0),
            behind,
            1e-6
        ));
    }
}
