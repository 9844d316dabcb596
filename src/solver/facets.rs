//! Cluster facets: a cluster's patches grouped by normal, so that a cluster of
//! boxes is taken whole by a leaf row where its faces' sides are known.
//!
//! [`super::Solver::cluster_parts`] takes a cluster whole only where its normal
//! cone says every patch faces the point; a cluster holding a box (faces five or
//! six ways) never passes, and was opened down to each face at every leaf that
//! links to it: in `tools/gen_cubes.py` rooms each leaf's row walked and cast rays
//! at every box face under its cluster links, `O(N)` parts a leaf at `N` polygons
//! (BENCHMARKS.md, "Scale").
//!
//! How: at the start, each cluster whose patches have at most [`MAX_FACETS`]
//! distinct normals gets one [`Facet`] per normal: the patches' summed area, their
//! area centroid, and the slab `[lo, hi]` of the plane offsets `n · p` of their
//! corners. A point `x` with `n · x >= hi` sees the front of every patch of the
//! facet, `n · x <= lo` none; between, the facet cannot tell and the cluster is
//! opened as before. Where every facet tells, the cluster's projected area toward
//! `x` is exactly `Σ A_f max(0, n_f · v_f)` over its facets (`v_f` towards `x` from
//! the facet's centroid), the vector-area estimate of Sillion (1995, §4) split by
//! orientation so that back faces count nothing; the parts hidden behind other
//! parts are left to the cluster's visibility rays, which stop at any patch
//! ([`crate::oracle::point_cluster_visibility`]). The facets hold where the
//! patches stand at the start: a scene with motion does not use them.
//!
//! What it costs: the cluster is gathered at its mean radiosity, not each
//! orientation at its own, so a ceiling over boxes takes their dark sides for
//! their bright tops; hence opt-in ([`super::SolveOptions::cluster_facets`]).

use glam::DVec3;

use crate::pools::ElementPool;

/// Most distinct normals a cluster may hold to have facets (an axis-aligned room
/// and its boxes hold six).
pub const MAX_FACETS: usize = 8;

/// Normals closer than this (`1 − cos`) share a facet.
const SAME_NORMAL: f64 = 1e-9;

/// The patches of one cluster facing one way. 36 bytes.
#[derive(Clone, Copy, Debug)]
pub struct Facet {
    /// Unit normal.
    pub normal: [f32; 3],
    /// Summed area.
    pub area: f32,
    /// Area centroid.
    pub centroid: [f32; 3],
    /// Least plane offset `n · p` over the patches' corners.
    pub lo: f32,
    /// Greatest plane offset.
    pub hi: f32,
}

const _: () = assert!(std::mem::size_of::<Facet>() == 36);

/// A facet as [`ClusterFacets::build`] sums it: normal, area, area moment, and
/// the slab `[lo, hi]`.
type Acc = (DVec3, f64, DVec3, f64, f64);

/// The facets of every cluster built at the start, as ranges of one array.
#[derive(Debug, Default)]
pub struct ClusterFacets {
    /// `start[e]..start[e + 1]` are element `e`'s facets (empty: none, or too many
    /// normals); elements past `start.len() - 1` have none.
    start: Vec<u32>,
    facets: Vec<Facet>,
}

impl ClusterFacets {
    /// The facets of the clusters (and patch roots) of `elems` as they stand.
    pub fn build(elems: &ElementPool) -> Self {
        let geoms = elems.geoms.as_slice();
        let nodes = elems.nodes.as_slice();
        let n = geoms.len();
        // Bottom-up (children have larger ids than their parents); `None`: too many.
        let mut lists: Vec<Option<Vec<Acc>>> = vec![None; n];
        for e in (0..n).rev() {
            let g = &geoms[e];
            if g.patch != u32::MAX {
                // Only patch roots (a cluster's child, or the root) start a list.
                let parent = nodes[e].parent;
                if parent != u32::MAX && geoms[parent as usize].patch != u32::MAX {
                    continue;
                }
                let nrm = DVec3::from_array(g.normal);
                let k = g.n as usize;
                let corners = g.corners[..k].iter().map(|&c| DVec3::from_array(c));
                let centroid = corners.clone().sum::<DVec3>() / k as f64;
                let (lo, hi) = corners
                    .map(|c| nrm.dot(c))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| {
                        (a.min(d), b.max(d))
                    });
                lists[e] = Some(vec![(nrm, g.area, centroid * g.area, lo, hi)]);
                continue;
            }
            let node = nodes[e];
            let mut out: Vec<Acc> = Vec::new();
            let mut ok = node.child_count > 0;
            for ch in node.first_child..node.first_child + node.child_count {
                let Some(list) = lists[ch as usize].as_ref() else {
                    ok = false;
                    break;
                };
                for &(nrm, a, m, lo, hi) in list {
                    match out.iter_mut().find(|f| f.0.dot(nrm) > 1.0 - SAME_NORMAL) {
                        Some(f) => {
                            f.1 += a;
                            f.2 += m;
                            f.3 = f.3.min(lo);
                            f.4 = f.4.max(hi);
                        }
                        None => out.push((nrm, a, m, lo, hi)),
                    }
                }
                if out.len() > MAX_FACETS {
                    ok = false;
                    break;
                }
            }
            if ok {
                lists[e] = Some(out);
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut facets = Vec::new();
        for (e, list) in lists.iter().enumerate() {
            start.push(facets.len() as u32);
            if geoms[e].patch != u32::MAX {
                continue;
            }
            for &(nrm, a, m, lo, hi) in list.iter().flatten() {
                let c = if a > 0.0 { m / a } else { m };
                facets.push(Facet {
                    normal: nrm.as_vec3().to_array(),
                    area: a as f32,
                    centroid: c.as_vec3().to_array(),
                    lo: lo as f32,
                    hi: hi as f32,
                });
            }
        }
        start.push(facets.len() as u32);
        ClusterFacets { start, facets }
    }

    /// The facets of cluster `e` (empty: it has none).
    pub fn of(&self, e: u32) -> &[Facet] {
        let e = e as usize;
        if e + 1 >= self.start.len() {
            return &[];
        }
        &self.facets[self.start[e] as usize..self.start[e + 1] as usize]
    }
}

/// The side of facet `f` point `x` is on: `Some(true)` in front of every patch,
/// `Some(false)` behind (or in the plane of) every one, `None` between. `tol`
/// widens the slab for the offsets' rounding to `f32`.
pub fn side(f: &Facet, x: DVec3, tol: f64) -> Option<bool> {
    let h = DVec3::from_array(f.normal.map(f64::from)).dot(x);
    if h >= f.hi as f64 + tol {
        Some(true)
    } else if h <= f.lo as f64 + tol {
        Some(false)
    } else {
        None
    }
}
