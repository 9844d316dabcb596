//! Posed flatland geometry: segments split into elements, the distinct element
//! endpoints ("points", whose dual curves carry the visibility complex, paper §2.3),
//! and the cast of one line through the scene.
//!
//! How it works: a line is given in normal form `(theta, p)`: direction
//! `d = (cos theta, sin theta)`, normal `n = (-sin theta, cos theta)`, points `x` with
//! `x . n = p` (the paper's duality of §2.3 with this parametrisation: the lines through
//! a point `v` form the curve `p = v . n(theta)`). A cast intersects the line with every
//! input segment (O(n)) and maps each hit to its element by binary search on the
//! segment's split parameters.
//!
//! What it does not do: no acceleration structure for casts (scenes here have at most
//! a few hundred segments); a line through a point exactly is not classified (the
//! sweep only casts lines strictly inside a gap, which pass through no point).

use std::collections::HashMap;

use super::scene::PosedSegment;

/// Index of a point (distinct element endpoint) in [`FlatGeometry::points`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PointId(pub u32);

/// Index of an element in [`FlatGeometry::elements`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ElemId(pub u32);

/// One element: the part `[t0, t1]` of an input segment. 64 bytes (60 + padding).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Element {
    /// First endpoint.
    pub a: [f64; 2],
    /// Second endpoint.
    pub b: [f64; 2],
    /// Parameter range on the segment.
    pub t: [f64; 2],
    /// Length.
    pub len: f64,
    /// The input segment (global index).
    pub segment: u32,
}
const _: () = assert!(std::mem::size_of::<Element>() == 64);

/// A posed, meshed scene.
#[derive(Clone, Debug)]
pub struct FlatGeometry {
    /// Input segments posed at one time.
    pub segments: Vec<PosedSegment>,
    /// Elements, grouped by segment in segment order.
    pub elements: Vec<Element>,
    /// `segment_elements[s]..segment_elements[s + 1]`: the elements of segment `s`.
    pub segment_elements: Vec<u32>,
    /// Distinct element endpoints (shared corners appear once).
    pub points: Vec<[f64; 2]>,
    /// For each point, the input segments having it as an endpoint or split point.
    pub point_segments: Vec<Vec<u32>>,
}

/// A hit of a cast line with an element, at abscissa `s` along the line's direction.
/// 16 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Abscissa along `d`.
    pub s: f64,
    /// The element hit.
    pub elem: u32,
    /// Its input segment.
    pub segment: u32,
}

const _: () = assert!(std::mem::size_of::<Hit>() == 16);

impl FlatGeometry {
    /// Builds the geometry from posed segments and, per segment, the sorted interior
    /// split parameters in `(0, 1)` (empty = the segment is one element).
    pub fn new(segments: Vec<PosedSegment>, splits: &[Vec<f64>]) -> Self {
        let mut elements = Vec::new();
        let mut segment_elements = Vec::with_capacity(segments.len() + 1);
        let mut points = Vec::new();
        let mut point_segments: Vec<Vec<u32>> = Vec::new();
        let mut index: HashMap<(u64, u64), u32> = HashMap::new();
        let mut add_point = |p: [f64; 2], s: u32, points: &mut Vec<[f64; 2]>| {
            let key = ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits());
            let id = *index.entry(key).or_insert_with(|| {
                points.push(p);
                point_segments.push(Vec::new());
                (points.len() - 1) as u32
            });
            if !point_segments[id as usize].contains(&s) {
                point_segments[id as usize].push(s);
            }
        };
        for (si, seg) in segments.iter().enumerate() {
            segment_elements.push(elements.len() as u32);
            let mut ts = vec![0.0];
            if let Some(sp) = splits.get(si) {
                ts.extend(sp.iter().copied().filter(|t| *t > 0.0 && *t < 1.0));
            }
            ts.push(1.0);
            for w in ts.windows(2) {
                let (a, b) = (seg.at(w[0]), seg.at(w[1]));
                let a = if w[0] == 0.0 { seg.a } else { a };
                let b = if w[1] == 1.0 { seg.b } else { b };
                elements.push(Element {
                    a,
                    b,
                    t: [w[0], w[1]],
                    len: (b[0] - a[0]).hypot(b[1] - a[1]),
                    segment: si as u32,
                });
            }
            for &t in &ts {
                let p = if t == 0.0 {
                    seg.a
                } else if t == 1.0 {
                    seg.b
                } else {
                    seg.at(t)
                };
                add_point(p, si as u32, &mut points);
            }
        }
        segment_elements.push(elements.len() as u32);
        FlatGeometry {
            segments,
            elements,
            segment_elements,
            points,
            point_segments,
        }
    }

    /// The element of segment `s` containing parameter `t`.
    pub fn element_at(&self, s: u32, t: f64) -> u32 {
        let lo = self.segment_elements[s as usize] as usize;
        let hi = self.segment_elements[s as usize + 1] as usize;
        let els = &self.elements[lo..hi];
        let k = els.partition_point(|e| e.t[1] <= t).min(els.len() - 1);
        (lo + k) as u32
    }

    /// Intersects the line `(theta, p)` with every segment; hits sorted along `d`.
    pub fn cast(&self, theta: f64, p: f64, out: &mut Vec<Hit>) {
        self.cast_sc(theta.sin_cos(), p, out);
    }

    /// [`FlatGeometry::cast`] with `(sin theta, cos theta)` given.
    pub fn cast_sc(&self, (sn, cs): (f64, f64), p: f64, out: &mut Vec<Hit>) {
        out.clear();
        let d = [cs, sn];
        let n = [-sn, cs];
        for (si, seg) in self.segments.iter().enumerate() {
            let da = seg.a[0] * n[0] + seg.a[1] * n[1] - p;
            let db = seg.b[0] * n[0] + seg.b[1] * n[1] - p;
            if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                let t = da / (da - db);
                let sa = seg.a[0] * d[0] + seg.a[1] * d[1];
                let sb = seg.b[0] * d[0] + seg.b[1] * d[1];
                out.push(Hit {
                    s: sa + t * (sb - sa),
                    elem: self.element_at(si as u32, t),
                    segment: si as u32,
                });
            }
        }
        out.sort_by(|x, y| x.s.total_cmp(&y.s));
    }

    /// Whether the free segment between consecutive hits `h0` then `h1` (along `d` of
    /// angle `theta`) leaves `h0`'s lit side and arrives on `h1`'s lit side.
    pub fn fronts_face(&self, theta: f64, h0: &Hit, h1: &Hit) -> bool {
        self.fronts_face_sc(theta.sin_cos(), h0, h1)
    }

    /// [`FlatGeometry::fronts_face`] with `(sin theta, cos theta)` given.
    pub fn fronts_face_sc(&self, (sn, cs): (f64, f64), h0: &Hit, h1: &Hit) -> bool {
        let n0 = self.segments[h0.segment as usize].n;
        let n1 = self.segments[h1.segment as usize].n;
        cs * n0[0] + sn * n0[1] > 0.0 && cs * n1[0] + sn * n1[1] < 0.0
    }

    /// True if the open segment `u w` meets no input segment (a visibility-graph edge,
    /// i.e. a vertex of the visibility complex, §2.2).
    pub fn sees(&self, u: [f64; 2], w: [f64; 2]) -> bool {
        use super::scene::orient;
        for seg in &self.segments {
            let d1 = orient(u, w, seg.a);
            let d2 = orient(u, w, seg.b);
            let d3 = orient(seg.a, seg.b, u);
            let d4 = orient(seg.a, seg.b, w);
            let inside = |p: [f64; 2]| {
                let t = (p[0] - u[0]) * (w[0] - u[0]) + (p[1] - u[1]) * (w[1] - u[1]);
                let l2 = (w[0] - u[0]).powi(2) + (w[1] - u[1]).powi(2);
                t > 0.0 && t < l2
            };
            if d1 == 0.0 && d2 == 0.0 {
                // Collinear: blocked if the segment overlaps the open segment u w.
                let dir = [w[0] - u[0], w[1] - u[1]];
                let proj = |p: [f64; 2]| (p[0] - u[0]) * dir[0] + (p[1] - u[1]) * dir[1];
                let l2 = dir[0] * dir[0] + dir[1] * dir[1];
                let (p0, p1) = (proj(seg.a), proj(seg.b));
                if p0.min(p1).max(0.0) < p1.max(p0).min(l2) {
                    return false;
                }
                continue;
            }
            // A segment endpoint strictly inside u w blocks (touching counts).
            if (d1 == 0.0 && inside(seg.a)) || (d2 == 0.0 && inside(seg.b)) {
                return false;
            }
            if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
                return false;
            }
        }
        true
    }
}

/// A map keyed by element pairs `(i, j)`, `i < j`, with a fast multiplicative hash
/// (keys are small integers chosen by the program, not by an adversary).
pub type PairMap = HashMap<(u32, u32), f64, std::hash::BuildHasherDefault<PairHasher>>;

/// The hasher of [`PairMap`]: one multiply-rotate per written integer (FxHash style).
#[derive(Clone, Copy, Debug, Default)]
pub struct PairHasher(u64);

impl std::hash::Hasher for PairHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

/// `(cos theta, sin theta)`: the antiderivative of `n(theta)` used in every exact
/// measure `integral x . n(theta) dtheta = x . (N(t1) - N(t0))`.
#[inline]
pub fn big_n(theta: f64) -> [f64; 2] {
    let (s, c) = theta.sin_cos();
    [c, s]
}

/// `v . n(theta)`: the dual curve of point `v` at `theta`.
#[inline]
pub fn proj(v: [f64; 2], theta: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    -v[0] * s + v[1] * c
}
