//! [`SceneBvh`]: ray visibility through obvhs compressed wide BVHs (CWBVH, Ylitie et
//! al. 2017, as built by obvhs' PLOC builder).
//!
//! Static objects are merged into one BVH in world space; every moving object has its
//! own BVH in object space, and a query at time `t` maps the ray into that object's
//! space with the inverse of its motion at `t` (rays are parameterised by the segment,
//! `o + s·d` with `s ∈ [0, 1]`, so an affine map keeps `s`). Quads enter the BVH as two
//! triangles; every triangle remembers its patch.
//!
//! The solver casts its rays in bundles, from one point to points of one source
//! ([`crate::oracle`]); a bundle carries a [`LastHit`], the triangle that blocked
//! its last blocked ray, and tests it before the traversal (Haines & Greenberg's
//! shadow cache, 1986). On ACTOR a third of the rays are blocked and two thirds of
//! those by the triangle cached; the answers are the traversal's.
//!
//! Occlusion is decided in f64: an f32 BVH finds the candidate triangles, and each
//! is tested on its f64 corners ([`SceneBvh::occluded_cached`]), so that the answer
//! does not depend on how the scene's unit rounds to f32; a candidate whose plane
//! both ends of the segment lie clearly on one side of is skipped before that test,
//! which it could not hit ([`PLANE_REJECT`]). The occlusion rays' BVH is
//! a 4-wide one with plain f32 boxes over the same padded triangle boxes
//! ([`super::wide::Bvh4`], from obvhs' PLOC tree); the CWBVH, whose byte-quantised
//! boxes cost more to decode than a ray's f64 tests, keeps closest hits and box
//! queries, and may find the occlusion candidates instead (`RHIER_RAYS=cwbvh`).
//!
//! Occlusion rays have a third backend, Embree 3 ([`Rays`], `RHIER_RAYS=embree`,
//! its library opened at run time): it finds the candidates in place of the BVHs
//! and the same f64 test decides ([`super::embree`]); closest hits and box queries
//! stay on obvhs.
//!
//! What it does not do: it never decides what a segment's end points may hit. Callers
//! pass segments between two surface points; the ends are trimmed by a fraction of the
//! segment's length so the surfaces they start and end on do not count.

use std::time::Duration;

use glam::{DAffine3, DVec3, UVec2, Vec3A};
use obvhs::{
    BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, cwbvh::builder::build_cwbvh, ray::Ray,
    triangle::Triangle,
};

use super::patches::Patches;
use super::wide::{Bvh4, Cull4};
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Which BVH finds the candidates of the occlusion rays of a [`SceneBvh`] (closest
/// hits and box queries are always obvhs' CWBVH's). All decide each candidate triangle
/// by the same f64 test, so they give the same answers (Embree's but for rays grazing
/// a triangle's edge at under ~1°, `geometry::embree`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Rays {
    /// The default: obvhs' PLOC BVH collapsed to 4 wide with plain f32 boxes,
    /// traversed by rhier (`geometry::wide`).
    #[default]
    Obvhs,
    /// obvhs' CWBVH traversal (the default before issue 48's rays; kept to compare).
    Cwbvh,
    /// Embree 3 (`libembree3.so.3`, opened when first asked for; Debian:
    /// `apt-get install libembree3-3`, or `libembree-dev`).
    Embree,
}

impl Rays {
    /// The environment variable that chooses the backend of [`SceneBvh::build`]
    /// (as `RHIER_STORAGE` chooses the pools'): unset, empty or `obvhs` for the
    /// default, `cwbvh` for obvhs' CWBVH traversal, `embree` for Embree (where its
    /// library can be opened). CI runs the visibility tests and a set of
    /// known-answer solves on obvhs and Embree.
    pub const ENV: &'static str = "RHIER_RAYS";

    /// The backend [`Rays::ENV`] names; refuses `embree` where Embree's library
    /// cannot be loaded, naming it and how to install it.
    pub fn from_env() -> Result<Rays> {
        let value = std::env::var_os(Self::ENV).unwrap_or_default();
        match value.to_str() {
            Some("" | "obvhs") => Ok(Rays::Obvhs),
            Some("cwbvh") => Ok(Rays::Cwbvh),
            Some("embree") => match super::embree::load() {
                Ok(()) => Ok(Rays::Embree),
                Err(e) => Err(Error::Usage(format!("{}=embree: {e}", Self::ENV))),
            },
            _ => Err(Error::Usage(format!(
                "{}: expected obvhs, cwbvh or embree, found {:?}",
                Self::ENV,
                value
            ))),
        }
    }
}

/// Relative trim of both ends of a visibility segment.
pub const SEGMENT_TRIM: f64 = 1e-4;

/// Relative trim of both ends of a segment between two surface points whose
/// patches, and those patches' back-to-back twins, are skipped
/// ([`SceneBvh::occluded_between`]): what [`SEGMENT_TRIM`] guards against, the
/// round-off hits on the surfaces the segment starts and ends on, is then left to
/// the skip, and the trim only has to absorb the round-off of a hit on a coplanar
/// neighbour at the very start (`1e-16 / sin θ` of the length for a ray leaving at
/// `θ`). Why: a leaf of Blender's Suzanne (`tests/data/blender/cornell-box.glb`,
/// two-sided) lies 0.14 mm from the lip folded over it; rays from its corners and
/// finer points passed through that lip inside the `1e-4` trim of a 1 m segment and
/// saw the room through the closed head, and its row summed to 1.38 (issue 45,
/// part 4).
pub const SURFACE_TRIM: f64 = 1e-9;

/// The ray parameter before which obvhs' CWBVH traversal drops a node whatever the
/// ray's `tmin` (`EPSILON` in obvhs 0.4 `cwbvh/node.rs`: a node's entry is clamped
/// to it, so a node the ray leaves sooner is never entered).
const NODE_EPSILON: f64 = 1e-4;

/// How much further than it is a face turned away from the ray counts in
/// [`SceneBvh::intersect_front_first`], in units of the ray's direction (the
/// callers' `d` is twice the scene's diameter: about 4·10⁻⁶ of the scene): far above
/// the f32 round-off of two coincident triangles' hits, far below any gap a scene
/// means.
pub const FRONT_FIRST_TIE: f64 = 2e-6;

/// Which parts of a [`SceneBvh`] a query looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parts {
    /// Everything.
    All,
    /// The static objects only.
    Static,
    /// The moving objects only.
    Moving,
}

/// The triangle that blocked the last segment of a bundle (a shadow cache, Haines &
/// Greenberg 1986): segments from one point to one source are mostly blocked by the
/// same triangle, so [`SceneBvh::occluded_cached`] tests it first and skips the
/// traversal when it blocks again. A hint only: a triangle the query may see that
/// the segment crosses is one the traversal would reach, so the answer does not
/// depend on what is cached here (but for f32 round-off at a node's box, which
/// could hide from the traversal a grazing hit the triangle test makes: none in
/// ACTOR's, LIGHT's and the Cornell box's files, nor in
/// `tests/it/geometry/visibility.rs`'s rays). Keep one per bundle (one call's rays), not
/// one per thread, so that what is tested first does not depend on scheduling.
/// 8 bytes.
#[derive(Clone, Copy, Debug)]
pub struct LastHit {
    /// Index of the part in [`SceneBvh`] (`u32::MAX`: none yet).
    part: u32,
    /// Index of the triangle in the part's BVH order.
    tri: u32,
}

impl Default for LastHit {
    fn default() -> Self {
        LastHit {
            part: u32::MAX,
            tri: 0,
        }
    }
}

impl Parts {
    /// True if a query over `self` looks at `part`.
    fn admits(self, part: &Part) -> bool {
        let moving = part.object != u32::MAX;
        match self {
            Parts::All => true,
            Parts::Static => !moving,
            Parts::Moving => moving,
        }
    }
}

/// A closest hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Patch hit.
    pub patch: u32,
    /// Ray parameter of the hit (in units of the given direction's length).
    pub t: f64,
    /// The triangle hit faces away from the ray, as its part is placed (its
    /// back face was hit).
    pub back: bool,
}

/// One BVH with the triangles it indexes.
struct Part {
    bvh: CwBvh,
    /// The occlusion rays' BVH over the same padded boxes (primitive `i` is
    /// `tris[i]`), for [`Rays::Obvhs`].
    wide: Bvh4,
    /// Triangles in BVH order (indexed by the BVH's primitive ids).
    tris: Vec<Triangle>,
    /// Patch of each triangle in `tris`.
    tri_patch: Vec<u32>,
    /// `tris` in f64 (part space): what shafts cull ([`SceneBvh::for_each_triangle_in_box`])
    /// and what occlusion tests ([`SceneBvh::occluded_cached`]).
    /// The f32 corners are off by up to 6e-8 of the coordinates, far above a
    /// shaft's tolerance (1e-9 of its box), and off differently in another unit:
    /// a block's face on the floor's plane was in front of a shaft's end in
    /// millimetres and behind it in metres (issue 45, part 3).
    tris64: Vec<[DVec3; 3]>,
    /// Each triangle's plane for [`Part::hit64_planed`]: `n = (e₁ × e₂) / (|e₁|
    /// |e₂|)` (the unit normal times the sine of the corner at `v₀`, 0 for a
    /// degenerate triangle) and `w = n · v₀`, part space ([`triangle_planes`]).
    planes64: Vec<(DVec3, f64)>,
    /// [`part_reach`] of `tris64`: what [`PLANE_REJECT`] is relative to.
    reach: f64,
    /// World → part space (identity for the static part).
    world_to_local: DAffine3,
    /// Part → world.
    local_to_world: DAffine3,
    /// Object placed by this part's motion (`u32::MAX` for the static part).
    object: u32,
    /// Part space is world (or object) space times this power of two
    /// ([`unit_scale`]).
    unit: f64,
    /// World box of the part where it is placed (segments that miss it skip the
    /// part).
    world_box: (DVec3, DVec3),
    /// The part's triangles in Embree (primitive `i` is `tris[i]`), when
    /// [`Rays::Embree`] casts the occlusion rays.
    embree: Option<super::embree::EmbreeScene>,
}

impl Part {
    fn build(
        (tris, tri_patch, tris64): Tris,
        local_to_world: DAffine3,
        object: u32,
        unit: f64,
    ) -> Option<Part> {
        if tris.is_empty() {
            return None;
        }
        // Of the triangles' set: the same in the BVH's order below.
        let reach = part_reach(&tris64);
        let pad = reach * BOX_PAD;
        let bvh = build_cwbvh(
            &padded_boxes(&tris64, pad),
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        // Reorder so the BVH's primitive ids index the triangles directly.
        let (tris, tri_patch) = bvh
            .primitive_indices
            .iter()
            .map(|&i| (tris[i as usize], tri_patch[i as usize]))
            .unzip();
        let tris64: Vec<[DVec3; 3]> = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris64[i as usize])
            .collect();
        let wide = Bvh4::build(&padded_boxes(&tris64, pad), &tris64, pad);
        let planes64 = triangle_planes(&tris64);
        let mut part = Part {
            bvh,
            wide,
            tris,
            tri_patch,
            tris64,
            planes64,
            reach,
            world_to_local: local_to_world.inverse(),
            local_to_world,
            object,
            unit,
            world_box: (DVec3::ZERO, DVec3::ZERO),
            embree: None,
        };
        part.update_box();
        Some(part)
    }

    /// Recomputes `world_box` from the BVH's box and the placement.
    fn update_box(&mut self) {
        let b = &self.bvh.total_aabb;
        let (lo, hi) = (
            DVec3::new(b.min.x as f64, b.min.y as f64, b.min.z as f64),
            DVec3::new(b.max.x as f64, b.max.y as f64, b.max.z as f64),
        );
        let mut wlo = DVec3::splat(f64::INFINITY);
        let mut whi = DVec3::splat(f64::NEG_INFINITY);
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let w = self.local_to_world.transform_point3(c);
            wlo = wlo.min(w);
            whi = whi.max(w);
        }
        // Pad by round-off of the f32 BVH: relative to the box's size and to its
        // coordinates (f32 round-off grows with them; an absolute floor would be
        // all of a micrometre scene and nothing of a kilometre one).
        let reach = whi.abs().max(wlo.abs()).max_element();
        let pad = DVec3::splat(((whi - wlo).length() + reach) * 1e-6);
        self.world_box = (wlo - pad, whi + pad);
    }

    /// True if the segment `a + s·d`, `s ∈ [s0, s1]`, misses the part's world box.
    fn misses_box(&self, a: DVec3, d: DVec3, s0: f64, s1: f64) -> bool {
        let (lo, hi) = self.world_box;
        let (mut t0, mut t1) = (s0, s1);
        for k in 0..3 {
            if d[k].abs() < 1e-300 {
                if a[k] < lo[k] || a[k] > hi[k] {
                    return true;
                }
                continue;
            }
            let inv = 1.0 / d[k];
            let (mut ta, mut tb) = ((lo[k] - a[k]) * inv, (hi[k] - a[k]) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return true;
            }
        }
        false
    }

    /// Parameter in `[tmin, tmax]` where the segment `o + s·d` (part space, f64)
    /// meets triangle `id` in f64 (Möller & Trumbore 1997, edges included), or
    /// infinity. See [`SceneBvh::occluded_cached`] for why f64.
    #[allow(clippy::manual_range_contains)]
    fn hit64(&self, id: usize, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> f64 {
        let [v0, v1, v2] = self.tris64[id];
        let (e1, e2) = (v1 - v0, v2 - v0);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return f64::INFINITY;
        }
        let inv = 1.0 / det;
        let c = o - v0;
        let u = c.dot(p) * inv;
        // What the test below refuses for any `v` (`u + v > 1` if `u > 1`, `v ≥ 0`:
        // rounding is monotone), before `v` is computed; a NaN goes on as before
        // (which `!(0.0..=1.0).contains(&u)` would not let it).
        if u < 0.0 || u > 1.0 {
            return f64::INFINITY;
        }
        let q = c.cross(e1);
        let v = d.dot(q) * inv;
        if u < 0.0 || v < 0.0 || u + v > 1.0 {
            return f64::INFINITY;
        }
        let t = e2.dot(q) * inv;
        if t >= tmin && t <= tmax {
            t
        } else {
            f64::INFINITY
        }
    }

    /// The segment `o + s·d`, `s ∈ [tmin, tmax]` (part space, f64), as
    /// [`Part::hit64_planed`] reads it.
    fn segment64(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Segment64 {
        Segment64 {
            o,
            d,
            tmin,
            tmax,
            ends: [o + d * tmin, o + d * tmax],
            reject: PLANE_REJECT * (self.reach + o.length() + d.length()),
        }
    }

    /// [`Part::hit64`] on `seg`, but infinity at once when both ends of `seg`
    /// lie on the same side of triangle `id`'s plane by more than `seg.reject`
    /// (scaled: [`Part::planes64`]). Two dot products instead of the cross
    /// products, divisions and dot products of the full test; the answer is
    /// [`Part::hit64`]'s ([`PLANE_REJECT`] says why).
    #[inline]
    fn hit64_planed(&self, id: usize, seg: &Segment64) -> f64 {
        let (n, w) = self.planes64[id];
        let (h0, h1) = (n.dot(seg.ends[0]) - w, n.dot(seg.ends[1]) - w);
        if (h0 > seg.reject && h1 > seg.reject) || (h0 < -seg.reject && h1 < -seg.reject) {
            return f64::INFINITY;
        }
        self.hit64(id, seg.o, seg.d, seg.tmin, seg.tmax)
    }

    /// The segment `o + s·d` in part space.
    fn local(&self, o: DVec3, d: DVec3) -> (DVec3, DVec3) {
        (
            self.world_to_local.transform_point3(o),
            self.world_to_local.transform_vector3(d),
        )
    }

    fn local_ray(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Ray {
        let (lo, ld) = self.local(o, d);
        Ray::new(
            Vec3A::new(lo.x as f32, lo.y as f32, lo.z as f32),
            Vec3A::new(ld.x as f32, ld.y as f32, ld.z as f32),
            tmin as f32,
            tmax as f32,
        )
    }
}

/// Visibility structure of a scene at one time.
pub struct SceneBvh {
    parts: Vec<Part>,
    /// What casts the occlusion rays.
    rays: Rays,
    /// Each patch's back-to-back twin (the same corners in reverse order: a
    /// two-sided polygon's other side), `u32::MAX` for none ([`twin_patches`]).
    twins: Vec<u32>,
    /// Each patch's plane at the build's time: unit normal and offset `n · v₀`
    /// ([`SceneBvh::occluded_between`] trims a segment's ends off them).
    planes: Vec<(DVec3, f64)>,
    /// [`PLANE_GAP`] times the scene's diameter.
    plane_gap: f64,
}

/// Height above the plane of the surface a segment starts or ends on, relative to
/// the scene's diameter, under which nothing blocks the segment
/// ([`SceneBvh::occluded_between`]): a straight segment leaving a plane never comes
/// back to it, so a face hit within this of that plane is a piece of the surface
/// itself or of its other side, a hair off its plane.
///
/// Why: contact meshing splits a two-sided slab's room side and its back-to-back
/// side into pieces that are no longer twins bit for bit ([`twin_patches`]), and
/// the back side's piece under a point, 3·10⁻⁸ m off the room side's plane, lay
/// beyond [`SURFACE_TRIM`] of the segment: on Blender's Cornell box
/// (`tests/data/blender/cornell-box.glb`) every ray from the final gather's
/// points by the ceiling's corner to the green wall, the floor and the red wall
/// met the ceiling's own back side, and those points gathered 0.20 of green
/// instead of 0.47 (issue 45, part 4). Far below any gap a scene means: Suzanne's
/// lip, 0.14 mm (6·10⁻⁵ of that scene) over a leaf, still blocks.
pub const PLANE_GAP: f64 = 1e-6;

/// Each patch's unit normal and plane offset; `moving(p)`: none (a NaN offset
/// no point lies within), as [`SceneBvh::place`] moves them.
fn patch_planes(patches: &Patches, moving: impl Fn(usize) -> bool) -> Vec<(DVec3, f64)> {
    (0..patches.len())
        .map(|p| {
            if moving(p) {
                return (DVec3::ZERO, f64::NAN);
            }
            let n = patches.normals[p];
            let v0 = patches.polys[p]
                .corners()
                .first()
                .copied()
                .unwrap_or(DVec3::ZERO);
            (n, n.dot(v0))
        })
        .collect()
}

/// Each patch's back-to-back twin among `patches`: the patch with the same corners
/// (bit for bit) in reverse order, as `scene::two_sided` and glTF's `doubleSided`
/// make them; `u32::MAX` for none.
pub fn twin_patches(patches: &Patches) -> Vec<u32> {
    use std::collections::HashMap;
    let key = |p: usize| {
        let mut k: Vec<[u64; 3]> = patches.polys[p]
            .corners()
            .iter()
            .map(|v| v.to_array().map(f64::to_bits))
            .collect();
        k.sort_unstable();
        k
    };
    let mut first: HashMap<Vec<[u64; 3]>, u32> = HashMap::new();
    let mut twins = vec![u32::MAX; patches.len()];
    for p in 0..patches.len() {
        match first.entry(key(p)) {
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(p as u32);
            }
            std::collections::hash_map::Entry::Occupied(e) => {
                let q = *e.get() as usize;
                let (cp, cq) = (patches.polys[p].corners(), patches.polys[q].corners());
                let n = cp.len();
                // Reversed: corner i of one is corner (j - i) of the other for
                // some shift j.
                let reversed =
                    n == cq.len() && (0..n).any(|j| (0..n).all(|i| cp[i] == cq[(j + n - i) % n]));
                if reversed && twins[q] == u32::MAX {
                    twins[p] = q as u32;
                    twins[q] = p as u32;
                }
            }
        }
    }
    twins
}

impl SceneBvh {
    /// Builds the BVHs of `patches` (which must be placed at time `t`): patches of
    /// static objects in one world-space BVH, those of each moving object in a BVH in
    /// object space placed by the object's motion at `t`.
    pub fn build(scene: &Scene, patches: &Patches, t: f64) -> SceneBvh {
        let mut parts = Vec::new();
        let mut st = Tris::default();
        let mut moving: Vec<Tris> = vec![Tris::default(); scene.objects.len()];
        let unit = unit_scale(patches.diameter);
        let is_moving = |p: usize| {
            scene
                .objects
                .get(patches.objects[p] as usize)
                .is_some_and(|o| o.is_moving())
        };
        for i in 0..patches.len() {
            let obj = patches.objects[i] as usize;
            if is_moving(i) {
                let g = &patches.geometry[i];
                push_triangles(
                    &g.vertices[..g.corners as usize],
                    unit,
                    i as u32,
                    &mut moving[obj],
                );
            } else {
                let corners = patches.polys[i].corners();
                push_triangles(corners, unit, i as u32, &mut st);
            }
        }
        for (obj, tris) in moving.into_iter().enumerate() {
            parts.extend(Part::build(
                tris,
                scene.objects[obj].to_world(t) * from_unit(unit),
                obj as u32,
                unit,
            ));
        }
        parts.extend(Part::build(st, from_unit(unit), u32::MAX, unit));
        SceneBvh {
            parts,
            rays: Rays::Obvhs,
            twins: twin_patches(patches),
            planes: patch_planes(patches, is_moving),
            plane_gap: PLANE_GAP * patches.diameter,
        }
        .with_env_rays()
    }

    /// Builds one world-space BVH of `patches` as they stand, moving or not: a
    /// frame solved as a static scene ([`crate::solver::Solver::freeze_motion`])
    /// sees the same triangles as the static scene of that frame would.
    pub fn build_static(patches: &Patches) -> SceneBvh {
        let mut st = Tris::default();
        let unit = unit_scale(patches.diameter);
        for i in 0..patches.len() {
            push_triangles(patches.polys[i].corners(), unit, i as u32, &mut st);
        }
        SceneBvh {
            parts: Part::build(st, from_unit(unit), u32::MAX, unit)
                .into_iter()
                .collect(),
            rays: Rays::Obvhs,
            twins: twin_patches(patches),
            planes: patch_planes(patches, |_| false),
            plane_gap: PLANE_GAP * patches.diameter,
        }
        .with_env_rays()
    }

    /// `self` casting its occlusion rays with the backend [`Rays::ENV`] names (a
    /// bad value, or an Embree that cannot be loaded, is refused by
    /// `SolveOptions::validate`; here, for the commands that do not solve, it, or
    /// an Embree that cannot start, leaves obvhs with a warning on stderr).
    fn with_env_rays(mut self) -> SceneBvh {
        let rays = match Rays::from_env() {
            Ok(rays) => rays,
            Err(e) => {
                eprintln!("warning: {e}; casting rays with obvhs");
                Rays::Obvhs
            }
        };
        if rays != Rays::Obvhs
            && let Err(e) = self.set_rays(rays)
        {
            eprintln!("warning: {e}; casting rays with obvhs");
        }
        self
    }

    /// Casts the occlusion rays with `rays` from now on (building Embree's scenes
    /// for [`Rays::Embree`]). Errors if Embree's library cannot be loaded (the
    /// error names it and how to install it) or Embree cannot start; `self` is then
    /// unchanged.
    pub fn set_rays(&mut self, rays: Rays) -> Result<()> {
        match rays {
            Rays::Obvhs | Rays::Cwbvh => {
                self.parts.iter_mut().for_each(|p| p.embree = None);
            }
            Rays::Embree => {
                let scenes = self
                    .parts
                    .iter()
                    .map(|p| {
                        let pad = part_reach(&p.tris64) * EMBREE_PAD;
                        super::embree::EmbreeScene::new(&p.tris64, pad)
                    })
                    .collect::<std::result::Result<Vec<_>, String>>()
                    .map_err(Error::Usage)?;
                for (p, e) in self.parts.iter_mut().zip(scenes) {
                    p.embree = Some(e);
                }
            }
        }
        self.rays = rays;
        Ok(())
    }

    /// What casts the occlusion rays.
    pub fn rays(&self) -> Rays {
        self.rays
    }

    /// Moves every moving object's BVH to its place at time `t` (no rebuild: only
    /// the part's transform changes).
    pub fn place(&mut self, scene: &Scene, t: f64) {
        self.place_with(|o| scene.objects.get(o as usize).map(|obj| obj.to_world(t)));
    }

    /// Moves the BVH of each moving object `o` for which `world(o)` gives its
    /// object → world map (no rebuild: only the part's transform changes).
    pub fn place_with(&mut self, world: impl Fn(u32) -> Option<DAffine3>) {
        for part in &mut self.parts {
            if part.object == u32::MAX {
                continue;
            }
            if let Some(m) = world(part.object) {
                part.local_to_world = m * from_unit(part.unit);
                part.world_to_local = part.local_to_world.inverse();
                part.update_box();
            }
        }
    }

    /// World boxes of the moving objects where they are placed now.
    pub fn moving_boxes(&self) -> Vec<(DVec3, DVec3)> {
        self.parts
            .iter()
            .filter(|p| p.object != u32::MAX)
            .map(|p| p.world_box)
            .collect()
    }

    /// True if something blocks the open segment between `a` and `b` (both ends
    /// trimmed by [`SEGMENT_TRIM`] of its length).
    pub fn occluded(&self, a: DVec3, b: DVec3) -> bool {
        self.occluded_except(a, b, [u32::MAX; 2])
    }

    /// [`SceneBvh::occluded`], ignoring the patches `skip` (the planar patches the
    /// segment starts and ends on cannot block it; their hits are round-off, which
    /// grazing segments make larger than any trim).
    pub fn occluded_except(&self, a: DVec3, b: DVec3, skip: [u32; 2]) -> bool {
        self.occluded_by(a, b, skip, Parts::All)
    }

    /// [`SceneBvh::occluded_except`] against only the static part or only the moving
    /// objects: a segment is occluded iff one of the two says so, so a space-time
    /// solve keeps the static answer of a ray and asks the (small) moving part again
    /// at each frame.
    pub fn occluded_by(&self, a: DVec3, b: DVec3, skip: [u32; 2], which: Parts) -> bool {
        self.occluded_cached(a, b, skip, which, &mut LastHit::default())
    }

    /// [`SceneBvh::occluded_by`], testing `last`'s triangle first and leaving in it
    /// the triangle that blocks this segment, if any ([`LastHit`]: the answer is
    /// that of [`SceneBvh::occluded_by`] whatever `last` holds, up to its f32 note).
    ///
    /// The f32 BVH only finds the candidates: whether a triangle blocks is decided
    /// in f64 on its f64 corners, and the ray is cast from `2 NODE_EPSILON` behind
    /// `a` so that no node near the trim is dropped. Decided in f32, a hit within
    /// the f32 round-off of the trim (a corner's gather point 10⁻⁴ m from a box,
    /// rays to the wall 1 m behind it crossing the box's face at `s ≈ 1.00007·10⁻⁴`)
    /// counted in metres and not in kilometres, and the corner's value changed by
    /// 5% (issue 45, part 3).
    pub fn occluded_cached(
        &self,
        a: DVec3,
        b: DVec3,
        skip: [u32; 2],
        which: Parts,
        last: &mut LastHit,
    ) -> bool {
        let skip = [skip[0], skip[1], u32::MAX, u32::MAX];
        self.occluded_trimmed(a, b, skip, (SEGMENT_TRIM, SEGMENT_TRIM), which, last)
    }

    /// [`SceneBvh::occluded_cached`] for a segment between two surface points on
    /// the patches `skip`: those patches' twins are skipped too, and the ends are
    /// trimmed by [`SURFACE_TRIM`] only, so that a surface nearer to an end than
    /// [`SEGMENT_TRIM`] of the length (a fold of a mesh lying over the point)
    /// still blocks; an end that lies in the plane of a patch of `skip` is trimmed
    /// up to where the segment has risen [`PLANE_GAP`] of the scene above that
    /// plane (at most half the segment), so that the surface's own other side, cut
    /// into other pieces than it ([`twin_patches`] finds no twin), does not block.
    pub fn occluded_between(
        &self,
        a: DVec3,
        b: DVec3,
        skip: [u32; 2],
        which: Parts,
        last: &mut LastHit,
    ) -> bool {
        let trims = self.surface_trims(a, b, skip);
        self.occluded_trimmed(a, b, self.with_twins(skip), trims, which, last)
    }

    /// The patches `skip` and their back-to-back twins ([`twin_patches`]).
    fn with_twins(&self, skip: [u32; 2]) -> [u32; 4] {
        let twin = |p: u32| self.twins.get(p as usize).copied().unwrap_or(u32::MAX);
        [skip[0], skip[1], twin(skip[0]), twin(skip[1])]
    }

    /// The trims at `a` and at `b` of a segment between surface points on the
    /// patches `skip` ([`SceneBvh::occluded_between`]).
    fn surface_trims(&self, a: DVec3, b: DVec3, skip: [u32; 2]) -> (f64, f64) {
        let d = b - a;
        // The trim of end `x` off the planes of `skip` that hold it.
        let trim = |x: DVec3| {
            skip.iter()
                .filter_map(|&p| self.planes.get(p as usize))
                .filter(|(n, off)| (n.dot(x) - off).abs() <= self.plane_gap)
                .map(|(n, _)| {
                    let h = n.dot(d).abs();
                    if h > 0.0 {
                        (self.plane_gap / h).min(0.5)
                    } else {
                        0.5
                    }
                })
                .fold(SURFACE_TRIM, f64::max)
        };
        (trim(a), trim(b))
    }

    /// Bit `j` set where [`SceneBvh::occluded_between`]`(a, ends[j], skip, which,
    /// _)` is true (at most 64 ends), for a fan of segments from `a` to ends on
    /// the convex polygon `hull` (3 or 4 corners; a source element's ray targets).
    ///
    /// Every triangle that can block one of them meets the hull of `a` and the
    /// polygon, so each part's BVH is walked once, by the shaft from `a` to the
    /// polygon ([`crate::shafts::Shaft::from_point`]: nodes whose box misses it
    /// and triangles it culls are left out), and each segment is tested in `f64`
    /// against the few triangles left only, by the very test
    /// [`SceneBvh::occluded_trimmed`] makes: the same answer segment by segment
    /// (but where the shaft's far end culls a triangle in the source's own plane
    /// that a segment would graze at its trimmed end, as a link's shaft does). A
    /// fan with no triangle left costs no segment test at all. Where more than
    /// [`FAN_CANDIDATES`] triangles are left, or the rays are Embree's or the
    /// CWBVH's, each segment is cast on its own.
    ///
    /// Why: the final gather casts 8 to 128 rays from a point to each source not
    /// proved clear, each walking the BVH from its root; in the Cornell box with
    /// blocks those walks and their set-up were about 60% of the run.
    pub fn occluded_fan(
        &self,
        a: DVec3,
        ends: &[DVec3],
        hull: &[DVec3],
        skip: [u32; 2],
        which: Parts,
    ) -> u64 {
        let each = || {
            let mut last = LastHit::default();
            ends.iter().take(64).enumerate().fold(0u64, |m, (j, &b)| {
                m | (u64::from(self.occluded_between(a, b, skip, which, &mut last)) << j)
            })
        };
        if self.rays != Rays::Obvhs || !(3..=4).contains(&hull.len()) {
            return each();
        }
        let skip4 = self.with_twins(skip);
        // The triangles the shafts leave, part by part: `(part, triangle)`.
        let mut cands = [(0u32, 0u32); FAN_CANDIDATES];
        let mut n = 0;
        for (ix, part) in self.parts.iter().enumerate() {
            if !which.admits(part) {
                continue;
            }
            let to_local = |p: DVec3| part.world_to_local.transform_point3(p);
            let mut corners = [DVec3::ZERO; 4];
            for (c, &p) in corners.iter_mut().zip(hull) {
                *c = to_local(p);
            }
            let shaft = crate::shafts::Shaft::from_point(to_local(a), &corners[..hull.len()]);
            // The boxes' coordinates are within the reach plus their padding.
            let mut cull = Cull4::new(2.0 * part.reach);
            shaft.box_tests(|m, t| cull.push(m, t));
            let over = part.wide.any_in(&cull, |id| {
                let i = id as usize;
                if skip4.contains(&part.tri_patch[i]) || shaft.culls(&part.tris64[i]) {
                    return false;
                }
                if n == FAN_CANDIDATES {
                    return true;
                }
                cands[n] = (ix as u32, id);
                n += 1;
                false
            });
            if over {
                return each();
            }
        }
        if n == 0 {
            return 0;
        }
        let mut blocked = 0u64;
        for (j, &b) in ends.iter().take(64).enumerate() {
            // The segment as `occluded_trimmed` makes it.
            let d = b - a;
            let (s0, s1) = self.surface_trims(a, b, skip);
            let (s0, s1) = (s0, 1.0 - s1);
            let back = 2.0 * NODE_EPSILON;
            let o = a - d * back;
            let (t0, t1) = (s0 + back, s1 + back);
            let mut seg = None;
            let mut seg_part = u32::MAX;
            for &(ix, id) in &cands[..n] {
                let part = &self.parts[ix as usize];
                if seg_part != ix {
                    let (lo, ld) = part.local(o, d);
                    seg = Some(part.segment64(lo, ld, t0, t1));
                    seg_part = ix;
                }
                if let Some(seg) = &seg
                    && part.hit64_planed(id as usize, seg).is_finite()
                {
                    blocked |= 1 << j;
                    break;
                }
            }
        }
        blocked
    }

    /// Whether a triangle not of the patches `skip` blocks the segment `a b` with
    /// its ends trimmed by `trims` (at `a`, at `b`) of its length.
    fn occluded_trimmed(
        &self,
        a: DVec3,
        b: DVec3,
        skip: [u32; 4],
        trims: (f64, f64),
        which: Parts,
        last: &mut LastHit,
    ) -> bool {
        let d = b - a;
        let (s0, s1) = (trims.0, 1.0 - trims.1);
        // Cast from `2 NODE_EPSILON` behind `a` ([`SceneBvh::closest_hit`]), so
        // that no node is dropped near the trim: the f64 test decides there.
        let back = 2.0 * NODE_EPSILON;
        let o = a - d * back;
        let (t0, t1) = (s0 + back, s1 + back);
        if let Some(part) = self.parts.get(last.part as usize)
            && which.admits(part)
            && let Some(tri) = part.tris.get(last.tri as usize)
        {
            let p = part.tri_patch[last.tri as usize];
            if !skip.contains(&p) {
                // Blocked only where the f32 test also hits: the f32 node boxes
                // can hide from the traversal a grazing hit only the f64 test
                // makes, and then the traversal, not the cache, must decide.
                let ray = part.local_ray(o, d, t0, t1);
                let (lo, ld) = part.local(o, d);
                let seg = part.segment64(lo, ld, t0, t1);
                if tri.intersect(&ray) < ray.tmax
                    && part.hit64_planed(last.tri as usize, &seg).is_finite()
                {
                    return true;
                }
            }
        }
        for (ix, part) in self.parts.iter().enumerate() {
            if !which.admits(part) {
                continue;
            }
            let moving = part.object != u32::MAX;
            if moving && part.misses_box(a, d, s0, s1) {
                continue;
            }
            let (lo, ld) = part.local(o, d);
            let seg = part.segment64(lo, ld, t0, t1);
            let mut blocker = u32::MAX;
            // Every backend's candidates are decided by the same f64 test on the
            // same segment; the first that blocks is remembered for the cache.
            let mut blocks = |id: usize| {
                if skip.contains(&part.tri_patch[id]) {
                    return false;
                }
                let hit = part.hit64_planed(id, &seg).is_finite();
                if hit {
                    blocker = id as u32;
                }
                hit
            };
            // (Only Embree breaks out of the block early.)
            let hit =
                'found: {
                    if let Some(scene) = &part.embree {
                        // Embree's f32 range is wider by `EMBREE_SLACK` so that it
                        // holds every hit the test takes.
                        break 'found scene.occluded(
                            lo,
                            ld,
                            t0 - EMBREE_SLACK,
                            t1 + EMBREE_SLACK,
                            &mut |id| blocks(id as usize),
                        );
                    }
                    if self.rays == Rays::Cwbvh {
                        let ray = part.local_ray(o, d, t0, t1);
                        !part.bvh.ray_traverse_miss(ray, |_, id| {
                            if blocks(id) { 0.0 } else { f32::INFINITY }
                        })
                    } else {
                        // The f32 range is wider than the f64 test's by
                        // `WIDE_SLACK`: the padded boxes hold every hit the test
                        // takes with a margin, and this keeps the range's own
                        // rounding out of the way.
                        part.wide
                            .any_hit(lo, ld, t0 - WIDE_SLACK, t1 + WIDE_SLACK, |id| {
                                blocks(id as usize)
                            })
                    }
                };
            if hit {
                *last = LastHit {
                    part: ix as u32,
                    tri: blocker,
                };
                return true;
            }
        }
        false
    }

    /// Closest hit along `o + s·d`, `s ∈ (smin, smax)`.
    ///
    /// The ray is cast from `NODE_EPSILON` `· 2` behind `o` (its `s` shifted to
    /// match): obvhs' CWBVH traversal drops every node the ray leaves before
    /// parameter `10⁻⁴`, so a hit that close to `o` was lost and the next one beyond
    /// returned. A bounce of `rhier reference` from a point within a millimetre of
    /// a room's corner went through the wall it faced: 2·10⁻⁴ of the bounces in a
    /// closed box, 2% of the light at ρ = 0.99 (`tests/it/reference.rs`).
    /// Occlusion queries need no shift: they trim their segments by
    /// [`SEGMENT_TRIM`], which is that same `10⁻⁴`.
    ///
    /// Of two polygons at the same place (a two-sided surface's back-to-back
    /// twins) it returns either; [`SceneBvh::intersect_front_first`] returns the
    /// one facing the ray.
    pub fn intersect(&self, o: DVec3, d: DVec3, smin: f64, smax: f64) -> Option<Hit> {
        self.closest_hit(o, d, smin, smax, 0.0)
    }

    /// [`SceneBvh::intersect`], but a face turned away from the ray counts as
    /// [`FRONT_FIRST_TIE`] further than it is, so that of back-to-back twins (a
    /// glTF `doubleSided` polygon, `--two-sided`) the one facing the ray is hit;
    /// its `t` is the true one. With a plain closest hit the traversal's order
    /// chose, and a path tracer that stops at a back face (the inside of a solid)
    /// stopped on about half of the bounces that met a two-sided wall: `rhier
    /// reference` read the Cornell box of `tests/data/blender/cornell-box.glb`
    /// 25–90% too dark.
    pub fn intersect_front_first(&self, o: DVec3, d: DVec3, smin: f64, smax: f64) -> Option<Hit> {
        self.closest_hit(o, d, smin, smax, FRONT_FIRST_TIE)
    }

    /// Closest hit, back faces pushed `tie` further along the ray.
    fn closest_hit(&self, o: DVec3, d: DVec3, smin: f64, smax: f64, tie: f64) -> Option<Hit> {
        let back = 2.0 * NODE_EPSILON;
        let o = o - d * back;
        // The best hit and its key (its parameter, pushed if it faces away).
        let mut best: Option<(Hit, f64)> = None;
        for part in &self.parts {
            let tmax = best.map_or(smax, |(_, key)| key);
            let ray = part.local_ray(o, d, smin + back, tmax + back);
            // A mirroring motion turns the triangles' winding over.
            let flip = part.local_to_world.matrix3.determinant() < 0.0;
            let away = |id: usize| {
                let t = &part.tris[id];
                let s = (t.v1 - t.v0).cross(t.v2 - t.v0).dot(ray.direction);
                (s > 0.0) != flip
            };
            let mut hit = obvhs::ray::RayHit::none();
            if part.bvh.ray_traverse(ray, &mut hit, |r, id| {
                let t = part.tris[id].intersect(r);
                if tie > 0.0 && t.is_finite() && away(id) {
                    t + tie as f32
                } else {
                    t
                }
            }) {
                let id = hit.primitive_id as usize;
                let pushed = if tie > 0.0 && away(id) { tie } else { 0.0 };
                let key = hit.t as f64 - back;
                let hit = Hit {
                    patch: part.tri_patch[id],
                    t: key - pushed,
                    back: away(id),
                };
                best = Some((hit, key));
            }
        }
        best.map(|(hit, _)| hit)
    }

    /// Calls `f(patch, triangle)` (world space) for every triangle whose box overlaps
    /// the box `[lo, hi]`, until `f` returns false. Returns false if stopped early.
    pub fn for_each_triangle_in_box(
        &self,
        lo: DVec3,
        hi: DVec3,
        mut f: impl FnMut(u32, [DVec3; 3]) -> bool,
    ) -> bool {
        for part in &self.parts {
            // Box of the query box's corners in part space.
            let mut llo = DVec3::splat(f64::INFINITY);
            let mut lhi = DVec3::splat(f64::NEG_INFINITY);
            for i in 0..8 {
                let c = DVec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let l = part.world_to_local.transform_point3(c);
                llo = llo.min(l);
                lhi = lhi.max(l);
            }
            // Widen by one f32 ulp-scale so touching boxes still overlap.
            let pad = (lhi - llo)
                .max_element()
                .max(llo.abs().max(lhi.abs()).max_element())
                * 1e-6;
            let aabb = Aabb::new(
                Vec3A::new(
                    (llo.x - pad) as f32,
                    (llo.y - pad) as f32,
                    (llo.z - pad) as f32,
                ),
                Vec3A::new(
                    (lhi.x + pad) as f32,
                    (lhi.y + pad) as f32,
                    (lhi.z + pad) as f32,
                ),
            );
            let bvh = &part.bvh;
            let mut state = bvh.new_traversal(Vec3A::X);
            let mut node;
            let mut go_on = true;
            obvhs::traverse!(
                bvh,
                node,
                state,
                node.intersect_aabb(&aabb, state.oct_inv4),
                {
                    let id = state.primitive_id as usize;
                    let tri = &part.tris[id];
                    if tri.aabb().intersect_aabb(&aabb) {
                        let w = |v: DVec3| part.local_to_world.transform_point3(v);
                        let [a, b, c] = part.tris64[id];
                        if !f(part.tri_patch[id], [w(a), w(b), w(c)]) {
                            go_on = false;
                            break;
                        }
                    }
                }
            );
            if !go_on {
                return false;
            }
        }
        true
    }

    /// Number of triangles indexed.
    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.tris.len()).sum()
    }

    /// Bytes held by the BVHs and their triangles.
    pub fn resident_bytes(&self) -> usize {
        self.parts
            .iter()
            .map(|p| {
                std::mem::size_of_val(p.bvh.nodes.as_slice())
                    + std::mem::size_of_val(p.bvh.primitive_indices.as_slice())
                    + std::mem::size_of_val(p.tris.as_slice())
                    + std::mem::size_of_val(p.tri_patch.as_slice())
                    + std::mem::size_of_val(p.tris64.as_slice())
                    + std::mem::size_of_val(p.planes64.as_slice())
                    + p.wide.resident_bytes()
            })
            .sum()
    }
}

/// The power of two that brings a scene of diameter `diameter` to a diameter in
/// `[0.5, 2)`: the BVHs are built in world (or object) space times it. obvhs has
/// absolute constants (a ray direction component under `f32::EPSILON` is taken as
/// that, not its value; f32 products of three lengths overflow past ~1e12), so a
/// scene in micrometres or in light years would lose rays that the same scene in
/// metres keeps. A power of two scales every f32 exactly: in part space the same
/// scene in any unit has the same coordinates up to their exponent, and a scene
/// of diameter ~1 is cast bit for bit as before.
fn unit_scale(diameter: f64) -> f64 {
    if diameter.is_finite() && diameter > 0.0 {
        2f64.powi(-(diameter.log2().round() as i32))
    } else {
        1.0
    }
}

/// Part space (`unit` × world or object space) → world or object space.
fn from_unit(unit: f64) -> DAffine3 {
    DAffine3::from_scale(DVec3::splat(1.0 / unit))
}

/// A segment `o + s·d`, `s ∈ [tmin, tmax]`, in a part's space (f64), with its two
/// ends and the plane distance beyond which [`Part::hit64_planed`] rejects a
/// triangle.
struct Segment64 {
    o: DVec3,
    d: DVec3,
    tmin: f64,
    tmax: f64,
    /// `o + tmin·d` and `o + tmax·d`.
    ends: [DVec3; 2],
    /// [`PLANE_REJECT`] of the part's reach plus the segment's size.
    reject: f64,
}

/// How far (relative to the part's reach plus the segment's `|o| + |d|`) both
/// ends of a segment must lie on one side of a triangle's scaled plane
/// ([`Part::planes64`]) for [`Part::hit64_planed`] to skip the triangle.
///
/// Why it never changes an answer: [`Part::hit64`]'s `t` is the zero of the
/// line `h(s) = (o + s·d − v₀) · (e₁ × e₂)` computed with round-off, which moves
/// that line by at most a few ulps times `(|o − v₀| + s|d|) |e₁| |e₂|` over
/// `[tmin, tmax]`. In units of `|e₁| |e₂|` (the scaled plane's), that is a few
/// `10⁻¹⁶` of the part's reach plus the segment's size whatever the triangle's
/// shape (a unit normal would need a margin growing as `1 / sin` of its
/// corner), so a segment whose ends are both `10⁻⁹` of it on one side has no
/// zero of the computed line in `[tmin, tmax]` either: `10⁶` times the round-off
/// (test `plane_rejection_keeps_every_hit`).
const PLANE_REJECT: f64 = 1e-9;

/// Each triangle's scaled plane (`Part::planes64`): `n = (e₁ × e₂) / (|e₁| |e₂|)`,
/// `w = n · v₀`; `n = 0` (never rejected) where `|e₁| |e₂|` is 0.
fn triangle_planes(tris: &[[DVec3; 3]]) -> Vec<(DVec3, f64)> {
    tris.iter()
        .map(|&[v0, v1, v2]| {
            let (e1, e2) = (v1 - v0, v2 - v0);
            let s = e1.length() * e2.length();
            let n = if s > 0.0 && s.is_finite() {
                e1.cross(e2) / s
            } else {
                DVec3::ZERO
            };
            (n, n.dot(v0))
        })
        .collect()
}

/// Triangles of a part as they are gathered: f32 corners for the BVH, the patch of
/// each, and the f64 corners (part space).
type Tris = (Vec<Triangle>, Vec<u32>, Vec<[DVec3; 3]>);

/// The BVH's boxes of the triangles `tris` (f64 corners, part space): each
/// triangle's f64 box widened by `pad`, [`BOX_PAD`] of the part's size plus its
/// farthest coordinate ([`part_reach`]), so that the f32 traversal (the ray and the node boxes rounded to
/// f32) reaches every triangle the f64 test hits ([`SceneBvh::occluded_cached`]).
///
/// Why: boxes of the f32 triangles, exact to their corners, lost a hit that the
/// f64 test makes within the f32 round-off of a triangle's edge (the f32 ray
/// passes the edge on the other side). In `tests/it/solver/scale_free.rs`'s
/// touching boxes, a final-gather point 10⁻⁴ m beside the small box's foot cast a
/// ray to the ceiling that crosses the box's side 6·10⁻⁸ m from its vertical edge:
/// the traversal missed that side in metres and millimetres and found it in
/// kilometres, and the point read 0.34% apart between the scales.
pub(super) fn padded_boxes(tris: &[[DVec3; 3]], pad: f64) -> Vec<Aabb> {
    let f = |p: DVec3| Vec3A::new(p.x as f32, p.y as f32, p.z as f32);
    tris.iter()
        .map(|&[a, b, c]| Aabb::new(f(a.min(b).min(c) - pad), f(a.max(b).max(c) + pad)))
        .collect()
}

/// The size of the triangles `tris` plus their farthest coordinate: what their
/// f32 round-off scales with ([`padded_boxes`]).
pub(super) fn part_reach(tris: &[[DVec3; 3]]) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for t in tris {
        for &v in t {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let reach = lo.abs().max(hi.abs()).max_element();
    (hi - lo).length() + reach
}

/// Relative dilation of the triangles given to Embree, of [`part_reach`]
/// (`super::embree::EmbreeScene::new`): the f32 ray strays from the f64 one by
/// ~2·10⁻⁷ of the reach, and a crossing at `θ` to a triangle's plane by that over
/// `tan θ`; 10⁻⁵ keeps every hit of the f64 test a candidate down to `θ ≈ 1°`
/// while adding candidates only in a band of 10⁻⁵ of the scene round each
/// triangle (10⁻⁴ cost 6% more CPU on `gen_cubes 10`).
const EMBREE_PAD: f64 = 1e-5;

/// How much wider (in the segment's parameter) Embree's f32 range is than the f64
/// test's: the crossing's parameter strays like its place (see [`EMBREE_PAD`]).
const EMBREE_SLACK: f64 = 1e-4;

/// Most triangles [`SceneBvh::occluded_fan`] tests its segments against before it
/// casts them one by one instead.
const FAN_CANDIDATES: usize = 16;

/// How much wider (in the segment's parameter) the f32 range of a [`Bvh4`]
/// traversal is than the f64 test's: a few f32 ulps of the parameter (which is
/// below 1.001), far below the boxes' padding ([`BOX_PAD`]) in units of a segment.
const WIDE_SLACK: f64 = 1e-6;

/// Relative widening of the BVH's triangle boxes ([`padded_boxes`]): 16 f32 ulps
/// of the part's size, as [`Part::update_box`] pads a part's world box. A ray's
/// f32 round-off moves it by a few ulps of its coordinates and length.
pub(super) const BOX_PAD: f64 = 1e-6;

fn push_triangles(v: &[DVec3], unit: f64, patch: u32, (tris, tp, t64): &mut Tris) {
    let f = |p: DVec3| {
        let p = p * unit;
        Vec3A::new(p.x as f32, p.y as f32, p.z as f32)
    };
    for k in 1..v.len().saturating_sub(1) {
        tris.push(Triangle {
            v0: f(v[0]),
            v1: f(v[k]),
            v2: f(v[k + 1]),
        });
        t64.push([v[0] * unit, v[k] * unit, v[k + 1] * unit]);
        tp.push(patch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle::xorshift;

    /// [`Part::hit64_planed`] answers as [`Part::hit64`], bit for bit, on random
    /// segments against random and sliver triangles: segments anywhere, grazing a
    /// triangle's plane, lying a hair off it on one side or across it, and ending
    /// on it (inside the triangle, on its edges and just outside), at heights from
    /// 10⁻³ down to 10⁻¹⁸ of the scene, across [`PLANE_REJECT`].
    #[test]
    fn plane_rejection_keeps_every_hit() {
        let mut rnd = xorshift(0x005e_ed0f_9a1e_u64);
        let mut r = move || 2.0 * rnd() - 1.0;
        let mut tris = Tris::default();
        for i in 0..200u32 {
            let (a, b) = (DVec3::new(r(), r(), r()), DVec3::new(r(), r(), r()) * 0.5);
            let c = if i % 4 == 0 {
                // A sliver: the third corner a hair off the first edge.
                a + b * (0.5 + 0.5 * r()) + DVec3::new(r(), r(), r()) * 10f64.powf(-4.0 + 5.0 * r())
            } else {
                a + DVec3::new(r(), r(), r()) * 0.5
            };
            push_triangles(&[a, a + b, c], 1.0, i, &mut tris);
        }
        let part = Part::build(tris, DAffine3::IDENTITY, u32::MAX, 1.0).expect("triangles");
        let (mut hits, mut near_hits, mut rejected, mut near_rejected) = (0, 0, 0, 0);
        for id in 0..part.tris64.len() {
            let [v0, v1, v2] = part.tris64[id];
            let n = (v1 - v0).cross(v2 - v0).normalize_or_zero();
            // In-plane axes.
            let (t1, t2) = n.any_orthonormal_pair();
            for k in 0..400 {
                // A point of the plane near the triangle (barycentric weights
                // a little beyond [0, 1] now and then), and one right on an edge.
                let (u, v) = (0.6 * r() + 0.4, 0.6 * r() + 0.4);
                let on = if k % 5 == 0 {
                    v0 + (v1 - v0) * (0.5 + 0.5 * r())
                } else {
                    v0 + (v1 - v0) * u * 0.6 + (v2 - v0) * v * 0.6
                };
                // A height from 10⁻³ down to 10⁻¹⁸, of the sign of `x`.
                let tiny = |x: f64| x.signum() * 10f64.powf(-3.0 - 15.0 * (0.5 + 0.5 * x.abs()));
                let (a, b) = match k % 4 {
                    // Anywhere.
                    0 => (DVec3::new(r(), r(), r()), DVec3::new(r(), r(), r())),
                    // Grazing: through (or by) `on`, nearly along the plane.
                    1 => {
                        let along = t1 * r() + t2 * r();
                        let off = n * tiny(r());
                        (on - along + off, on + along + off + n * (r() * tiny(r())))
                    }
                    // Ending on the plane at `on`.
                    2 => {
                        let a = on + DVec3::new(r(), r(), r());
                        if r() < 0.0 { (a, on) } else { (on, a) }
                    }
                    // Both ends a hair off the plane, on one side or across.
                    _ => {
                        let (h0, h1) = (n * tiny(r()), n * tiny(r()));
                        (
                            on + (t1 * r() + t2 * r()) * 0.5 + h0,
                            on + (t1 * r() + t2 * r()) * 0.5 + h1,
                        )
                    }
                };
                let d = b - a;
                let (tmin, tmax) = match k % 3 {
                    0 => (0.0, 1.0),
                    1 => (SURFACE_TRIM, 1.0 - SURFACE_TRIM),
                    _ => (SEGMENT_TRIM + 2.0 * NODE_EPSILON, 1.0 + 2.0 * NODE_EPSILON),
                };
                let o = a - d * (tmin - SEGMENT_TRIM).max(0.0);
                let seg = part.segment64(o, d, tmin, tmax);
                let plain = part.hit64(id, o, d, tmin, tmax);
                let planed = part.hit64_planed(id, &seg);
                assert_eq!(
                    plain.to_bits(),
                    planed.to_bits(),
                    "triangle {id} {:?}, segment {o} + s {d}, s in [{tmin}, {tmax}]",
                    part.tris64[id]
                );
                let (pn, w) = part.planes64[id];
                let (h0, h1) = (pn.dot(seg.ends[0]) - w, pn.dot(seg.ends[1]) - w);
                let near = h0.abs().min(h1.abs()) < 1e-6;
                if (h0 > seg.reject && h1 > seg.reject) || (h0 < -seg.reject && h1 < -seg.reject) {
                    rejected += 1;
                    near_rejected += usize::from(near);
                }
                if plain.is_finite() {
                    hits += 1;
                    near_hits += usize::from(near);
                }
            }
        }
        eprintln!(
            "{hits} hits ({near_hits} with an end within 1e-6 of the plane), \
             {rejected} rejected ({near_rejected} within 1e-6)"
        );
        // The rays exercise both sides of the rejection, close to the plane.
        assert!(
            hits > 1000 && near_hits > 500,
            "{hits} hits, {near_hits} near"
        );
        assert!(
            rejected > 1000 && near_rejected > 500,
            "{rejected} rejected, {near_rejected} near"
        );
    }
}
