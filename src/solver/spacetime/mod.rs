//! Space-time solve of an animation whose motion is known, streamed in time order
//! (Damez & Sillion, "Space-Time Hierarchical Radiosity", EGWR 1999; paper 001).
//!
//! **Constant and varying.** The radiosity equation holds at each instant on its own
//! (paper eq. 1–2: `K` carries `δ(t, t')`), so time couples only through what can be
//! *reused*. Per §5.2 a link whose ends share a motion has a constant kernel, and one
//! whose shaft no moving object crosses has constant visibility; here both are
//! decided against the boxes the moving objects sweep (the motion volumes of §7
//! item 1): over a time range a link is **constant** or **varying** (`Solver::varying`).
//!
//! The solve runs in three stages:
//! 1. *Shared part* ([`Solver::run_shared`]): the usual rounds at the start time,
//!    links classified over the whole animation and only constant links refined.
//! 2. *Windows*, earliest first, with keyframes spaced by motion (`plan.rs`). A window
//!    re-classifies the links against the boxes swept during it; each frame places
//!    the moving objects, refines its varying links and solves the leaf system
//!    (`window.rs`). What holds over the window is kept: constant links' coefficients,
//!    leaf-row entries and final-gather terms (`kept_terms.rs`). Keyframes gather at
//!    every point; the frames between, solved by bisection (§4.3's time split at the
//!    midpoint), take on the line between the solved frames around them what they
//!    allow (`interpolate.rs`).
//! 3. *Release* ([`Solver::release_window`]): the window's leaves go to the output,
//!    the pools are restored to the shared part and the window's kept terms dropped,
//!    so memory does not grow with the animation's length and no window depends on
//!    another: each is a function of the shared part and its own frames.
//!
//! **Shards.** The windows, cut into contiguous runs of about equal estimated cost,
//! can be solved on separate machines and merged into the file one machine writes
//! (`shards.rs`; `rhier solve --shard K/N`, `rhier merge`).
//!
//! **Elements with time ranges.** A cell whose corners hold over consecutive frames
//! becomes one leaf with a longer time range (`merge.rs`; §4.3, eq. 8–9).
//!
//! **State.** The solver's space-time fields are one `SpaceTimeState` (its field
//! `st`): set by this folder, and by the leaf rows of a window's frame (`rows.rs`).
//!
//! **How this departs from the paper.** It splits *elements* in time and keeps every
//! time level in one hierarchy (§6); here varying links are evaluated per frame,
//! constant ones once, and leaves merged in time where their values hold. No light
//! flows between times (inter-temporal exchange is an artefact of the discretisation,
//! §4.3). Compared: BENCHMARKS.md, "Space-time against frame by frame (ACTOR, LIGHT)".

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

pub(in crate::solver) mod interpolate;
pub(in crate::solver) mod kept_terms;
mod merge;
mod plan;
mod shards;
#[cfg(test)]
mod tests;
pub(in crate::solver) mod window;

use merge::{TimeMerge, in_file_order};
use plan::before;
pub(in crate::solver) use plan::sweep_times;
pub use plan::{
    MAX_KEY_FRAMES, Step, WINDOW_KEYS, WindowPlan, frame_motion, solve_order, swept_boxes,
    time_layout,
};
pub use shards::{FREE_COST, Plan, START_COST, TESTED_COST, plan, plan_patches, split_bounds};

pub use super::frames::frame_instants;
use super::frames::frame_range;
use super::{
    FrameBetween, FrameCost, FrameRows, FrameValues, Leaf, Reconstruction, RoundRecord,
    SharedRadiosity, SolveOptions, Solver, TimeRange,
};
use crate::Result;
use crate::pools::Column;
use crate::scene::Scene;
use window::Window;

/// Settings of the time dimension.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SpaceTimeOptions {
    /// Frames per second: the times at which radiosity is solved.
    pub fps: f64,
    /// Window length in seconds (at least one frame); `None`: a window spans
    /// [`WINDOW_KEYS`] key intervals ([`time_layout`]), so it is as long in motion
    /// as its keyframes are, whatever the frame rate or the speed.
    pub window: Option<f64>,
    /// A cell keeps one value over consecutive frames while its corners stay within
    /// this fraction of the RMS reflected radiosity of their running mean.
    pub merge_tol: f64,
    /// Most bytes a window keeps in final-gather terms and leaf rows
    /// ([`Solver::set_kept_budget`]); `None`: everything that holds over the window.
    /// Changes the work, not the result.
    pub kept_budget: Option<u64>,
    /// Every `key_stride`-th frame of a window (and its first and last) is a
    /// keyframe, reconstructed by final gathers at every point; the frames between
    /// two keyframes, taken by bisection ([`solve_order`]), interpolate the points
    /// where the solved frames around allow it ([`FrameBetween`]). 1: every frame is a
    /// keyframe. `None`: keyframes are spaced by motion, `key_motion` apart
    /// ([`time_layout`]).
    pub key_stride: Option<u32>,
    /// With `key_stride: None`, the next keyframe is the last frame no point of a
    /// moving object has moved more than this fraction of the scene's diameter
    /// since the keyframe before ([`frame_motion`]), and at most
    /// [`MAX_KEY_FRAMES`] frames on.
    pub key_motion: f64,
    /// A point is interpolated between two solved frames when their values differ by
    /// at most this fraction of the RMS reflected radiosity in every channel, or the
    /// earlier lies within it of the line through the frame as far before and the
    /// later ([`FrameBetween`]).
    pub interp_tol: f64,
    /// A frame between two solved frames over which no moving object travels more
    /// than this fraction of the scene's diameter ([`frame_motion`]) takes the line
    /// between them at every point both know, without the test of `interp_tol`,
    /// and skips its leaf solve: the shortest time a light change is resolved
    /// over, in motion, not in frames ([`FrameBetween::free`]). 0: never, every frame
    /// between is tested.
    pub interp_motion: f64,
    /// A frame between two solved frames skips its leaf solve, and takes the
    /// shared radiosity on the line between them, when no moving surface's power
    /// changes between them by more than this fraction of the moving surfaces'
    /// total ([`MOVING_POWER_TOL`]); 0: only where it does not change at all.
    pub moving_power_tol: f64,
    /// The points on moving surfaces keep their direct light apart: a frame
    /// between two solved frames computes it anew and takes the line over the rest
    /// of their light only (`Solver::direct_light`, [`FrameBetween`]). A panel
    /// sliding past a lamp is lit along a curve the line cannot follow; its
    /// inter-reflections with what it passes follow it less steeply. `false`: the
    /// line over the whole light, as in a scene lit by more than 16 emitting
    /// patches, where the direct light would cost too many rays.
    pub direct_apart: bool,
}

impl SpaceTimeOptions {
    /// Checks the time settings before any work (as [`SolveOptions::validate`]):
    /// `fps`, `window`, `key_motion`, `merge_tol` and `interp_tol` finite and > 0,
    /// `interp_motion` and `moving_power_tol` finite and >= 0, `key_stride` >= 1,
    /// each named by its `rhier solve` flag.
    pub fn validate(&self) -> Result<()> {
        super::check_domains(
            &[
                ("--fps", Some(self.fps)),
                ("--window", self.window),
                ("--key-motion", Some(self.key_motion)),
                ("--merge-tol", Some(self.merge_tol)),
                ("--interp-tol", Some(self.interp_tol)),
            ],
            &[
                ("--interp-motion", Some(self.interp_motion)),
                ("--moving-power-tol", Some(self.moving_power_tol)),
            ],
            &[("--key-stride", self.key_stride.unwrap_or(1))],
        )
    }
}

impl Default for SpaceTimeOptions {
    fn default() -> Self {
        SpaceTimeOptions {
            fps: 25.0,
            window: None,
            merge_tol: 0.01,
            kept_budget: None,
            key_stride: None,
            key_motion: 0.05,
            interp_tol: 0.01,
            interp_motion: INTERP_MOTION,
            moving_power_tol: MOVING_POWER_TOL,
            direct_apart: true,
        }
    }
}

/// Fields of [`SolveOptions`] left out of [`result_settings`], because they change
/// how a solve runs but not the windows it writes. Every other field is in.
pub const SOLVE_OPTIONS_NOT_IN_KEY: &[&str] = &[
    // RAM or memory-mapped files hold the same numbers (the test suite runs on
    // both; tests/it/cli/spacetime.rs compares the files), and a space-time solve's
    // default, files in the journal directory, names the output's directory.
    "storage",
    // A space-time solve keeps its passive links whatever it says (only a static
    // solve drops them, `Solver::drop_passive_links`).
    "keep_passive",
    // Only a scene without motion leaves dark patches out (`Solver::at_time`): a
    // space-time solve solves every patch whatever it says.
    "sealed_regions",
];

/// Fields of [`SpaceTimeOptions`] left out of [`result_settings`]: none.
/// `kept_budget` is in: a term dropped under the budget is gathered again, and the
/// value moves a little where the frame has opened a source into finer children
/// than when the term was kept (tests/it/spacetime.rs,
/// `a_budget_on_kept_terms_bounds_them_and_keeps_the_result`), so a file resumed
/// under another budget would match neither solve.
pub const SPACE_TIME_OPTIONS_NOT_IN_KEY: &[&str] = &[];

/// The settings that decide the windows a space-time solve writes, as JSON objects
/// named `solve` and `space_time`: every field of `opts` and `st`, serialized whole,
/// but for those [`SOLVE_OPTIONS_NOT_IN_KEY`] and [`SPACE_TIME_OPTIONS_NOT_IN_KEY`]
/// name. A setting added to either struct is therefore in them unless it is left
/// out there on purpose. What a resume journal is keyed by
/// (`store::journal::fingerprint`).
pub fn result_settings(
    opts: &SolveOptions,
    st: &SpaceTimeOptions,
) -> Result<Vec<(&'static str, serde_json::Value)>> {
    Ok(vec![
        ("solve", settings_of(opts, SOLVE_OPTIONS_NOT_IN_KEY)?),
        (
            "space_time",
            settings_of(st, SPACE_TIME_OPTIONS_NOT_IN_KEY)?,
        ),
    ])
}

/// The fields of `options` as a JSON object, without those `left_out` names.
fn settings_of(options: &impl serde::Serialize, left_out: &[&str]) -> Result<serde_json::Value> {
    let mut value = serde_json::to_value(options)
        .map_err(|e| crate::Error::Usage(format!("journal fingerprint: {e}")))?;
    if let Some(fields) = value.as_object_mut() {
        for name in left_out {
            fields.remove(*name);
        }
    }
    Ok(value)
}

/// Default [`SpaceTimeOptions::interp_motion`]: 3% of the scene's diameter, under
/// two thirds of the default `key_motion`, so the bisection of a key interval tests
/// its midpoint and takes the line over each half below it. Further out the line
/// leaves stains where shadows move; what each value costs and gains on ACTOR and
/// LIGHT is in BENCHMARKS.md, "Frames between on the line over half a key interval".
pub const INTERP_MOTION: f64 = 0.03;

/// Default [`SpaceTimeOptions::moving_power_tol`]. Frames between two keyframes
/// skip their leaf solve when no moving surface's power changes by more than this
/// fraction of the moving surfaces' total between the two nearest solved frames
/// (the shared radiosity is then taken on the line between them,
/// [`Solver::place_between`]). Actors walking through a room's light change their
/// power little over a key interval and skip; a panel passing its lamp changes it
/// much and is solved. Measured in BENCHMARKS.md, "Midpoints skip their solve where
/// the actors' light holds".
pub const MOVING_POWER_TOL: f64 = 0.03;

/// What one frame cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameRecord {
    /// Frame index.
    pub frame: u32,
    /// Window index.
    pub window: u32,
    /// Time of the frame.
    pub t: f64,
    /// Seconds since the solve began.
    pub seconds: f64,
    /// Reconstruction cells of the frame.
    pub cells: u64,
    /// Elements in the pool.
    pub elements: u64,
    /// Links in the pool (active and passive).
    pub links: u64,
    /// Varying links re-evaluated.
    pub varying_links: u64,
    /// Rays cast by link evaluation and leaf rows.
    pub rays: u64,
    /// Leaf-row entries with a moving end taken between the solved frames around
    /// instead of computed ([`crate::solver::TimeRange`]).
    pub rows_between: u64,
    /// Leaf-row entries with a moving end.
    pub rows_moving: u64,
    /// Bytes of the element and link pools.
    pub bytes_pools: u64,
    /// Bytes of the final-gather terms and leaf rows the window keeps.
    pub bytes_kept: u64,
    /// GMRES relative residual.
    pub residual: f64,
    /// Reconstruction points gathered at this frame.
    pub gathered: u64,
    /// Reconstruction points interpolated between keyframes.
    pub interpolated: u64,
}

impl FrameRecord {
    /// One line for the terminal.
    pub fn summary(&self) -> String {
        format!(
            "frame {:4} (window {}) t={:.3}  {:7.2}s  cells {} (points: {} gathered, {} interpolated)  elements {}  links {} ({} varying)  rays {}  moving rows {} ({} between)  pools {:.1} MB  kept {:.1} MB  residual {:.1e}",
            self.frame,
            self.window,
            self.t,
            self.seconds,
            self.cells,
            self.gathered,
            self.interpolated,
            self.elements,
            self.links,
            self.varying_links,
            self.rays,
            self.rows_moving,
            self.rows_between,
            self.bytes_pools as f64 / 1e6,
            self.bytes_kept as f64 / 1e6,
            self.residual
        )
    }
}

/// The leaves of one finished window.
#[derive(Debug, PartialEq)]
pub struct WindowOutput {
    /// Window index.
    pub index: u32,
    /// Time range of the window.
    pub t0: f64,
    /// End of the window.
    pub t1: f64,
    /// Leaves starting in the window, sorted by start time, patch and parameters,
    /// on the pools' storage: out of core on `--storage mmap`, where
    /// [`Column::release_resident`] hands back the pages a reader of them touched.
    pub leaves: Column<Leaf>,
    /// Sum over the window's frames of their cell counts (what storing every frame
    /// separately would hold).
    pub frame_cells: u64,
}

/// Totals of a space-time solve.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpaceTimeStats {
    /// Frames solved (skipped windows excluded).
    pub frames: u32,
    /// Windows in the animation.
    pub windows: u32,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Seconds of the shared part.
    pub shared_seconds: f64,
    /// Elements and links of the shared part.
    pub shared_elements: u64,
    /// Links of the shared part.
    pub shared_links: u64,
    /// Largest element and link pool bytes seen at a frame.
    pub peak_pool_bytes: u64,
    /// Largest bytes of kept terms seen at a frame.
    pub peak_kept_bytes: u64,
    /// Rounds of the shared part.
    pub rounds: Vec<RoundRecord>,
    /// RMS reflected radiosity of the shared solution (the error scale).
    pub b_ref: f64,
}

/// The space-time state a [`Solver`] holds (its field `st`): the current window
/// and what a frame solved between two others takes from them. Empty in a static solve.
pub(in crate::solver) struct SpaceTimeState {
    /// Whether `Solver::balancing` is fixed: space-time windows keep the shared
    /// part's choice.
    pub(in crate::solver) balance_fixed: bool,
    /// The current time window (`None` in a static solve and between windows).
    pub(in crate::solver) window: Option<Window>,
    /// Solving the part shared by all windows: varying links are not refined.
    pub(in crate::solver) shared_phase: bool,
    /// Time the varying links were last evaluated at: their visibility (and shaft
    /// test) holds at `now` only when the two are equal ([`Solver::place_between`]
    /// moves the objects without evaluating them).
    pub(in crate::solver) links_at: f64,
    /// Most bytes a window keeps in final-gather terms (`None`: no bound).
    pub(in crate::solver) kept_budget: Option<usize>,
    /// [`Solver::set_direct_apart`].
    pub(in crate::solver) direct_apart: bool,
    /// The solved frames around a frame solved between them, whose row entries
    /// with a moving end this frame may take ([`TimeRange`]).
    pub(in crate::solver) time_range: Option<TimeRange>,
    /// The row entries with a moving end the last leaf rows of a window's frame
    /// computed or took ([`Solver::take_frame_rows`]).
    pub(in crate::solver) frame_rows: FrameRows,
    /// Row entries the last leaf rows took from [`SpaceTimeState::time_range`].
    pub(in crate::solver) rows_between: u64,
    /// Row coefficients a window's frame computed, `(leaf, link) → (F, visible
    /// fraction)`, for its next refine-and-solve pass: within a frame the geometry
    /// and the ids hold, so a leaf whose chain link did not change gets the same
    /// coefficient bit for bit (LIGHT computed its rows 1.8 times a frame).
    /// Emptied when the frame's passes end. Sorted by key, 24 bytes an entry.
    pub(in crate::solver) pass_rows: Vec<((u32, u32), (f64, f64))>,
    /// The rays of the partly hidden ones ([`crate::solver::EntryRay`]), keyed and
    /// sorted alike.
    pub(in crate::solver) pass_rays: Vec<crate::solver::rows::KeyedRays>,
}

impl SpaceTimeState {
    /// No window, the varying links evaluated at `t`.
    pub(in crate::solver) fn new(t: f64) -> Self {
        SpaceTimeState {
            balance_fixed: false,
            window: None,
            shared_phase: false,
            links_at: t,
            kept_budget: None,
            direct_apart: false,
            time_range: None,
            frame_rows: FrameRows::default(),
            rows_between: 0,
            pass_rows: Vec::new(),
            pass_rays: Vec::new(),
        }
    }
}

/// A space-time solve in progress: the shared part is solved by
/// [`SpaceTime::new`], then the caller asks for the windows in time order with
/// [`SpaceTime::solve_window`], all of them or any run of them (a shard's windows,
/// or those an interrupted run did not write): a window depends on no other.
pub struct SpaceTime<'a> {
    /// How far the moving objects travel from each frame of the animation to the
    /// next ([`frame_motion`]).
    motion: Vec<f64>,
    solver: Solver<'a>,
    st: SpaceTimeOptions,
    /// Frame times and keyframes of each window.
    windows: Vec<WindowPlan>,
    shared_tr: Vec<crate::pools::links::Transport>,
    shared_b: Vec<[f32; 3]>,
    /// The shared part's directional power ([`crate::pools::Emission`]; cluster emission depends on `B`).
    shared_dir: Vec<crate::pools::Emission>,
    start: Instant,
    /// Totals so far.
    pub stats: SpaceTimeStats,
}

impl<'a> SpaceTime<'a> {
    /// Builds the solver at the scene's start time and solves the shared part.
    pub fn new(
        scene: &'a Scene,
        opts: SolveOptions,
        st: SpaceTimeOptions,
        on_round: impl FnMut(&mut RoundRecord, &Solver),
    ) -> Result<Self> {
        st.validate()?;
        static_only(&opts)?;
        let start = Instant::now();
        let (t_start, t_end) = (scene.time.start, scene.time.end);
        let times = frame_instants(scene.time, st.fps)?;
        let mut solver = Solver::at_time(scene, opts, t_start, [t_start as f32, t_end as f32])?;
        let motion = frame_motion(scene, &times, solver.patches.diameter);
        let windows = time_layout(&times, &motion, &st);
        solver.set_kept_budget(st.kept_budget);
        solver.set_direct_apart(st.direct_apart);
        let rounds = solver.run_shared([t_start, t_end], on_round)?;
        let b_ref = solver.radiosity_scale().max(f64::MIN_POSITIVE);
        let stats = SpaceTimeStats {
            windows: windows.len() as u32,
            shared_seconds: start.elapsed().as_secs_f64(),
            shared_elements: solver.elems.len() as u64,
            shared_links: solver.links.len() as u64,
            rounds,
            b_ref,
            ..SpaceTimeStats::default()
        };
        // The state every window starts from.
        let shared_tr = solver.links.transports.as_slice().to_vec();
        let shared_b = solver.elems.radiosities.as_slice().to_vec();
        let shared_dir = solver.elems.directions.as_slice().to_vec();
        Ok(SpaceTime {
            motion,
            solver,
            st,
            windows,
            shared_tr,
            shared_b,
            shared_dir,
            start,
            stats,
        })
    }

    /// Number of windows.
    pub fn window_count(&self) -> usize {
        self.windows.len()
    }

    /// Frame times and keyframes of every window (what [`plan`] plans).
    pub fn windows(&self) -> &[WindowPlan] {
        &self.windows
    }

    /// Index of the first frame of window `w`.
    fn first_frame(&self, w: usize) -> u32 {
        self.windows[..w].iter().map(|p| p.times.len() as u32).sum()
    }

    /// The patches leaves refer to (for the file's header).
    pub fn patches(&self) -> &[super::PatchGeometry] {
        &self.solver.patches.geometry
    }

    /// The solver (pools, geometry) as it stands.
    pub fn solver(&self) -> &Solver<'a> {
        &self.solver
    }

    /// Solves window `wi` frame by frame and returns its leaves; the pools are back to
    /// the shared part afterwards. `on_frame` sees every frame's record.
    pub fn solve_window(
        &mut self,
        wi: usize,
        mut on_frame: impl FnMut(&FrameRecord),
    ) -> Result<WindowOutput> {
        let WindowPlan {
            times: frames,
            keys,
        } = self.windows[wi].clone();
        let first = self.first_frame(wi);
        let b_ref = self.stats.b_ref;
        let [w0, w1] = self.window_span(wi);
        self.solver.set_time(frames[0]);
        self.solver.begin_window([w0, w1], b_ref)?;
        let tol = self.st.merge_tol * b_ref;
        let mut merge = InTimeOrder {
            merge: TimeMerge::new(&self.solver.opts.storage, tol)?,
            pending: Default::default(),
            next: 0,
            first: first as usize,
        };
        let mut frame_cells = 0u64;
        let order = solve_order(&keys);
        let mut solved = SolvedFrames::default();
        for (at, step) in order.iter().enumerate() {
            let k = step.frame;
            let t = frames[k];
            let (cost, r) = match step.brackets {
                None => self.solve_keyframe(&keys, k, t, &mut solved)?,
                Some(brackets) => {
                    let between = StepBetween {
                        keys: &keys,
                        to_come: &order[at..],
                        first: first as usize,
                        k,
                        t,
                        brackets,
                    };
                    self.solve_between(between, &mut solved)?
                }
            };
            let (gathered, interpolated) = (r.gathered, r.interpolated);
            // The frame's cells are shared by the time merge and its values (which
            // later frames interpolate where the frame did not gather).
            let cells: Arc<[Leaf]> = r.leaves.into();
            solved.values.insert(k, r.values.with_cells(cells.clone()));
            // The frame's gathers leave the heaps fragmented (ACTOR, out of core:
            // 6 MB less resident at the end of a window); a frame that gathered
            // nothing allocated what the next one reuses.
            if gathered > 0 {
                super::release_free_memory();
            }
            let n_cells = cells.len() as u64;
            frame_cells += n_cells;
            merge.push(k, cells, |f| self.frame_span(f)[0])?;
            let record = FrameRecord {
                frame: first + k as u32,
                window: wi as u32,
                t,
                cells: n_cells,
                gathered,
                interpolated,
                ..self.frame_record(&cost)
            };
            on_frame(&record);
        }
        let closed = merge.merge.finish(w1)?;
        self.restore_shared();
        // Sorted once the window's memory is back (out of core the two columns are
        // paged through a bucket at a time).
        let leaves = in_file_order(closed, &self.solver.opts.storage)?;
        self.stats.seconds = self.start.elapsed().as_secs_f64();
        Ok(WindowOutput {
            index: wi as u32,
            t0: w0,
            t1: w1,
            leaves,
            frame_cells,
        })
    }

    /// The time range of frame `f` of the animation.
    fn frame_span(&self, f: usize) -> [f64; 2] {
        let n = self.windows.iter().map(|w| w.times.len()).sum();
        frame_range(f, n, self.solver.scene.time, self.st.fps)
    }

    /// The time range of window `wi`: from its first frame's start to its last
    /// frame's end.
    fn window_span(&self, wi: usize) -> [f64; 2] {
        let first = self.first_frame(wi) as usize;
        let last = first + self.windows[wi].times.len() - 1;
        [self.frame_span(first)[0], self.frame_span(last)[1]]
    }

    /// Solves keyframe `k` (at `t`) of the window with keyframes `keys`, and
    /// reconstructs it by a final gather at every point.
    fn solve_keyframe(
        &mut self,
        keys: &[usize],
        k: usize,
        t: f64,
        solved: &mut SolvedFrames,
    ) -> Result<(FrameCost, Reconstruction)> {
        let solver = &mut self.solver;
        let cost = solver.solve_frame(t, self.stats.b_ref)?;
        let rad = &mut solved.rad;
        rad.insert(k, solver.shared_radiosity());
        // Where the moving light holds between this keyframe and the one before,
        // the frames between skip their solve: the one before ends no range of
        // rows any more, and this one is kept only if the light did not hold (the
        // next interval likely does as this one did; ACTOR's mostly hold, LIGHT's
        // never).
        let i = keys.partition_point(|&f| f < k);
        let prev = i.checked_sub(1).map(|i| keys[i]);
        let held = prev.and_then(|p| rad.get(&p)).is_some_and(|ra| {
            SharedRadiosity::moving_power_holds(ra, &rad[&k], self.st.moving_power_tol)
        });
        let rows = solver.take_frame_rows();
        if let Some(p) = prev.filter(|_| held) {
            solved.rows_at.remove(&p);
        } else {
            solved.rows_at.insert(k, Arc::new(rows));
        }
        Ok((cost, solver.reconstruct_between(None)))
    }

    /// Solves a frame between two solved frames: it takes the shared radiosity on
    /// the line between the solved frames around where the moving light holds (and
    /// skips its solve), else solves with the row entries that hold taken between
    /// them; then reconstructs, taking on the line what its brackets allow.
    fn solve_between(
        &mut self,
        at: StepBetween,
        solved: &mut SolvedFrames,
    ) -> Result<(FrameCost, Reconstruction)> {
        let StepBetween {
            keys,
            to_come,
            first,
            k,
            t,
            brackets: (lo, hi),
        } = at;
        let b_ref = self.stats.b_ref;
        let interp_tol = self.st.interp_tol * b_ref;
        let SolvedFrames {
            values,
            rad,
            rows_at,
        } = solved;
        // The keyframe starting the interval (`solve_order` solves the one ending
        // it just before the frames in it).
        let a = keys[keys.partition_point(|&f| f < k) - 1];
        // What the rest of the window still reads: the brackets and look-back
        // frames of the steps to come.
        let to_come = || to_come.iter().filter_map(|s| s.brackets);
        let brackets: std::collections::HashSet<usize> =
            to_come().flat_map(|(l, h)| [l, h]).collect();
        let looked_back: std::collections::HashSet<usize> =
            to_come().filter_map(|(l, h)| before(l, h)).collect();
        values.retain(|f, _| brackets.contains(f) || looked_back.contains(f));
        rad.retain(|&f, _| f >= a);
        // Rows end ranges only.
        rows_at.retain(|f, _| brackets.contains(f));
        // The solved frames nearest on either side (the keyframes, or a midpoint
        // that had to be solved): the moving surfaces' light is checked, and the
        // shared radiosity interpolated, between them.
        let sa = rad.keys().filter(|&&f| f < k).max().copied();
        let sb = rad.keys().filter(|&&f| f > k).min().copied();
        // Brackets closer in motion than `interp_motion`: the frame takes the line
        // at every point (`FrameBetween::free`), and its gathers (cells the
        // brackets lack) need no solve.
        let travel: f64 = self.motion[first + lo..first + hi].iter().sum();
        let free = self.st.interp_motion > 0.0 && travel <= self.st.interp_motion;
        let holds = match (sa, sb) {
            (Some(sa), Some(sb)) => {
                let (ra, rb) = (&rad[&sa], &rad[&sb]);
                (free || SharedRadiosity::moving_power_holds(ra, rb, self.st.moving_power_tol))
                    .then_some((sa, ra, sb, rb))
            }
            _ => None,
        };
        let solver = &mut self.solver;
        let cost = match holds {
            Some((sa, ra, sb, rb)) => {
                let alpha = (k - sa) as f64 / (sb - sa) as f64;
                solver.place_between(t, ra, rb, alpha);
                FrameCost::default()
            }
            None => {
                // Row entries with a moving end that hold over the solved frames
                // around are taken between them.
                let range = sa.zip(sb).and_then(|(sa, sb)| {
                    Some(TimeRange {
                        a: rows_at.get(&sa)?.clone(),
                        b: rows_at.get(&sb)?.clone(),
                        alpha: (k - sa) as f64 / (sb - sa) as f64,
                        tol: interp_tol,
                    })
                });
                solver.set_time_range(range);
                let cost = solver.solve_frame(t, b_ref);
                solver.set_time_range(None);
                let cost = cost?;
                rad.insert(k, solver.shared_radiosity());
                rows_at.insert(k, Arc::new(solver.take_frame_rows()));
                cost
            }
        };
        let known = |f: Option<usize>| Some((f? as f64, values.get(&f?)?));
        let between = known(Some(lo))
            .zip(known(Some(hi)))
            .map(|(a, b)| FrameBetween {
                free,
                before: known(before(lo, hi)),
                a,
                b,
                t: k as f64,
                tol: interp_tol,
            });
        Ok((cost, solver.reconstruct_between(between.as_ref())))
    }

    /// A frame's record but for what its reconstruction tells (frame, time, cells,
    /// points), with the peaks of the totals brought up to date.
    fn frame_record(&mut self, cost: &FrameCost) -> FrameRecord {
        let solver = &self.solver;
        let bytes = (solver.elems.bytes() + solver.links.bytes()) as u64;
        self.stats.peak_pool_bytes = self.stats.peak_pool_bytes.max(bytes);
        let kept = solver.kept_bytes();
        self.stats.peak_kept_bytes = self.stats.peak_kept_bytes.max(kept);
        self.stats.frames += 1;
        FrameRecord {
            seconds: self.start.elapsed().as_secs_f64(),
            elements: solver.elems.len() as u64,
            links: solver.links.len() as u64,
            varying_links: cost.varying_links,
            rays: cost.rays,
            rows_between: cost.rows_between,
            rows_moving: cost.rows_moving,
            bytes_pools: bytes,
            bytes_kept: kept,
            residual: cost.residual,
            ..FrameRecord::default()
        }
    }

    /// Releases the window and puts back the shared part's coefficients,
    /// radiosities and directional power.
    fn restore_shared(&mut self) {
        let solver = &mut self.solver;
        solver.release_window();
        solver
            .links
            .transports
            .as_mut_slice()
            .copy_from_slice(&self.shared_tr);
        solver
            .elems
            .radiosities
            .as_mut_slice()
            .copy_from_slice(&self.shared_b);
        solver
            .elems
            .directions
            .as_mut_slice()
            .copy_from_slice(&self.shared_dir);
    }
}

/// What a window's solve keeps of its solved frames for the frames still to come:
/// the values of the frames later frames interpolate (about 0.9 MB each on ACTOR:
/// the keyframes around the interval being solved, its frames solved so far and the
/// frames before it a bisection step looks back to), the shared radiosity of the
/// interval's solved frames, and the row entries with a moving end of the same.
#[derive(Default)]
struct SolvedFrames {
    values: HashMap<usize, FrameValues>,
    rad: HashMap<usize, SharedRadiosity>,
    rows_at: HashMap<usize, Arc<FrameRows>>,
}

/// A frame between two solved frames, as [`SpaceTime::solve_between`] takes it.
struct StepBetween<'o> {
    /// The window's keyframes.
    keys: &'o [usize],
    /// The steps of the window's solve order from this frame's on.
    to_come: &'o [Step],
    /// Index in the animation of the window's first frame.
    first: usize,
    /// The frame (in the window) and its time.
    k: usize,
    t: f64,
    /// The solved frames just before and after it.
    brackets: (usize, usize),
}

/// Finished frames handed to the time merge in time order: a frame between two
/// solved frames finishes after the later one, so frames wait for those before
/// them.
struct InTimeOrder {
    merge: TimeMerge,
    pending: std::collections::BTreeMap<usize, Arc<[Leaf]>>,
    /// The next frame (in the window) the merge takes.
    next: usize,
    /// Index in the animation of the window's first frame.
    first: usize,
}

impl InTimeOrder {
    /// Adds the cells of frame `k` and merges every frame now in order; `start`
    /// gives the start time of a frame of the animation.
    fn push(&mut self, k: usize, cells: Arc<[Leaf]>, start: impl Fn(usize) -> f64) -> Result<()> {
        self.pending.insert(k, cells);
        while let Some(cells) = self.pending.remove(&self.next) {
            let f0 = start(self.first + self.next);
            self.merge.push_frame(&cells, self.next as u32, f0)?;
            self.next += 1;
        }
        // Out of core: the closed leaves' pages go back to the scratch file.
        self.merge.release_resident();
        Ok(())
    }
}

/// Refuses the settings a space-time solve has no use for: `leaf_shapes` and
/// `split_spread` act after the last round of one static solve, and a window's
/// frames gather from leaves shared over time without reaching that point.
/// [`SpaceTime::new`] calls it; a caller may call it before creating its output.
pub fn static_only(opts: &SolveOptions) -> Result<()> {
    for (on, flag) in [
        (opts.leaf_shapes > 0.0, "--leaf-shapes"),
        (opts.split_spread > 0.0, "--split-spread"),
    ] {
        if on {
            return Err(crate::Error::Usage(format!(
                "{flag} applies to static solves and to the frames of --per-frame; a space-time solve of a moving scene does not use it"
            )));
        }
    }
    Ok(())
}

/// Solves every window of `scene` in order (see the module docs); `on_window`
/// receives each finished window (write it to a `.rhier` chunk).
pub fn solve(
    scene: &Scene,
    opts: SolveOptions,
    st: &SpaceTimeOptions,
    mut on_frame: impl FnMut(&FrameRecord),
    mut on_window: impl FnMut(WindowOutput) -> Result<()>,
) -> Result<SpaceTimeStats> {
    let mut run = SpaceTime::new(scene, opts, *st, |_, _| {})?;
    for w in 0..run.window_count() {
        let out = run.solve_window(w, &mut on_frame)?;
        on_window(out)?;
    }
    Ok(run.stats)
}
