//! What an interactive session ([`crate::interactive`]) asks of the solver: place
//! objects by transforms that arrive one move at a time (not by a motion track),
//! evaluate given links again, complete the children of refined links whose ends
//! moved, and refine and solve again from the radiosity the last move left.
//!
//! How it works: a session solves a scene whose movable objects carry a motion
//! track (so that their patches are kept apart by contact meshing and their
//! triangles sit in BVH parts of their own, [`SceneBvh::place_with`]); the track is
//! never evaluated after the start. [`Solver::place_objects`] places the patches,
//! elements and clusters as `set_time` does, from the maps given. Links are
//! evaluated again in place ([`Solver::reevaluate`]: same id, same state), so the
//! refinement history (passive links) stays the line-space hierarchy of paper 000
//! section 2. A refined link whose end moved may have children pairs the refinement
//! dropped as empty (facing away) that face each other now:
//! [`Solver::complete_children`] evaluates and adds those. [`Solver::settle`] then
//! runs the passes a space-time frame runs: refine the given links, solve the leaf
//! system warm-started, refine every active link whose error the new radiosity
//! pushed over the threshold, solve again.
//!
//! A static solve calls none of this: the only change to its paths is that
//! `set_time` now places through [`Solver::place_patches`], the same code.

use glam::DAffine3;

use super::row_patch::{Dirty, RowPatch};
use super::{FastMap, Solver};
use crate::Result;
use crate::oracle::{self, Split};
use crate::pools::{ElementId, LinkId, LinkState};

/// Most refine-and-solve passes one move runs ([`Solver::settle`]).
pub const MOVE_PASSES: usize = 3;

/// A later pass of [`Solver::settle_local`] refines the links of the sources whose
/// radiosity the solve raised by more than this fraction: a link's error bound
/// grows with its source's radiosity, and one that rose less stays within a
/// hair of the threshold it met before.
pub const SOURCE_RISE: f32 = 0.01;

/// A link with a cluster end that a move evaluated again dirties every row under
/// its receiver only when the light it hands on changed by more than this
/// fraction of the refinement threshold `eps · B_ref` (a change below is within
/// the error the hierarchy allows the link); otherwise only the rows of the
/// leaves near the moved objects ([`Solver::settle_local`]). Links between two
/// surfaces always dirty their receiver's rows.
pub const MOVE_CHANGE: f64 = 0.1;

/// What [`Solver::settle`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Settled {
    /// Links split (made passive) by the passes.
    pub refined: u64,
    /// Relative residual of the last linear solve.
    pub residual: f64,
    /// Leaf rows computed (every row of every pass for [`Solver::settle`]).
    pub rows: u64,
    /// Seconds computing and copying leaf rows ([`Solver::settle_local`] only).
    pub rows_s: f64,
    /// Seconds in the linear solves ([`Solver::settle_local`] only).
    pub solve_s: f64,
}

impl<'a> Solver<'a> {
    /// Places each object `o` with `world[o] = Some(map)` (object → world) and
    /// leaves the others where they stand: patches, elements, clusters, BVH parts
    /// and the moving boxes the gathers test. Only objects the solver treats as
    /// moving (they had a track at the start) can be placed.
    pub(crate) fn place_objects(&mut self, world: &[Option<DAffine3>]) {
        if !self.has_motion() {
            return;
        }
        let at = |o: u32| world.get(o as usize).copied().flatten();
        self.place_patches(at);
        self.bvh.place_with(at);
        self.motion.moving_now = self.bvh.moving_boxes();
    }

    /// Per element: true if a patch of an object flagged in `objects` lies under
    /// it (the element itself for a surface element).
    pub(crate) fn elements_holding(&self, objects: &[bool]) -> Vec<bool> {
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let mut out = vec![false; geoms.len()];
        for e in 0..geoms.len() {
            let p = geoms[e].patch;
            if p == u32::MAX || out[e] {
                continue;
            }
            let o = self.patches.objects[p as usize] as usize;
            if !objects.get(o).copied().unwrap_or(false) {
                continue;
            }
            out[e] = true;
            // Up to the first ancestor marked already.
            let mut a = nodes[e].parent;
            while a != u32::MAX && !out[a as usize] {
                out[a as usize] = true;
                a = nodes[a as usize].parent;
            }
        }
        out
    }

    /// Evaluates links `ids` again where their ends stand now (same ids, same
    /// states); returns the rays cast.
    pub(crate) fn reevaluate_links(&mut self, ids: &[LinkId]) -> u64 {
        let rays0 = self.rays;
        self.reevaluate(ids);
        self.rays - rays0
    }

    /// For each passive link of `passive`: the children pairs of its split that
    /// have no link in `pairs` (dropped as empty when it was refined) are
    /// evaluated, and those that exchange light now are added, active, and
    /// recorded in `pairs`. Returns the added links.
    pub(crate) fn complete_children(
        &mut self,
        passive: &[LinkId],
        pairs: &mut FastMap<(u32, u32), u32>,
    ) -> Result<Vec<LinkId>> {
        let mut missing: Vec<(ElementId, ElementId)> = Vec::new();
        for &l in passive {
            let t = self.links.transports.as_slice()[l.ix()];
            if t.state() != LinkState::Passive {
                continue;
            }
            let e = self.links.ends.as_slice()[l.ix()];
            let (r, s) = (ElementId(e.receiver), ElementId(e.source));
            // The end it was split at: where a child link is (the sizes that chose it
            // may have changed with the move: a cluster's box grows with an object
            // that leaves it); only a split none of whose children exchanged light is
            // chosen again.
            let has = |a: u32, b: u32| pairs.contains_key(&(a, b));
            let split = if self.elems.children(r).any(|c| has(c, s.0)) {
                r
            } else if self.elems.children(s).any(|c| has(r.0, c)) {
                s
            } else {
                match oracle::choose_split(&self.elems, r, s, self.link_floor(r, s)) {
                    Split::Keep => continue,
                    Split::Receiver => r,
                    Split::Source => s,
                }
            };
            for c in self.elems.children(split) {
                let pair = if split == r {
                    (ElementId(c), s)
                } else {
                    (r, ElementId(c))
                };
                if !pairs.contains_key(&(pair.0.0, pair.1.0)) {
                    missing.push(pair);
                }
            }
        }
        missing.sort_unstable_by_key(|p| (p.0.0, p.1.0));
        missing.dedup();
        let set = self.settings();
        let this = &*self;
        let evals: Vec<_> = {
            use rayon::prelude::*;
            missing
                .par_iter()
                .map(|&(r, s)| {
                    let ids = [this.ray_id(r.0), this.ray_id(s.0)];
                    oracle::evaluate(&this.elems, &this.bvh, r, s, ids, &set, this.plane_tol)
                })
                .collect()
        };
        let mut added = Vec::new();
        for ((r, s), ev) in missing.into_iter().zip(evals) {
            self.rays += u64::from(ev.rays);
            if ev.empty {
                continue;
            }
            let id = self.links.push(r, s, ev.transport)?;
            pairs.insert((r.0, s.0), id.0);
            added.push(id);
        }
        Ok(added)
    }

    /// Refines the links of `wave` against `eps · B_ref`, solves the leaf system
    /// warm-started from the radiosity in the pool, then refines every active link
    /// the new radiosity pushed over the threshold and solves again, for at most
    /// [`MOVE_PASSES`] passes (a space-time frame's passes, `solve_frame`).
    pub(crate) fn settle(&mut self, wave: Vec<LinkId>) -> Result<Settled> {
        let passive0 = self.links.counts().1;
        let mut residual = f64::NAN;
        let mut wave = wave;
        let mut rows = 0;
        for pass in 0..MOVE_PASSES {
            let thr = self.opts.eps * self.b_ref();
            let changed = self.refine(wave, thr)?;
            if pass > 0 && !changed {
                break;
            }
            self.index_links();
            residual = self.solve_rows()?;
            rows += self.sys.leaves.len() as u64;
            wave = self.active_links(false);
            if pass == 0 {
                // A cluster source's coefficient depends on its radiosity (its
                // visibility points are drawn by power): the move changed it.
                self.reevaluate_cluster_sources(&wave);
            }
        }
        Ok(Settled {
            refined: self.links.counts().1 - passive0,
            residual,
            rows,
            rows_s: 0.0,
            solve_s: 0.0,
        })
    }

    /// [`Solver::settle`] for a move whose links the session found: the leaf
    /// system of the last move is kept, and only what the move changed is done
    /// again (paper 000 section 2: the update touches the links the move affects).
    ///
    /// `dirty_links`: the links the move evaluated again or added, each with its
    /// factor before (0 for an added link); `changed`: those whose transport
    /// changed, and the added ones; `moved`: per object, whether the move placed
    /// it; `boxes`: the moved objects' boxes before and after. Each pass refines
    /// the links of `changed` (later passes: the active links whose source's radiosity the last solve raised by
    /// more than [`SOURCE_RISE`], the only ones the new radiosity can push over the
    /// threshold), then recomputes the rows of the *dirty* leaves only
    /// ([`Solver::rows_of`]): new leaves; leaves under the receiver of a link that
    /// was split or added, or of a wave link between two surfaces, or of a wave
    /// link with a cluster end whose light changed by more than [`MOVE_CHANGE`] of
    /// the threshold; and, under the other wave links with a cluster end, the
    /// leaves that meet a box of `near` (the moved objects' boxes before and after,
    /// grown: where a cluster source is opened down to the moved surfaces, or their
    /// shadow falls close). In a recomputed row the entries of the links the move
    /// left are kept, and those of the links it evaluated again are updated in
    /// place ([`RowPatch`], `super::row_patch`: only the parts that hold the moved
    /// objects, or whose rays their boxes before or after meet, are computed
    /// again). Every other row is copied from the last move: its chain links and
    /// their shafts are untouched, so are its coefficients. The leaf system is then
    /// solved by GMRES warm-started from the radiosity the last move left. A
    /// balanced system keeps its row scales and gains; a recomputed row that
    /// balancing scaled keeps its scale times its old sum over its new one (the
    /// column passes' share of the scale stays; `1 / sum` undid it).
    ///
    /// What is not done again: cluster-source links the move did not affect keep
    /// the estimate of the radiosity they were evaluated with (a fresh solve
    /// evaluates them once more after its first solve), and a row whose source was
    /// split keeps the source whole instead of opening it into the new children.
    pub(crate) fn settle_local(
        &mut self,
        changed: Vec<LinkId>,
        dirty_links: Vec<(LinkId, f32)>,
        near: &[(glam::DVec3, glam::DVec3)],
        moved: &[bool],
        boxes: &[(glam::DVec3, glam::DVec3)],
    ) -> Result<Settled> {
        let passive0 = self.links.counts().1;
        let mut residual = f64::NAN;
        let mut rows_done = 0u64;
        let (mut rows_s, mut solve_s) = (0.0, 0.0);
        let thr0 = self.opts.eps * self.b_ref();
        let mut dirty = vec![Dirty::Clean; self.elems.len()];
        // The links whose kept row entries are stale: everywhere (`All`), or in
        // the rows of the leaves near the moved objects (`Near`).
        let mut stale: FastMap<u32, Dirty> = FastMap::default();
        {
            let ends = self.links.ends.as_slice();
            let geoms = self.elems.geoms.as_slice();
            for &(l, f_old) in &dirty_links {
                let e = ends[l.ix()];
                let r = e.receiver as usize;
                let surfaces =
                    geoms[r].patch != u32::MAX && geoms[e.source as usize].patch != u32::MAX;
                let level = if surfaces || self.light_change(l, f_old) > MOVE_CHANGE * thr0 {
                    Dirty::All
                } else {
                    Dirty::Near
                };
                dirty[r] = dirty[r].max(level);
                stale.insert(l.0, level);
            }
        }
        let mut wave = changed;
        for pass in 0..MOVE_PASSES {
            let thr = self.opts.eps * self.b_ref();
            let links0 = self.links.len();
            if pass > 0 {
                dirty = vec![Dirty::Clean; self.elems.len()];
            }
            let active_before: Vec<bool> = {
                let tr = self.links.transports.as_slice();
                wave.iter()
                    .map(|l| tr[l.ix()].state() == LinkState::Active)
                    .collect()
            };
            let changed = self.refine(wave.clone(), thr)?;
            if pass > 0 && !changed {
                break;
            }
            dirty.resize(self.elems.len(), Dirty::Clean);
            {
                let ends = self.links.ends.as_slice();
                let tr = self.links.transports.as_slice();
                for (l, was) in wave.iter().zip(active_before) {
                    if was && tr[l.ix()].state() != LinkState::Active {
                        dirty[ends[l.ix()].receiver as usize] = Dirty::All;
                    }
                }
                for e in &ends[links0..] {
                    dirty[e.receiver as usize] = Dirty::All;
                }
            }
            let before: Vec<[f32; 3]> = self.elems.radiosities.as_slice().to_vec();
            let t = std::time::Instant::now();
            let patch = RowPatch {
                holding: self.elements_holding(moved),
                boxes: boxes.to_vec(),
                near: near.to_vec(),
                stale: std::mem::take(&mut stale),
                order: super::row_patch::tree_order(self.elems.nodes.as_slice()),
            };
            rows_done += self.update_rows(&dirty, &patch);
            rows_s += t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            residual = self.solve_leaves()?;
            solve_s += t.elapsed().as_secs_f64();
            wave = self.risen_sources(&before);
        }
        Ok(Settled {
            refined: self.links.counts().1 - passive0,
            residual,
            rows: rows_done,
            rows_s,
            solve_s,
        })
    }

    /// How much the light link `l` hands its receiver changed when its factor
    /// went from `f_old` to what it is now: `ρ_r B_s |Δf|` (largest channel).
    fn light_change(&self, l: LinkId, f_old: f32) -> f64 {
        let e = self.links.ends.as_slice()[l.ix()];
        let f = self.links.transports.as_slice()[l.ix()].f;
        let b = self.elems.radiosities.as_slice()[e.source as usize];
        let bmax = b.iter().copied().fold(0.0f32, f32::max) as f64;
        self.rho_of(ElementId(e.receiver)) * bmax * f64::from((f - f_old).abs())
    }

    /// The active links whose source's radiosity (largest channel) rose by more
    /// than [`SOURCE_RISE`] of itself over `before` (elements past `before`: new,
    /// never).
    fn risen_sources(&self, before: &[[f32; 3]]) -> Vec<LinkId> {
        let b = self.elems.radiosities.as_slice();
        let max = |v: &[f32; 3]| v.iter().copied().fold(0.0f32, f32::max);
        let risen: Vec<bool> = before
            .iter()
            .zip(b)
            .map(|(o, n)| max(n) > max(o) * (1.0 + SOURCE_RISE) + f32::MIN_POSITIVE)
            .collect();
        let ends = self.links.ends.as_slice();
        let tr = self.links.transports.as_slice();
        (0..tr.len() as u32)
            .map(LinkId)
            .filter(|l| {
                tr[l.ix()].state() == LinkState::Active
                    && risen.get(ends[l.ix()].source as usize) == Some(&true)
            })
            .collect()
    }

    /// Re-indexes the active links and rebuilds the leaf system's rows, keeping
    /// the rows of the leaves that are neither new nor under an element flagged in
    /// `dirty` (module docs, [`Solver::settle_local`]). Returns the rows computed.
    fn update_rows(&mut self, dirty: &[Dirty], patch: &RowPatch) -> u64 {
        let near = &patch.near;
        let old_leaves = std::mem::take(&mut self.sys.leaves);
        let old_index = std::mem::take(&mut self.sys.leaf_index);
        let old_start = std::mem::take(&mut self.sys.row_start);
        let old_sources = std::mem::take(&mut self.sys.row_sources);
        let old_coefs = std::mem::take(&mut self.sys.row_coefs);
        let old_scale = std::mem::take(&mut self.sys.row_scale);
        let old_gain = std::mem::take(&mut self.sys.leaf_gain);
        let had_rows = old_start.len() == old_leaves.len() + 1;
        self.index_links();
        let nodes = self.elems.nodes.as_slice();
        let geoms = self.elems.geoms.as_slice();
        // The old leaf a leaf was or lies under (its row's and gain's heir).
        let old_of = |e: u32| -> Option<usize> {
            let mut a = e;
            loop {
                match old_index.get(a as usize) {
                    Some(&i) if i != u32::MAX => return Some(i as usize),
                    _ => {}
                }
                a = nodes[a as usize].parent;
                if a == u32::MAX {
                    return None;
                }
            }
        };
        let is_dirty = |leaf: ElementId| -> bool {
            if !had_rows || old_index.get(leaf.ix()).is_none_or(|&i| i == u32::MAX) {
                return true;
            }
            let mut a = leaf.0;
            let mut level = Dirty::Clean;
            while a != u32::MAX {
                level = level.max(dirty.get(a as usize).copied().unwrap_or(Dirty::Clean));
                a = nodes[a as usize].parent;
            }
            match level {
                Dirty::All => true,
                Dirty::Near => {
                    let (lo, hi) = super::geom_box(&geoms[leaf.ix()]);
                    crate::shafts::meets_any(lo, hi, near)
                }
                Dirty::Clean => false,
            }
        };
        let leaves = self.sys.leaves.clone();
        let redo: Vec<ElementId> = leaves.iter().copied().filter(|&l| is_dirty(l)).collect();
        // The kept entries of the links evaluated again are stale: updated in
        // place (`super::row_patch`), their rays at static geometry known from the
        // moves before where both ends stand still (`Solver::move_row_masks`).
        self.sys.move_rows = true;
        let fresh = self.rows_of(&redo, patch);
        self.sys.move_rows = false;
        if let Ok(made) = self.sys.move_masks_made.get_mut() {
            self.sys.move_masks.extend(made.drain(..));
        }
        if let Ok(made) = self.sys.move_part_masks_made.get_mut() {
            self.sys.move_part_masks.extend(made.drain(..));
        }
        if let Ok(made) = self.sys.move_traces_made.get_mut() {
            self.sys.move_traces.extend(made.drain(..));
        }
        let balanced = !old_scale.is_empty();
        let mut fresh = redo.iter().zip(fresh);
        let mut next = fresh.next();
        let (mut scale, mut gain) = (Vec::new(), Vec::new());
        let nl = leaves.len();
        self.sys.row_start = Vec::with_capacity(nl + 1);
        self.sys.row_start.push(0);
        self.sys.row_sources = Vec::with_capacity(old_sources.len());
        self.sys.row_coefs = Vec::with_capacity(old_coefs.len());
        for &leaf in &leaves {
            let heir = old_of(leaf.0);
            match next {
                Some((&l, ref mut fresh_row)) if l == leaf => {
                    let row = std::mem::take(&mut fresh_row.row);
                    self.sys
                        .row_cache
                        .insert(l.0, std::mem::take(&mut fresh_row.kept));
                    self.sys
                        .row_rays
                        .insert(l.0, std::mem::take(&mut fresh_row.kept_rays));
                    self.sys
                        .move_cluster_cache
                        .insert(l.0, std::mem::take(&mut fresh_row.move_clusters));
                    self.sys.row_sources.extend(row.iter().map(|e| e.0));
                    self.sys.row_coefs.extend(row.iter().map(|e| e.1));
                    if balanced {
                        // The balanced scale follows the row's sum: it keeps what
                        // the column passes gave it (`1 / sum` undid them).
                        let (was, old_sum) = heir.map_or((1.0, 0.0), |i| {
                            let (r0, r1) = (old_start[i] as usize, old_start[i + 1] as usize);
                            (old_scale[i], old_coefs[r0..r1].iter().sum::<f64>())
                        });
                        let sum: f64 = row.iter().map(|e| e.1).sum();
                        let scaled = was != 1.0 && sum > 0.0 && old_sum > 0.0;
                        scale.push(if scaled { was * old_sum / sum } else { 1.0 });
                    }
                    next = fresh.next();
                }
                _ => {
                    let i = heir.expect("a kept row has its old leaf");
                    let (r0, r1) = (old_start[i] as usize, old_start[i + 1] as usize);
                    self.sys.row_sources.extend_from_slice(&old_sources[r0..r1]);
                    self.sys.row_coefs.extend_from_slice(&old_coefs[r0..r1]);
                    if balanced {
                        scale.push(old_scale[i]);
                    }
                }
            }
            if balanced {
                gain.push(heir.map_or(1.0, |i| old_gain[i]));
            }
            self.sys.row_start.push(self.sys.row_sources.len() as u32);
        }
        self.sys.row_scale = scale;
        self.sys.leaf_gain = gain;
        redo.len() as u64
    }

    /// Leaves in the leaf system as last solved.
    pub(crate) fn leaf_count(&self) -> usize {
        self.sys.leaves.len()
    }

    /// The links by their ends `(receiver, source) → link`.
    pub(crate) fn link_pairs(&self) -> FastMap<(u32, u32), u32> {
        self.links
            .ends
            .as_slice()
            .iter()
            .enumerate()
            .map(|(i, e)| ((e.receiver, e.source), i as u32))
            .collect()
    }
}
