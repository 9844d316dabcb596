//! Meshing of flatland segments into elements: none, uniform, or the discontinuity
//! mesh derived from the visibility complex (paper §3.2, §4.1, Figures 8–9).
//!
//! How it works (discontinuity): every vertex of the complex is a line through two
//! mutually visible points `u, w`. Its maximal free segment is extended past `u` and
//! past `w` while the line is tangent there (the point's segments all on one side), up
//! to the first segment hit on each side. If the part of that line on one side of a hit
//! point `q` touches a light source (ends on an emitting segment, or passes through or
//! stops at an endpoint of one), then `q` is a point where the visibility of that
//! source changes for the receiver through `q` (types (1)–(5) of Figure 9), and the
//! receiver is split there when `q` is strictly inside it and the line reaches its lit
//! side. Splits closer than `1e-9` (in segment parameter) are merged.
//!
//! What it does not do: only discontinuities of direct light (sources = segments with
//! emission); those of indirect light (every element is a secondary source) are not
//! added, and there is no adaptive refinement beyond the discontinuities.

use super::complex::sweep;
use super::geometry::FlatGeometry;
use super::scene::{PosedSegment, orient};

/// How segments are split into elements.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mesh {
    /// Every input segment is one element.
    None,
    /// Split where the visibility of a light source changes.
    Discontinuity,
    /// Every segment split into `N` equal elements.
    Uniform(u32),
}

impl std::str::FromStr for Mesh {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Mesh::None),
            "discontinuity" => Ok(Mesh::Discontinuity),
            _ => match s.strip_prefix("uniform:").map(str::parse::<u32>) {
                Some(Ok(n)) if (1..=10_000).contains(&n) => Ok(Mesh::Uniform(n)),
                _ => Err(format!(
                    "expected none, discontinuity or uniform:N (1 <= N <= 10000), found {s:?}"
                )),
            },
        }
    }
}

/// Split parameters per segment for `mesh`; `emitters[s]` says whether segment `s`
/// emits.
pub fn splits(segments: &[PosedSegment], emitters: &[bool], mesh: Mesh) -> Vec<Vec<f64>> {
    match mesh {
        Mesh::None => vec![Vec::new(); segments.len()],
        Mesh::Uniform(n) => {
            let ts: Vec<f64> = (1..n).map(|k| k as f64 / n as f64).collect();
            vec![ts; segments.len()]
        }
        Mesh::Discontinuity => discontinuities(segments, emitters),
    }
}

/// The discontinuity points of direct light, as sorted parameters per segment.
pub fn discontinuities(segments: &[PosedSegment], emitters: &[bool]) -> Vec<Vec<f64>> {
    let geom = FlatGeometry::new(segments.to_vec(), &[]);
    let mut out = vec![Vec::new(); segments.len()];
    if !emitters.iter().any(|&e| e) {
        return out;
    }
    let complex = sweep(&geom, None, true).complex.unwrap_or_default();
    let touches_emitter = |p: u32| {
        geom.point_segments[p as usize]
            .iter()
            .any(|&s| emitters[s as usize])
    };
    for v in &complex.vertices {
        let (pu, pw) = (geom.points[v.u as usize], geom.points[v.w as usize]);
        let d = [(pw[0] - pu[0]) / v.length, (pw[1] - pu[1]) / v.length];
        let back = [-d[0], -d[1]];
        let end_w = extend(&geom, v.w, d);
        let end_u = extend(&geom, v.u, back);
        let through = touches_emitter(v.u) || touches_emitter(v.w);
        let lit = |end: &End| match end {
            End::Hit(s, _) => emitters[*s as usize],
            End::Stop | End::Escape => false,
        };
        for (end, dir, other) in [(&end_w, d, &end_u), (&end_u, back, &end_w)] {
            if let End::Hit(s, t) = *end
                && (through || lit(other))
                && t > 1e-9
                && t < 1.0 - 1e-9
            {
                let n = segments[s as usize].n;
                if dir[0] * n[0] + dir[1] * n[1] < 0.0 {
                    out[s as usize].push(t);
                }
            }
        }
    }
    for ts in &mut out {
        ts.sort_by(f64::total_cmp);
        ts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    }
    out
}

enum End {
    /// The line enters a polygon at the point itself.
    Stop,
    /// First segment hit past the point, with the parameter on it.
    Hit(u32, f64),
    /// Nothing is hit (open scene).
    Escape,
}

/// Follows the line from point `p` in direction `d`, if it is tangent at `p`.
fn extend(geom: &FlatGeometry, p: u32, d: [f64; 2]) -> End {
    let o = geom.points[p as usize];
    let ahead = [o[0] + d[0], o[1] + d[1]];
    let (mut left, mut right) = (false, false);
    for &s in &geom.point_segments[p as usize] {
        let seg = &geom.segments[s as usize];
        let other = if seg.a == o { seg.b } else { seg.a };
        let side = orient(o, ahead, other);
        if side > 0.0 {
            left = true;
        } else if side < 0.0 {
            right = true;
        } else if (other[0] - o[0]) * d[0] + (other[1] - o[1]) * d[1] > 0.0 {
            return End::Stop; // the line runs along a segment
        }
    }
    if left && right {
        return End::Stop;
    }
    let mut best: Option<(f64, u32, f64)> = None;
    for (si, seg) in geom.segments.iter().enumerate() {
        if geom.point_segments[p as usize].contains(&(si as u32)) {
            continue;
        }
        // Solve o + r d = a + t (b - a).
        let e = [seg.b[0] - seg.a[0], seg.b[1] - seg.a[1]];
        let den = d[0] * e[1] - d[1] * e[0];
        if den == 0.0 {
            continue;
        }
        let w = [seg.a[0] - o[0], seg.a[1] - o[1]];
        let r = (w[0] * e[1] - w[1] * e[0]) / den;
        let t = (w[0] * d[1] - w[1] * d[0]) / den;
        if r > 1e-12 && (0.0..=1.0).contains(&t) && best.is_none_or(|b| r < b.0) {
            best = Some((r, si as u32, t));
        }
    }
    match best {
        Some((_, s, t)) => End::Hit(s, t),
        None => End::Escape,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesh_names_parse() {
        assert_eq!("none".parse::<Mesh>(), Ok(Mesh::None));
        assert_eq!("uniform:4".parse::<Mesh>(), Ok(Mesh::Uniform(4)));
        assert_eq!("discontinuity".parse::<Mesh>(), Ok(Mesh::Discontinuity));
        assert!("uniform:0".parse::<Mesh>().is_err());
        assert!("uniform:4000000000".parse::<Mesh>().is_err());
        assert!("fine".parse::<Mesh>().is_err());
    }

    #[test]
    fn shadow_boundaries_of_a_point_like_occluder() {
        // Floor y = 0 (lit side up), light at y = 2 facing down over x in [0.4, 0.6],
        // a small occluder segment at y = 1, x in [0.45, 0.55] (lit side down).
        let floor = PosedSegment::new([-2.0, 0.0], [2.0, 0.0], 0);
        let light = PosedSegment::new([0.6, 2.0], [0.4, 2.0], 1);
        let occ = PosedSegment::new([0.55, 1.0], [0.45, 1.0], 2);
        let ts = discontinuities(&[floor, light, occ], &[false, true, false]);
        // Umbra/penumbra boundaries: lines through a light endpoint and an occluder
        // endpoint: x = 2 * xo - xl for xl in {0.4, 0.6}, xo in {0.45, 0.55}.
        let mut xs: Vec<f64> = ts[0].iter().map(|t| -2.0 + 4.0 * t).collect();
        xs.sort_by(f64::total_cmp);
        let want = [0.3, 0.5, 0.5, 0.7]; // 0.5 appears twice (two lines), merged
        assert_eq!(xs.len(), 3, "{xs:?}");
        for (x, w) in xs.iter().zip([want[0], want[1], want[3]]) {
            assert!((x - w).abs() < 1e-12, "{xs:?}");
        }
    }
}
