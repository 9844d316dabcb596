//! Contact meshing: cut patches along the lines where other polygons rest on them, and
//! drop the pieces hidden underneath.
//!
//! A block standing on a floor darkens the floor right up to its base and is dark
//! itself near the floor: radiosity has a derivative discontinuity (and the floor
//! under the block a value discontinuity) along the contact line. An element that
//! straddles that line averages light and dark, which no refinement of links repairs;
//! the published hierarchical systems stall there. So before solving, every patch of
//! a static object is cut by the lines of **contact segments**: edges of other static
//! polygons that lie in the patch's plane (within a tolerance of 1e-6 of the scene's
//! diameter) and stand on its front side, every edge of a coplanar polygon that
//! faces the opposite way (a resting face), and where another polygon passes
//! through the patch (a slab through a slab at a room's corner, a leg sunk into
//! the floor), the segment along which it crosses the patch's plane, clipped to
//! the patch (`crossing_segment`). Each cut splits a convex polygon into two
//! convex polygons along a segment's line, and only the pieces the segment runs
//! through, or passes within half its length, are cut (`cut_by_lines`: whole lines
//! cut tiles far from a table leg into slivers); pieces with more than four corners
//! are fanned into triangles.
//! A piece whose inner point (off its centre, see `inner_point`), raised a hair along
//! the normal, first meets a back face straight above (it lies inside the solid
//! resting on it), or meets one first along every ray slanted 45° off the normal
//! (inside a solid open above, a pillar from floor to ceiling without its ends: see
//! `SLANTED_RAYS`), is dropped: it exchanges no light with the rest of the scene. So is
//! a face resting face to face on a coplanar polygon with its own solid behind it (a
//! box's bottom on the floor); a thin panel modelled as two coincident faces has open
//! space behind each and keeps both. A two-sided surface (a polygon and its reversed
//! twin, glTF `doubleSided`) is no solid: the twin is not a resting face, and the
//! rays meet the face turned to them first ([`SceneBvh::intersect_front_first`]).
//! With the traversal's order deciding, the Blender Cornell box of
//! `tests/data/blender/` (two-sided slabs) lost the room side of its floor, walls
//! and ceiling: the room read 0.1–4% of the path tracer (74–101% now). The
//! pieces of a two-sided slab that lie inside another are kept so (each face
//! has a twin turned to the inside), but as pieces of their own: uncut, the
//! floor's room side ran 6.5 cm into the back wall's slab and the back wall's
//! into the floor, ceiling and side walls (18% of its area), and their leaves
//! handed on the average of the lit room side and the dark inside: the room
//! read 11.1% off the path tracer, 4.5% with the crossings cut.
//!
//! **Covered regions.** A polygon hanging parallel just in front of a patch with its
//! back to it (a lamp hung 1 cm under a ceiling) covers a region that sees little:
//! within [`NEAR_GAP_OF_SIZE`] of the polygon's size. The patch is cut along that
//! outline too, and the covered piece is kept (a probe there finds the ceiling, dark,
//! as a path tracer does), not dropped. Why: whole, the patch hands on its *average*
//! radiosity, dark covered part included, to receivers that see only its lit part
//! (2.3% of the power of `tests/data/hung_lamp_room.json` lost; a one-quad ceiling
//! 1 cm over a 1 m lamp in a 6 m room, uncut, was 2–4% dark everywhere).
//!
//! **Moving objects.** Their contacts change over time: no patch is cut along them
//! (the refinement meshes them), but a piece of a static patch that lies inside a
//! moving solid is hidden as under a static one, *where the solid stands at the
//! scene's start time*, in every frame: the patch set must not depend on the time,
//! so that the frames of a per-frame solve are one file's (their leaves are played
//! back on frame 0's patches) and a space-time solve's windows share its patches
//! (Damez & Sillion, section 4: one hierarchy over the whole animation). Hidden by
//! where the solid stands at each frame's own time, the fanned floor under a
//! block sliding over it lost two pieces at 0.4 s that it had at 0, and `rhier
//! solve --per-frame` refused the file ("frame 2 at t = 0.4: expected the 73
//! patches of frame 0, found 71"). The floor under where the solid stood at the
//! start stays hidden after it has left; keeping it (hiding behind static solids
//! only) leaves a piece the solid covers at some times only, uncut, whose leaves
//! average the dark covered part with the lit rest: the sliding Cornell block's
//! faces read 4.0% off the fine static solve at 0.8 s for 1.4%, and space-time
//! 1.06–1.15 times the static solve's error (commit 47e60f0, reverted).
//!
//! Shadow boundaries away from contacts are meshed by the reconstruction's
//! adaptive cells, not here.

use glam::DVec3;

use super::patches::Patches;
use super::polygon::{Poly, clip_to_half_space};
use super::visibility::SceneBvh;
use crate::scene::Scene;

/// What contact meshing did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContactStats {
    /// Patches that were cut.
    pub patches_cut: u32,
    /// Pieces dropped as hidden under a resting solid.
    pub pieces_hidden: u32,
}

/// Returns `patches` with every static patch cut along its contact lines and hidden
/// pieces removed (see the module docs).
///
/// The pieces hidden under a moving object are those under it at the scene's start
/// time, whatever `t` (module docs, "Moving objects"): every frame of an animation
/// gets the same patches.
pub fn split_at_contacts(scene: &Scene, patches: &Patches, t: f64) -> (Patches, ContactStats) {
    split_at_contacts_but(scene, patches, t, &[])
}

/// [`split_at_contacts`], with the patches `cut_nothing` marks (a flag per patch
/// of `patches`; empty: none) drawing no line as resting faces and cut by none:
/// the patches no light reaches ([`super::Shells::dark`]). A dark polygon face to
/// face with a lit one lies behind it (a sealed room's wall against the lit
/// room's): cut along it, the lit wall took every edge of the dark room's
/// tessellated wall. Their other lines are kept: where a dark face passes through
/// a lit one (a two-sided slab's inner face through the room side of another,
/// Blender's box) the cut is where the lit side ends, and without those cuts the
/// Blender box read 6.0% off the path tracer for 2.8%. A dark patch itself is
/// black whole: left uncut, or dropped whole where hidden.
pub fn split_at_contacts_but(
    scene: &Scene,
    patches: &Patches,
    t: f64,
    cut_nothing: &[bool],
) -> (Patches, ContactStats) {
    // The static part does not depend on the time; the moving objects stand where
    // they stand at the start (module docs, "Moving objects").
    let start = scene.time.start;
    let bvh = SceneBvh::build(scene, patches, start);
    let tol = patches.diameter * 1e-6;
    // The widest gap any polygon of the scene covers (see `NEAR_GAP_OF_SIZE`).
    let near_gap = NEAR_GAP_OF_SIZE * patches.areas.iter().fold(0.0f64, |m, &a| m.max(a)).sqrt();
    let moving = |i: usize| {
        scene
            .objects
            .get(patches.objects[i] as usize)
            .is_some_and(|o| o.is_moving())
    };
    let mut out = Patches::default();
    let mut stats = ContactStats::default();
    for i in 0..patches.len() {
        let poly = patches.polys[i];
        let g = patches.geometry[i];
        if moving(i) {
            out.push(
                scene,
                poly,
                g.vertices,
                g.corners as usize,
                patches.objects[i],
                g.material,
            );
            continue;
        }
        let n = patches.normals[i];
        let dark = |j: usize| cut_nothing.get(j).copied().unwrap_or(false);
        let Contacts {
            lines,
            facing,
            covering,
        } = contacts(patches, &bvh, i, (&moving, &dark), tol, near_gap);
        // A dark patch is black whole: cut, it would only store more cells (it is
        // still dropped whole where hidden, as a box's bottom on the floor).
        let lines = if dark(i) { Vec::new() } else { lines };
        let pieces = cut_by_lines(poly, n, lines, tol);
        // Hidden: inside the solid resting on the patch (the first thing straight
        // above is a back face), or a face resting face to face on a coplanar
        // polygon with its own solid behind it (a box's bottom on the floor: the
        // first thing straight behind it is the inside of the box). A thin panel
        // modelled as two coincident faces is neither: behind each face lies open
        // space.
        let hidden = |piece: &Poly| {
            let x = inner_point(piece);
            let behind_is_back_face = |dir: DVec3| {
                bvh.intersect_front_first(x + dir * (tol * 4.0), dir * patches.diameter, 0.0, 1.0)
                    .is_some_and(|h| h.back)
            };
            let on = |&j: &usize| patches.polys[j].contains(patches.normals[j], x, tol);
            // A solid open at both ends (a pillar from floor to ceiling, its ends
            // left out) has no back face straight above its footprint, only the
            // footprint on the ceiling; every slanted ray meets its sides' backs.
            let (t, b) = n.any_orthonormal_pair();
            let enclosed = || {
                (0..SLANTED_RAYS).all(|k| {
                    let phi = std::f64::consts::TAU * (k as f64 + 0.5) / SLANTED_RAYS as f64;
                    let side = t * phi.cos() + b * phi.sin();
                    behind_is_back_face((n + side) * std::f64::consts::FRAC_1_SQRT_2)
                })
            };
            // The ray first: a floor under a field of boxes faces every box bottom,
            // and nothing lies behind the floor.
            // A covered piece is kept (module docs) unless a solid rests on it: a
            // flat box's top covers the floor under it, and its bottom rests there.
            (pieces.len() > 1
                && (!covering.iter().any(on) || facing.iter().any(on))
                && (behind_is_back_face(n) || enclosed()))
                || (behind_is_back_face(-n) && facing.iter().any(on))
        };
        if pieces.len() == 1 {
            if hidden(&poly) {
                stats.pieces_hidden += 1;
                continue;
            }
            out.push(
                scene,
                poly,
                g.vertices,
                g.corners as usize,
                patches.objects[i],
                g.material,
            );
            continue;
        }
        stats.patches_cut += 1;
        let to_object = scene.objects[patches.objects[i] as usize]
            .to_world(t)
            .inverse();
        for piece in &pieces {
            if hidden(piece) {
                stats.pieces_hidden += 1;
                continue;
            }
            let corners = piece.corners();
            let mut emit = |w: &[DVec3]| {
                let mut obj = [DVec3::ZERO; 4];
                for (o, &v) in obj.iter_mut().zip(w) {
                    *o = to_object.transform_point3(v);
                }
                out.push(
                    scene,
                    Poly::new(w),
                    obj,
                    w.len(),
                    patches.objects[i],
                    g.material,
                );
            };
            if corners.len() <= 4 {
                emit(corners);
            } else {
                for k in 1..corners.len() - 1 {
                    emit(&[corners[0], corners[k], corners[k + 1]]);
                }
            }
        }
    }
    out.finish();
    (out, stats)
}

/// What meets static patch `i` (see the module docs): the contact lines, the
/// coplanar polygons facing it and those hanging just in front of it.
struct Contacts {
    /// Contact lines: (point, in-plane direction).
    lines: Vec<(DVec3, DVec3)>,
    /// Coplanar polygons facing the other way (faces resting face to face).
    facing: Vec<usize>,
    /// Polygons hanging just in front, parallel, their back to the patch.
    covering: Vec<usize>,
}

/// The [`Contacts`] of patch `i` with the static patches near it (`moving` tells
/// the others), within `tol` of its plane or, parallel and facing away, within
/// `near_gap` (the widest gap a polygon of the scene covers) in front of it.
fn contacts(
    patches: &Patches,
    bvh: &SceneBvh,
    i: usize,
    (moving, dark): (&impl Fn(usize) -> bool, &impl Fn(usize) -> bool),
    tol: f64,
    near_gap: f64,
) -> Contacts {
    let poly = patches.polys[i];
    let n = patches.normals[i];
    let d = n.dot(poly.v[0]);
    // Contact lines: (point, in-plane direction).
    let mut lines: Vec<(DVec3, DVec3)> = Vec::new();
    // Coplanar polygons facing the other way (faces resting face to face).
    let mut facing: Vec<usize> = Vec::new();
    // Polygons hanging just in front, parallel, their back to the patch.
    let mut covering: Vec<usize> = Vec::new();
    let (lo, hi) = poly.bounds();
    // The patch swept `near_gap` along its normal: what rests on it or covers it.
    let pad = DVec3::splat(tol * 2.0);
    let (lo, hi) = (
        lo.min(lo + n * near_gap) - pad,
        hi.max(hi + n * near_gap) + pad,
    );
    // In patch order, each once. Not in the order the BVH meets them: that order
    // follows the f32 tree, which another unit's rounding builds otherwise, and
    // the order of the cuts decides the pieces' order and corners (issue 45,
    // part 3).
    let mut seen = Vec::new();
    bvh.for_each_triangle_in_box(lo, hi, |j, _| {
        let j = j as usize;
        if j != i && !moving(j) {
            seen.push(j);
        }
        true
    });
    seen.sort_unstable();
    seen.dedup();
    for &j in &seen {
        let other = &patches.polys[j];
        let nj = patches.normals[j];
        let dist: Vec<f64> = other.corners().iter().map(|&v| n.dot(v) - d).collect();
        let coplanar = dist.iter().all(|x| x.abs() <= tol);
        let k = other.n;
        if coplanar {
            if n.dot(nj) < -0.99 && !is_twin(&poly, other, tol) {
                facing.push(j);
                // A dark polygon resting face to face (a sealed room's wall behind
                // this one) draws no line on it ([`split_at_contacts_but`]).
                if !dark(j) {
                    for e in 0..k {
                        lines.push((other.v[e], other.v[(e + 1) % k] - other.v[e]));
                    }
                }
            }
            continue;
        }
        if dist.iter().any(|&x| x < -tol) {
            // Passing through the patch (a slab through a slab, a leg sunk into
            // the floor): cut along where it crosses (module docs).
            if dist.iter().any(|&x| x > tol)
                && let Some((a, b)) = crossing_segment(&poly, n, d, other, &dist, tol)
            {
                lines.push((a, b - a));
            }
            continue; // not standing on the front side
        }
        let gap = dist.iter().copied().fold(0.0, f64::max);
        if n.dot(nj) > 0.99 && gap <= NEAR_GAP_OF_SIZE * other.area().sqrt() {
            covering.push(j);
            for e in 0..k {
                let (a, b) = (other.v[e], other.v[(e + 1) % k]);
                lines.push((a - n * (n.dot(a) - d), b - a));
            }
            continue;
        }
        for e in 0..k {
            let (a, b) = (e, (e + 1) % k);
            if dist[a].abs() <= tol && dist[b].abs() <= tol {
                lines.push((other.v[a], other.v[b] - other.v[a]));
            }
        }
    }
    Contacts {
        lines,
        facing,
        covering,
    }
}

/// Where polygon `other` (its corners at signed distances `dist` from the plane
/// `n · x = d` of `poly`, on both sides of it by more than `tol`) crosses that
/// plane, clipped to `poly`: the segment's ends, or `None` where it misses
/// `poly` or meets it over no more than `tol`.
///
/// `other` is convex, so it crosses the plane along one segment: between the
/// points where its edges change side (and its corners within `tol` of the
/// plane). Clipped to `poly` by its edges' inward half-planes (Cyrus & Beck),
/// so that only what passes through the patch cuts it: a neighbouring triangle
/// of a curved mesh that crosses the plane beside the patch cuts nothing.
fn crossing_segment(
    poly: &Poly,
    n: DVec3,
    d: f64,
    other: &Poly,
    dist: &[f64],
    tol: f64,
) -> Option<(DVec3, DVec3)> {
    let k = other.n;
    let mut pts: Vec<DVec3> = Vec::with_capacity(4);
    for e in 0..k {
        let (a, b) = (e, (e + 1) % k);
        let (sa, sb) = (dist[a], dist[b]);
        if sa.abs() <= tol {
            pts.push(other.v[a]);
        } else if (sa > tol && sb < -tol) || (sa < -tol && sb > tol) {
            pts.push(other.v[a] + (other.v[b] - other.v[a]) * (sa / (sa - sb)));
        }
    }
    // The two points farthest apart, on the plane.
    let (mut best, mut ends) = (0.0, None);
    for (i, &p) in pts.iter().enumerate() {
        for &q in &pts[i + 1..] {
            let l = p.distance_squared(q);
            if l > best {
                best = l;
                ends = Some((p, q));
            }
        }
    }
    let (p, q) = ends?;
    let onto = |x: DVec3| x - n * (n.dot(x) - d);
    let (p, q) = (onto(p), onto(q));
    let dir = q - p;
    let mut t = [0.0, 1.0];
    let c = poly.corners();
    for e in 0..c.len() {
        let (a, b) = (c[e], c[(e + 1) % c.len()]);
        // Inward in the plane for corners counter-clockwise about `n`.
        let m = n.cross(b - a);
        if !clip_to_half_space(&mut t, m.dot(p - a), m.dot(dir)) {
            return None;
        }
    }
    ((t[1] - t[0]) * dir.length() > tol).then(|| (p + dir * t[0], p + dir * t[1]))
}

/// True if `other` has the corners of `poly` (within `tol`): its back-to-back twin,
/// the other side of one two-sided surface (glTF `doubleSided`, `--two-sided`), not
/// a face resting on it.
fn is_twin(poly: &Poly, other: &Poly, tol: f64) -> bool {
    poly.n == other.n
        && poly.corners().iter().all(|&c| {
            other
                .corners()
                .iter()
                .any(|&o| o.distance_squared(c) <= tol * tol)
        })
}

/// `poly` (normal `n`) cut along each of `lines`, segments `(p0, dir)` from `p0` to
/// `p0 + dir`: a piece is cut by the segment's whole line, so the pieces stay
/// convex, but only where the segment, lengthened by [`CUT_REACH`] of its length
/// at each end, runs through the piece's interior (longer than `tol` inside it),
/// so that a contact outline cuts the pieces near it and no others.
///
/// Cut along the whole lines, a floor tile under a round table leg of `k` sides
/// was cut by `k` lines across the tile, into up to `k²/2` pieces most of which
/// lie far from the leg: the 49 room polygons of `tools/gen_furnished.py --detail
/// 0.15 --static` became 8 684 patches (slivers down to 2e-10 m²), two thirds of
/// the room's 12 696; near the segments they become 841. Afterwards no piece's
/// interior meets any segment, so every piece lies wholly inside or wholly outside
/// each outline the segments close, which is what the hidden test needs.
fn cut_by_lines(poly: Poly, n: DVec3, lines: Vec<(DVec3, DVec3)>, tol: f64) -> Vec<Poly> {
    // The segments grouped by their line, in the order each line is first met,
    // each line cut along once over the union of its segments' reaches, from its
    // first segment's side (the order of the halves, and so of the patches, is
    // the whole lines' where the reaches cover them: `gen_cubes` solves bit for
    // bit as before; with the halves swapped its 2.41% went to 1.66% by the
    // patch order alone). A line met
    // again (boxes in a row share their edges' lines; a box's bottom and its sides
    // give each edge twice) cut nothing the first did not but slivers within the
    // tolerance; one cut per line also keeps the work at lines × pieces, not
    // segments × pieces (the 66k box edges on the floor of `gen_cubes 129` lie on
    // 516 lines).
    struct Line {
        p0: DVec3,
        cut_n: DVec3,
        along: DVec3,
        reach: Vec<(f64, f64)>,
    }
    let mut groups: Vec<Line> = Vec::new();
    let mut index = std::collections::HashMap::new();
    for (p0, dir) in lines {
        let cut_n = n.cross(dir);
        let len = cut_n.length();
        if len <= 0.0 {
            continue;
        }
        let cut_n = cut_n / len;
        let (m, off) = line_key_normal(cut_n, p0);
        let g = *index.entry(line_key(m, off, tol)).or_insert_with(|| {
            groups.push(Line {
                p0,
                cut_n,
                along: n.cross(cut_n),
                reach: Vec::new(),
            });
            groups.len() - 1
        });
        let along = groups[g].along;
        let (a0, a1) = (along.dot(p0), along.dot(p0 + dir));
        let (lo, hi) = (a0.min(a1), a0.max(a1));
        let r = CUT_REACH * (hi - lo);
        groups[g].reach.push((lo - r, hi + r));
    }
    let mut pieces = vec![poly];
    let mut next = Vec::new();
    for line in &mut groups {
        // The union of the reaches, as disjoint intervals in order.
        line.reach.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut merged: Vec<(f64, f64)> = Vec::with_capacity(line.reach.len());
        for &(lo, hi) in &line.reach {
            match merged.last_mut() {
                Some(last) if lo <= last.1 => last.1 = last.1.max(hi),
                _ => merged.push((lo, hi)),
            }
        }
        let (p0, cut_n) = (line.p0, line.cut_n);
        next.clear();
        for &piece in &pieces {
            let mut s = [0.0f64; super::polygon::MAX_CORNERS];
            for (x, &v) in s.iter_mut().zip(piece.corners()) {
                *x = cut_n.dot(v - p0);
            }
            let s = &s[..piece.n];
            let crosses = s.iter().any(|&x| x > tol) && s.iter().any(|&x| x < -tol);
            if !crosses || !reaches_inside(piece.corners(), s, line.along, &merged, tol) {
                next.push(piece);
                continue;
            }
            for side in [cut_n, -cut_n] {
                let half = piece.clip_front_within(p0, side, tol);
                if half.n >= 3 && half.area() > tol * tol {
                    next.push(half);
                }
            }
        }
        std::mem::swap(&mut pieces, &mut next);
    }
    pieces
}

/// The unit normal `m` of a line through `p0` with its sign fixed so that its
/// largest component is positive, and the line's offset `m · p0`: the same line
/// gets the same pair whichever way its segment runs.
fn line_key_normal(m: DVec3, p0: DVec3) -> (DVec3, f64) {
    let a = m.abs();
    let big = if a.x >= a.y && a.x >= a.z {
        m.x
    } else if a.y >= a.z {
        m.y
    } else {
        m.z
    };
    let m = if big < 0.0 { -m } else { m };
    (m, m.dot(p0))
}

/// The infinite line `{x : m·x = off}` (unit `m` from [`line_key_normal`], in the
/// patch's plane) as a key: direction to 1e-9 and offset to `tol`. Equal keys are
/// the same line within those; the same line can still get two keys at a rounding
/// boundary, which only costs a cut that splits nothing.
fn line_key(m: DVec3, off: f64, tol: f64) -> [i64; 4] {
    let q = |x: f64| (x * 1e9).round() as i64;
    [q(m.x), q(m.y), q(m.z), (off / tol).round() as i64]
}

/// True if one of the disjoint intervals `reach` (positions along `along`) of a
/// line that crosses the convex piece with corners `c` (signed distances `s` from
/// the line) runs more than `tol` through the piece: the line's chord through the
/// piece, from the points where its edges cross the line and its corners on the
/// line, overlaps it by more than `tol`.
fn reaches_inside(c: &[DVec3], s: &[f64], along: DVec3, reach: &[(f64, f64)], tol: f64) -> bool {
    let (mut t0, mut t1) = (f64::INFINITY, f64::NEG_INFINITY);
    let k = c.len();
    for e in 0..k {
        let (sa, sb) = (s[e], s[(e + 1) % k]);
        if sa.abs() <= tol {
            let t = along.dot(c[e]);
            t0 = t0.min(t);
            t1 = t1.max(t);
        }
        if (sa > tol && sb < -tol) || (sa < -tol && sb > tol) {
            let x = c[e] + (c[(e + 1) % k] - c[e]) * (sa / (sa - sb));
            let t = along.dot(x);
            t0 = t0.min(t);
            t1 = t1.max(t);
        }
    }
    reach.iter().any(|&(lo, hi)| t1.min(hi) - t0.max(lo) > tol)
}

/// How far past its ends a contact segment cuts the pieces along its line, as a
/// fraction of its length (`cut_by_lines`). Cut along the segments alone (0), the
/// floor of `tools/gen_cubes.py 20` lost the cuts across its gaps at the boxes'
/// corners: its 3 295 patches became 2 434, the gaps long strips, and the solve
/// went from 76.5 to 107.0 CPU s and from 2.41% to 3.77% off the path tracer
/// (box sides 2.4% → 6.9%). Past half its length a box's edge reaches the next
/// box's across the gap, and the floors of `gen_cubes` 20, 65 and 129 are cut as
/// by whole lines (3 295, 34 075, 133 659 patches); the furnished room of
/// `tools/gen_furnished.py --detail 0.15 --static` has 4 219 patches (12 696 by
/// whole lines, 2 766 by the segments alone).
const CUT_REACH: f64 = 0.5;

/// Largest gap between a patch and a parallel polygon hanging in front of it with
/// its back to it, as a fraction of that polygon's size (square root of its area),
/// for the patch to be cut along the polygon's outline (module docs, "Covered
/// regions"). The covered region of a square of side `L` hung `h` away sees out
/// through about `2h/L` of its hemisphere on average: half at this gap, a dark
/// region whose edge runs along the outline. Relative to the polygon alone, so
/// that a scaled scene is cut alike (issue 45, part 3). At 0.1, a 1 m lamp hung
/// 20 cm under the ceiling of a 6 m room left the ceiling whole: the one-quad
/// room's ceiling over the lamp read 0.396 against the path tracer's 0.054, and
/// its estimate 3.9% where the tiled room's read 0.35%.
pub const NEAR_GAP_OF_SIZE: f64 = 0.25;

/// Slanted rays (45° off the normal, spread evenly around it) that must all meet
/// a back face first for a cut piece to lie inside a solid open above it (module
/// docs): the footprint of a pillar standing from floor to ceiling without its
/// ends. Its floor and ceiling pieces see only each other and the pillar's
/// insides; kept, they lost their light on the sides' backs, the closure test
/// found the room open and the room was never balanced (its pillar read 2.2% low
/// at `ρ = 0.5`, 21–25% everywhere at 0.99).
const SLANTED_RAYS: usize = 6;

/// A point well inside convex polygon `p` but off its centroid, for the hidden
/// test's ray: a box's top is two triangles whose shared diagonal runs straight
/// over the centroid of the floor piece under the box, and a ray through that edge
/// can miss both (measured: half the boxes of `tools/gen_cubes.py 6` kept the floor
/// under them).
fn inner_point(p: &Poly) -> DVec3 {
    let c = p.centroid();
    let v = p.corners();
    c + 0.137 * (v[0] - c) + 0.071 * (v[1] - c)
}
