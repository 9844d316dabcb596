//! A space-time window on the solver's pools: what it adds to the shared part and
//! how it gives it back, and one frame's refine-and-solve inside it (the solver
//! side of [`super`]; Damez & Sillion, paper 001, §5.2–5.3).
//!
//! **Pools.** [`Solver::begin_window`] re-classifies the shared part's links
//! against the boxes the moving objects sweep during the window and refines those
//! that became constant (the window's base, a [`Snapshot`]); each
//! [`Solver::solve_frame`] places the objects, re-evaluates and refines the varying links
//! and solves the leaf system warm-started from the previous frame;
//! [`Solver::release_window`] truncates the pools back to the shared part and
//! restores what the window changed in older records (links made passive, elements
//! subdivided), so memory does not grow with the animation's length.
//!
//! **Keys by place.** The leaves and links a frame's refinement makes are made
//! again by the next frame under other ids. Their rays, and the window's caches,
//! are keyed by their place under the shared part (the path of child indices,
//! `Solver::ray_id`), so a frame's element keeps its key and its jitter from frame
//! to frame.
//!
//! **What a window keeps** ([`Window`]): the final-gather terms of its static
//! points ([`super::kept_terms`]), and the leaf-row coefficients, opened entries, hidden
//! coefficients and masks that hold over the window ([`crate::solver::rows`]). All of it
//! goes with the window: the next starts from the shared part and an empty cache, so a
//! window's leaves do not depend on which windows were solved before it in the same
//! process (`Solver::release_window`).

use crate::solver::*;

/// Pool lengths at some moment, and what was done since to older records (links
/// made passive, elements subdivided): enough to restore the pools to that moment.
#[derive(Default)]
pub(in crate::solver) struct Snapshot {
    pub(in crate::solver) elems_len: usize,
    pub(in crate::solver) links_len: usize,
    pub(in crate::solver) passivated: Vec<LinkId>,
    pub(in crate::solver) subdivided: Vec<ElementId>,
}

impl Snapshot {
    pub(in crate::solver) fn of(elems: &ElementPool, links: &LinkPool) -> Self {
        Snapshot {
            elems_len: elems.len(),
            links_len: links.len(),
            ..Snapshot::default()
        }
    }
}

/// What a time window needs beyond the static solver (see [`spacetime`]).
#[derive(Default)]
pub(in crate::solver) struct Window {
    /// Boxes swept by the moving objects over the window, one per moving object in
    /// scene order ([`super::swept_boxes`]).
    pub(in crate::solver) swept: Vec<(DVec3, DVec3)>,
    /// The time range `swept` covers (the window's, or the whole animation's in the
    /// shared part).
    pub(in crate::solver) span: [f64; 2],
    /// The shared part, as the window found it (restored when it is released).
    pub(in crate::solver) base: Snapshot,
    /// The window's own base: the shared part plus the refinement of the links
    /// that are constant in this window (restored before each frame).
    pub(in crate::solver) frame: Snapshot,
    /// True once the window's base is built: refinement now belongs to a frame.
    pub(in crate::solver) in_frame: bool,
    /// Leaf-row coefficients of constant links on static leaves: `(leaf, link) →
    /// (F, visible fraction)`, keyed as [`Solver::row_key`] keys them (the leaves
    /// and links a frame makes by what they stand for).
    pub(in crate::solver) rows: FastMap<(u32, u32), (f32, f32)>,
    /// The row entries a cached coefficient of [`Window::rows`] opens into when its
    /// source is opened ([`Solver::push_opened`]): the same children and factors at
    /// every frame while none of them has children the frame refined, so they are
    /// computed once (the same values, bit for bit; LIGHT spent a fifth of its time
    /// on these factors, frame after frame).
    pub(in crate::solver) opened: FastMap<(u32, u32), RowEntries>,
    /// Entries held by [`Window::opened`].
    pub(in crate::solver) opened_entries: usize,
    /// Leaf-row `(F, visible fraction)` of varying links between static ends (a
    /// static leaf or source a frame made too, [`Solver::row_key`]), computed at a
    /// frame with no moving object's box in the shaft between the ends
    /// ([`Solver::clear_of_moving`]): at any such frame their rays meet static
    /// geometry only, with the same keys, so the value is the same bit for bit.
    pub(in crate::solver) hidden: FastMap<(u32, u32), (f64, f64)>,
    /// The rays of the partly hidden entries of [`Window::rows`] and
    /// [`Window::hidden`], keyed alike, for the children of the sources they open
    /// ([`EntryRay`]): the same entry opens into the same entries at every frame.
    pub(in crate::solver) entry_rays: FastMap<(u32, u32), Box<[EntryRay]>>,
    /// The static part of the rays at a static leaf's quadrature points for row
    /// entries of varying links between static ends, keyed as [`Window::hidden`],
    /// at frames with a moving object's box in the shaft between the ends (which
    /// [`Window::hidden`] cannot keep): bit `i·m + j` is set where nothing static
    /// blocks ray `j` of point `i` (`m` rays a point, [`RowMasks`](crate::solver::rows::RowMasks)). The static
    /// geometry and the rays' keys hold over the window, so a later frame casts
    /// only the rays a mask leaves clear, at the moving objects only, and gets the
    /// value casting every ray would give, bit for bit (the final gather's
    /// [`super::kept_terms::MaskedTerm`] for rows; paper 001 §5.2: what a moving object cannot
    /// change is computed once).
    pub(in crate::solver) masks: FastMap<(u32, u32), u64>,
    /// Exact factors `Σ_q w_q F(x_q → e)` from a static leaf (keyed by
    /// [`Solver::stable_id`]) to a static element `e` of the window's base that a
    /// source of its row opens into ([`Solver::push_opened`]): the geometry of both
    /// holds over the window, so the factor is the same bit for bit at every frame.
    /// Those of a varying link's source were computed again at every solved frame
    /// (LIGHT: 5.0 M of them over its 76 frames), where [`Window::opened`] keeps
    /// only a constant link's entries.
    pub(in crate::solver) factors: FastMap<(u32, u32), f64>,
    /// Ids that the caches above key a frame's own elements by, which the next frame
    /// makes again with other ids: `(element of the window's base, path of child
    /// indices below it) → id` from [`FRAME_SID`] up ([`Solver::intern_frame_elements`]).
    /// A static leaf a frame's refinement makes has the same geometry and casts the
    /// same rays ([`Solver::ray_id`]) at every frame that makes it, so what the
    /// caches hold for it holds at all of them.
    pub(in crate::solver) stable: FastMap<(u32, u64), u32>,
    /// This frame's elements past the window's base: their ids in [`Window::stable`]
    /// (`u32::MAX`: too deep to key).
    pub(in crate::solver) sids: Vec<u32>,
    /// Final-gather terms that hold over the window at static reconstruction points.
    /// `None` in the shared part's rounds (nothing is reconstructed there).
    pub(in crate::solver) points: std::sync::Mutex<Option<PointCache>>,
    /// The radiosity scale every frame of the window reconstructs against (cell
    /// tolerance, gather limits): the RMS reflected radiosity of the window's first
    /// solved frame. Each frame's own would move with the moving objects and change
    /// the decisions, hence the values, at static points; the shared part's (solved
    /// with the varying links coarse) is lower on LIGHT and made it 36% slower.
    pub(in crate::solver) b_ref: Option<f64>,
}

impl Window {
    /// Bytes of the leaf-row cache: per entry the key, the value and the hash
    /// table's control byte, over its capacity.
    pub(in crate::solver) fn rows_bytes(&self) -> usize {
        self.rows.capacity() * (std::mem::size_of::<((u32, u32), (f32, f32))>() + 1)
            + self.opened.capacity() * (std::mem::size_of::<((u32, u32), RowEntries)>() + 1)
            + self.opened_entries * std::mem::size_of::<(u32, f64)>()
            + self.hidden.capacity() * (std::mem::size_of::<((u32, u32), (f64, f64))>() + 1)
            + self.masks.capacity() * (std::mem::size_of::<((u32, u32), u64)>() + 1)
            + self.factors.capacity() * (std::mem::size_of::<((u32, u32), f64)>() + 1)
            + self.stable.capacity() * (std::mem::size_of::<((u32, u64), u32)>() + 1)
    }
}

/// First id [`Window::stable`] gives a frame's own elements: above every element id
/// of a window's base (the pools hold far fewer), below the link keys' tag bit
/// ([`Solver::row_key`]).
pub(in crate::solver) const FRAME_SID: u32 = 1 << 30;

/// Levels below the window's base a frame's element may lie and still get an id
/// in [`Window::stable`] (3 bits a level under a sentinel bit, in 64).
pub(in crate::solver) const MAX_FRAME_DEPTH: u32 = 20;

/// What one space-time frame cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCost {
    /// Varying links re-evaluated.
    pub varying_links: u64,
    /// Rays cast in the frame (link evaluation and leaf rows; not reconstruction).
    pub rays: u64,
    /// GMRES relative residual.
    pub residual: f64,
    /// Leaf-row entries with a moving end the frame's last rows took between the
    /// solved frames around ([`TimeRange`]) rather than computed.
    pub rows_between: u64,
    /// Leaf-row entries with a moving end in the frame's last rows (taken between
    /// or computed).
    pub rows_moving: u64,
}

impl Solver<'_> {
    /// Starts a time window whose moving objects sweep the boxes `swept`: what the
    /// pools hold now is the shared part, kept for every window; what the window adds
    /// is released by [`Solver::release_window`]. Every active link is classified as
    /// constant or varying over the window; a link that was varying and is now
    /// constant is re-evaluated once (it may have been evaluated with a moving object
    /// in its shaft).
    ///
    /// Links that are constant in the window but were varying over the whole
    /// animation were left coarse by the shared part: they are refined here, against
    /// `eps · b_ref`, once for all the window's frames.
    ///
    /// The window's final-gather terms start empty ([`Solver::release_window`]).
    pub fn begin_window(&mut self, span: [f64; 2], b_ref: f64) -> Result<()> {
        let swept = super::swept_boxes(self.scene, span[0], span[1]);
        self.begin_window_in(span, swept, b_ref)
    }

    /// [`Solver::begin_window`] with the boxes the moving objects sweep over `span`
    /// already made (`spacetime::swept_boxes`).
    fn begin_window_in(
        &mut self,
        span: [f64; 2],
        swept: Vec<(DVec3, DVec3)>,
        b_ref: f64,
    ) -> Result<()> {
        let points = PointCache::new(&self.opts.storage, self.st.kept_budget)?;
        self.st.window = Some(Window {
            swept,
            span,
            base: Snapshot::of(&self.elems, &self.links),
            points: std::sync::Mutex::new(Some(points)),
            ..Window::default()
        });
        let active = self.active_links(false);
        let classes: Vec<bool> = active
            .par_iter()
            .map(|l| {
                let e = self.links.ends.as_slice()[l.ix()];
                self.varying(ElementId(e.receiver), ElementId(e.source))
            })
            .collect();
        let mut stale = Vec::new();
        for (&l, v) in active.iter().zip(classes) {
            let t = &mut self.links.transports.as_mut_slice()[l.ix()];
            if t.varying() && !v {
                stale.push(l);
            }
            t.flags[2] = v as u8;
        }
        self.reevaluate(&stale);
        self.st.shared_phase = true;
        let refined = self.refine(stale, self.opts.eps * b_ref);
        self.st.shared_phase = false;
        refined?;
        let frame = Snapshot::of(&self.elems, &self.links);
        if let Some(w) = self.st.window.as_mut() {
            w.frame = frame;
            w.in_frame = true;
        }
        Ok(())
    }

    /// Solves the part of a space-time solve that all windows share: the usual
    /// rounds at the current time, with links classified against the boxes the
    /// moving objects sweep over `span` (the whole animation) and only constant
    /// links refined (a varying link stays as coarse as it was created; each window
    /// refines it for its own frames), but for the varying links that have no
    /// estimate at all (a cluster's self-link, a too-close cluster link), which would
    /// otherwise carry no light and leave the rounds without a radiosity scale. The
    /// start time is then solved once with its varying links refined, and the
    /// constant links refined again against that radiosity. This hierarchy and its
    /// coefficients are computed once and kept for every window.
    pub fn run_shared(
        &mut self,
        span: [f64; 2],
        on_round: impl FnMut(&mut RoundRecord, &Solver),
    ) -> Result<Vec<RoundRecord>> {
        let swept = super::swept_boxes(self.scene, span[0], span[1]);
        self.st.window = Some(Window {
            swept: swept.clone(),
            span,
            ..Window::default()
        });
        self.st.shared_phase = true;
        let records = self.run(on_round);
        self.st.shared_phase = false;
        self.st.window = None;
        let records = records?;
        // Every frame balances its leaf system as the shared part's last round did.
        self.st.balance_fixed = true;
        // The rounds' radiosity misses what the unrefined varying links carry, so the
        // constant links were refined against too little light. Solve the start time
        // with its varying links refined (in a window, released at once), take that
        // radiosity, and refine the constant links against it. Once: a second pass
        // of LIGHT's solved the start time again and refined nothing (the same
        // hierarchy and error, 3.516%; 0.15 s), and ACTOR's first refines nothing
        // already (BENCHMARKS.md, "Serial time").
        let t = self.motion.now;
        let b_ref = self.b_ref();
        self.begin_window_in(span, swept.clone(), b_ref)?;
        self.solve_frame(t, b_ref)?;
        let shared = self.st.window.as_ref().map_or(0, |w| w.base.elems_len);
        let b = self.elems.radiosities.as_slice()[..shared].to_vec();
        self.release_window();
        self.elems.radiosities.as_mut_slice().copy_from_slice(&b);
        self.index_links();
        let b_ref = self.b_ref();
        self.st.window = Some(Window {
            swept,
            span,
            ..Window::default()
        });
        self.st.shared_phase = true;
        let active = self.active_links(false);
        let changed = self.refine(active, self.opts.eps * b_ref);
        self.st.shared_phase = false;
        self.st.window = None;
        if changed? {
            self.index_links();
            self.solve_rows()?;
        }
        self.index_links();
        Ok(records)
    }

    /// Drops what the current window added to the pools and restores the shared part
    /// as it was when the window began. The final-gather terms the window kept go
    /// with it: the next window gathers from an empty cache. A kept term is not the
    /// value a fresh gather makes later in the animation (it keeps the sources'
    /// opening and elements of when it was gathered, `Solver::point_terms`), so terms
    /// handed from window to window made a window's leaves depend on every window
    /// solved before it: a farm's shard, starting cold, differed from one machine's
    /// solve by up to 0.7% at a frame (LIGHT750, BENCHMARKS.md "Farm"). Starting
    /// every window empty makes the windows independent: any run of them, on one
    /// machine, in shards or resumed from a journal, writes the same leaves, for
    /// about 5% more time than handing the terms on.
    pub fn release_window(&mut self) {
        self.reset_frame();
        if let Some(mut w) = self.st.window.take() {
            self.restore(&mut w.base);
            drop(w);
            release_free_memory();
        }
        self.pull_pool();
    }

    /// Restores the pools to `snap` (see [`Snapshot`]).
    fn restore(&mut self, snap: &mut Snapshot) {
        // Element and link ids past the snapshot will be reused.
        self.sys.row_cache.clear();
        self.sys.row_rays.clear();
        self.elems.truncate(snap.elems_len);
        self.links.truncate(snap.links_len);
        for l in snap.passivated.drain(..) {
            self.links.set_active(l);
        }
        for e in snap.subdivided.drain(..) {
            let node = &mut self.elems.nodes.as_mut_slice()[e.ix()];
            node.first_child = 0;
            node.child_count = 0;
        }
    }

    /// Drops the refinement of the previous frame: elements and links beyond the
    /// window's start, and the passive state and children they gave to older ones.
    /// A frame refines its varying links from the window's start again, so the
    /// hierarchy near a moving object is as fine as this frame needs, not the union
    /// over the window.
    fn reset_frame(&mut self) {
        self.st.pass_rows = Vec::new();
        self.st.pass_rays = Vec::new();
        if let Some(mut w) = self.st.window.take() {
            if w.in_frame {
                self.restore(&mut w.frame);
            }
            self.st.window = Some(w);
        }
    }

    /// Re-evaluates the links `ids` where the geometry stands now (state and time
    /// class kept).
    pub(in crate::solver) fn reevaluate(&mut self, ids: &[LinkId]) {
        if ids.is_empty() {
            return;
        }
        let set = self.settings();
        let this = &*self;
        let evals: Vec<_> = ids
            .par_iter()
            .map(|&l| {
                let e = this.links.ends.as_slice()[l.ix()];
                oracle::evaluate(
                    &this.elems,
                    &this.bvh,
                    ElementId(e.receiver),
                    ElementId(e.source),
                    [this.ray_id(e.receiver), this.ray_id(e.source)],
                    &set,
                    this.plane_tol,
                )
            })
            .collect();
        for (&l, ev) in ids.iter().zip(evals) {
            self.rays += ev.rays as u64;
            let tr = &mut self.links.transports.as_mut_slice()[l.ix()];
            let flags = tr.flags;
            *tr = ev.transport;
            tr.flags[0] = flags[0];
            tr.flags[2] = flags[2];
        }
    }

    /// Evaluates again the links of `ids` whose source is a cluster. A cluster
    /// source's coefficient depends on its radiosity: the directional emission of
    /// [`oracle::cluster_emission`] and the visibility, whose source points are drawn
    /// by power ([`oracle::cluster_visibility`]). The links of the first round were
    /// made when only the emitters had any, so their clusters radiated isotropically
    /// and were seen by area; after the first solve they are evaluated once more
    /// with the radiosity known (links made later are evaluated with it already).
    /// Why: boxes on a floor are seen from above by their (black or lit) tops while
    /// the floor between them hands on the light; by area, a room of black boxes
    /// (`tools/gen_cubes.py 20`, boxes ρ = 0) came out with its ceiling 7.2% and its
    /// walls 3.3% too bright against the path tracer, by power 1.1% and 0.7%. A
    /// space-time solve does the same, though its constant links keep their
    /// visibility while `B` changes: by area, a cluster holding a small lamp is
    /// seen from its other surfaces, and LIGHT's panel hid the wall lamp from no
    /// coarse link (14% too bright at eps 0.5 while it covers the lamp; 8.4%
    /// against its reference over the shot, by power 3.6%).
    pub(in crate::solver) fn reevaluate_cluster_sources(&mut self, ids: &[LinkId]) {
        let geoms = self.elems.geoms.as_slice();
        let ends = self.links.ends.as_slice();
        let clusters: Vec<LinkId> = ids
            .iter()
            .copied()
            .filter(|l| geoms[ends[l.ix()].source as usize].patch == u32::MAX)
            .collect();
        self.reevaluate(&clusters);
    }

    /// One frame of a space-time solve at time `t` (inside the current window): the
    /// moving objects are placed at `t`, the window's varying links re-evaluated and
    /// refined against `eps · b_ref`, and the leaf system solved again, warm-started
    /// from the previous frame. Constant links keep their coefficients, leaf rows
    /// and final-gather terms from earlier frames of the window.
    pub fn solve_frame(&mut self, t: f64, b_ref: f64) -> Result<FrameCost> {
        let rays0 = self.rays;
        self.reset_frame();
        self.set_time(t);
        let varying = self.active_links(true);
        self.reevaluate(&varying);
        self.st.links_at = t;
        let n_varying = varying.len() as u64;
        let mut residual = 0.0;
        // Refine and solve again while refining changes something (radiosity moved
        // by the new links can push others over the threshold), as the rounds of a
        // static solve do.
        let mut wave = varying;
        for pass in 0..FRAME_PASSES {
            let changed = self.refine(wave, self.opts.eps * b_ref)?;
            if pass > 0 && !changed {
                break;
            }
            self.index_links();
            residual = self.solve_rows()?;
            wave = self.active_links(true);
        }
        // Only the passes share them; the frame's gathers need the memory.
        self.st.pass_rows = Vec::new();
        self.st.pass_rays = Vec::new();
        // The window's reconstruction scale: the first solved frame's.
        if self.st.window.as_ref().is_some_and(|w| w.b_ref.is_none()) {
            let scale = self.rms_radiosity();
            if let Some(w) = self.st.window.as_mut() {
                w.b_ref = Some(scale);
            }
        }
        Ok(FrameCost {
            varying_links: n_varying,
            rays: self.rays - rays0,
            residual,
            rows_between: self.st.rows_between,
            rows_moving: self.st.frame_rows.len() as u64,
        })
    }

    /// Bounds the final-gather terms a time window keeps to `bytes` (see
    /// [`spacetime`]): over it, the points the last frame did not use are dropped
    /// and new points are gathered afresh at every frame instead of kept. `None`
    /// keeps everything that holds over the window. Applies from the next window.
    pub fn set_kept_budget(&mut self, bytes: Option<u64>) {
        self.st.kept_budget = bytes.map(|b| usize::try_from(b).unwrap_or(usize::MAX));
    }

    /// Whether a window's reconstructions keep the direct light of the points on
    /// moving surfaces apart ([`super::SpaceTimeOptions::direct_apart`]).
    pub fn set_direct_apart(&mut self, on: bool) {
        self.st.direct_apart = on;
    }

    /// Bytes of what the current window keeps: final-gather terms and leaf-row
    /// coefficients (0 outside a window).
    pub fn kept_bytes(&self) -> u64 {
        self.st.window.as_ref().map_or(0, |w| {
            let points = w
                .points
                .lock()
                .map_or(0, |p| p.as_ref().map_or(0, PointCache::bytes));
            (points + w.rows_bytes()) as u64
        })
    }

    /// Element `e` as the path down to it from the nearest ancestor below `base`
    /// (ids below `base` are their own ancestor): `(ancestor, path)`, the path a 1
    /// followed by 3 bits per level (the child's index under its parent), and the
    /// number of levels.
    fn path_below(&self, e: u32, base: usize) -> (u32, u64, u32) {
        let nodes = self.elems.nodes.as_slice();
        let (mut x, mut path, mut depth) = (e, 1u64, 0u32);
        while x as usize >= base {
            let parent = nodes[x as usize].parent;
            let index = x.wrapping_sub(nodes[parent as usize].first_child);
            path = path.wrapping_shl(3) | u64::from(index.min(7));
            depth += if index < 8 { 1 } else { MAX_FRAME_DEPTH + 1 };
            x = parent;
        }
        (x, path, depth)
    }

    /// What the rays' jitter of element `e` is hashed from: its id outside a
    /// space-time window and for the part all windows share, else its shared
    /// ancestor and the path of child indices down to it. A window's and a frame's
    /// refinement make elements again with other ids (each frame starts from the
    /// window's base, each window from the shared part), with the same geometry
    /// when they split the same element: keyed by the path, such an element casts
    /// the same rays at every frame and in every window, so a static one gets the
    /// same coefficients wherever nothing moves between it and its sources (the
    /// caches of [`Window`] can then keep them), and its jitter does not flicker
    /// from frame to frame.
    pub(in crate::solver) fn ray_id(&self, e: u32) -> u64 {
        let shared = self.st.window.as_ref().map_or(0, |w| w.base.elems_len);
        if shared == 0 || (e as usize) < shared {
            return u64::from(e);
        }
        let (ancestor, path, _) = self.path_below(e, shared);
        oracle::hash3(u64::from(ancestor), path, 0x5ab1e) | 1 << 63
    }

    /// Gives the elements a frame's refinement made (past the window's base) their
    /// ids in [`Window::stable`], for the caches of the leaf rows.
    pub(in crate::solver) fn intern_frame_elements(&mut self) {
        let Some(base) = self
            .st
            .window
            .as_ref()
            .filter(|w| w.in_frame)
            .map(|w| w.frame.elems_len)
        else {
            return;
        };
        let keys: Vec<Option<(u32, u64)>> = (base..self.elems.len())
            .map(|e| {
                let (ancestor, path, depth) = self.path_below(e as u32, base);
                (depth <= MAX_FRAME_DEPTH).then_some((ancestor, path))
            })
            .collect();
        if let Some(w) = self.st.window.as_mut() {
            // Over the kept budget no new id is given: nothing new would be kept
            // under it.
            let admits = w
                .points
                .get_mut()
                .map_or(true, |p| p.as_ref().is_none_or(PointCache::admits));
            w.sids.clear();
            for key in keys {
                let next = FRAME_SID.saturating_add(w.stable.len() as u32);
                let sid = match key {
                    Some(k) if admits && next < 2 * FRAME_SID => *w.stable.entry(k).or_insert(next),
                    Some(k) => w.stable.get(&k).copied().unwrap_or(u32::MAX),
                    None => u32::MAX,
                };
                w.sids.push(sid);
            }
        }
    }

    /// The id the caches of a window key element `e` by: its own in the window's
    /// base, [`Window::stable`]'s for a frame's element (`u32::MAX`: none).
    pub(in crate::solver) fn stable_id(&self, e: u32) -> u32 {
        match &self.st.window {
            Some(w) if w.in_frame && (e as usize) >= w.frame.elems_len => w
                .sids
                .get(e as usize - w.frame.elems_len)
                .copied()
                .unwrap_or(u32::MAX),
            _ => e,
        }
    }
}
