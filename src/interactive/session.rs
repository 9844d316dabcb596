//! One interactive session: a solved scene and the moves applied to it, one at a
//! time (paper 000, section 2: the line-space update of Drettakis & Sillion).
//!
//! A move ([`Session::apply`]):
//! 1. places the moved objects (patches, elements, clusters, BVH parts) and records
//!    their boxes before and after;
//! 2. traverses the links once (`Session::traverse`): a link with an end that
//!    holds a moved object is affected without a test (its shaft, stale now, is
//!    forgotten); a link between two surfaces whose box meets an old or new box is
//!    tested with its shaft (from the [`ShaftStore`], built on the fly if missing)
//!    and affected if the shaft meets the box; a link with a cluster end is
//!    tested the same way with the shaft between its ends' boxes
//!    ([`crate::shafts::box_shaft_misses`], made on the spot, not stored);
//! 3. evaluates the affected active links again (visibility and form factor),
//!    adds the children a refined link whose end moved had dropped as empty and
//!    that exchange light now, then refines the links whose transport changed and
//!    brings the leaf system up to date ([`Update::Local`]: only the rows under
//!    the links it touched are computed again, and in them only those links'
//!    entries; the solve is warm-started from the last radiosity —
//!    [`crate::solver::Solver`]'s `settle_local`);
//! 4. makes ready, in one more pass over the links as the refinement left them,
//!    the shafts of the links whose ends' box meets a predicted box of the next
//!    moves or a moved object's box now (the next move's old box): the manager's
//!    part, Fig. 1 (with `--predict none` shafts are only built on the fly);
//! 5. runs the shaft collector (Fig. 2) and reports [`MoveStats`].
//!
//! **Priming** ([`Session::prime`]). A move keeps, for the rows it computes,
//! which of their rays static geometry blocks and which the moved objects
//! blocked, so that the next move casts only the rays at the moved objects and
//! keeps the entries whose rays they block as before ([`crate::solver::Solver`]'s
//! row patching). The first move finds none of that and computes its rows in
//! full, with every ray (in the 889-polygon room of `tools/interactive_bench.py`
//! about twice the processor time of a later move). A session primes itself before it reads the first
//! move: a move of each movable object to where it stands, which finds the links
//! around the objects, evaluates them again (their transports come out as they
//! were: nothing changed), computes the rows near the objects as a move does and
//! builds the shafts around them (paper 000, section 3.2: shafts built ahead of
//! the movement). It costs the start-up about what it spares the first move.
//!
//! With [`Traversal::Every`] step 2 takes every link as affected: the brute force
//! the tests hold the traversal to. What it does not do yet: re-activate passive
//! links whose refinement a move made needless (the hierarchy only gets finer,
//! which costs time, not accuracy), or descend the link hierarchy instead of
//! scanning the link pool (every link's box is tested; shafts only where it meets).

use std::path::Path;
use std::time::Instant;

use glam::{DAffine3, DVec3};

use super::moves::{ObjectMove, Pose};
use super::predict::{Aabb, Method, Predictor};
use super::stage::Stage;
use super::stats::MoveStats;
use super::store::{Policy, SHAFT_BYTES, ShaftStore};
use crate::pools::elements::Geom;
use crate::pools::{LinkId, LinkState};
use crate::shafts::{Shaft, box_shaft_misses};
use crate::solution::Solution;
use crate::solver::restore::options_differ;
use crate::solver::{FastMap, SolveOptions, Solver};
use crate::store::Hierarchy;
use crate::{Error, Result};

/// How a move finds the links it affects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    /// By shafts and boxes (module docs).
    Affected,
    /// Every link: the brute force.
    Every,
}

/// How a move brings the leaf system up to date.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Update {
    /// Only the rows of the leaves under the links the move changed are computed
    /// again, the others kept ([`crate::solver::Solver`]'s `settle_local`).
    Local,
    /// Every leaf row is computed again at every pass (the first version's way,
    /// kept to measure against).
    Full,
}

/// The settings of a session beyond the solve's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// How affected links are found.
    pub traversal: Traversal,
    /// The shaft store's collector and budget.
    pub policy: Policy,
    /// Movement prediction.
    pub predict: Method,
    /// Moves predicted ahead.
    pub ahead: u32,
    /// Scale of the predicted boxes.
    pub scale: f64,
    /// How the leaf system is brought up to date.
    pub update: Update,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            traversal: Traversal::Affected,
            policy: Policy::default(),
            predict: Method::Linear,
            ahead: 1,
            scale: 1.1,
            update: Update::Local,
        }
    }
}

/// What a traversal found.
#[derive(Debug, Default)]
struct Found {
    affected: Vec<LinkId>,
    at_old: u64,
    at_new: u64,
    tests: u64,
}

/// A solved scene and the moves applied to it.
pub struct Session<'a> {
    stage: &'a Stage,
    solver: Solver<'a>,
    poses: Vec<Pose>,
    pairs: FastMap<(u32, u32), u32>,
    shafts: ShaftStore,
    predictor: Predictor,
    settings: Settings,
    moves: u32,
    /// Links the last move evaluated again whose transport changed (every
    /// traversal records it; the brute force's is what the tests check against).
    changed: Vec<u32>,
    /// The links the last traversal found affected.
    affected: Vec<u32>,
}

impl<'a> Session<'a> {
    /// Solves `stage` with `opts` (every object at its scene pose) and starts a
    /// session on it.
    pub fn start(stage: &'a Stage, mut opts: SolveOptions, settings: Settings) -> Result<Self> {
        // Moves refine the hierarchy further: keep the refined links a static solve
        // would drop ([`SolveOptions::keep_passive`]).
        opts.keep_passive = true;
        // A move may open a shell: no patch is left out as dark.
        opts.sealed_regions = false;
        let mut solver = Solver::new(&stage.scene, opts)?;
        if stage.scene.has_emitter() {
            solver.run(|_, _| {})?;
        }
        Ok(Self::with_solver(stage, solver, settings))
    }

    /// Starts a session on `stage` from the persisted hierarchy `h` read from
    /// `file` (`rhier solve --keep-links --movable`), without solving: the stored
    /// pools are checked and taken up ([`Solver::from_hierarchy`]: the leaf rows built
    /// and the leaf system solved once, no refinement). `h` must have been solved
    /// with the objects `stage` lets move and at the settings `opts`: a mismatch
    /// is refused with a message naming what differs.
    pub fn restore(
        stage: &'a Stage,
        mut opts: SolveOptions,
        settings: Settings,
        h: &Hierarchy,
        file: &Path,
    ) -> Result<Self> {
        opts.keep_passive = true;
        // A move may open a shell: no patch is left out as dark.
        opts.sealed_regions = false;
        let movable = stage.movable_names();
        if h.movable != movable {
            return Err(Error::Usage(format!(
                "{}: its hierarchy was solved with --movable {}, not {}; give the same objects to both",
                file.display(),
                list(&h.movable),
                list(&movable)
            )));
        }
        if let Some(what) = options_differ(&h.options, &opts) {
            return Err(Error::Usage(format!(
                "{}: its hierarchy was solved at other settings ({what}); give `rhier interact` the accuracy flags the solve had",
                file.display()
            )));
        }
        let solver = Solver::from_hierarchy(&stage.scene, opts, h, file)?;
        Ok(Self::with_solver(stage, solver, settings))
    }

    /// A session on a solver that holds the solution of `stage` at its scene poses.
    fn with_solver(stage: &'a Stage, solver: Solver<'a>, settings: Settings) -> Self {
        let n = stage.scene.objects.len();
        Session {
            stage,
            pairs: solver.link_pairs(),
            solver,
            poses: vec![Pose::IDENTITY; n],
            shafts: ShaftStore::new(settings.policy),
            predictor: Predictor::new(settings.predict, settings.ahead, settings.scale, n),
            settings,
            moves: 0,
            changed: Vec::new(),
            affected: Vec::new(),
        }
    }

    /// The solver (pools, leaf system) as the last move left it.
    pub fn solver(&self) -> &Solver<'a> {
        &self.solver
    }

    /// Each object's pose now.
    pub fn poses(&self) -> &[Pose] {
        &self.poses
    }

    /// The links the last move found affected.
    pub fn affected(&self) -> &[u32] {
        &self.affected
    }

    /// The links the last move evaluated again whose transport changed.
    pub fn changed(&self) -> &[u32] {
        &self.changed
    }

    /// The stored answer now: the final gather reconstructed over every patch,
    /// with the scene held at the current poses.
    ///
    /// A scene with no emitter was never solved: its answer is zero everywhere, as
    /// `rhier solve` writes it ([`Solution::zero`]).
    pub fn solution(&self) -> Solution {
        let scene = self.stage.posed(&self.poses);
        if !self.stage.scene.has_emitter() {
            return Solution::zero(&scene);
        }
        let mut s = self.solver.solution();
        s.scene = scene;
        s
    }

    /// Applies one move (module docs) and returns its statistics.
    pub fn apply(&mut self, moves: &[ObjectMove]) -> Result<MoveStats> {
        self.moves += 1;
        if !self.stage.scene.has_emitter() {
            return Ok(self.dark_move(moves));
        }
        self.step(moves, true)
    }

    /// A move in a scene with no emitter, whose answer is zero in every pose:
    /// the objects are placed and nothing is computed (no links, rows or shafts;
    /// [`Session::start`] did not solve such a scene either).
    fn dark_move(&mut self, moves: &[ObjectMove]) -> MoveStats {
        let start = Instant::now();
        let mut world: Vec<Option<DAffine3>> = vec![None; self.poses.len()];
        for m in moves {
            world[m.object as usize] = Some(m.pose.to_affine());
            self.poses[m.object as usize] = m.pose;
        }
        self.solver.place_objects(&world);
        MoveStats {
            r#move: self.moves,
            links_total: self.solver.links.len() as u64,
            leaves_total: self.solver.leaf_count() as u64,
            total_s: start.elapsed().as_secs_f64(),
            ..MoveStats::default()
        }
    }

    /// Makes ready, before the first move, what the first move of the movable
    /// objects would otherwise make itself: a move of each to where it stands
    /// (module docs, "Priming"). Returns its statistics (move 0), or `None`
    /// where there is nothing to prime (no movable object; [`Update::Full`],
    /// whose moves keep nothing between them; or a scene with no emitter, whose
    /// answer is zero in every pose and which [`Session::start`] did not solve). No link changes; the rows it
    /// computes again are drawn as a move draws them, so the light moves by the
    /// rows' noise (under 4e-4 at the points of `interactive::prime`'s test), and
    /// from the first move on the session is an unprimed one's within 1e-6.
    pub fn prime(&mut self) -> Result<Option<MoveStats>> {
        if self.settings.update != Update::Local || !self.stage.scene.has_emitter() {
            return Ok(None);
        }
        let here: Vec<ObjectMove> = (0..self.poses.len() as u32)
            .filter(|&o| self.stage.movable[o as usize])
            .map(|o| ObjectMove {
                object: o,
                pose: self.poses[o as usize],
            })
            .collect();
        if here.is_empty() {
            return Ok(None);
        }
        self.step(&here, false).map(Some)
    }

    /// Applies `moves` (module docs); `record`: a move of the user's, which the
    /// predictor learns from (not a priming move).
    fn step(&mut self, moves: &[ObjectMove], record: bool) -> Result<MoveStats> {
        let start = Instant::now();
        self.shafts.begin_move();
        let n = self.poses.len();
        let mut moved = vec![false; n];
        let mut world: Vec<Option<DAffine3>> = vec![None; n];
        for m in moves {
            moved[m.object as usize] = true;
            world[m.object as usize] = Some(m.pose.to_affine());
        }
        let old = self.object_boxes(&moved);
        self.solver.place_objects(&world);
        for m in moves {
            self.poses[m.object as usize] = m.pose;
        }
        let new = self.object_boxes(&moved);
        if record {
            for (m, &(_, b)) in moves.iter().zip(&new) {
                self.predictor.record(m.object, m.pose.to_affine(), b);
            }
        }
        let t_trav = Instant::now();
        let holding = self.solver.elements_holding(&moved);
        let old: Vec<Aabb> = old.into_iter().map(|x| x.1).collect();
        let new: Vec<Aabb> = new.into_iter().map(|x| x.1).collect();
        let found = self.traverse(&holding, &old, &new);
        let mut traversal_s = t_trav.elapsed().as_secs_f64() - self.shafts.seconds;
        let t_solve = Instant::now();
        let (mut active, mut passive) = (Vec::new(), Vec::new());
        {
            let tr = self.solver.links.transports.as_slice();
            let ends = self.solver.links.ends.as_slice();
            for &l in &found.affected {
                let e = ends[l.ix()];
                if tr[l.ix()].state() == LinkState::Active {
                    active.push(l);
                } else if holding[e.receiver as usize] || holding[e.source as usize] {
                    passive.push(l);
                }
            }
        }
        let before: Vec<[u32; 4]> = active.iter().map(|&l| self.transport_bits(l)).collect();
        let f_old: Vec<f32> = before.iter().map(|b| f32::from_bits(b[0])).collect();
        self.solver.reevaluate_links(&active);
        self.changed = active
            .iter()
            .zip(&before)
            .filter(|(l, b)| self.transport_bits(**l) != **b)
            .map(|(l, _)| l.0)
            .collect();
        self.affected = found.affected.iter().map(|l| l.0).collect();
        let added = self.solver.complete_children(&passive, &mut self.pairs)?;
        let links_before = self.solver.links.len();
        let settled = match self.settings.update {
            Update::Local => {
                let mut wave: Vec<(LinkId, f32)> =
                    active.iter().copied().zip(f_old.iter().copied()).collect();
                wave.extend(added.iter().map(|&l| (l, 0.0)));
                let near: Vec<Aabb> = old.iter().chain(&new).map(|&b| grown(b)).collect();
                let mut changed: Vec<LinkId> = self.changed.iter().map(|&l| LinkId(l)).collect();
                changed.extend(&added);
                let boxes: Vec<Aabb> = old.iter().chain(&new).copied().collect();
                self.solver
                    .settle_local(changed, wave, &near, &moved, &boxes)?
            }
            Update::Full => {
                let mut wave = active.clone();
                wave.extend(&added);
                self.solver.settle(wave)?
            }
        };
        let ends = self.solver.links.ends.as_slice();
        for (i, e) in ends.iter().enumerate().skip(links_before) {
            self.pairs.insert((e.receiver, e.source), i as u32);
        }
        let solve_s = t_solve.elapsed().as_secs_f64();
        if self.settings.predict != Method::None {
            // The manager's part (Fig. 1): the boxes of the next moves, and where the
            // objects stand now (the next move's old boxes), over the links as the
            // refinement left them, in one traversal.
            let t_pred = Instant::now();
            let shaft_s = self.shafts.seconds;
            let mut boxes = self.predictor.boxes();
            boxes.extend(&new);
            let holding = self.solver.elements_holding(&moved);
            self.prepare(&holding, &boxes);
            traversal_s += t_pred.elapsed().as_secs_f64() - (self.shafts.seconds - shaft_s);
        }
        let links = self.solver.links.len();
        let c0 = self.shafts.counters;
        self.shafts.collect(links);
        let c = self.shafts.counters;
        Ok(MoveStats {
            r#move: self.moves,
            shafts_at_old: found.at_old,
            shafts_at_new: found.at_new,
            shaft_tests: found.tests,
            shafts_built: c.built,
            shafts_predicted: c.predicted,
            shafts_existing: c.existing,
            shafts_collected: c.collected,
            shafts_evicted: c.evicted,
            shafts_restored: c.restored,
            shafts_total: self.shafts.len() as u64,
            resident_shaft_bytes: self.shafts.resident_bytes(),
            compressed_shaft_bytes: self.shafts.compressed_bytes(),
            all_shaft_bytes: links as u64 * SHAFT_BYTES,
            links_affected: found.affected.len() as u64,
            links_reevaluated: active.len() as u64,
            links_added: added.len() as u64,
            links_refined: settled.refined,
            links_reactivated: 0,
            links_total: links as u64,
            rows_recomputed: settled.rows,
            rows_s: settled.rows_s,
            gmres_s: settled.solve_s,
            leaves_total: self.solver.leaf_count() as u64,
            evicted_during_move: c0.collected,
            traversal_s,
            shaft_s: self.shafts.seconds,
            solve_s,
            total_s: start.elapsed().as_secs_f64(),
            residual: settled.residual,
        })
    }

    /// The transport of link `l` as bits (for exact comparison).
    fn transport_bits(&self, l: LinkId) -> [u32; 4] {
        let t = self.solver.links.transports.as_slice()[l.ix()];
        [
            t.f.to_bits(),
            t.spread.to_bits(),
            t.visibility.to_bits(),
            u32::from_le_bytes(t.flags),
        ]
    }

    /// The world box of each flagged object's patches where they stand now, with
    /// the object's index.
    fn object_boxes(&self, flags: &[bool]) -> Vec<(u32, Aabb)> {
        let p = &self.solver.patches;
        let pad = DVec3::splat(1e-9 * p.diameter);
        let mut boxes: Vec<Option<Aabb>> = vec![None; flags.len()];
        for i in 0..p.len() {
            let o = p.objects[i] as usize;
            if !flags[o] {
                continue;
            }
            let b = boxes[o].get_or_insert((DVec3::INFINITY, DVec3::NEG_INFINITY));
            for &c in p.polys[i].corners() {
                b.0 = b.0.min(c);
                b.1 = b.1.max(c);
            }
        }
        boxes
            .into_iter()
            .enumerate()
            .filter_map(|(o, b)| b.map(|(lo, hi)| (o as u32, (lo - pad, hi + pad))))
            .collect()
    }

    /// The links the move affects (module docs, step 2), and the shafts the
    /// predicted boxes meet built ahead.
    fn traverse(&mut self, holding: &[bool], old: &[Aabb], new: &[Aabb]) -> Found {
        let mut f = Found::default();
        let every = self.settings.traversal == Traversal::Every;
        let geoms = self.solver.elems.geoms.as_slice();
        let ends = self.solver.links.ends.as_slice();
        let now: Vec<Aabb> = old.iter().chain(new).copied().collect();
        // Each element's box once, not each link end's.
        let elem_boxes: Vec<Aabb> = geoms.iter().map(geom_box).collect();
        for (i, e) in ends.iter().enumerate() {
            let l = i as u32;
            if holding[e.receiver as usize] || holding[e.source as usize] {
                self.shafts.forget(l);
                f.affected.push(LinkId(l));
                continue;
            }
            let (gr, gs) = (&geoms[e.receiver as usize], &geoms[e.source as usize]);
            let (br, bs) = (
                elem_boxes[e.receiver as usize],
                elem_boxes[e.source as usize],
            );
            let reach = union(br, bs);
            if !meets_any(reach, &now) {
                if every {
                    f.affected.push(LinkId(l));
                }
                continue;
            }
            // A cluster end: the shaft between the ends' boxes, made on the spot
            // (twelve lines; no store).
            let boxes = gr.patch == u32::MAX || gs.patch == u32::MAX;
            let shaft = if boxes {
                None
            } else {
                Some(self.shafts.get(l, true, || shaft_between(gr, gs)))
            };
            let mut hit = false;
            for (k, b) in now.iter().enumerate() {
                if !meets_any(reach, std::slice::from_ref(b)) {
                    continue;
                }
                f.tests += 1;
                let misses = match &shaft {
                    Some(s) => s.misses_box(b.0, b.1),
                    None => box_shaft_misses(br, bs, *b),
                };
                if !misses {
                    hit = true;
                    if k < old.len() {
                        f.at_old += 1;
                    } else {
                        f.at_new += 1;
                    }
                }
            }
            if hit || every {
                f.affected.push(LinkId(l));
            }
        }
        f
    }
}

impl Session<'_> {
    /// Makes ready the shafts of the links between two surfaces, neither holding a
    /// moved object, whose ends' box meets one of `boxes` (built ahead, or
    /// restored; a stored shaft's age is reset).
    fn prepare(&mut self, holding: &[bool], boxes: &[Aabb]) {
        if boxes.is_empty() {
            return;
        }
        let geoms = self.solver.elems.geoms.as_slice();
        let ends = self.solver.links.ends.as_slice();
        let around = boxes
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |a, &b| union(a, b));
        let elem_boxes: Vec<Aabb> = geoms.iter().map(geom_box).collect();
        for (i, e) in ends.iter().enumerate() {
            let (r, s) = (e.receiver as usize, e.source as usize);
            let (gr, gs) = (&geoms[r], &geoms[s]);
            if holding.get(r).copied().unwrap_or(false)
                || holding.get(s).copied().unwrap_or(false)
                || gr.patch == u32::MAX
                || gs.patch == u32::MAX
            {
                continue;
            }
            let reach = union(elem_boxes[r], elem_boxes[s]);
            if meets_any(reach, std::slice::from_ref(&around)) && meets_any(reach, boxes) {
                self.shafts.get(i as u32, false, || shaft_between(gr, gs));
            }
        }
    }
}

/// The shaft between two surface elements.
fn shaft_between(a: &Geom, b: &Geom) -> Shaft {
    let (pa, pb) = (crate::oracle::poly(a), crate::oracle::poly(b));
    Shaft::new(
        pa.corners(),
        DVec3::from_array(a.normal),
        pb.corners(),
        DVec3::from_array(b.normal),
    )
}

/// The box of an element: its corners, or a cluster's box.
fn geom_box(g: &Geom) -> Aabb {
    let k = if g.patch == u32::MAX {
        2
    } else {
        (g.n as usize).clamp(1, 4)
    };
    g.corners[..k]
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
            let c = DVec3::from_array(*c);
            (lo.min(c), hi.max(c))
        })
}

/// Box `b` grown on every side by its largest extent: the neighbourhood where a
/// moved object's own light and shadow change rows that a cluster link carries
/// ([`crate::solver::Solver`]'s `settle_local`).
fn grown(b: Aabb) -> Aabb {
    let pad = DVec3::splat((b.1 - b.0).max_element());
    (b.0 - pad, b.1 + pad)
}

fn union(a: Aabb, b: Aabb) -> Aabb {
    (a.0.min(b.0), a.1.max(b.1))
}

fn meets_any(b: Aabb, boxes: &[Aabb]) -> bool {
    crate::shafts::meets_any(b.0, b.1, boxes)
}

/// `names` comma-separated, or `(none)`.
fn list(names: &[String]) -> String {
    if names.is_empty() {
        "(none)".into()
    } else {
        names.join(",")
    }
}
