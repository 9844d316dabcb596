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
//! orientation so that back faces count nothing. What hides a facet, other
//! patches of its own cluster included, is left to rays aimed at the facet's own
//! patches ([`ClusterFacets::point_on`]), a visible fraction per facet, in the
//! leaf rows and the final gather alike (`Solver::part_visibility`): one
//! fraction for the cluster, its rays drawn by power, took a side hidden behind
//! the next box as visible as the lit tops the rays mostly went to. The facets
//! hold where the patches stand at the start: a scene with motion does not use them.
//!
//! Every static scene builds them: the leaf rows take a far, small cluster whole by
//! its facets even where a point lies in a facet's slab
//! (`Solver::far_facet_factors`), each facet's patches at their own plane offsets
//! ([`ClusterFacets::front_depth`]); `--cluster-facets` takes near ones too, where
//! every facet tells, in the rows and the final gather.
//!
//! Each facet is a source of its own, gathered at its own radiosity: the area mean
//! of the patch roots and sub-cluster facets it sums ([`ClusterFacets::pull`],
//! run after the hierarchy's pull; [`ClusterFacets::push_down`] its transpose).
//! Row entries and final-gather terms name a facet by [`FACET_BIT`] and its index.
//! Gathered at the cluster's mean instead, a ceiling over boxes took their dark
//! sides for their bright tops (`tools/gen_cubes.py 20`: 3.66% off the emitters
//! against 2.93% with the clusters opened, BENCHMARKS.md "Scale").

use glam::DVec3;

use crate::oracle;
use crate::pools::ElementPool;

/// Most distinct normals a cluster may hold to have facets (an axis-aligned room
/// and its boxes hold six).
pub const MAX_FACETS: usize = 8;

/// Normals closer than this (`1 − cos`) share a facet.
const SAME_NORMAL: f64 = 1e-9;

/// A row entry's or a gather term's source with this bit set is facet
/// `id & !FACET_BIT` ([`ClusterFacets::pull`]), not an element.
pub const FACET_BIT: u32 = 1 << 31;

/// The value of row source, gather term or facet member `s`: element `s`'s in
/// `b`, or, with [`FACET_BIT`], its facet's in `fb` ([`ClusterFacets::pull`]).
#[inline]
pub fn source_value<T: Copy>(b: &[T], fb: &[T], s: u32) -> T {
    if s & FACET_BIT != 0 {
        fb[(s & !FACET_BIT) as usize]
    } else {
        b[s as usize]
    }
}

/// The slot of `s` as [`source_value`] reads it, to add to (column masses, the
/// transpose of a pull).
#[inline]
pub fn source_slot<'a, T>(b: &'a mut [T], fb: &'a mut [T], s: u32) -> &'a mut T {
    if s & FACET_BIT != 0 {
        &mut fb[(s & !FACET_BIT) as usize]
    } else {
        &mut b[s as usize]
    }
}

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

/// Most plane offsets a facet keeps ([`ClusterFacets::front_depth`]): beyond,
/// the nearest two merge.
const MAX_OFFSETS: usize = 8;

/// A facet as [`ClusterFacets::build`] sums it: normal, area, area moment, the
/// slab `[lo, hi]`, its members `(child element, the child's facet index or
/// `u32::MAX` for a patch root, area)`, and its patches' plane offsets with their
/// areas (at most [`MAX_OFFSETS`]).
type Acc = (
    DVec3,
    f64,
    DVec3,
    f64,
    f64,
    Vec<(u32, u32, f64)>,
    Vec<(f64, f64)>,
);

/// Merges the nearest two of `offs` (plane offset, area), area-weighted, until
/// at most [`MAX_OFFSETS`] are left.
fn merge_offsets(offs: &mut Vec<(f64, f64)>) {
    offs.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The same offset (the faces of a row of boxes in one plane) first, within
    // rounding of the largest offset: relative, so a scene scaled by a power of
    // two merges the same offsets (an absolute floor merged every offset of a
    // scene 2^-30 across).
    let tol = 1e-9 * offs.iter().fold(0.0f64, |m, o| m.max(o.0.abs()));
    offs.dedup_by(|b, a| {
        let same = (b.0 - a.0).abs() <= tol;
        if same {
            a.1 += b.1;
        }
        same
    });
    while offs.len() > MAX_OFFSETS {
        let i = (0..offs.len() - 1)
            .min_by(|&i, &j| (offs[i + 1].0 - offs[i].0).total_cmp(&(offs[j + 1].0 - offs[j].0)))
            .unwrap_or(0);
        let (a, b) = (offs[i], offs[i + 1]);
        let area = a.1 + b.1;
        let o = if area > 0.0 {
            (a.0 * a.1 + b.0 * b.1) / area
        } else {
            0.5 * (a.0 + b.0)
        };
        offs[i] = (o, area);
        offs.remove(i + 1);
    }
}

/// The facets of every cluster built at the start, as ranges of one array.
#[derive(Debug, Default)]
pub struct ClusterFacets {
    /// `start[e]..start[e + 1]` are element `e`'s facets (empty: none, or too many
    /// normals); elements past `start.len() - 1` have none.
    start: Vec<u32>,
    facets: Vec<Facet>,
    /// `members_start[f]..members_start[f + 1]` are facet `f`'s members in
    /// `members`.
    members_start: Vec<u32>,
    /// `(source, area share)`: a patch root's element id, or [`FACET_BIT`] | a
    /// sub-cluster's facet. 8 bytes each.
    members: Vec<(u32, f32)>,
    /// The cluster each facet belongs to.
    owner: Vec<u32>,
    /// `offsets_start[f]..offsets_start[f + 1]` are facet `f`'s plane offsets
    /// in `offsets`: `(n · p, area share)` of its patches, the nearest merged
    /// beyond [`MAX_OFFSETS`] ([`ClusterFacets::front_depth`]). 8 bytes each.
    offsets_start: Vec<u32>,
    offsets: Vec<(f32, f32)>,
}

impl ClusterFacets {
    /// SCRATCH: the cluster facet `f` belongs to.
    pub fn owner_of(&self, f: u32) -> u32 {
        self.owner[f as usize]
    }

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
                let me = vec![(e as u32, u32::MAX, g.area)];
                let offs = vec![(nrm.dot(centroid), g.area)];
                lists[e] = Some(vec![(nrm, g.area, centroid * g.area, lo, hi, me, offs)]);
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
                let patch_root = geoms[ch as usize].patch != u32::MAX;
                for (j, (nrm, a, m, lo, hi, _, offs)) in list.iter().enumerate() {
                    let (nrm, a, m, lo, hi) = (*nrm, *a, *m, *lo, *hi);
                    let member = (ch, if patch_root { u32::MAX } else { j as u32 }, a);
                    match out.iter_mut().find(|f| f.0.dot(nrm) > 1.0 - SAME_NORMAL) {
                        Some(f) => {
                            f.1 += a;
                            f.2 += m;
                            f.3 = f.3.min(lo);
                            f.4 = f.4.max(hi);
                            f.5.push(member);
                            f.6.extend_from_slice(offs);
                            merge_offsets(&mut f.6);
                        }
                        None => out.push((nrm, a, m, lo, hi, vec![member], offs.clone())),
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
            for (nrm, a, m, lo, hi, _, _) in list.iter().flatten() {
                let c = if *a > 0.0 { *m / *a } else { *m };
                facets.push(Facet {
                    normal: nrm.as_vec3().to_array(),
                    area: *a as f32,
                    centroid: c.as_vec3().to_array(),
                    lo: *lo as f32,
                    hi: *hi as f32,
                });
            }
        }
        start.push(facets.len() as u32);
        let mut members_start = Vec::with_capacity(facets.len() + 1);
        let mut members = Vec::new();
        let mut owner = Vec::with_capacity(facets.len());
        let mut offsets_start = Vec::with_capacity(facets.len() + 1);
        let mut offsets = Vec::new();
        for (e, list) in lists.iter().enumerate() {
            if geoms[e].patch != u32::MAX {
                continue;
            }
            for (_, a, _, _, _, ms, offs) in list.iter().flatten() {
                offsets_start.push(offsets.len() as u32);
                for &(o, ao) in offs {
                    let w = if *a > 0.0 { ao / *a } else { 0.0 };
                    offsets.push((o as f32, w as f32));
                }
                members_start.push(members.len() as u32);
                owner.push(e as u32);
                for &(ch, j, am) in ms {
                    let src = if j == u32::MAX {
                        ch
                    } else {
                        FACET_BIT | (start[ch as usize] + j)
                    };
                    let w = if *a > 0.0 { am / *a } else { 0.0 };
                    members.push((src, w as f32));
                }
            }
        }
        members_start.push(members.len() as u32);
        offsets_start.push(offsets.len() as u32);
        ClusterFacets {
            start,
            facets,
            members_start,
            members,
            owner,
            offsets_start,
            offsets,
        }
    }

    /// How many facets there are.
    pub fn count(&self) -> usize {
        self.facets.len()
    }

    /// The cluster facet `f` belongs to.
    pub fn owner(&self, f: u32) -> u32 {
        self.owner[f as usize]
    }

    /// The index of cluster `e`'s first facet (its facets follow on).
    pub fn first(&self, e: u32) -> u32 {
        self.start[e as usize]
    }

    /// Each facet's radiosity, the area mean of its members, from the elements'
    /// `b` as [`super::pull`] left them. Sub-cluster facets come after their
    /// parents', so a reverse sweep is bottom-up.
    pub fn pull(&self, b: &[[f64; 3]], out: &mut Vec<[f64; 3]>) {
        out.clear();
        out.resize(self.facets.len(), [0.0; 3]);
        for f in (0..self.facets.len()).rev() {
            let (m0, m1) = (
                self.members_start[f] as usize,
                self.members_start[f + 1] as usize,
            );
            let mut acc = [0.0; 3];
            for &(src, w) in &self.members[m0..m1] {
                let v = source_value(b, out, src);
                for k in 0..3 {
                    acc[k] += w as f64 * v[k];
                }
            }
            out[f] = acc;
        }
    }

    /// The transpose of [`ClusterFacets::pull`] on one value per source: what each
    /// facet holds (`facet`, emptied) is handed to its members in the weights the
    /// pull gives them, into the elements' `v` (patch roots), before
    /// [`super::push_down`] takes it on to the leaves.
    pub fn push_down(&self, facet: &mut [f64], v: &mut [f64]) {
        for f in 0..self.facets.len() {
            let x = std::mem::take(&mut facet[f]);
            if x == 0.0 {
                continue;
            }
            let (m0, m1) = (
                self.members_start[f] as usize,
                self.members_start[f + 1] as usize,
            );
            for &(src, w) in &self.members[m0..m1] {
                *source_slot(v, facet, src) += x * w as f64;
            }
        }
    }

    /// A point of facet `f`'s patches drawn by area from the hash `h`, its normal
    /// and its patch: the members are drawn by their area shares, down through
    /// sub-cluster facets to a patch root, and a point of that patch by
    /// [`oracle::patch_point`]. The rays of a facet's visible fraction go there.
    pub fn point_on(&self, elems: &ElementPool, f: u32, h: u64) -> (DVec3, DVec3, u32) {
        let geoms = elems.geoms.as_slice();
        let mut cur = f as usize;
        let mut level = 0;
        loop {
            let (m0, m1) = (
                self.members_start[cur] as usize,
                self.members_start[cur + 1] as usize,
            );
            let u = oracle::unit(oracle::hash3(h, level, 0xfac));
            let mut acc = 0.0;
            let mut pick = self.members[m1 - 1].0;
            for &(src, w) in &self.members[m0..m1] {
                acc += w as f64;
                if u < acc {
                    pick = src;
                    break;
                }
            }
            if pick & FACET_BIT != 0 {
                cur = (pick & !FACET_BIT) as usize;
                level += 1;
                continue;
            }
            return oracle::patch_point(&geoms[pick as usize], h, level);
        }
    }

    /// The mean of `max(0, h − n · p)` over the points `p` of facet `f`'s patches,
    /// `h` a point's plane offset `n · x`: each patch at its own offset (the
    /// nearest merged beyond [`MAX_OFFSETS`]), weighted by area. `h − n · c` in
    /// front of every patch, 0 behind; between, the part in front. Over the
    /// facet's distance it is the mean cosine its patches turn toward the point
    /// (`Solver::far_facet_factors`): the centroid's offset alone would count a
    /// facet half in front as wholly in front or not at all.
    pub fn front_depth(&self, f: u32, h: f64) -> f64 {
        let f = f as usize;
        let (o0, o1) = (
            self.offsets_start[f] as usize,
            self.offsets_start[f + 1] as usize,
        );
        self.offsets[o0..o1]
            .iter()
            .map(|&(o, w)| w as f64 * (h - o as f64).max(0.0))
            .sum()
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
