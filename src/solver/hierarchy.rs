//! Building the element hierarchy: the cluster tree over patches, the patch root
//! elements, and the 4-way spatial split of surface elements.
//!
//! Clusters (Smits, Arvo & Greenberg 1994; Sillion 1995) are built top-down by
//! splitting the patch set at the median centroid along the longest axis of the
//! centroids' box, until a cluster holds one patch, whose root element then takes the
//! cluster's place. Parents are always allocated before their children, so
//! element ids increase downwards: a reverse sweep over ids is a bottom-up pass and a
//! forward sweep a top-down one.
//!
//! A surface element splits into 4 children in the patch's parameter space: a quad
//! rectangle into 4 rectangles at its parametric midpoints, a triangle into its 3
//! corner triangles and the middle one (midpoint subdivision).

use glam::DVec3;

use crate::Result;
use crate::geometry::{Patches, Poly};
use crate::pools::elements::{Cone, Geom, Node};
use crate::pools::{ElementId, ElementKind, ElementPool};

/// Builds the cluster tree and patch roots into an empty pool; returns the root
/// (`None` for a scene with no patches). Every element gets time range `time`.
///
/// `dark` (empty, or a flag per patch): patches no light reaches
/// ([`crate::geometry::dark_patches`]). When some are and some are not, the root's
/// two children are the lit patches' tree and the dark patches' tree, so that no
/// cluster mixes them and the lit tree is the one the lit patches alone would
/// make.
pub fn build(
    pool: &mut ElementPool,
    patches: &Patches,
    time: [f32; 2],
    dark: &[bool],
) -> Result<Option<ElementId>> {
    if patches.is_empty() {
        return Ok(None);
    }
    let mut ids: Vec<u32> = (0..patches.len() as u32).collect();
    let root = if ids.len() == 1 {
        push_patch_root(pool, patches, 0, u32::MAX, time)?
    } else {
        push_cluster(pool, patches, &ids, u32::MAX, 0, time)?
    };
    let is_dark = |i: u32| dark.get(i as usize).copied().unwrap_or(false);
    let split_dark = ids.iter().any(|&i| is_dark(i)) && ids.iter().any(|&i| !is_dark(i));
    // Top-down: each cluster allocates its two children together.
    let mut stack = vec![(root, std::mem::take(&mut ids))];
    while let Some((cluster, members)) = stack.pop() {
        if pool.kind(cluster) != ElementKind::Cluster {
            continue;
        }
        let (left, right) = if cluster == root && split_dark {
            members.into_iter().partition(|&i| !is_dark(i))
        } else {
            split_median(patches, members)
        };
        let depth = pool.nodes.as_slice()[cluster.ix()].depth.saturating_add(1);
        let first = pool.len() as u32;
        let mut kids = Vec::with_capacity(2);
        for part in [left, right] {
            let id = if part.len() == 1 {
                push_patch_root(pool, patches, part[0] as usize, cluster.0, time)?
            } else {
                push_cluster(pool, patches, &part, cluster.0, depth, time)?
            };
            kids.push((id, part));
        }
        let node = &mut pool.nodes.as_mut_slice()[cluster.ix()];
        node.first_child = first;
        node.child_count = 2;
        stack.extend(kids);
    }
    Ok(Some(root))
}

/// Relative tolerance of the cluster split's comparisons ([`split_median`]):
/// extents within it of each other are equal, and centroids are ordered on a grid
/// of this fraction of the split axis's extent. Coplanar tiles and symmetric rooms
/// put many centroids (and a room's width and depth) at exactly equal values, and a
/// scene scaled by 1000 rounds them apart in either order: compared exactly, the
/// cluster tree of the same scene in millimetres and in metres differed, and with
/// it every refinement decision (issue 45, part 3).
const SPLIT_TOLERANCE: f64 = 1.0 / (1u64 << 30) as f64;

/// Splits `members` at the median centroid along the longest axis of the
/// centroids' box. Ties (within [`SPLIT_TOLERANCE`]) go to the first axis and to
/// the lower patch index, so the tree depends on the scene's shape, not its unit.
fn split_median(patches: &Patches, mut members: Vec<u32>) -> (Vec<u32>, Vec<u32>) {
    let c = |i: u32| patches.polys[i as usize].centroid();
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for &m in &members {
        lo = lo.min(c(m));
        hi = hi.max(c(m));
    }
    let ext = hi - lo;
    let at_least = |a: f64, b: f64| a >= b * (1.0 - SPLIT_TOLERANCE);
    let axis = if at_least(ext.x, ext.y) && at_least(ext.x, ext.z) {
        0
    } else if at_least(ext.y, ext.z) {
        1
    } else {
        2
    };
    // Centroids on a grid of `SPLIT_TOLERANCE · extent` (integers below 2^31).
    let step = ext[axis] * SPLIT_TOLERANCE;
    let key = |i: u32| {
        if step > 0.0 {
            ((c(i)[axis] - lo[axis]) / step).round() as u64
        } else {
            0
        }
    };
    let mid = members.len() / 2;
    members.select_nth_unstable_by_key(mid, |&a| (key(a), a));
    let right = members.split_off(mid);
    (members, right)
}

fn push_cluster(
    pool: &mut ElementPool,
    patches: &Patches,
    members: &[u32],
    parent: u32,
    depth: u8,
    time: [f32; 2],
) -> Result<ElementId> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut area = 0.0;
    let mut moment = DVec3::ZERO;
    for &m in members {
        let poly = &patches.polys[m as usize];
        for &p in poly.corners() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        area += patches.areas[m as usize];
        moment += patches.areas[m as usize] * poly.centroid();
    }
    let centroid = if area > 0.0 {
        moment / area
    } else {
        (lo + hi) * 0.5
    };
    let mut geom = Geom {
        corners: [[0.0; 3]; 4],
        normal: [0.0; 3],
        area,
        uv: [[0.0; 2]; 4],
        patch: u32::MAX,
        n: 2,
    };
    geom.set_cluster_box(lo, hi, centroid);
    geom.set_cluster_cone(&Cone::merge(members.iter().map(|&m| {
        (
            Cone::of_normal(patches.normals[m as usize]),
            patches.areas[m as usize],
        )
    })));
    let node = Node {
        parent,
        first_child: 0,
        child_count: 0,
        kind: ElementKind::Cluster as u8,
        depth,
        pad: [0; 2],
    };
    pool.push(node, geom, time)
}

fn push_patch_root(
    pool: &mut ElementPool,
    patches: &Patches,
    patch: usize,
    parent: u32,
    time: [f32; 2],
) -> Result<ElementId> {
    let geom = whole_patch_geom(patches, patch);
    let node = Node {
        parent,
        first_child: 0,
        child_count: 0,
        kind: ElementKind::Surface as u8,
        depth: 0,
        pad: [0; 2],
    };
    pool.push(node, geom, time)
}

/// Geometry of the whole of `patch` (its root element's).
pub fn whole_patch_geom(patches: &Patches, patch: usize) -> Geom {
    let n = patches.polys[patch].n;
    let uv = if n == 3 {
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]
    } else {
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    };
    surface_geom(patches, patch, n, &uv)
}

/// Geometry of the sub-domain `uv` (3 or 4 parameter corners) of `patch`.
pub fn surface_geom(patches: &Patches, patch: usize, n: usize, uv: &[[f32; 2]; 4]) -> Geom {
    let mut corners = [[0.0; 3]; 4];
    for (c, p) in corners.iter_mut().zip(uv).take(n) {
        *c = patches.point(patch, p[0] as f64, p[1] as f64).to_array();
    }
    let world: Vec<DVec3> = corners[..n].iter().map(|&c| DVec3::from_array(c)).collect();
    let poly = Poly::new(&world);
    Geom {
        corners,
        normal: patches.normals[patch].to_array(),
        area: poly.area(),
        uv: *uv,
        patch: patch as u32,
        n: n as u32,
    }
}

/// Splits surface element `e` into 4 children (no-op if it has children already).
/// Children start with the parent's radiosity.
pub fn subdivide(pool: &mut ElementPool, patches: &Patches, e: ElementId) -> Result<()> {
    let node = pool.nodes.as_slice()[e.ix()];
    if node.child_count > 0 || node.kind != ElementKind::Surface as u8 {
        return Ok(());
    }
    let g = pool.geoms.as_slice()[e.ix()];
    let time = pool.times.as_slice()[e.ix()];
    let b = pool.radiosities.as_slice()[e.ix()];
    let n = g.n as usize;
    let kids = child_domains(n, &g.uv);
    let first = pool.len() as u32;
    let patch = g.patch as usize;
    let mut geoms: Vec<Geom> = kids
        .iter()
        .map(|k| surface_geom(patches, patch, n, k))
        .collect();
    // Make the children's areas sum to the parent's exactly (round-off only).
    let sum: f64 = geoms.iter().map(|c| c.area).sum();
    if sum > 0.0 {
        for c in &mut geoms {
            c.area *= g.area / sum;
        }
    }
    for geom in geoms {
        let node = Node {
            parent: e.0,
            first_child: 0,
            child_count: 0,
            kind: ElementKind::Surface as u8,
            depth: node.depth.saturating_add(1),
            pad: [0; 2],
        };
        let id = pool.push(node, geom, time)?;
        pool.radiosities.as_mut_slice()[id.ix()] = b;
    }
    let parent = &mut pool.nodes.as_mut_slice()[e.ix()];
    parent.first_child = first;
    parent.child_count = 4;
    Ok(())
}

/// Parameter corners of the 4 children of a domain with `n` corners `uv`: a quad
/// rectangle split at its parametric midpoints, a triangle into its 3 corner
/// triangles and the middle one. Shared by element subdivision and reconstruction
/// cells.
pub fn child_domains(n: usize, uv: &[[f32; 2]; 4]) -> [[[f32; 2]; 4]; 4] {
    let m = |a: [f32; 2], b: [f32; 2]| [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5];
    if n == 3 {
        let (a, b, c) = (uv[0], uv[1], uv[2]);
        let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
        let z = [0.0; 2];
        [
            [a, ab, ca, z],
            [ab, b, bc, z],
            [ca, bc, c, z],
            [bc, ca, ab, z],
        ]
    } else {
        let (u0, v0, u1, v1) = (uv[0][0], uv[0][1], uv[2][0], uv[2][1]);
        let (um, vm) = ((u0 + u1) * 0.5, (v0 + v1) * 0.5);
        let r = |a: f32, b: f32, c: f32, d: f32| [[a, b], [c, b], [c, d], [a, d]];
        [
            r(u0, v0, um, vm),
            r(um, v0, u1, vm),
            r(um, vm, u1, v1),
            r(u0, vm, um, v1),
        ]
    }
}
