//! Sealed regions: closed shells of polygons that no light crosses, and the patches
//! that no emitter's light can reach, found before solving so that they cost nothing
//! (issue 48, target 4).
//!
//! **Shells.** Polygons are opaque from both sides (a visibility ray stops at any
//! patch). A set of polygons whose edges pair up exactly, each edge used once in
//! each direction (a closed, consistently oriented 2-manifold: a crate, a box, a
//! room of six walls, a closed tessellated mesh), divides space into its inside and
//! its outside, and no ray from one reaches the other. Shells are found in the
//! scene's polygons as loaded (before contact meshing cuts them): vertices are
//! welded on a grid of [`WELD_OF_DIAMETER`] of the scene's diameter, and along each
//! edge the polygons that use it are paired, one running it each way
//! ([`pair_around`]: where more than two meet, as where two rooms share a wall,
//! each pairs with its neighbour across the air in front of it). A connected set of
//! polygons whose every edge pairs is a shell, if it encloses a volume (a polygon
//! and its reversed twin, a two-sided surface alone, pair up but enclose nothing),
//! whatever objects its polygons belong to. A T-junction, a gap or an edge whose
//! polygons do not pair leaves a set open: it is no shell, and nothing is
//! concluded from it. Two-sided surfaces (a polygon and its reversed twin in one
//! object) are left out (`find_shells` says why).
//!
//! **Sides.** A point's side of a shell is its generalised winding number
//! (the shell's solid angle over 4π, Van Oosterom & Strackee's formula per
//! triangle): 0 outside, ±1 inside. A patch is strictly on one side if five points
//! of it (its centroid, and its corners drawn a tenth towards the centroid), each
//! moved [`OFFSET_OF_DIAMETER`] of the scene's diameter along its normal, all read
//! the same side, none near ½, and no edge of it crosses a face of the shell nor an
//! edge of the shell crosses it. Moving the points off the surface is what places
//! a face of the shell itself: a face is on the side it faces (a crate's faces
//! outside it, a room's walls inside it).
//!
//! **Dark patches.** Light leaves an emitter into the region on its front side and
//! every path it takes stays in one region (every segment of it would cross a shell
//! otherwise). So a patch is dark if, for every emitter, some shell holds the two
//! strictly on different sides: its radiosity is exactly zero, it sends nothing, and
//! nothing that reaches it or that it reaches matters to the lit patches (a segment
//! between two lit points stays in their region, so a dark patch cannot shade it).
//! The solver leaves dark patches out of every link and gather and stores them
//! black. Whatever is unsure (a patch straddling a shell, a winding number near ½, a
//! scene with motion) is taken as lit: the analysis only ever saves work, never
//! changes a lit patch's answer.
//!
//! Cost: shells with more than [`MAX_SHELL_FACES`] faces are not used (the sides are
//! computed face by face); candidate shells are found through a uniform grid over
//! the shells' boxes.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::patches::Patches;
use super::polygon::Poly;

/// Vertices within this fraction of the scene's diameter on each axis weld into one
/// (the grid's cell).
pub const WELD_OF_DIAMETER: f64 = 1e-9;

/// How far a patch's sample points are moved along its normal, as a fraction of the
/// scene's diameter, to place them on the side it faces.
pub const OFFSET_OF_DIAMETER: f64 = 1e-6;

/// Largest shell used: the sides are computed against each face of it.
pub const MAX_SHELL_FACES: usize = 4096;

/// What the analysis found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sealed {
    /// Per patch of the analysed set: true if no emitter's light can reach it.
    pub dark: Vec<bool>,
    /// Closed shells found (of at most 4 096 faces: larger ones are not used).
    pub shells: usize,
    /// Patches marked dark.
    pub dark_patches: usize,
}

/// One closed shell: its triangles (quads split along their first diagonal), its
/// edges once each and its box.
struct Shell {
    tris: Vec<[DVec3; 3]>,
    edges: Vec<[DVec3; 2]>,
    lo: DVec3,
    hi: DVec3,
}

/// Which side of a shell a patch lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Side {
    Outside,
    Inside,
    /// Straddling, or too close to call.
    Unsure,
}

/// The closed shells of a scene (module docs, "Shells"), to mark the patches no
/// emitter can light ([`Shells::dark`]).
pub struct Shells {
    shells: Vec<Shell>,
    diameter: f64,
}

impl Shells {
    /// Finds the closed shells of `shapes` (the scene's polygons as loaded).
    pub fn find(shapes: &Patches) -> Shells {
        let diameter = shapes.diameter;
        let shells = if diameter > 0.0 {
            find_shells(shapes, diameter * WELD_OF_DIAMETER)
        } else {
            Vec::new()
        };
        Shells { shells, diameter }
    }

    /// Shells found.
    pub fn len(&self) -> usize {
        self.shells.len()
    }

    /// True if none was found.
    pub fn is_empty(&self) -> bool {
        self.shells.is_empty()
    }

    /// Marks the patches of `patches` (the scene's polygons as loaded, or the set
    /// solved after contact meshing) that no emitter of `patches` can light
    /// (module docs, "Dark patches").
    pub fn dark(&self, patches: &Patches) -> Sealed {
        dark_among(&self.shells, self.diameter.max(patches.diameter), patches)
    }
}

/// [`Shells::find`] in `shapes`, then [`Shells::dark`] of `patches`.
pub fn dark_patches(shapes: &Patches, patches: &Patches) -> Sealed {
    Shells::find(shapes).dark(patches)
}

fn dark_among(shells: &[Shell], diameter: f64, patches: &Patches) -> Sealed {
    let mut out = Sealed {
        dark: vec![false; patches.len()],
        shells: shells.len(),
        ..Sealed::default()
    };
    if diameter.is_nan() || diameter <= 0.0 || patches.is_empty() || shells.is_empty() {
        return out;
    }
    let emitters: Vec<usize> = (0..patches.len()).filter(|&i| patches.emits(i)).collect();
    if emitters.is_empty() {
        // The solver answers a scene with no emitter at once; nothing to save here.
        return out;
    }
    let tol = diameter * 1e-9;
    let offset = diameter * OFFSET_OF_DIAMETER;
    let grid = ShellGrid::new(shells);
    // Each emitter's region: the shells it is inside of, or straddles (`Unsure`),
    // among those whose box it overlaps; it is outside every other. Emitters in
    // the same region separate the same patches: each region once.
    let mut regions: Vec<Vec<(usize, Side)>> = emitters
        .par_iter()
        .map(|&e| {
            let (poly, n) = (&patches.polys[e], patches.normals[e]);
            let (lo, hi) = poly.bounds();
            grid.overlapping(lo, hi)
                .into_iter()
                .map(|s| (s, side_of(&shells[s], poly, n, offset, tol)))
                .filter(|&(_, side)| side != Side::Outside)
                .collect()
        })
        .collect();
    regions.sort();
    regions.dedup();
    let dark: Vec<bool> = (0..patches.len())
        .into_par_iter()
        .map(|i| {
            if patches.emits(i) {
                return false;
            }
            let poly = &patches.polys[i];
            let (lo, hi) = poly.bounds();
            let near = grid.overlapping(lo, hi);
            let mut sides: HashMap<usize, Side> = HashMap::new();
            let mut side = |s: usize| {
                *sides
                    .entry(s)
                    .or_insert_with(|| side_of(&shells[s], poly, patches.normals[i], offset, tol))
            };
            // Separated from a region by a shell the region is inside of and the
            // patch strictly outside (its box missing the shell's, or its side), or
            // by a shell the patch is strictly inside of and the region outside.
            let mut separated = |region: &Vec<(usize, Side)>| {
                region.iter().any(|&(s, e_side)| {
                    e_side == Side::Inside
                        && (near.binary_search(&s).is_err() || side(s) == Side::Outside)
                }) || near.iter().any(|&s| {
                    region.binary_search_by_key(&s, |&(t, _)| t).is_err() && side(s) == Side::Inside
                })
            };
            regions.iter().all(&mut separated)
        })
        .collect();
    out.dark_patches = dark.iter().filter(|&&d| d).count();
    out.dark = dark;
    out
}

/// The closed shells of `shapes` (module docs, "Shells").
fn find_shells(shapes: &Patches, weld: f64) -> Vec<Shell> {
    let key = |p: DVec3| {
        let q = (p / weld).round();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    let mut ids: HashMap<(i64, i64, i64), u32> = HashMap::new();
    // Each welded vertex's position (its first corner's).
    let mut at: Vec<DVec3> = Vec::new();
    let mut loops: Vec<Vec<u32>> = Vec::with_capacity(shapes.len());
    for poly in &shapes.polys {
        let mut l: Vec<u32> = Vec::with_capacity(poly.n);
        for &c in poly.corners() {
            let next = ids.len() as u32;
            let id = *ids.entry(key(c)).or_insert_with(|| {
                at.push(c);
                next
            });
            if l.last() != Some(&id) {
                l.push(id);
            }
        }
        while l.len() > 1 && l.first() == l.last() {
            l.pop();
        }
        loops.push(l);
    }
    // Two-sided surfaces (a polygon and its reversed twin on the same corners, in
    // one object: glTF's `doubleSided`, `--two-sided`) are left out. On Blender's
    // box of two-sided slabs, every slab a shell inside and out and its inner
    // twins dark, the answer came 2.2% off the path tracer (2.8% solving every
    // patch) but the row ray check read 64% (`Solver::row_ray_check`), not yet
    // understood. Twins in two objects are two rooms' walls back to back.
    let mut by_corners: HashMap<(u32, Vec<u32>), Vec<usize>> = HashMap::new();
    for (p, l) in loops.iter().enumerate() {
        let mut k = l.clone();
        k.sort_unstable();
        let object = shapes.objects.get(p).copied().unwrap_or(0);
        by_corners.entry((object, k)).or_default().push(p);
    }
    let mut two_sided = vec![false; loops.len()];
    for group in by_corners.values().filter(|g| g.len() > 1) {
        for &p in group {
            let l = &loops[p];
            let reversed: Vec<u32> = l.iter().rev().copied().collect();
            let turns = |a: &[u32], b: &[u32]| {
                (0..a.len()).any(|r| a.iter().cycle().skip(r).take(a.len()).eq(b.iter()))
            };
            if group.iter().any(|&q| q != p && turns(&loops[q], &reversed)) {
                two_sided[p] = true;
            }
        }
    }
    // Undirected edge (lower vertex first) -> the polygons using it, and whether
    // each runs it from the lower vertex.
    let mut edges: HashMap<(u32, u32), Vec<(u32, bool)>> = HashMap::new();
    for (p, l) in loops.iter().enumerate() {
        if l.len() < 3 || two_sided[p] {
            continue;
        }
        for k in 0..l.len() {
            let (a, b) = (l[k], l[(k + 1) % l.len()]);
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push((p as u32, a < b));
        }
    }
    // Union of the polygons each edge pairs (`pair_around`), and which sets have an
    // edge that pairs nothing.
    let mut parent: Vec<u32> = (0..loops.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    let mut open = vec![false; loops.len()];
    for (&(a, b), uses) in &edges {
        match pair_around(shapes, at[a as usize], at[b as usize], uses) {
            Some(pairs) => {
                for (x, y) in pairs {
                    let (rx, ry) = (find(&mut parent, x), find(&mut parent, y));
                    if rx != ry {
                        parent[rx as usize] = ry;
                    }
                }
            }
            None => {
                for &(u, _) in uses {
                    open[u as usize] = true;
                }
            }
        }
    }
    let mut sets: HashMap<u32, Vec<u32>> = HashMap::new();
    for (p, l) in loops.iter().enumerate() {
        if l.len() >= 3 && !two_sided[p] {
            let r = find(&mut parent, p as u32);
            sets.entry(r).or_default().push(p as u32);
        }
    }
    let mut bad_roots: Vec<u32> = Vec::new();
    for (p, &o) in open.iter().enumerate() {
        if o {
            bad_roots.push(find(&mut parent, p as u32));
        }
    }
    bad_roots.sort_unstable();
    bad_roots.dedup();
    let mut roots: Vec<u32> = sets.keys().copied().collect();
    roots.sort_unstable();
    let mut shells = Vec::new();
    for r in roots {
        let members = &sets[&r];
        if bad_roots.binary_search(&r).is_ok()
            || members.len() < 2
            || members.len() > MAX_SHELL_FACES
        {
            continue;
        }
        let mut tris = Vec::new();
        let mut shell_edges = Vec::new();
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut volume = 0.0;
        for &m in members {
            let c = shapes.polys[m as usize].corners();
            for k in 1..c.len() - 1 {
                let t = [c[0], c[k], c[k + 1]];
                volume += t[0].dot(t[1].cross(t[2])) / 6.0;
                tris.push(t);
            }
            for k in 0..c.len() {
                let (a, b) = (c[k], c[(k + 1) % c.len()]);
                // Each undirected edge once: from the use whose start sorts first.
                if key(a) < key(b) {
                    shell_edges.push([a, b]);
                }
                lo = lo.min(a);
                hi = hi.max(a);
            }
        }
        let extent = (hi - lo).length();
        // A polygon and its reversed twin pair up but hold nothing.
        if volume.abs() <= 1e-9 * extent.powi(3) {
            continue;
        }
        shells.push(Shell {
            tris,
            edges: shell_edges,
            lo,
            hi,
        });
    }
    shells
}

/// The polygons that the edge from `a` to `b` joins into one surface: `uses` are
/// the polygons along it, each with whether it runs from `a` to `b`. Two that run
/// it opposite ways pair. More (two rooms sharing a wall: each room's floor and
/// wall on one edge, the walls back to back) pair across the air: sorted by the
/// angle they leave the edge at, each polygon pairs with the next one round the
/// edge on its front side, which must turn its front back to it and run the edge
/// the other way (at equal angles, the one whose front turns back first: the two
/// faces of a wall between rooms bound different rooms). `None` if they do not
/// pair so, each once: the edge is open. Whatever pairs, each pair runs the edge
/// both ways, so every set of pairs closes into a surface whose winding number is
/// whole off it; the angles only choose the smallest such surfaces.
fn pair_around(
    shapes: &Patches,
    a: DVec3,
    b: DVec3,
    uses: &[(u32, bool)],
) -> Option<Vec<(u32, u32)>> {
    if uses.len() == 2 {
        return (uses[0].1 != uses[1].1).then(|| vec![(uses[0].0, uses[1].0)]);
    }
    if uses.len() % 2 == 1 {
        return None;
    }
    let u = (b - a).normalize_or_zero();
    let (e1, e2) = u.any_orthonormal_pair();
    // (angle on a grid, sense, polygon, runs a to b): sense -1 (front turned
    // clockwise about `u`) before +1 at equal angles.
    let mut round: Vec<(i64, i8, u32, bool)> = Vec::with_capacity(uses.len());
    for &(p, forward) in uses {
        let w = shapes.polys[p as usize].centroid() - a;
        let w = (w - u * w.dot(u)).normalize_or_zero();
        let turn = shapes.normals[p as usize].dot(u.cross(w));
        if w == DVec3::ZERO || turn.abs() < 1e-9 {
            return None;
        }
        let angle = w.dot(e2).atan2(w.dot(e1));
        round.push((
            (angle * 1e9).round() as i64,
            turn.signum() as i8,
            p,
            forward,
        ));
    }
    round.sort_unstable();
    let k = round.len();
    let mut pairs = Vec::with_capacity(k / 2);
    for i in 0..k {
        if round[i].1 > 0 {
            let next = round[(i + 1) % k];
            if next.1 > 0 || next.3 == round[i].3 {
                return None;
            }
            pairs.push((round[i].2, next.2));
        }
    }
    (pairs.len() * 2 == k).then_some(pairs)
}

/// The generalised winding number of `shell` at `x`: the solid angle its
/// triangles subtend (Van Oosterom & Strackee 1983) over 4π.
fn winding(shell: &Shell, x: DVec3) -> f64 {
    let mut omega = 0.0;
    for t in &shell.tris {
        let (a, b, c) = (t[0] - x, t[1] - x, t[2] - x);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        omega += 2.0 * num.atan2(den);
    }
    omega / (4.0 * std::f64::consts::PI)
}

/// The side of `shell` that `poly` (normal `n`) lies on (module docs, "Sides").
fn side_of(shell: &Shell, poly: &Poly, n: DVec3, offset: f64, tol: f64) -> Side {
    let (lo, hi) = poly.bounds();
    let pad = DVec3::splat(offset * 2.0);
    if lo.cmpgt(shell.hi + pad).any() || hi.cmplt(shell.lo - pad).any() {
        return Side::Outside;
    }
    let c = poly.centroid();
    let mut side = None;
    for x in std::iter::once(c).chain(poly.corners().iter().map(|&v| v + 0.1 * (c - v))) {
        let w = winding(shell, x + n * offset).abs();
        let s = if w < 0.25 {
            Side::Outside
        } else if w > 0.75 {
            Side::Inside
        } else {
            return Side::Unsure;
        };
        if side.is_some_and(|t| t != s) {
            return Side::Unsure;
        }
        side = Some(s);
    }
    if crosses(shell, poly, n, tol) {
        return Side::Unsure;
    }
    side.unwrap_or(Side::Unsure)
}

/// True if an edge of `poly` crosses a triangle of `shell`, or an edge of `shell`
/// crosses `poly`: both ends of the edge more than `tol` off the plane, and the
/// point where it meets the plane more than `tol` inside the face. A touch is no
/// crossing: a floor tile's edge under a box's corner meets the box's face at its
/// edge, and a box's edge standing on the floor lies in the floor's plane. A
/// straddle through edges alone, exactly, would also pass unseen here; the five
/// sample points of [`side_of`] must then agree too.
fn crosses(shell: &Shell, poly: &Poly, n: DVec3, tol: f64) -> bool {
    let c = poly.corners();
    let through = |a: DVec3, b: DVec3, corners: &[DVec3], fn_: DVec3| {
        let (da, db) = ((a - corners[0]).dot(fn_), (b - corners[0]).dot(fn_));
        if !(da > tol && db < -tol || da < -tol && db > tol) {
            return false;
        }
        let x = a + (b - a) * (da / (da - db));
        Poly::new(corners).contains(fn_, x, tol)
    };
    for t in &shell.tris {
        let tn = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        if tn == DVec3::ZERO {
            continue;
        }
        for k in 0..c.len() {
            if through(c[k], c[(k + 1) % c.len()], t, tn) {
                return true;
            }
        }
    }
    shell.edges.iter().any(|e| through(e[0], e[1], c, n))
}

/// A uniform grid over the shells' boxes: which shells a box may overlap.
struct ShellGrid {
    lo: DVec3,
    cell: DVec3,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
    /// Shells spanning more than [`ShellGrid::MAX_CELLS`] cells, asked every time.
    big: Vec<u32>,
    boxes: Vec<(DVec3, DVec3)>,
}

impl ShellGrid {
    const MAX_CELLS: usize = 64;

    fn new(shells: &[Shell]) -> Self {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for s in shells {
            lo = lo.min(s.lo);
            hi = hi.max(s.hi);
        }
        let ext = (hi - lo).max(DVec3::splat(1e-30));
        // About 8 cells a shell, by the box's proportions.
        let target = (shells.len() * 8).clamp(1, 1 << 21) as f64;
        let k = (target / (ext.x * ext.y * ext.z)).cbrt();
        let dims = [
            ((ext.x * k).ceil() as usize).clamp(1, 1024),
            ((ext.y * k).ceil() as usize).clamp(1, 1024),
            ((ext.z * k).ceil() as usize).clamp(1, 1024),
        ];
        let cell = ext / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
        let mut g = ShellGrid {
            lo,
            cell,
            dims,
            cells: vec![Vec::new(); dims[0] * dims[1] * dims[2]],
            big: Vec::new(),
            boxes: shells.iter().map(|s| (s.lo, s.hi)).collect(),
        };
        for (i, s) in shells.iter().enumerate() {
            let (a, b) = g.range(s.lo, s.hi);
            let count = (b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1);
            if count > Self::MAX_CELLS {
                g.big.push(i as u32);
                continue;
            }
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        let c = g.index(x, y, z);
                        g.cells[c].push(i as u32);
                    }
                }
            }
        }
        g
    }

    fn index(&self, x: usize, y: usize, z: usize) -> usize {
        (x * self.dims[1] + y) * self.dims[2] + z
    }

    fn range(&self, lo: DVec3, hi: DVec3) -> ([usize; 3], [usize; 3]) {
        let at = |p: DVec3, k: usize| {
            let f = ((p[k] - self.lo[k]) / self.cell[k]).floor();
            (f.max(0.0) as usize).min(self.dims[k] - 1)
        };
        (
            [at(lo, 0), at(lo, 1), at(lo, 2)],
            [at(hi, 0), at(hi, 1), at(hi, 2)],
        )
    }

    /// The shells whose box overlaps `lo..hi` (grown by a hair), sorted.
    fn overlapping(&self, lo: DVec3, hi: DVec3) -> Vec<usize> {
        let pad = (self.cell.x + self.cell.y + self.cell.z) * 1e-9;
        let (lo, hi) = (lo - DVec3::splat(pad), hi + DVec3::splat(pad));
        let meets = |i: u32| {
            let (a, b) = self.boxes[i as usize];
            !(lo.cmpgt(b).any() || hi.cmplt(a).any())
        };
        let mut out: Vec<usize> = self
            .big
            .iter()
            .filter(|&&i| meets(i))
            .map(|&i| i as usize)
            .collect();
        let (a, b) = self.range(lo, hi);
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    out.extend(
                        self.cells[self.index(x, y, z)]
                            .iter()
                            .filter(|&&i| meets(i))
                            .map(|&i| i as usize),
                    );
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(v: [[f64; 3]; 4]) -> Poly {
        Poly::new(&v.map(DVec3::from_array))
    }

    /// The six faces of an axis box, turned out (`out`) or in.
    fn cuboid(lo: [f64; 3], hi: [f64; 3], out: bool) -> Vec<Poly> {
        let [x0, y0, z0] = lo;
        let [x1, y1, z1] = hi;
        let faces = [
            [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]],
            [[x0, y1, z0], [x1, y1, z0], [x1, y0, z0], [x0, y0, z0]],
            [[x1, y1, z1], [x0, y1, z1], [x0, y0, z1], [x1, y0, z1]],
            [[x0, y1, z1], [x0, y1, z0], [x0, y0, z0], [x0, y0, z1]],
            [[x1, y1, z0], [x1, y1, z1], [x1, y0, z1], [x1, y0, z0]],
            [[x1, y0, z0], [x1, y0, z1], [x0, y0, z1], [x0, y0, z0]],
        ];
        faces
            .into_iter()
            .map(|mut f| {
                if !out {
                    f.reverse();
                }
                quad(f)
            })
            .collect()
    }

    /// A scene under construction: each [`Build::add`] is an object of its own.
    #[derive(Default)]
    struct Build {
        p: Patches,
        objects: u32,
    }

    impl Build {
        /// Adds `polys` as one object; returns their patch indices.
        fn add(&mut self, polys: Vec<Poly>, emits: bool) -> std::ops::Range<usize> {
            let first = self.p.len();
            for q in polys {
                self.p.normals.push(q.normal());
                self.p.areas.push(q.area());
                self.p.polys.push(q);
                self.p.rhos.push([0.5; 3]);
                self.p
                    .emissions
                    .push(if emits { [1.0; 3] } else { [0.0; 3] });
                self.p.objects.push(self.objects);
            }
            self.objects += 1;
            first..self.p.len()
        }

        fn done(mut self) -> Patches {
            self.p.finish();
            self.p
        }
    }

    /// A lamp facing down under the ceiling of the room `[0, 4]^3`.
    fn lamp() -> Poly {
        let q = quad([
            [1.0, 3.9, 1.0],
            [2.0, 3.9, 1.0],
            [2.0, 3.9, 2.0],
            [1.0, 3.9, 2.0],
        ]);
        assert!(q.normal().y < -0.99);
        q
    }

    fn shells_of(polys: Vec<Poly>) -> Vec<Shell> {
        let mut b = Build::default();
        b.add(polys, false);
        find_shells(&b.done(), 1e-9)
    }

    #[test]
    fn a_box_and_a_room_wind_once_inside_and_never_outside() {
        let r = shells_of(cuboid([0.0; 3], [4.0, 3.0, 5.0], false));
        let c = shells_of(cuboid([1.0; 3], [2.0; 3], true));
        assert_eq!((r.len(), c.len()), (1, 1));
        let inside = DVec3::new(1.5, 1.4, 1.6);
        assert!((winding(&r[0], inside).abs() - 1.0).abs() < 1e-12);
        assert!((winding(&c[0], inside).abs() - 1.0).abs() < 1e-12);
        let between = DVec3::new(3.0, 2.5, 4.0);
        assert!((winding(&r[0], between).abs() - 1.0).abs() < 1e-12);
        assert!(winding(&c[0], between).abs() < 1e-12);
        assert!(winding(&r[0], DVec3::new(9.0, 1.0, 1.0)).abs() < 1e-12);
    }

    #[test]
    fn an_open_box_a_two_sided_panel_and_a_t_junction_are_no_shells() {
        let mut open = cuboid([0.0; 3], [1.0; 3], true);
        open.pop();
        assert!(shells_of(open).is_empty());
        let q = quad([
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]);
        let mut twin = q;
        twin.v[..4].reverse();
        assert!(shells_of(vec![q, twin]).is_empty());
        // A box of two-sided faces (each with its reversed twin): left out.
        let out = cuboid([0.0; 3], [1.0; 3], true);
        let both: Vec<Poly> = out
            .iter()
            .copied()
            .chain(cuboid([0.0; 3], [1.0; 3], false))
            .collect();
        assert!(shells_of(both).is_empty());
        // One face of a box tiled into two, its neighbours not: two T-junctions.
        let mut tiled = cuboid([0.0; 3], [1.0; 3], true);
        let top = tiled.remove(0);
        let [a, b, c, d] = [top.v[0], top.v[1], top.v[2], top.v[3]];
        let (m0, m1) = ((a + b) / 2.0, (c + d) / 2.0);
        tiled.push(Poly::new(&[a, m0, m1, d]));
        tiled.push(Poly::new(&[m0, b, c, m1]));
        assert!(shells_of(tiled.clone()).is_empty());
        // Tiled without T-junctions (the neighbours cut at the same points), it is.
        let mut conforming = cuboid([0.0; 3], [1.0; 3], true);
        conforming.remove(0);
        conforming.push(Poly::new(&[a, m0, m1, d]));
        conforming.push(Poly::new(&[m0, b, c, m1]));
        for f in conforming.iter_mut().take(5) {
            // Insert the midpoint into the faces that share the cut edges.
            let cs: Vec<DVec3> = f.corners().to_vec();
            let mut out = Vec::new();
            for k in 0..cs.len() {
                out.push(cs[k]);
                let (p, q) = (cs[k], cs[(k + 1) % cs.len()]);
                for m in [m0, m1] {
                    if (p.distance(m) + m.distance(q) - p.distance(q)).abs() < 1e-12 {
                        out.push(m);
                    }
                }
            }
            *f = Poly::new(&out);
        }
        assert_eq!(shells_of(conforming).len(), 1);
    }

    #[test]
    fn two_rooms_sharing_a_wall_in_one_object_and_a_crate_of_six_objects_are_shells() {
        // Rooms [0,4]^3 and [4,8] x [0,4]^2, faces in, two objects: the shared
        // wall's edges carry four polygons each (each room's wall and its
        // neighbour). In one object the wall's two faces would read as one
        // two-sided surface, and neither room would be a shell.
        let mut b = Build::default();
        b.add(cuboid([0.0; 3], [4.0; 3], false), false);
        b.add(cuboid([4.0, 0.0, 0.0], [8.0, 4.0, 4.0], false), false);
        let shells = find_shells(&b.done(), 1e-9);
        assert_eq!(shells.len(), 2);
        let (a, b) = (DVec3::new(2.0, 1.0, 1.0), DVec3::new(6.0, 1.0, 1.0));
        let w = |s: &Shell, x: DVec3| winding(s, x).abs().round() as i32;
        let sides: Vec<(i32, i32)> = shells.iter().map(|s| (w(s, a), w(s, b))).collect();
        assert!(
            sides.contains(&(1, 0)) && sides.contains(&(0, 1)),
            "{sides:?}"
        );
        // The same crate, each face an object of its own.
        let mut b = Build::default();
        for f in cuboid([1.0; 3], [2.0; 3], true) {
            b.add(vec![f], false);
        }
        assert_eq!(find_shells(&b.done(), 1e-9).len(), 1);
        // Two boxes stacked face to face, as two objects: the faces between them
        // run inside each other's solid, and no pairing round their shared edges
        // holds. As one object those two faces read as a two-sided surface, left
        // out, and the rest closes round both: one shell, the tall box.
        let mut b = Build::default();
        b.add(cuboid([0.0; 3], [1.0; 3], true), false);
        b.add(cuboid([0.0, 1.0, 0.0], [1.0, 2.0, 1.0], true), false);
        assert!(find_shells(&b.done(), 1e-9).is_empty());
        let mut stacked = cuboid([0.0; 3], [1.0; 3], true);
        stacked.extend(cuboid([0.0, 1.0, 0.0], [1.0, 2.0, 1.0], true));
        let tall = shells_of(stacked);
        assert_eq!(tall.len(), 1);
        assert!((winding(&tall[0], DVec3::new(0.5, 1.5, 0.5)).abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn what_a_sealed_crate_holds_and_a_sealed_room_beyond_the_wall_are_dark() {
        // A lit room [0,4]^3 with a lamp under its ceiling and a crate on its floor
        // holding a small box; a second room [4,8] x [0,4] x [0,4] beyond the wall
        // x = 4 (two faces back to back), with a box of its own.
        let scene = |holed: bool, far_lamp: bool| {
            let mut b = Build::default();
            let room = b.add(cuboid([0.0; 3], [4.0; 3], false), false);
            let lamp_at = b.add(vec![lamp()], true);
            let mut crate_ = cuboid([2.5, 0.0, 2.5], [3.5, 1.0, 3.5], true);
            if holed {
                crate_.remove(0);
            }
            let crate_ = b.add(crate_, false);
            let held = b.add(cuboid([2.7, 0.0, 2.7], [3.0, 0.4, 3.0], true), false);
            let far = b.add(cuboid([4.0, 0.0, 0.0], [8.0, 4.0, 4.0], false), false);
            let far_box = b.add(cuboid([5.0, 0.0, 1.0], [5.5, 0.5, 1.5], true), false);
            if far_lamp {
                let l = lamp().v.map(|v| v + DVec3::X * 4.0);
                b.add(vec![Poly::new(&l[..4])], true);
            }
            let p = b.done();
            let s = dark_patches(&p, &p);
            let dark = |r: std::ops::Range<usize>| r.clone().all(|i| s.dark[i]);
            let lit = |r: std::ops::Range<usize>| r.clone().all(|i| !s.dark[i]);
            (
                s.clone(),
                [room, lamp_at, crate_, held, far, far_box].map(|r| (dark(r.clone()), lit(r))),
            )
        };
        // A box's bottom resting on a floor faces the floor's underside, outside
        // the room: dark (contact meshing drops it too). `cuboid`'s last face.
        let (s, [room, lamp, crate_, held, far, far_box]) = scene(false, false);
        assert_eq!(s.shells, 5);
        assert_eq!(s.dark_patches, 6 + 6 + 6 + 1);
        assert!(room.1 && lamp.1 && held.0 && far.0 && far_box.0);
        assert!(
            !crate_.0 && !crate_.1,
            "the crate's bottom is dark, its sides lit"
        );
        // A hole in the crate (its top gone) lets the light in: the box it holds is
        // lit but for its bottom; the other room is still dark.
        let (s, [room, _, _, held, far, far_box]) = scene(true, false);
        assert_eq!(
            (s.shells, s.dark_patches),
            (4, 6 + 6 + 1 + 1),
            "and both bottoms"
        );
        assert!(room.1 && !held.0 && !held.1 && far.0 && far_box.0);
        // A lamp in the far room lights it and its box but for the box's bottom.
        let (s, [room, _, _, held, far, far_box]) = scene(false, true);
        assert_eq!(s.dark_patches, 6 + 1 + 1);
        assert!(room.1 && far.1 && !far_box.1 && held.0);
    }

    #[test]
    fn a_patch_half_out_of_a_sealed_crate_is_not_dark() {
        // A panel standing in a sealed crate and out through its top: part of it
        // is lit.
        let mut b = Build::default();
        b.add(cuboid([0.0; 3], [4.0; 3], false), false);
        b.add(vec![lamp()], true);
        b.add(cuboid([2.0, 0.0, 2.0], [3.0, 1.0, 3.0], true), false);
        let panel = b.add(
            vec![quad([
                [2.2, 0.5, 2.5],
                [2.8, 0.5, 2.5],
                [2.8, 1.5, 2.5],
                [2.2, 1.5, 2.5],
            ])],
            false,
        );
        let p = b.done();
        let s = dark_patches(&p, &p);
        assert!(!s.dark[panel.start]);
        // The crossing alone says so: the panel's corners, raised inside the crate.
        let shells = find_shells(&p, 1e-9);
        let crate_shell = shells
            .iter()
            .find(|sh| sh.tris.len() == 12 && sh.hi.y < 1.5)
            .unwrap();
        let q = p.polys[panel.start];
        assert!(crosses(crate_shell, &q, q.normal(), 1e-9));
        let low = quad([
            [2.2, 0.5, 2.5],
            [2.8, 0.5, 2.5],
            [2.8, 0.9, 2.5],
            [2.2, 0.9, 2.5],
        ]);
        assert!(!crosses(crate_shell, &low, low.normal(), 1e-9));
        assert_eq!(
            side_of(crate_shell, &low, low.normal(), 1e-6, 1e-9),
            Side::Inside
        );
    }
}
