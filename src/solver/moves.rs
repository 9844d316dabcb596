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

use super::{FastMap, Solver};
use crate::Result;
use crate::oracle::{self, Split};
use crate::pools::{ElementId, LinkId, LinkState};

/// Most refine-and-solve passes one move runs ([`Solver::settle`]).
pub const MOVE_PASSES: usize = 3;

/// What [`Solver::settle`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Settled {
    /// Links split (made passive) by the passes.
    pub refined: u64,
    /// Relative residual of the last linear solve.
    pub residual: f64,
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
        for pass in 0..MOVE_PASSES {
            let thr = self.opts.eps * self.b_ref();
            let changed = self.refine(wave, thr)?;
            if pass > 0 && !changed {
                break;
            }
            self.index_links();
            residual = self.solve_rows()?;
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
        })
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
