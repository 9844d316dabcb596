//! What a space-time window carries from one solved frame to the frames solved
//! between it and the next (Damez & Sillion, paper 001, §4.3 eq. 8–9: an
//! interaction or an element that is not split in time holds one value over its
//! time range; here the values are linear over the range).
//!
//! Three records of a solved frame, each kept while a frame still to be solved
//! brackets it ([`super`] decides which):
//! - [`FrameRows`]: the leaf-row entries with a moving end, sorted by what they
//!   stand for; a frame solved between two takes an entry on the line between
//!   their values where its light changes by at most a tolerance ([`TimeRange`]).
//! - [`SharedRadiosity`]: the radiosity of the elements all the window's frames
//!   share, and the power each moving surface hands on; a frame between two solved
//!   frames whose moving light holds skips its solve and takes the shared
//!   radiosity on the line between them ([`Solver::place_between`]).
//! - [`FrameValues`]: the value of every reconstruction point; a frame between two
//!   solved frames takes a point's value on the line between theirs where they
//!   agree or the point's light is linear in time ([`FrameBetween`]), and gathers it
//!   otherwise. A point on a moving surface also keeps the direct light it
//!   reflects ([`Solver::direct_light`]): the line is over the rest of its light,
//!   and the frame between adds its own direct light.

use std::sync::Arc;

use glam::DVec3;

use crate::geometry::{Poly, point_to_polygon};
use crate::oracle;
use crate::pools::elements::Geom;
use crate::solver::{ElementId, Emission, Leaf, PointKey, Solver, hierarchy};

/// The leaf-row entries with a moving end (a moving leaf, or a moving source) of
/// one solved frame of a space-time window, keyed by what they stand for (the
/// leaf's `Solver::ray_id` and the link's `Solver::row_link_id`, the same at
/// every frame that makes them): `(F, visible fraction)`. The ends of the time
/// range of the frames solved between ([`TimeRange`]). Sorted by key, 24 bytes an
/// entry.
#[derive(Clone, Debug, Default)]
pub struct FrameRows(pub(in crate::solver) Vec<TimedEntry>);

/// One entry of [`FrameRows`]: `((leaf, link), (F, visible fraction))`.
pub(in crate::solver) type TimedEntry = ((u64, u64), (f32, f32));

impl FrameRows {
    /// Number of entries.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True if there is none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Entry `key`, widened.
    pub(in crate::solver) fn get(&self, key: &(u64, u64)) -> Option<(f64, f64)> {
        let i = self.0.binary_search_by_key(key, |e| e.0).ok()?;
        let (f, v) = self.0[i].1;
        Some((f64::from(f), f64::from(v)))
    }
}

/// A frame solved between two solved frames `a` and `b` of a window (Damez &
/// Sillion §4.3, eq. 8–9: an interaction that is not split in time holds one
/// coefficient over its time range). A leaf-row entry with a moving end whose
/// coefficient at `a` and at `b` differs by at most `tol` in the light it carries
/// (`ρ_leaf · max B_s · |F_a − F_b|`, radiosity units) is not split in time over
/// `[a, b]`: the frame takes it on the line between the two (`alpha` of the way
/// from `a`), instead of its exact factors and rays; any other entry is split in
/// time at this frame and computed here, and the frame's entries become an end
/// for the frames between it and `a` or `b` ([`super::solve_order`] bisects).
/// Linear rather than the paper's constant-in-time basis, as the frames between
/// keyframes are ([`FrameBetween`]). Entries between two static ends are never taken:
/// a moving object in the shaft between them (they are computed per frame only
/// then) may block it at this frame and at neither end, the transient blocker the
/// paper's shaft test forces a time split for (§5.2).
#[derive(Clone, Debug)]
pub struct TimeRange {
    /// Row entries of the solved frame before.
    pub a: Arc<FrameRows>,
    /// Row entries of the solved frame after.
    pub b: Arc<FrameRows>,
    /// Where the frame lies, `(t − t_a) / (t_b − t_a)`.
    pub alpha: f64,
    /// Largest change of an entry's light over `[a, b]` (radiosity units).
    pub tol: f64,
}

impl TimeRange {
    /// Entry `key` on the line between `a` and `b`, if both have it and its light
    /// (`weight · F`) changes by at most `tol` between them.
    pub(in crate::solver) fn value(&self, key: &(u64, u64), weight: f64) -> Option<(f64, f64)> {
        let (fa, va) = self.a.get(key)?;
        let (fb, vb) = self.b.get(key)?;
        ((fa - fb).abs() * weight <= self.tol)
            .then_some((fa + self.alpha * (fb - fa), va + self.alpha * (vb - va)))
    }
}

/// Radiosity of the elements a window's frames share, at one frame
/// ([`Solver::shared_radiosity`]).
#[derive(Clone, Debug, Default)]
pub struct SharedRadiosity {
    pub(in crate::solver) b: Vec<[f32; 3]>,
    pub(in crate::solver) dir: Vec<Emission>,
    /// Power (area × max channel) of each moving surface element, in id order.
    pub(in crate::solver) moving_power: Vec<f64>,
}

impl SharedRadiosity {
    /// True if the moving surfaces hand on the same light at `a` and `b`: the power
    /// each emits changes by at most `tol` times their total power.
    pub fn moving_power_holds(a: &SharedRadiosity, b: &SharedRadiosity, tol: f64) -> bool {
        let total: f64 = b.moving_power.iter().sum();
        a.moving_power.len() == b.moving_power.len()
            && a.moving_power
                .iter()
                .zip(&b.moving_power)
                .all(|(x, y)| (x - y).abs() <= tol * total)
    }
}

/// The values a frame's reconstruction gave its points, gathered or interpolated
/// (radiosity, and whether the point lies outside every solid), by point key: what
/// the frames between two solved frames interpolate ([`FrameBetween`]).
///
/// With [`FrameValues::with_cells`], a point the keyframe did not gather takes the
/// value of the keyframe's cell that holds it (the stored interpolant), so a frame
/// that meshes a cell differently can still interpolate its new points.
///
/// The points are a sorted array of 28-byte records with `f32` radiosity, what the
/// leaves store (a window keeps those of about six frames: a hash map of `f64`s
/// held 2.4 MB of ACTOR's out-of-core peak for four); the direct light of those on
/// moving surfaces is a second sorted array, of 24-byte records.
#[derive(Clone, Debug, Default)]
pub struct FrameValues {
    /// (point, radiosity, outside every solid), sorted by point.
    points: Vec<(PointKey, [f32; 3], bool)>,
    /// The direct light the points on moving surfaces reflect ([`Solver::direct_light`]),
    /// sorted by point: a frame between takes the line over the rest of their light
    /// only.
    direct: Vec<(PointKey, [f32; 3])>,
    /// The keyframe's cells, sorted by patch (as [`Solver::reconstruct`] returns
    /// them), shared with the window's time merge until it has taken them.
    cells: std::sync::Arc<[Leaf]>,
}

impl FrameValues {
    /// The values gathered at `points` (in any order).
    pub(in crate::solver) fn from_points(
        points: impl Iterator<Item = (PointKey, [f64; 3], bool)>,
    ) -> Self {
        let mut points: Vec<_> = points
            .map(|(pk, b, ok)| (pk, b.map(|x| x as f32), ok))
            .collect();
        points.sort_unstable_by_key(|p| p.0);
        FrameValues {
            points,
            direct: Vec::new(),
            cells: Default::default(),
        }
    }

    /// Adds the direct light of the points on moving surfaces (in any order).
    pub(in crate::solver) fn with_direct(mut self, mut direct: Vec<(PointKey, [f32; 3])>) -> Self {
        direct.sort_unstable_by_key(|p| p.0);
        self.direct = direct;
        self
    }

    /// The direct light point `pk` reflected at the frame, if it is on a moving
    /// surface.
    pub(in crate::solver) fn direct(&self, pk: &PointKey) -> Option<[f64; 3]> {
        let i = self.direct.binary_search_by_key(pk, |p| p.0).ok()?;
        Some(self.direct[i].1.map(f64::from))
    }

    /// The value the frame gave point `pk` (gathered or interpolated) and whether it
    /// lay outside every solid.
    pub(in crate::solver) fn known(&self, pk: &PointKey) -> Option<([f64; 3], bool)> {
        let i = self.points.binary_search_by_key(pk, |p| p.0).ok()?;
        let (_, b, ok) = self.points[i];
        Some((b.map(f64::from), ok))
    }

    /// Adds the keyframe's cells (sorted by patch) for the points it did not gather.
    pub fn with_cells(mut self, cells: std::sync::Arc<[Leaf]>) -> Self {
        self.cells = cells;
        self
    }

    /// [`FrameValues::at`] less the direct light, for a point on a moving surface: the
    /// frame's own value less its direct light if it had the point (outside the
    /// solids), else the frame's cell holding it, interpolated over its corners'
    /// values less their direct light; `None` if a value or a direct light is
    /// missing.
    pub(in crate::solver) fn indirect_at(&self, pk: &PointKey) -> Option<[f64; 3]> {
        if let Some((v, ok)) = self.known(pk) {
            let d = self.direct(pk).filter(|_| ok)?;
            return Some(std::array::from_fn(|k| v[k] - d[k]));
        }
        let (cell, u, v) = self.cell_holding(pk)?;
        let w = cell.weights(u, v);
        let mut out = [0.0; 3];
        for (c, wc) in w.iter().enumerate().take(cell.corners as usize) {
            let ck = (pk.0, point_coord(cell.uv[c][0]), point_coord(cell.uv[c][1]));
            let d = self.direct(&ck)?;
            for k in 0..3 {
                out[k] += wc * (f64::from(cell.b[c][k]) - d[k]);
            }
        }
        Some(out)
    }

    /// The value at point `pk` outside every solid: the frame's own if it had the
    /// point (and it lay outside the solids then), else the frame's cell holding it.
    pub(in crate::solver) fn at(&self, pk: &PointKey) -> Option<[f64; 3]> {
        if let Some((v, true)) = self.known(pk) {
            return Some(v);
        }
        self.cell_holding(pk).map(|(l, u, v)| l.eval(u, v))
    }

    /// The frame's cell holding point `pk`, and the point's parameters.
    fn cell_holding(&self, pk: &PointKey) -> Option<(&Leaf, f64, f64)> {
        let lo = self.cells.partition_point(|l| l.patch < pk.0);
        let hi = self.cells.partition_point(|l| l.patch <= pk.0);
        let (u, v) = (point_param(pk.1), point_param(pk.2));
        crate::solution::leaf_at(&self.cells[lo..hi], u, v).map(|l| (l, u, v))
    }
}

/// A point key's coordinate for the parameter `x` (`VertexCache::register` in `reconstruct.rs`).
pub(in crate::solver) fn point_coord(x: f32) -> u32 {
    (x as f64 * (1u64 << 24) as f64).round() as u32
}

/// The parameter a point key's coordinate stands for (`VertexCache::register` in `reconstruct.rs`).
pub(in crate::solver) fn point_param(q: u32) -> f64 {
    q as f64 / (1u64 << 24) as f64
}

/// A solved frame of a space-time window: its position (frame index, or any time
/// unit shared by the frames of a [`FrameBetween`]) and the values it gave its points.
pub type Keyframe<'k> = (f64, &'k FrameValues);

/// A frame at `t` between two solved frames `a` and `b` of a space-time window (two
/// keyframes, or a keyframe and the midpoint of a bisection, see
/// [`crate::solver::spacetime::solve_order`]), with the frame `before` as far
/// before `a` as `b` is after, when there is one. A reconstruction point known at
/// both with the same validity takes the linear interpolation of their values
/// instead of a final gather when
/// - their values differ by at most `tol` in every channel, or
/// - the point's values are linear in time over the three frames: `a` lies
///   within `tol` of the line through `before` and `b`.
///
/// Every other point is gathered at the frame. A frame's values hold its
/// interpolated points as well as its gathered ones, so a bisection step
/// interpolates what the step above it interpolated (the same line) and gathers
/// only within the half a change was found in.
///
/// Why this holds: a point's value changes between two frames through the
/// radiosity of its sources, which varies smoothly, and through moving objects
/// crossing its view of them. A moving blocker larger than the distance it travels
/// between the two frames cannot cover and uncover a point's view within that time,
/// so a point whose values agree at both ends, or follow one line over three
/// frames, saw no shadow edge pass in between; a shadow edge that passes within
/// the interval puts `a` off the line through `before` and `b` by about half the
/// edge's contrast, and the point is gathered.
///
/// Where the brackets are close in motion (`free`), the line is taken without the
/// test: a shadow edge passing in between is then placed by the line to within
/// the distance the objects travel over the interval (at most `interp_motion` of
/// the scene's diameter: 3% by default, 20 cm in ACTOR's room), where a gather
/// would resolve it to the steps its rays make as the blocker crosses them. That
/// is an approximation in time, and the error at each reference time measures it:
/// at the default, ACTOR's and LIGHT's worst times are below per-frame's; with
/// the halves of keyframes 10% apart free (5%) they were not (BENCHMARKS.md,
/// "Frames between on the line over half a key interval"). The paper splits a
/// time range only while the light over it varies by more than its threshold
/// (§5.2, criterion 2), so its time elements do not shorten with the frame
/// interval; here that floor is set in motion. What it costs is the paper's
/// "stains" (§5.2): a moving shadow's edge fades over the distance of one free
/// interval instead of stepping.
#[derive(Clone, Copy, Debug)]
pub struct FrameBetween<'k> {
    /// The moving objects travel less than [`super::SpaceTimeOptions::interp_motion`]
    /// between `a` and `b`: a point both know (with the same validity) takes the
    /// line between them whatever its values.
    pub free: bool,
    /// The frame as far before `a` as `b` is after, if any.
    pub before: Option<Keyframe<'k>>,
    /// The solved frame that starts the interval.
    pub a: Keyframe<'k>,
    /// The solved frame that ends the interval.
    pub b: Keyframe<'k>,
    /// Position of the frame, strictly between `a` and `b`.
    pub t: f64,
    /// Largest deviation (radiosity units) of a point's values at the solved
    /// frames from agreement or from a line for the point to be interpolated.
    pub tol: f64,
}

impl FrameBetween<'_> {
    /// The interpolated value of point `pk` and whether it lies outside every
    /// solid, if the solved frames allow it. A point both frames had keeps their
    /// validity (they must agree on it); any other point asks `outside_now` (one
    /// ray, no gather) and, if outside the solids, interpolates the frames' cells
    /// ([`FrameValues::with_cells`]).
    ///
    /// A point on a moving surface comes with its direct light now (`direct_now`,
    /// [`Solver::direct_light`]): where the frames hold its direct light too, the
    /// line (and the tests above) are over the rest of its light, and its direct
    /// light now is added, else over its whole light.
    pub(in crate::solver) fn value(
        &self,
        pk: &PointKey,
        outside_now: impl Fn() -> bool,
        direct_now: Option<[f64; 3]>,
    ) -> Option<([f64; 3], bool)> {
        let less = |d| self.value_less(pk, &outside_now, d);
        match direct_now.map(|d| less(Some(d))) {
            Some(Ok(v)) => v,
            // The frames lack a direct light: the line over the whole light.
            Some(Err(Missing)) | None => less(None).ok().flatten(),
        }
    }

    /// [`FrameBetween::value`], the line over the light less `direct_now` (`None`: the
    /// whole light); `Err` if the frames lack a value or a direct light the line
    /// needs.
    fn value_less(
        &self,
        pk: &PointKey,
        outside_now: &impl Fn() -> bool,
        direct_now: Option<[f64; 3]>,
    ) -> Result<Option<([f64; 3], bool)>, Missing> {
        // A point on a moving surface whose direct light the frames hold: the line
        // over the rest of its light, and its direct light now.
        let minus = |(v, ok): ([f64; 3], bool), d: [f64; 3]| -> ([f64; 3], bool) {
            (std::array::from_fn(|k| v[k] - d[k]), ok)
        };
        let known = |kv: &FrameValues| match direct_now {
            Some(_) => kv.known(pk).zip(kv.direct(pk)).map(|(v, d)| minus(v, d)),
            None => kv.known(pk),
        };
        let at = |kv: &FrameValues| match direct_now {
            Some(_) => kv.indirect_at(pk),
            None => kv.at(pk),
        };
        let (va, vb, valid) = match (known(self.a.1), known(self.b.1)) {
            (Some((va, oka)), Some((vb, okb))) if oka == okb => (va, vb, oka),
            (Some(_), Some(_)) => return Ok(None),
            _ => {
                if !outside_now() {
                    // Inside a solid: the cell takes its other corners' values.
                    return Ok(Some(([0.0; 3], false)));
                }
                (
                    at(self.a.1).ok_or(Missing)?,
                    at(self.b.1).ok_or(Missing)?,
                    true,
                )
            }
        };
        let (ta, tb) = (self.a.0, self.b.0);
        let close = |x: &[f64; 3], y: &[f64; 3]| (0..3).all(|k| (x[k] - y[k]).abs() <= self.tol);
        // Value at `t` of the line through `(t0, v0)` and `(t1, v1)`; `v0 + α (v1 − v0)`,
        // so equal values give back exactly the same value.
        let line = |t0: f64, v0: &[f64; 3], t1: f64, v1: &[f64; 3], t: f64| -> [f64; 3] {
            let alpha = (t - t0) / (t1 - t0);
            std::array::from_fn(|k| v0[k] + alpha * (v1[k] - v0[k]))
        };
        let linear = || {
            self.before.is_some_and(|(tp, p)| {
                at(p).is_some_and(|vp| close(&va, &line(tp, &vp, tb, &vb, ta)))
            })
        };
        if !(self.free || close(&va, &vb) || linear()) {
            return Ok(None);
        }
        let v = line(ta, &va, tb, &vb, self.t);
        let d = direct_now.unwrap_or_default();
        Ok(Some((std::array::from_fn(|k| v[k] + d[k]), valid)))
    }
}

/// The frames lack a value or a direct light ([`FrameBetween::value_less`]).
#[derive(Clone, Copy, Debug)]
struct Missing;

/// An emitting patch as placed at the current time: its index, geometry, polygon
/// and emission ([`Solver::direct_light`]).
pub(in crate::solver) type Emitter = (u32, Geom, Poly, [f64; 3]);

/// Most emitting patches [`Solver::direct_light`] is computed over. Each costs a
/// factor and the final gather's rays to an emitter (32 by default) at every point
/// on a moving surface at every frame; a scene lit by more (an emissive mesh of many
/// triangles) takes the line over the whole light of its moving points, as with
/// [`super::SpaceTimeOptions::direct_apart`] off, rather than pay that.
pub(in crate::solver) const MAX_DIRECT_EMITTERS: usize = 16;

impl Solver<'_> {
    /// The emitting patches as placed now, for [`Solver::direct_light`]; `None` if
    /// there are more than [`MAX_DIRECT_EMITTERS`].
    pub(in crate::solver) fn emitters_now(&self) -> Option<Vec<Emitter>> {
        let lit: Vec<usize> = (0..self.patches.len())
            .filter(|&p| self.patches.emits(p))
            .take(MAX_DIRECT_EMITTERS + 1)
            .collect();
        (lit.len() <= MAX_DIRECT_EMITTERS).then(|| {
            lit.into_iter()
                .map(|p| {
                    let g = hierarchy::whole_patch_geom(&self.patches, p);
                    let poly = oracle::poly(&g);
                    (p as u32, g, poly, self.patches.emissions[p])
                })
                .collect()
        })
    }

    /// The direct light a point `x` (normal `n`) of patch `p` reflects: `ρ_p Σ_e E_e
    /// F(x, e) V(x, e)` over the emitting patches `emitters`, exact point-to-polygon
    /// factors and the final gather's rays to an emitter (jittered by the point's
    /// key, so the same point casts the same rays at every frame).
    ///
    /// On a moving surface this is the part of the light that changes fastest as it
    /// passes a lamp (a panel sliding 45 cm in front of one: the inverse square and
    /// the cosines); a frame between two solved frames takes the line over the rest
    /// only ([`FrameBetween::value`]).
    pub(in crate::solver) fn direct_light(
        &self,
        x: DVec3,
        n: DVec3,
        p: u32,
        pk: &PointKey,
        emitters: &[Emitter],
    ) -> [f64; 3] {
        let mut h = [0.0; 3];
        for (e, g, poly, em) in emitters {
            if *e == p {
                continue;
            }
            let f = point_to_polygon(x, n, poly);
            if f <= 0.0 {
                continue;
            }
            let key = oracle::hash3(
                u64::from(pk.0) << 32 | u64::from(*e),
                u64::from(pk.1) << 32 | u64::from(pk.2),
                0xd1ec,
            );
            let r = oracle::PointRays {
                x,
                n,
                gs: g,
                pols: poly,
                ns: DVec3::from_array(g.normal),
                m: self.opts.corner_rays * 4,
                key,
                skip: [p, *e],
            };
            let v = oracle::visible_fraction(&self.bvh, &r);
            for k in 0..3 {
                h[k] += em[k] * f * v;
            }
        }
        let rho = self.patches.rhos[p as usize];
        std::array::from_fn(|k| rho[k] * h[k])
    }

    /// The solved frames around the next frames solved, whose row entries with a
    /// moving end those frames take where they hold ([`TimeRange`]); `None`: every
    /// entry is computed (a keyframe).
    pub fn set_time_range(&mut self, range: Option<TimeRange>) {
        self.st.time_range = range;
    }

    /// The row entries with a moving end of the frame solved last (computed, or
    /// taken from its [`TimeRange`]), for the frames to be solved between it and
    /// another.
    pub fn take_frame_rows(&mut self) -> FrameRows {
        let mut rows = std::mem::take(&mut self.st.frame_rows);
        rows.0.sort_unstable_by_key(|e| e.0);
        rows.0.shrink_to_fit();
        rows
    }

    /// Places the moving objects at `t` (inside the current window) without solving:
    /// the hierarchy of the last frame solved stays, and the radiosity of the
    /// window's own elements (those every frame of the window shares) is set to
    /// `B_a + alpha · (B_b − B_a)` between two solved frames' values `a` and `b`
    /// ([`Solver::shared_radiosity`]; the solved frames nearest `t` on either
    /// side). The elements the last frame solved refined keep its values. For the
    /// gathers of a frame between two keyframes ([`super`]).
    pub fn place_between(&mut self, t: f64, a: &SharedRadiosity, b: &SharedRadiosity, alpha: f64) {
        let n = a.b.len().min(b.b.len()).min(self.elems.len());
        let lerp =
            |x: [f32; 3], y: [f32; 3]| std::array::from_fn(|k| x[k] + alpha as f32 * (y[k] - x[k]));
        for (i, out) in self.elems.radiosities.as_mut_slice()[..n]
            .iter_mut()
            .enumerate()
        {
            *out = lerp(a.b[i], b.b[i]);
        }
        for (i, out) in self.elems.directions.as_mut_slice()[..n]
            .iter_mut()
            .enumerate()
        {
            *out = a.dir[i].lerp(&b.dir[i], alpha as f32);
        }
        self.set_time(t);
    }

    /// The radiosity (and power-weighted directions) of the elements every frame of
    /// the current window shares, as solved now.
    pub fn shared_radiosity(&self) -> SharedRadiosity {
        let n = self
            .st
            .window
            .as_ref()
            .map_or(self.elems.len(), |w| w.frame.elems_len);
        let b = self.elems.radiosities.as_slice()[..n].to_vec();
        // Power of the moving surfaces (what they hand the rest of the scene).
        let geoms = self.elems.geoms.as_slice();
        let moving_power = (0..n)
            .filter(|&e| geoms[e].patch != u32::MAX && self.elem_moving(ElementId(e as u32)))
            .map(|e| geoms[e].area * b[e].iter().copied().fold(0.0f32, f32::max) as f64)
            .collect();
        SharedRadiosity {
            b,
            dir: self.elems.directions.as_slice()[..n].to_vec(),
            moving_power,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_entry_is_taken_between_its_ends_only_if_its_light_holds() {
        let rows = |e: &[TimedEntry]| Arc::new(FrameRows(e.to_vec()));
        let range = TimeRange {
            a: rows(&[
                ((1, 1), (0.25, 0.5)),
                ((1, 2), (0.5, 1.0)),
                ((2, 1), (0.1, 1.0)),
            ]),
            b: rows(&[
                ((1, 1), (0.75, 1.0)),
                ((1, 2), (0.5, 1.0)),
                ((3, 1), (0.1, 1.0)),
            ]),
            alpha: 0.25,
            tol: 0.1,
        };
        // Light `weight · |F_a − F_b|`: 0.5 · 0.5 = 0.25 > 0.1, 0.1 · 0.5 = 0.05.
        assert_eq!(range.value(&(1, 1), 0.5), None);
        assert_eq!(range.value(&(1, 1), 0.1), Some((0.375, 0.625)));
        assert_eq!(range.value(&(1, 2), 1e9), Some((0.5, 1.0)));
        // Both ends must have the entry.
        assert_eq!(range.value(&(2, 1), 0.0), None);
        assert_eq!(range.value(&(3, 1), 0.0), None);
    }

    fn values(points: &[(u32, [f64; 3], bool)]) -> FrameValues {
        FrameValues::from_points(points.iter().map(|&(i, v, ok)| ((0, i, 0), v, ok)))
    }

    fn grey(v: f64) -> [f64; 3] {
        [v, v, v]
    }

    #[test]
    fn frames_between_keyframes_interpolate_only_what_the_keyframes_allow() {
        // Point 0 holds its value, point 1 drifts along a line, point 2 sees a shadow
        // edge pass between a and b, point 3 is missing at b, point 4 is inside a
        // solid at a only, point 5 drifts too fast and the keyframe before lacks it.
        let p = values(&[(1, grey(0.8), true), (2, grey(1.0), true)]);
        let a = values(&[
            (0, grey(0.5), true),
            (1, grey(1.0), true),
            (2, grey(1.0), true),
            (3, grey(0.5), true),
            (4, grey(0.5), false),
            (5, grey(0.5), true),
        ]);
        let b = values(&[
            (0, grey(0.505), true),
            (1, grey(1.2), true),
            (2, grey(0.4), true),
            (4, grey(0.5), true),
            (5, grey(0.9), true),
        ]);
        let between = FrameBetween {
            free: false,
            before: Some((0.0, &p)),
            a: (4.0, &a),
            b: (8.0, &b),
            t: 5.0,
            tol: 0.01,
        };
        let at = |i: u32| between.value(&(0, i, 0), || true, None);
        let (v0, ok0) = at(0).expect("agreeing keyframes interpolate");
        assert!(ok0);
        // Keyframe values are kept in f32, as the leaves store them.
        assert!((v0[0] - 0.50125).abs() < 1e-7, "{v0:?}");
        let (v1, _) = at(1).expect("a value on one line over three keyframes");
        assert!((v1[1] - 1.05).abs() < 1e-7, "{v1:?}");
        assert_eq!(at(2), None, "a shadow edge passed between a and b");
        assert_eq!(at(3), None, "not gathered at b");
        assert_eq!(at(4), None, "inside a solid at a only");
        assert_eq!(at(5), None, "the keyframe before does not hold point 5");
        // Without a keyframe before the interval only agreement counts.
        let bare = FrameBetween {
            before: None,
            ..between
        };
        assert!(bare.value(&(0, 0, 0), || true, None).is_some());
        assert_eq!(bare.value(&(0, 1, 0), || true, None), None);
        // Brackets closer in motion than `interp_motion`: a point both hold takes
        // the line whatever its values (the shadow edge of point 2 fades over the
        // interval); one they do not both hold, or with another validity, does not.
        let free = FrameBetween { free: true, ..bare };
        let (v2, ok2) = free
            .value(&(0, 2, 0), || true, None)
            .expect("free: the line");
        assert!(ok2);
        assert!((v2[2] - (1.0 + 0.25 * (0.4 - 1.0))).abs() < 1e-7, "{v2:?}");
        assert_eq!(free.value(&(0, 3, 0), || true, None), None);
        assert_eq!(free.value(&(0, 4, 0), || true, None), None);
        // Equal values come back bit for bit (where nothing changes, consecutive
        // frames are equal and the store merges them).
        let same = values(&[(0, [0.1, 0.2, 0.3], true)]);
        let flat = FrameBetween {
            free: false,
            before: None,
            a: (0.0, &same),
            b: (3.0, &same),
            t: 1.0,
            tol: 0.0,
        };
        let kept = [0.1f32, 0.2, 0.3].map(f64::from);
        assert_eq!(flat.value(&(0, 0, 0), || true, None), Some((kept, true)));
    }

    #[test]
    fn moving_power_holds_within_a_share_of_the_moving_total() {
        let at = |p: &[f64]| SharedRadiosity {
            moving_power: p.to_vec(),
            ..SharedRadiosity::default()
        };
        let a = at(&[10.0, 90.0]);
        // 1 of a total of 100 moves: within 1%, not within 0.5%.
        assert!(SharedRadiosity::moving_power_holds(
            &a,
            &at(&[11.0, 89.0]),
            0.01
        ));
        assert!(!SharedRadiosity::moving_power_holds(
            &a,
            &at(&[11.0, 89.0]),
            0.005
        ));
        // A panel sliding over a lamp: one surface's light doubles.
        assert!(!SharedRadiosity::moving_power_holds(
            &a,
            &at(&[20.0, 90.0]),
            0.01
        ));
        // Different surfaces (never within one window): not comparable.
        assert!(!SharedRadiosity::moving_power_holds(&a, &at(&[10.0]), 0.5));
    }

    #[test]
    fn a_point_no_keyframe_gathered_interpolates_their_cells() {
        // Patch 7 is one quad cell at each keyframe, corners 1, 2, 2, 1 at `a` (a
        // ramp in u) and 0.005 brighter at `b`; the frame asks for (0.25, 0.5).
        let cell = |lift: f32| Leaf {
            patch: 7,
            corners: 4,
            time: [0.0, 0.0],
            uv: [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            b: [1.0, 2.0, 2.0, 1.0].map(|v| [v + lift; 3]),
        };
        let a = FrameValues::default().with_cells([cell(0.0)].into());
        let b = FrameValues::default().with_cells([cell(0.005)].into());
        let between = FrameBetween {
            free: false,
            before: None,
            a: (0.0, &a),
            b: (2.0, &b),
            t: 1.0,
            tol: 0.01,
        };
        let q = |x: f64| (x * (1u64 << 24) as f64) as u32;
        let pk = (7, q(0.25), q(0.5));
        let (v, valid) = between.value(&pk, || true, None).expect("the cells agree");
        assert!(valid);
        assert!((v[0] - 1.2525).abs() < 1e-6, "{v:?}");
        // Inside a solid now: no value is needed, no gather is made.
        assert_eq!(between.value(&pk, || false, None), Some(([0.0; 3], false)));
        // A patch neither keyframe has cells on is gathered.
        assert_eq!(between.value(&(8, q(0.25), q(0.5)), || true, None), None);
    }

    #[test]
    fn a_moving_point_takes_the_line_over_its_light_less_its_direct_light() {
        // Point 1 on a moving surface: the rest of its light 1.0, 1.2, 1.4 at the
        // frames 0, 4, 8 (a line), its direct light 2, 6, 3 (a bump the line cannot
        // follow). Point 2 lacks its direct light at `b`.
        let frame = |v: &[(u32, f64, f64)], lacking: Option<u32>| {
            FrameValues::from_points(v.iter().map(|&(i, b, d)| ((0, i, 0), grey(b + d), true)))
                .with_direct(
                    v.iter()
                        .filter(|p| Some(p.0) != lacking)
                        .map(|&(i, _, d)| ((0, i, 0), [d as f32; 3]))
                        .collect(),
                )
        };
        let p = frame(&[(1, 1.0, 2.0), (2, 1.0, 2.0)], None);
        let a = frame(&[(1, 1.2, 6.0), (2, 1.2, 6.0)], None);
        let b = frame(&[(1, 1.4, 3.0), (2, 1.4, 3.0)], Some(2));
        let between = FrameBetween {
            free: false,
            before: Some((0.0, &p)),
            a: (4.0, &a),
            b: (8.0, &b),
            t: 5.0,
            tol: 0.01,
        };
        let pk = (0, 1, 0);
        let (v, ok) = between
            .value(&pk, || true, Some(grey(5.5)))
            .expect("the rest of its light is on a line");
        assert!(ok);
        // 1.25 on the line, 5.5 of direct light now.
        assert!((v[0] - 6.75).abs() < 1e-6, "{v:?}");
        // The whole light (3.0, 7.2 and 4.4 at the frames 0, 4, 8) is on no line.
        assert_eq!(between.value(&pk, || true, None), None);
        // Without the direct light at `b`, point 2 is tested on its whole light:
        // gathered here, and on the line between `a` and `b` when free.
        assert_eq!(between.value(&(0, 2, 0), || true, Some(grey(5.5))), None);
        let free = FrameBetween {
            free: true,
            ..between
        };
        let (v2, _) = free
            .value(&(0, 2, 0), || true, Some(grey(5.5)))
            .expect("free: the line");
        assert!((v2[0] - (7.2 + 0.25 * (4.4 - 7.2))).abs() < 1e-6, "{v2:?}");
    }

    #[test]
    fn a_moving_point_no_frame_gathered_takes_the_cells_less_their_corners_direct_light() {
        // Patch 7 is one quad cell at each frame; its corners' direct light is known
        // at both frames, the rest of their light is 1 at `a` and 2 at `b`.
        let q = point_coord;
        let corners = [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let frame = |rest: f32, direct: [f32; 4]| {
            let cell = Leaf {
                patch: 7,
                corners: 4,
                time: [0.0, 0.0],
                uv: corners,
                b: direct.map(|d| [rest + d; 3]),
            };
            FrameValues::default()
                .with_direct(
                    corners
                        .iter()
                        .zip(direct)
                        .map(|(c, d)| ((7, q(c[0]), q(c[1])), [d; 3]))
                        .collect(),
                )
                .with_cells([cell].into())
        };
        let a = frame(1.0, [4.0, 0.0, 0.0, 4.0]);
        let b = frame(2.0, [0.0, 8.0, 8.0, 0.0]);
        let pk = (7, q(0.25), q(0.5));
        let rest = |kv: &FrameValues| kv.indirect_at(&pk).map(|v| v[0]);
        assert!((rest(&a).unwrap() - 1.0).abs() < 1e-6);
        assert!((rest(&b).unwrap() - 2.0).abs() < 1e-6);
        let between = FrameBetween {
            free: true,
            before: None,
            a: (0.0, &a),
            b: (4.0, &b),
            t: 1.0,
            tol: 0.01,
        };
        let (v, _) = between.value(&pk, || true, Some(grey(3.0))).unwrap();
        assert!((v[0] - 4.25).abs() < 1e-6, "{v:?}");
        // A corner without its direct light: no rest to take.
        let lacking = FrameValues::default().with_cells(a.cells.clone());
        assert_eq!(lacking.indirect_at(&pk), None);
    }

    #[test]
    fn the_direct_light_of_a_point_is_its_exact_factor_to_each_lamp() {
        // The Cornell box's floor under the centre of its lamp (130 × 105 mm,
        // 548.8 mm up, nothing between): `ρ E F`, with the factor of a parallel
        // rectangle over a point, the sum of four rectangles with a corner over it.
        let scene = crate::scene::cornell_box(false);
        let s = Solver::at_time(
            &scene,
            crate::solver::SolveOptions::default(),
            0.0,
            [0.0, 0.0],
        )
        .unwrap();
        let floor = (0..s.patches.len())
            .find(|&p| s.patches.normals[p].y > 0.99 && s.patches.point(p, 0.5, 0.5).y.abs() < 1e-9)
            .expect("the Cornell box has a floor") as u32;
        let emitters = s.emitters_now().expect("one lamp");
        assert_eq!(emitters.len(), 1);
        let x = DVec3::new(278.0, 0.0, 279.5);
        let d = s.direct_light(x, DVec3::Y, floor, &(floor, 0, 0), &emitters);
        let corner = |a: f64, b: f64| {
            let (x, y) = (a / 548.8, b / 548.8);
            let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
            (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
        };
        let f = 4.0 * corner(65.0, 52.5);
        let (rho, e) = (s.patches.rhos[floor as usize], emitters[0].3);
        for k in 0..3 {
            let want = rho[k] * e[k] * f;
            assert!(
                (d[k] - want).abs() < 1e-9 * want,
                "{k}: {} against {want}",
                d[k]
            );
        }
        // The lamp itself gets no direct light from itself; the ceiling around it
        // none either (the lamp is in its plane).
        let lamp = emitters[0].0;
        let c = s.patches.point(lamp as usize, 0.5, 0.5);
        assert_eq!(
            s.direct_light(c, -DVec3::Y, lamp, &(lamp, 0, 0), &emitters),
            [0.0; 3]
        );
    }

    #[test]
    fn a_scene_lit_by_many_emitters_takes_the_line_over_the_whole_light() {
        // The Cornell box with its lamp cut into a grid of n × n lamps: up to
        // `MAX_DIRECT_EMITTERS` the direct light is kept apart, over it not.
        let lamps = |n: usize| {
            let mut scene = crate::scene::cornell_box(false);
            let lamp = scene
                .objects
                .iter_mut()
                .find(|o| o.name == "light")
                .expect("the Cornell box has a light");
            let v = lamp.polygons[0].vertices.clone();
            let material = lamp.polygons[0].material;
            let at = |s: f64, t: f64| v[0] + s * (v[1] - v[0]) + t * (v[3] - v[0]);
            lamp.polygons = (0..n * n)
                .map(|k| {
                    let (i, j) = ((k % n) as f64, (k / n) as f64);
                    let d = 1.0 / n as f64;
                    crate::scene::Polygon {
                        vertices: vec![
                            at(i * d, j * d),
                            at((i + 1.0) * d, j * d),
                            at((i + 1.0) * d, (j + 1.0) * d),
                            at(i * d, (j + 1.0) * d),
                        ],
                        material,
                    }
                })
                .collect();
            let s = Solver::at_time(
                &scene,
                crate::solver::SolveOptions::default(),
                0.0,
                [0.0, 0.0],
            )
            .unwrap();
            s.emitters_now().map(|e| e.len())
        };
        assert_eq!(lamps(4), Some(16));
        assert_eq!(lamps(5), None);
    }
}
