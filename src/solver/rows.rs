//! The leaf system: one row per leaf, `B_i = E_i + ρ_i Σ_j K_ij B_j` over the
//! leaves `j` that the sources of the links of leaf `i` and of its ancestors open
//! into, solved by GMRES ([`super::gmres`]) with push-pull through the hierarchy.
//!
//! A row entry's coefficient is the link's transfer from the source seen from the
//! leaf's quadrature points, its visibility from rays keyed by the place of both
//! ends under the shared part (so the same entry casts the same rays at every frame,
//! `Solver::row_ray_key`). A source opened into its children hands each child the
//! visible fraction of the entry's rays that land on it ([`EntryRay`], kept from
//! round to round as [`KeptRays`]). In a space-time window what holds is kept
//! (paper 001 §5.2's shortcuts applied to the rows, [`super::spacetime`]): the rows of
//! constant links, the opened entries of static sources, the hidden coefficients of
//! varying links between static ends while no moving object's box meets their shaft,
//! and, for the others, the static part of their rays as masks ([`RowMasks`]);
//! entries with a moving end are taken on the line between two solved frames where
//! their light holds ([`super::TimeRange`]).

use super::row_patch::RowPatch;
use super::*;
use crate::geometry::point_to_point_kernel;

/// Row entries `(source element, coefficient)`, as a leaf's row holds them.
pub(super) type RowEntries = Box<[(u32, f64)]>;

/// The ray ids a leaf row's rays to one source hash their jitter from
/// ([`Solver::row_ray_ids`]). 24 bytes.
#[derive(Clone, Copy, Debug)]
pub(super) struct RowRayIds {
    /// The leaf's [`Solver::ray_id`].
    leaf: u64,
    /// The chain link's [`Solver::row_link_id`] (rays at the leaf's points).
    link: u64,
    /// The source's [`Solver::ray_id`] (rays at its corners and finer points).
    source: u64,
}

/// One visibility ray of a leaf row's entry for a surface source, as the source's
/// children take it ([`Solver::push_opened`]): where it lands on the source, in the
/// source's unit-square parameters ([`oracle::ray_params`], before a triangle's
/// fold), and its weight in the entry as [`Solver::hidden_row_coef`] integrates
/// it (`w_q F(x_q → s) k_j / Σ_i k_i` at its point `x_q`, `k` the point-to-point
/// kernel), negated where the ray was blocked. 12 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct EntryRay {
    st: [f32; 2],
    w: f32,
}

const _: () = assert!(std::mem::size_of::<EntryRay>() == 12);

/// The [`EntryRay`]s of a row entry by the key of a window's caches
/// ([`Solver::row_key`]) or of a frame's passes (`(leaf, link)`).
pub(super) type KeyedRays = ((u32, u32), Box<[EntryRay]>);

/// A leaf's [`EntryRay`]s by chain link and source element (the link's source,
/// or a surface part of its cluster source, [`ClusterPart`]), for the entries
/// partly hidden from it, kept from round to round beside its [`KeptCoef`]s and
/// cluster parts. 24 bytes.
#[derive(Clone, Debug)]
pub(super) struct KeptRays {
    pub(super) link: u32,
    elem: u32,
    rays: Box<[EntryRay]>,
}

/// The rays `kept` (sorted by link and element) holds for the entry of element
/// `e` in chain link `l`.
fn kept_rays_of(kept: &[KeptRays], l: u32, e: u32) -> Option<&KeptRays> {
    let i = kept
        .binary_search_by_key(&(l, e), |x| (x.link, x.elem))
        .ok()?;
    Some(&kept[i])
}

const _: () = assert!(std::mem::size_of::<KeptRays>() == 24);

/// The kernel-weighted visible fraction of `rays` ([`EntryRay`]), `None` if they
/// weigh nothing.
fn rays_visibility(rays: &[EntryRay]) -> Option<f64> {
    let (mut seen, mut all) = (0.0f64, 0.0f64);
    for r in rays {
        let w = f64::from(r.w.abs());
        all += w;
        if r.w.is_sign_positive() {
            seen += w;
        }
    }
    (all > 0.0).then(|| seen / all)
}

/// The rays of `rays` that land on child `j` of their source, in the child's own
/// unit-square parameters: a quad's children are its parametric quarters and a
/// triangle's its three corner triangles and the middle one, in the order
/// [`super::hierarchy::child_domains`] makes them, and [`oracle::point_at`] maps
/// a child's parameters to the point the parent's map to.
fn child_rays(rays: &[EntryRay], triangle: bool, j: usize, out: &mut Vec<EntryRay>) {
    out.clear();
    for r in rays {
        let [mut s, mut t] = r.st;
        let st = if triangle {
            if s + t > 1.0 {
                (s, t) = (1.0 - s, 1.0 - t);
            }
            let k = if 1.0 - s - t > 0.5 {
                0
            } else if s > 0.5 {
                1
            } else if t > 0.5 {
                2
            } else {
                3
            };
            (k == j).then_some(match k {
                0 => [2.0 * s, 2.0 * t],
                1 => [2.0 * s - 1.0, 2.0 * t],
                2 => [2.0 * s, 2.0 * t - 1.0],
                _ => [1.0 - 2.0 * s, 1.0 - 2.0 * t],
            })
        } else {
            let (hs, ht) = (s >= 0.5, t >= 0.5);
            let k = match (hs, ht) {
                (false, false) => 0,
                (true, false) => 1,
                (true, true) => 2,
                (false, true) => 3,
            };
            let half = |x: f32, hi: bool| if hi { 2.0 * x - 1.0 } else { 2.0 * x };
            (k == j).then(|| [half(s, hs), half(t, ht)])
        };
        if let Some(st) = st {
            out.push(EntryRay { st, w: r.w });
        }
    }
}

/// How the rays of a row entry at a leaf's quadrature points treat static
/// geometry ([`Solver::hidden_row_coef`], [`Window::masks`]).
#[derive(Clone, Copy, Debug)]
pub(super) enum RowMasks {
    /// Every ray is cast at everything.
    None,
    /// Cast at the static part first, the masks handed back, then the rays it leaves
    /// clear at the moving objects.
    Make,
    /// The static part's answers, as [`Window::masks`] keeps them: only the rays
    /// they leave clear are cast, at the moving objects.
    Known(u64),
    /// An interactive move's masks ([`Solver::move_row_masks`]), the quadrature
    /// points' and the corners' as far as they are known (`0`: none): the layout
    /// of [`move_mask`]. What is not known yet is made (cast at the static part
    /// first), and the mask with it is handed back.
    Move(u64),
}

/// The layout of a [`RowMasks::Move`] mask with `m` rays a point: the rays of
/// point `i` (quadrature points `i < 4`, the leaf's corners `4..8`,
/// [`Solver::hidden_row_coef`]) at bits `i·m ..`; bit [`move_mask::QUAD`] says the
/// quadrature points' are known, bit `CORNER + c` corner `c`'s. Corners are
/// masked only while `8 m` bits fit under the flags ([`move_mask::corners`]).
pub(super) mod move_mask {
    /// The flag of the quadrature points' masks.
    pub(in crate::solver) const QUAD: u32 = 60;
    /// The flag of corner 0's mask (corner `c`: `CORNER + c`).
    pub(in crate::solver) const CORNER: u32 = 56;

    /// True if the corners' rays (`m` a point) fit in a mask.
    pub(in crate::solver) fn corners(m: u32) -> bool {
        8 * m <= CORNER
    }

    /// In the record of the rays a moving object blocked
    /// (`Solver::hidden_row_coef`, same layout below the flags): the
    /// record holds.
    pub(in crate::solver) const SEEN: u32 = 63;
    /// In the same record: the corners were looked at.
    pub(in crate::solver) const CORNERS_SEEN: u32 = 62;
}

/// What one leaf's row computation hands back ([`Solver::compute_leaf_rows`]): the
/// row, and what the caches are to keep of it.
#[derive(Default)]
pub(super) struct LeafRow {
    /// The row's entries `(source, coefficient)`.
    pub(super) row: Vec<(u32, f64)>,
    /// With `keep_clusters`: each chain link's entries (surface or cluster
    /// source), sorted by link, for the next move (`super::moves`).
    pub(super) move_clusters: Vec<(u32, RowEntries)>,
    /// New constant-link coefficients for [`Window::rows`].
    fresh: Vec<((u32, u32), (f32, f32))>,
    /// A static solve's coefficients by link, for the next round.
    pub(super) kept: Vec<KeptCoef>,
    /// The rays of its partly hidden ones, for the next round.
    pub(super) kept_rays: Vec<KeptRays>,
    /// The rays of its partly hidden cluster surface parts, for the next round.
    part_rays: Vec<KeptRays>,
    /// A static solve's cluster parts by link, for the next round.
    clusters: Vec<ClusterPart>,
    /// A static solve's factors of the children its sources opened into, for the
    /// next round.
    opened_factors: OpenedFactors,
    /// New opened entries for [`Window::opened`].
    opened: Vec<((u32, u32), RowEntries)>,
    /// New hidden coefficients for [`Window::hidden`].
    hidden: Vec<((u32, u32), (f64, f64))>,
    /// New static masks for [`Window::masks`].
    masks: Vec<((u32, u32), u64)>,
    /// New factors for [`Window::factors`].
    factors: Vec<((u32, u32), f64)>,
    /// Its entries with a moving end ([`FrameRows`]).
    timed: Vec<TimedEntry>,
    /// How many of them it took between the solved frames around.
    between: u64,
    /// The rays of the partly hidden entries of `fresh` and `hidden`, keyed alike.
    fresh_rays: Vec<KeyedRays>,
    /// The rays of the partly hidden entries of `passed`, keyed alike.
    passed_rays: Vec<KeyedRays>,
    /// Coefficients for the frame's next pass (`Solver::pass_rows`).
    passed: Vec<((u32, u32), (f64, f64))>,
    /// The rays a moving object blocked in the entry [`Solver::fresh_row_coef`]
    /// just computed ([`Solver::hidden_row_coef`]; 0: none to keep).
    trace: u64,
}

impl LeafRow {
    /// Whether nothing is left of it once its row and kept records are taken: no
    /// entry for the space-time window's caches or the interactive moves' (what a
    /// static solve's rows always are).
    fn is_spent(&self) -> bool {
        self.move_clusters.is_empty()
            && self.fresh.is_empty()
            && self.opened.is_empty()
            && self.hidden.is_empty()
            && self.masks.is_empty()
            && self.factors.is_empty()
            && self.timed.is_empty()
            && self.between == 0
            && self.passed.is_empty()
    }
}

/// The leaf rows as [`Solver::compute_leaf_rows`] makes them, chunk by chunk: the
/// leaf system's CSR ([`LeafSystem`]'s `row_start`, `row_sources`, `row_coefs`) and
/// what is left of the leaves' [`LeafRow`]s that have more to hand on.
#[derive(Default)]
struct LeafRows {
    start: Vec<u32>,
    sources: Vec<u32>,
    coefs: Vec<f64>,
    rest: Vec<(ElementId, LeafRow)>,
}

impl LeafRows {
    /// Appends the next leaf's row, and frees it.
    fn push(&mut self, row: &mut Vec<(u32, f64)>) {
        self.sources.extend(row.iter().map(|e| e.0));
        self.coefs.extend(row.iter().map(|e| e.1));
        self.start.push(self.sources.len() as u32);
        *row = Vec::new();
    }
}

/// A window cache by the key of a leaf row's entry (its leaf and link, [`Solver::row_key`]).
type KeyMap<V> = FastMap<(u32, u32), V>;

/// `(coefficient, visible fraction)` by the key of a leaf row's entry.
type KeyedCoefs = Vec<((u32, u32), (f64, f64))>;

/// What every leaf's row computation reads ([`Solver::compute_leaf_rows`]): the
/// pools, the space-time window's caches, and how the rows are kept.
#[derive(Clone, Copy)]
struct RowInputs<'r> {
    geoms: &'r [Geom],
    ends: &'r [Ends],
    tr: &'r [Transport],
    cache: Option<&'r KeyMap<(f32, f32)>>,
    opened: Option<&'r KeyMap<RowEntries>>,
    hidden: Option<&'r KeyMap<(f64, f64)>>,
    /// The rays of the partly hidden entries of `cache` and `hidden`.
    entry_rays: Option<&'r KeyMap<Box<[EntryRay]>>>,
    /// The rays of the partly hidden entries of `passed`, sorted by key.
    pass_rays: &'r [KeyedRays],
    masks: Option<&'r KeyMap<u64>>,
    rays_per_point: u32,
    factors: Option<(&'r KeyMap<f64>, usize)>,
    keep_rows: bool,
    /// Keep each cluster source's entries by chain link too (`Solver::rows_of`).
    keep_clusters: bool,
    /// An interactive move's stale entries, updated in place (`Solver::rows_of`).
    patch: Option<&'r RowPatch>,
    timed: bool,
    passed: Option<&'r KeyedCoefs>,
    radiosities: &'r [[f32; 3]],
}

/// The factors one static leaf's row reuses and adds while it opens sources
/// ([`Window::factors`]).
struct FactorMemo<'m> {
    leaf: u32,
    kept: &'m FastMap<(u32, u32), f64>,
    fresh: Vec<((u32, u32), f64)>,
}

/// A static leaf's row's polygon factors of the children it opened sources into
/// for their size ([`Solver::push_opened`]), sorted by child, kept for the next
/// round ([`LeafSystem::opened_factors`]). A factor depends on the leaf's
/// quadrature and the child's polygon alone, so it holds from round to round while
/// which sources are opened follows the links and the spread the last solve left:
/// a round that changes few links (the Cornell box's last round at eps 0.1 adds
/// 18 links to 5 098) computed every opened child's factor again, a third of the
/// rows' time. A table per row, not one keyed by `(leaf, child)`: the lookups of
/// one hash map over every row cost what the factors did. The factors are rounded
/// to `f32` once, so a reused factor equals the first (8 bytes an entry: the
/// Cornell box with its blocks at eps 0.04 peaks 23 MB higher, at 304 MB).
#[derive(Default)]
pub(super) struct OpenedFactors {
    elems: Box<[u32]>,
    factors: Box<[f32]>,
}

/// What one static leaf's row reuses of its [`OpenedFactors`] and takes into the
/// next round's while it opens sources.
struct OpenedMemo<'m> {
    before: Option<&'m OpenedFactors>,
    used: Vec<(u32, f32)>,
}

impl OpenedMemo<'_> {
    /// The factor of child `ch`: the one kept, else `factor()`; kept either way.
    fn factor(&mut self, ch: u32, factor: impl FnOnce() -> f64) -> f64 {
        let kept = self
            .before
            .and_then(|b| b.elems.binary_search(&ch).ok().map(|i| b.factors[i]));
        let f = kept.unwrap_or_else(|| factor() as f32);
        self.used.push((ch, f));
        f64::from(f)
    }

    /// The factors this row used, for the next round.
    fn keep(mut self) -> OpenedFactors {
        // A leaf's chain links cover the scene once: each child comes once.
        self.used.sort_unstable_by_key(|e| e.0);
        OpenedFactors {
            elems: self.used.iter().map(|e| e.0).collect(),
            factors: self.used.iter().map(|e| e.1).collect(),
        }
    }
}

/// A closed scene's leaf system is balanced once it absorbs more or less than the
/// power emitted by this fraction (`Solver::solve_balanced`; the solver module
/// docs). With exact surface factors and cluster estimates only where they hold,
/// what is left is quadrature and visibility noise that reflectance near 1
/// amplifies by `ρ/(1 − ρ)`: a deficit the answer carries everywhere, so the
/// trigger sits at the tolerance the known-answer tests hold the answer to
/// (BENCHMARKS.md, "Stiff scenes"). The CLI warns at the same level.
pub const BALANCE_TRIGGER: f64 = 0.01;
/// A cluster part that rays from a leaf's points (or a final-gather point) find
/// partly hidden is cast again with this many times the rays ([`Solver::part_visibility`]'s
/// callers); so is a surface source a final-gather point finds partly hidden
/// (`Solver::surface_visibility`). Why: with `cluster_rays` = 8 (2 a leaf point) the fraction comes in
/// steps of 1/8 and the row or point sums it enters were off by a few percent where
/// an object hides part of a cluster: in the room with a pillar and a floating box
/// (`tests/it/solver/enclosures.rs`) at `ρ = 0.99`, balanced, the final gather read
/// the ceiling 1.4% low and the box's side 1.45% high (0.5% and 0.7% with 64
/// rays, 0.1% and 0.5% with 256).
pub(super) const PARTIAL_CLUSTER_RAYS: u32 = 8;
/// Most passes of [`Solver::balance_rows`] (a column pass, then a row pass).
const BALANCE_PASSES: usize = 200;
/// A row summing to less than this, or more than its inverse, is not scaled:
/// scaling rows that see much less than their hemisphere (the leaves in the narrow
/// slots of `tests/it/solver/scale.rs`) makes those leaves far too bright.
const BALANCE_ROW_MIN: f64 = 0.8;
/// A row summing to at most this sees next to nothing (a leaf inside a solid).
const BALANCE_HIDDEN: f64 = 0.05;
/// A leaf system is not balanced when rows left unscaled that see something
/// (sum between [`BALANCE_HIDDEN`] and [`BALANCE_ROW_MIN`], or above its inverse)
/// hold more than this share of the area: what they miss is then lost, amplified
/// by reflectance, and balancing the rest of the system makes the answer worse (a
/// floor of cubes with slots between them; BENCHMARKS.md, "Stiff scenes").
const BALANCE_OUT_MAX: f64 = 0.005;
/// [`Solver::balance_rows`] stops when a pass takes less than 1% off what the
/// leaves send astray: after the first few passes what is left is what the capped
/// gains ([`BALANCE_GAIN_MAX`]) cannot send, and further passes barely move it.
const BALANCE_STALL: f64 = 0.99;
/// Largest gain of a leaf as a source: a leaf the factors hardly see is not made
/// to shine for the few that gather from it. The cap binds on a tiny part of a
/// room's area, and the answer does not depend on it.
const BALANCE_GAIN_MAX: f64 = 4.0;

/// A leaf's row entry for a surface source, kept from round to round in a static
/// solve (12 bytes): the chain link, its coefficient re-integrated over the leaf,
/// and the visible fraction of the source seen from the leaf (coefficient over
/// unoccluded coefficient).
#[derive(Clone, Copy, Debug)]
pub(super) struct KeptCoef {
    pub(super) link: u32,
    coef: f32,
    pub(super) vis: f32,
}

const _: () = assert!(std::mem::size_of::<KeptCoef>() == 12);

/// One part of a cluster source as a static leaf's row took it ([`Solver::push_cluster`]),
/// kept for the next round: `vis >= 0`, a surface part to open at `(coef, vis)`
/// ([`Solver::push_opened`], whose opening follows the source's children as they
/// are then); `vis < 0`, a cluster part (a facet or a sub-cluster) whose entry is
/// `coef`: [`PART_OWN_RAYS`] if its visibility came from its own rays to its own
/// patches, [`PART_ON_ESTIMATE`] if it hangs on the link's estimate or on the
/// radiosity (a sub-cluster seen by power, a point with no ray that took the link's
/// fraction), which [`Solver::drop_estimate_parts`] then drops. 16 bytes.
#[derive(Clone, Copy, Debug)]
pub(super) struct ClusterPart {
    pub(super) link: u32,
    elem: u32,
    coef: f32,
    vis: f32,
}

const _: () = assert!(std::mem::size_of::<ClusterPart>() == 16);

/// [`ClusterPart::vis`] of a cluster part whose visibility is its own rays' to its
/// own patches (a facet's, drawn by area): it does not depend on the radiosity.
const PART_OWN_RAYS: f32 = -1.0;
/// [`ClusterPart::vis`] of a cluster part that depends on the link's estimate or on
/// the radiosity: a sub-cluster (rays to points drawn by power), or a facet one of
/// whose points cast no ray and took the link's fraction.
const PART_ON_ESTIMATE: f32 = -2.0;
/// [`ClusterPart::elem`] of the mark [`Solver::drop_estimate_parts`] puts first in a
/// link's kept parts when some hung on the estimate: the link is walked again, its
/// other parts taken as kept.
const WALK_AGAIN: u32 = u32::MAX;
/// Leaves whose rows [`Solver::compute_leaf_rows`] makes before it frees the
/// cluster parts they read.
const ROW_CHUNK: usize = 1024;

/// What [`Solver::push_kept_cluster`] found kept of a link.
enum KeptParts<'p> {
    /// Nothing: the link is cast afresh.
    None,
    /// Every part, pushed.
    Used,
    /// The parts that do not hang on the estimate, in the walk's order: the
    /// link is walked again and only the others cast.
    Walk(&'p [ClusterPart]),
}

/// True if cluster `g`'s box lies wholly behind the tangent plane (normal `n`) of
/// every point of `q`: nothing in it is above a point's horizon, so it gives the
/// points nothing, and [`Solver::cluster_parts`] skips its walk (the walk into
/// clusters was a third of `gen_cubes 20`'s final gather; with the skip the solve
/// took 81 CPU s instead of 90, BENCHMARKS.md "Scale"). Exact for
/// the surfaces under it (a factor counts only what is above the receiver's
/// plane); a part it would have taken whole by its bounding sphere could reach
/// over the plane and get a clipped cosine above 0, light from behind the point
/// that is not there.
pub(super) fn box_behind(g: &Geom, q: &oracle::Samples, n: DVec3) -> bool {
    let (lo, hi) = geom_box(g);
    let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let reach = n.abs().dot(h);
    q.points[..q.count]
        .iter()
        .all(|&x| n.dot(c - x) + reach <= 0.0)
}

/// A far cluster is taken whole by its facets in a leaf's row
/// ([`Solver::far_facet_factors`]) only where their summed factor is at most this
/// at each of the leaf's points; a larger one is opened, each face with its exact
/// factor and rays. The final gather's bound for small far clusters
/// (`gather::WHOLE_CLUSTER_MAX_FACTOR`): what the estimate errs is then a share of
/// a small term.
pub(super) const ROW_FAR_FACETS_MAX_FACTOR: f64 = 3e-3;

impl Solver<'_> {
    /// Visits what a leaf gathers of cluster `s` from its quadrature points `q`
    /// (normal `n`), unoccluded, handing each part to `part` with its factor at
    /// each point (entries past `q.count` are 0):
    /// - a sub-cluster whose patches all face away from every point, or whose box
    ///   lies behind every point's plane ([`box_behind`]), gives nothing;
    /// - one whose patches all face every point, and whose bounding sphere subtends
    ///   a half-angle below [`SolveOptions::cluster_open_ratio`] (radius over
    ///   distance), is taken whole: its projected area toward the point is then
    ///   exactly `N · v` (`N` its summed vector area, [`Cone`]), and the estimate
    ///   placed at its area centroid errs to second order in `r/d` (Sillion
    ///   1995's cluster estimate with the cosines it can know);
    /// - any other is opened into its children, down to surfaces, which get their
    ///   exact point-to-polygon factor.
    ///
    /// Why not the cluster's directional emission ([`oracle::cluster_emission`])
    /// for a cluster whose patches face several ways: it counts the coherent part
    /// and then spreads the rest by axis on top, so a cluster of two perpendicular
    /// wall pieces seen by both was taken 29% larger than it is, and a closed room
    /// whose walls were tiled summed its rows to 1.085 (the exact 1) and came out
    /// `ρ/(1 − ρ · 1.085)`-fold too bright (at `ρ = 0.8`, 7.2–7.9 for the exact 5).
    pub(super) fn cluster_parts(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        part: &mut impl FnMut(u32, [f64; 4]),
    ) {
        self.cluster_parts_reusing(q, n, s, part, &mut |_| false);
    }

    /// [`Solver::cluster_parts`], handing each child it would open first to
    /// `reuse`, which takes it (true: what it gives is known already, an
    /// interactive move's kept entries, `super::row_patch`) or leaves it.
    pub(super) fn cluster_parts_reusing(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        part: &mut impl FnMut(u32, [f64; 4]),
        reuse: &mut impl FnMut(u32) -> bool,
    ) {
        self.walk_cluster(q, n, s, part, reuse, false);
    }

    /// The leaf rows' walk: [`Solver::cluster_parts_reusing`], but a far
    /// cluster of several orientations is taken whole by its facets where
    /// [`Solver::far_facet_factors`] allows ([`ROW_FAR_FACETS_MAX_FACTOR`]), not
    /// opened down to every face.
    pub(super) fn row_cluster_parts(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        part: &mut impl FnMut(u32, [f64; 4]),
        reuse: &mut impl FnMut(u32) -> bool,
    ) {
        self.walk_cluster(q, n, s, part, reuse, true);
    }

    /// [`Solver::cluster_parts_reusing`]; `far_facets`: as
    /// [`Solver::row_cluster_parts`].
    fn walk_cluster(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        part: &mut impl FnMut(u32, [f64; 4]),
        reuse: &mut impl FnMut(u32) -> bool,
        far_facets: bool,
    ) {
        let elems = &self.elems;
        let gs = &elems.geoms.as_slice()[s as usize];
        let mut k = [0.0; 4];
        if gs.patch != u32::MAX {
            let ps = oracle::poly(gs);
            for (ki, &x) in k.iter_mut().zip(&q.points).take(q.count) {
                *ki = point_to_polygon(x, n, &ps);
            }
            part(s, k);
            return;
        }
        if box_behind(gs, q, n) {
            return;
        }
        let (c, r) = oracle::sphere(gs);
        let cone = gs.cluster_cone();
        let (axis, cos_a) = (cone.axis, cone.cos);
        let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
        let ratio = self.opts.cluster_open_ratio;
        // Per point: 1 if every patch faces it, -1 if every patch faces away, 0
        // if the cone and the box cannot tell, or the cluster is near.
        let side = |x: DVec3| -> i32 {
            let w = x - c;
            let d = w.length();
            if d.is_nan() || d <= 0.0 || cos_a <= -1.0 {
                return 0;
            }
            // A normal within the cone, at a point in the sphere: its cosine to
            // the point is at least `cos(θ + α) d − r` (θ the axis's angle to w)
            // while `θ + α ≤ π` (the sine of the sum not negative), else `−d − r`:
            // the sum's cosine wraps round past π, and a cone wider than a right
            // angle seen from behind its axis was taken as facing the point whole,
            // its vector area then giving it nothing (a box's cluster of five
            // faces seen by a final-gather point).
            let cos_t = axis.dot(w) / d;
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let least = |cos_t: f64| {
                if sin_t * cos_a + cos_t * sin_a >= 0.0 {
                    (cos_t * cos_a - sin_t * sin_a) * d
                } else {
                    -d
                }
            };
            let front = least(cos_t);
            let back = least(-cos_t);
            if back > r {
                -1
            } else if front > r && r < ratio * d {
                1
            } else {
                0
            }
        };
        let sides: [i32; 4] =
            std::array::from_fn(|i| if i < q.count { side(q.points[i]) } else { 0 });
        if sides[..q.count].iter().all(|&x| x < 0) {
            return;
        }
        let node = elems.nodes.as_slice()[s as usize];
        if sides[..q.count].contains(&0) && node.child_count > 0 {
            let facets = self.facet_factors(q, n, s, c, r).or_else(|| {
                far_facets
                    .then(|| self.far_facet_factors(q, n, s, (c, r), ROW_FAR_FACETS_MAX_FACTOR))
                    .flatten()
            });
            if let Some((ks, count)) = facets {
                for &(f, k) in &ks[..count] {
                    if k.iter().any(|&ki| ki > 0.0) {
                        part(FACET_BIT | f, k);
                    }
                }
                return;
            }
            for ch in node.first_child..node.first_child + node.child_count {
                if !reuse(ch) {
                    self.walk_cluster(q, n, ch, part, reuse, far_facets);
                }
            }
            return;
        }
        // The patches' vector area seen along `v`: their projected area, since
        // every one faces the point.
        let vector_area = gs.area * cone.coherence * axis;
        for (i, (ki, &x)) in k.iter_mut().zip(&q.points).take(q.count).enumerate() {
            if sides[i] < 0 {
                continue;
            }
            let w = x - c;
            let d2 = w.length_squared();
            let v = w / d2.sqrt();
            let projected = vector_area.dot(v).max(0.0);
            let cos = clipped_cosine(-n.dot(v), r * r / d2);
            *ki = projected * cos / (std::f64::consts::PI * d2);
        }
        part(s, k);
    }

    /// The visible fraction of cluster part `e` from the point `x` (normal `n`, on
    /// patch `patch`), the `i`-th point of a leaf row or a final-gather point (`i` =
    /// 0), by `m` rays: a facet ([`FACET_BIT`]) by rays to its own patches, drawn by
    /// area ([`super::facets::ClusterFacets::point_on`]), a cluster by rays to
    /// points drawn by power ([`oracle::point_cluster_visibility`]). The jitter
    /// depends on the part, the patch and `i` only, so the points of one patch aim
    /// at the same surface points. Returns `(visibility, rays cast)`; no ray cast
    /// (every one below the point's horizon or on faces turned away) says nothing.
    pub(super) fn part_visibility(
        &self,
        x: DVec3,
        n: DVec3,
        patch: u32,
        e: u32,
        m: u32,
        i: u64,
    ) -> (f64, u32) {
        let h = self.part_ray_key(e, patch, i);
        if e & FACET_BIT != 0 {
            oracle::kernel_weighted_visibility(&self.bvh, m, |j| {
                let y = self
                    .facets
                    .point_on(&self.elems, e & !FACET_BIT, oracle::hash3(h, j, 2));
                ((x, n, patch), y)
            })
        } else {
            oracle::point_cluster_visibility(
                &self.elems,
                &self.bvh,
                x,
                n,
                patch,
                ElementId(e),
                m,
                h,
                SOURCES_BY_POWER,
            )
        }
    }

    /// The jitter key of the rays of [`Solver::part_visibility`] from point `i` (on
    /// patch `patch`) to cluster part `e`.
    pub(super) fn part_ray_key(&self, e: u32, patch: u32, i: u64) -> u64 {
        let key = oracle::hash3(self.opts.seed ^ 0xc105, e as u64, patch as u64);
        oracle::hash3(key, i, 3)
    }

    /// The factors from the points `q` (normal `n`) to each facet of cluster `s`
    /// (bounding sphere `c`, `r`) taken whole ([`super::facets`]): `(facet, factor
    /// at each point)` for the first `count` of them; `None` without
    /// [`SolveOptions::cluster_facets`], in a scene with motion, for a cluster with
    /// no facets, where a point is nearer than [`SolveOptions::cluster_open_ratio`]
    /// allows, or where a facet cannot tell which side of its patches a point is
    /// on. Each facet in front of a point gives `A_f (n_f · v) cos θ / (π d²)` from
    /// its centroid, the receiver's cosine clipped to the cluster's sphere as the
    /// cone's estimate clips it; each is a source of its own, at its own radiosity.
    #[allow(clippy::type_complexity)]
    pub(super) fn facet_factors(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        c: DVec3,
        r: f64,
    ) -> Option<([(u32, [f64; 4]); MAX_FACETS], usize)> {
        if !self.opts.cluster_facets || self.has_motion() {
            return None;
        }
        let (facets, mut ks) = self.far_facets(q, s, (c, r))?;
        for (i, &x) in q.points.iter().enumerate().take(q.count) {
            // The offsets are kept in f32.
            let tol = 1e-6 * (self.patches.diameter + x.abs().max_element());
            for (j, f) in facets.iter().enumerate() {
                if !super::facets::side(f, x, tol)? {
                    continue;
                }
                let w = x - DVec3::from_array(f.centroid.map(f64::from));
                let d2 = w.length_squared();
                let v = w / d2.sqrt();
                let nf = DVec3::from_array(f.normal.map(f64::from));
                let projected = f.area as f64 * nf.dot(v).max(0.0);
                let cos = clipped_cosine(-n.dot(v), (r * r / d2).min(1.0));
                ks[j].1[i] = projected * cos / (std::f64::consts::PI * d2);
            }
        }
        Some((ks, facets.len()))
    }

    /// The factors from the points `q` (normal `n`) to each facet of cluster `s`
    /// (bounding sphere `c`, `r`) taken whole as a leaf's row takes a far cluster
    /// ([`Solver::row_cluster_parts`]), if it is: a static scene, a cluster with
    /// facets and no emitter under it, far for its size from every point
    /// ([`SolveOptions::cluster_open_ratio`]), whose facets' summed factor is at
    /// most `max_factor` at each. `None`: the walk opens it.
    ///
    /// Each facet gives `A_f D_f cos θ / (π d_f²)` from its centroid (`d_f` away),
    /// `D_f / d_f` the mean cosine of its patches toward the point
    /// ([`super::facets::ClusterFacets::front_depth`]): where the point is in front
    /// of every patch it is [`Solver::facet_factors`]' exact `n_f · v`, where it is
    /// in the facet's slab (a ceiling point over a cluster of boxes: some of the
    /// boxes' `+x` sides face it, some turn away) the part in front, each patch at
    /// its own plane offset. Everything it reads is geometry, so a row
    /// takes a cluster whole or opens it the same way in every round, and the parts
    /// kept from round to round equal those cast afresh
    /// ([`Solver::drop_estimate_parts`]); each facet is seen by rays to its own
    /// patches and gathered at its own radiosity (Sillion 1995 §4's vector area split
    /// by orientation; Willmott, Heckbert & Garland 1999's face clusters keep the
    /// orientations apart for the same reason).
    ///
    /// Why: a cluster of boxes has faces looking every way, so the walk opened a
    /// leaf's cluster sources down to every face above the leaf's plane, each with
    /// its own factor and rays, and the faces a leaf's row visited grew with the
    /// scene (`gen_cubes` 10 → 20: 481 → 1 828 a leaf), the rows as `P^1.7`
    /// (BENCHMARKS.md, "Scale"). Kept whole by the links' estimate instead (one
    /// part at the cluster's mean, its light spread by the axes its power leaves
    /// by), the whole/open choice hung on the radiosity and the dark box sides were
    /// gathered at the mean with the lit tops (`gen_cubes 20`: 2.48% → 2.62%).
    #[allow(clippy::type_complexity)]
    pub(super) fn far_facet_factors(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        (c, r): (DVec3, f64),
        max_factor: f64,
    ) -> Option<([(u32, [f64; 4]); MAX_FACETS], usize)> {
        if self.has_motion() || self.emits_under.get(s as usize).copied().unwrap_or(true) {
            return None;
        }
        let (facets, mut ks) = self.far_facets(q, s, (c, r))?;
        for (i, &x) in q.points.iter().enumerate().take(q.count) {
            let mut sum = 0.0;
            for (j, f) in facets.iter().enumerate() {
                let nf = DVec3::from_array(f.normal.map(f64::from));
                let cf = DVec3::from_array(f.centroid.map(f64::from));
                let depth = self.facets.front_depth(ks[j].0, nf.dot(x));
                if depth <= 0.0 {
                    continue;
                }
                let w = x - cf;
                let d2 = w.length_squared();
                let v = w / d2.sqrt();
                let projected = f.area as f64 * depth / d2.sqrt();
                let cos = clipped_cosine(-n.dot(v), (r * r / d2).min(1.0));
                let k = projected * cos / (std::f64::consts::PI * d2);
                ks[j].1[i] = k;
                sum += k;
                // Opened: the facets left cannot take the sum back under.
                if sum > max_factor {
                    return None;
                }
            }
        }
        Some((ks, facets.len()))
    }

    /// What [`Solver::facet_factors`] and [`Solver::far_facet_factors`] start
    /// from: cluster `s`'s facets and a factor array naming each, all zero;
    /// `None` for a cluster with no facets or one not far for its size
    /// (bounding sphere `c`, `r`) from every point of `q`
    /// ([`SolveOptions::cluster_open_ratio`]).
    #[allow(clippy::type_complexity)]
    fn far_facets(
        &self,
        q: &oracle::Samples,
        s: u32,
        (c, r): (DVec3, f64),
    ) -> Option<(&[super::facets::Facet], [(u32, [f64; 4]); MAX_FACETS])> {
        let facets = self.facets.of(s);
        if facets.is_empty() {
            return None;
        }
        let ratio = self.opts.cluster_open_ratio;
        for &x in q.points.iter().take(q.count) {
            let d = (x - c).length();
            if d.is_nan() || r >= ratio * d {
                return None;
            }
        }
        let first = self.facets.first(s);
        Some((
            facets,
            std::array::from_fn(|j| (first + j as u32, [0.0; 4])),
        ))
    }

    /// A leaf's row entries for the chain link `l` to cluster `s`: the parts of
    /// [`Solver::cluster_parts`], each a row entry of its own (a surface part
    /// opened further as [`Solver::push_opened`] opens surface sources), each with
    /// its visibility cast from the leaf's own points (a surface as
    /// [`Solver::hidden_row_coef`], a cluster as the final gather does,
    /// [`oracle::point_cluster_visibility`]). The link's own fraction is an average
    /// over its receiver and its whole source, and a ray that meets any part of a
    /// cluster counts as seeing it, so it says nothing of a part hidden behind
    /// another: the wall behind a floating box was counted whole, rows summed up
    /// to 5% over 1 and the closed room came out unsound at `ρ = 0.99`. A link
    /// whose estimate is zero is still opened when its receiver is a cluster: the
    /// average of a box's faces may see nothing of the floor beside the box while
    /// one face sees it at 0.4. A link too close for the cluster estimate
    /// ([`oracle::close_cluster_factor`]) is opened the same way. With `kept` (a
    /// static solve) the parts are recorded for the next round ([`ClusterPart`]).
    /// `reuse` takes the parts whose entries are known already
    /// ([`Solver::cluster_parts_reusing`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn push_cluster(
        &self,
        leaf: ElementId,
        l: u32,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        row: &mut Vec<(u32, f64)>,
        kept: Option<&mut Vec<ClusterPart>>,
        reuse: &mut impl FnMut(u32) -> bool,
    ) {
        self.push_cluster_known(leaf, l, q, n, s, row, kept, reuse, &[], None, &[]);
    }

    /// [`Solver::push_cluster`], taking the parts of `known` (the parts an earlier
    /// round kept of link `l` that do not hang on its estimate, in the order the
    /// walk met them: [`Solver::drop_estimate_parts`]) as they were kept instead
    /// of casting their rays again; the others are cast. The walk into the
    /// cluster depends on the geometry only, so it meets the known parts in the
    /// same order, and the row equals the row cast afresh entry by entry.
    /// `rays_before` holds the rays of the known surface parts partly hidden
    /// ([`KeptRays`]); with `kept_rays` (a static solve) the rays of the surface
    /// parts taken are kept for the next round.
    #[allow(clippy::too_many_arguments)]
    fn push_cluster_known(
        &self,
        leaf: ElementId,
        l: u32,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        row: &mut Vec<(u32, f64)>,
        mut kept: Option<&mut Vec<ClusterPart>>,
        reuse: &mut impl FnMut(u32) -> bool,
        known: &[ClusterPart],
        mut kept_rays: Option<&mut Vec<KeptRays>>,
        rays_before: &[KeptRays],
    ) {
        let t = &self.links.transports.as_slice()[l as usize];
        let mut vis = t.visibility as f64;
        if t.f <= 0.0 || vis <= 0.0 {
            // A cluster receiver's estimate is an average over patches that need
            // not face one way; the leaf looks for itself.
            let r = self.links.ends.as_slice()[l as usize].receiver;
            if self.elems.geoms.as_slice()[r as usize].patch != u32::MAX {
                return;
            }
            vis = 1.0;
        }
        let geoms = self.elems.geoms.as_slice();
        let patch = geoms[leaf.ix()].patch;
        let mut next_known = 0;
        let mut part = |e: u32, k: [f64; 4]| {
            if let Some(p) = known.get(next_known).filter(|p| p.elem == e) {
                next_known += 1;
                let rays = kept_rays_of(rays_before, l, e);
                self.push_part(q, n, p, rays.map_or(&[][..], |r| &r.rays), row);
                if let Some(k) = kept.as_deref_mut() {
                    k.push(*p);
                }
                if let Some(k) = kept_rays.as_deref_mut() {
                    k.extend(rays.cloned());
                }
                return;
            }
            let coef: f64 = (0..q.count).map(|i| q.weights[i] * k[i]).sum::<f64>();
            if coef <= 0.0 {
                return;
            }
            let facet = e & FACET_BIT != 0;
            if !facet && geoms[e as usize].patch != u32::MAX {
                let how = self.move_row_masks(leaf, l, e, q);
                let mut rays = Vec::new();
                let ((coef, v), made, traced) =
                    self.hidden_row_coef(leaf, l, e, q, n, how, Some(&mut rays));
                self.keep_move_mask(leaf, l, e, how, made);
                let at = row.len();
                // Rounded once, so a reused part equals the first.
                let (coef, v) = match kept.as_deref_mut() {
                    Some(k) => {
                        let (c, v) = (coef as f32, v.max(0.0) as f32);
                        k.push(ClusterPart {
                            link: l,
                            elem: e,
                            coef: c,
                            vis: v,
                        });
                        (c as f64, v as f64)
                    }
                    None => (coef, v),
                };
                self.push_opened(q, n, e, coef, v, &rays, row, None, None);
                if let Some(k) = kept_rays.as_deref_mut().filter(|_| !rays.is_empty()) {
                    k.push(KeptRays {
                        link: l,
                        elem: e,
                        rays: rays.into(),
                    });
                }
                self.keep_move_trace(leaf, l, e, traced, &row[at..]);
                return;
            }
            // A point whose rays all fall below its horizon or on faces
            // turned away counts none: it takes the link's fraction, not 0
            // (the estimate still gives it the part of the sphere above).
            let mut on_estimate = !facet;
            let at = |m: u32| -> [(f64, u32); 4] {
                std::array::from_fn(|i| {
                    if i < q.count {
                        self.row_part_visibility(leaf, q.points[i], n, patch, e, m, i as u64)
                    } else {
                        (0.0, 0)
                    }
                })
            };
            let m = (self.opts.cluster_rays / q.count as u32).max(1);
            let mut seen = at(m);
            // Partly hidden (a point's rays disagree, or the points do): cast
            // again with more rays (`PARTIAL_CLUSTER_RAYS`).
            let cast = &seen[..q.count];
            let partial = cast.iter().any(|&(v, r)| r > 0 && v > 0.0 && v < 1.0)
                || cast.iter().any(|&(v, r)| r > 0 && v > 0.0)
                    && cast.iter().any(|&(v, r)| r > 0 && v <= 0.0);
            // (In a move's rows, where an end moves, fewer for a small part:
            // [`Solver::move_entry_rays`].)
            let more = self.move_entry_rays(leaf, e, coef, m * PARTIAL_CLUSTER_RAYS);
            if partial && more > m {
                seen = at(more);
            }
            let v: f64 = (0..q.count)
                .map(|i| {
                    let (v, rays) = seen[i];
                    on_estimate |= rays == 0;
                    q.weights[i] * if rays > 0 { v } else { vis }
                })
                .sum();
            // A part that gave nothing is kept too where the estimate may change
            // that, so that the link's other parts are not reused without it.
            if v <= 0.0 && !on_estimate {
                return;
            }
            let entry = match kept.as_deref_mut() {
                Some(k) => {
                    let c = (coef * v.max(0.0)) as f32;
                    k.push(ClusterPart {
                        link: l,
                        elem: e,
                        coef: c,
                        vis: if on_estimate {
                            PART_ON_ESTIMATE
                        } else {
                            PART_OWN_RAYS
                        },
                    });
                    c as f64
                }
                None => coef * v,
            };
            if v > 0.0 {
                row.push((e, entry));
            }
        };
        self.row_cluster_parts(q, n, s, &mut part, reuse);
    }

    /// After [`Solver::reevaluate_cluster_sources`] has evaluated the cluster links
    /// again with the radiosity known: drops the kept cluster parts
    /// ([`ClusterPart`]) that hang on the link's estimate or on the radiosity
    /// ([`PART_ON_ESTIMATE`]), marking their links to be walked again
    /// ([`WALK_AGAIN`]), and every part of a link whose new estimate
    /// [`Solver::push_cluster`] would now take nothing from (a surface receiver and
    /// a link that sees nothing). What is left, surface parts and facets seen by
    /// their own rays, is what the rows would cast again to the same answer:
    /// dropping everything made the second round cast every leaf's rows once more,
    /// as long as the first round (`gen_cubes 20`, BENCHMARKS.md "Scale"); dropping
    /// every part of a link with one sub-cluster in it cast its surface parts
    /// again (`the_clutter_keeps_its_light`: 121.5 CPU s, 93.4 with them kept;
    /// BENCHMARKS.md "Scale").
    pub(super) fn drop_estimate_parts(&mut self) {
        let tr = self.links.transports.as_slice();
        let ends = self.links.ends.as_slice();
        let geoms = self.elems.geoms.as_slice();
        for parts in self.sys.cluster_cache.values_mut() {
            let mut left = Vec::with_capacity(parts.len());
            let mut from = 0;
            while from < parts.len() {
                let l = parts[from].link;
                let to = from + parts[from..].partition_point(|p| p.link == l);
                let t = &tr[l as usize];
                let surface_receiver = geoms[ends[l as usize].receiver as usize].patch != u32::MAX;
                let empty = surface_receiver && (t.f <= 0.0 || t.visibility <= 0.0);
                let link = &parts[from..to];
                if empty {
                    // Cast again, to nothing.
                } else if link.iter().any(|p| p.vis == PART_ON_ESTIMATE) {
                    // Walked again: the parts that hang on the estimate are cast,
                    // the others taken as kept.
                    left.push(ClusterPart {
                        link: l,
                        elem: WALK_AGAIN,
                        coef: 0.0,
                        vis: PART_ON_ESTIMATE,
                    });
                    left.extend(link.iter().filter(|p| p.vis != PART_ON_ESTIMATE));
                } else {
                    left.extend_from_slice(link);
                }
                from = to;
            }
            left.shrink_to_fit();
            *parts = left;
        }
        self.sys.cluster_cache.retain(|_, parts| !parts.is_empty());
    }

    /// How many links' kept parts [`Solver::drop_estimate_parts`] left to walk
    /// again ([`WALK_AGAIN`]).
    #[cfg(test)]
    pub(super) fn links_to_walk_again(&self) -> usize {
        self.sys
            .cluster_cache
            .values()
            .flatten()
            .filter(|p| p.elem == WALK_AGAIN)
            .count()
    }

    /// The row entries of kept cluster part `p` ([`ClusterPart`]): a surface part
    /// opened at its coefficient and visibility, a cluster part at its entry.
    /// `rays`: a partly hidden surface part's ([`KeptRays`]).
    fn push_part(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        p: &ClusterPart,
        rays: &[EntryRay],
        row: &mut Vec<(u32, f64)>,
    ) {
        if p.vis < 0.0 {
            if p.coef > 0.0 {
                row.push((p.elem, p.coef as f64));
            }
        } else {
            self.push_opened(
                q,
                n,
                p.elem,
                p.coef as f64,
                p.vis as f64,
                rays,
                row,
                None,
                None,
            );
        }
    }

    /// The row entries of cluster link `l` from the parts an earlier round kept
    /// (`parts`, sorted by link; [`ClusterPart`]): [`KeptParts::None`] if it kept
    /// none for `l` (a link new since, or one whose parts all gave nothing: those
    /// are cast again, which finds nothing again), [`KeptParts::Walk`] with the
    /// parts to take as kept where some hang on an estimate that changed
    /// ([`Solver::drop_estimate_parts`]; nothing is pushed then). The rays of its
    /// partly hidden surface parts are taken from `rays_before` and kept in
    /// `kept_rays` ([`KeptRays`]).
    #[allow(clippy::too_many_arguments)]
    fn push_kept_cluster<'p>(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        l: u32,
        parts: &'p [ClusterPart],
        row: &mut Vec<(u32, f64)>,
        kept: &mut Vec<ClusterPart>,
        rays_before: &[KeptRays],
        kept_rays: &mut Vec<KeptRays>,
    ) -> KeptParts<'p> {
        let from = parts.partition_point(|p| p.link < l);
        let to = from + parts[from..].partition_point(|p| p.link == l);
        if to == from {
            return KeptParts::None;
        }
        if parts[from].elem == WALK_AGAIN {
            return KeptParts::Walk(&parts[from + 1..to]);
        }
        for p in &parts[from..to] {
            let rays = kept_rays_of(rays_before, l, p.elem);
            self.push_part(q, n, p, rays.map_or(&[][..], |r| &r.rays), row);
            kept_rays.extend(rays.cloned());
        }
        kept.extend_from_slice(&parts[from..to]);
        KeptParts::Used
    }

    /// A leaf's row coefficient for the partly hidden chain link `l` to surface
    /// source `s`, with visibility from the leaf's own points: `(F, visible
    /// fraction)`, `F = Σ_q w_q F(x_q → A_s) V(x_q)`.
    ///
    /// Where every quadrature point is hidden (or every one sees the whole source), a
    /// shadow edge may still cross the leaf between them and its corners; for an
    /// entry above [`ROW_CORNER_MIN_COEF`] the corners are checked (inset by
    /// [`CORNER_INSET`]) and, if one disagrees, the leaf is integrated on the finer
    /// rule of [`oracle::fine_samples`]. Why: in a closed room lit by a lamp hung
    /// just under its ceiling, the ceiling leaves that straddle the lamp's edge had
    /// all their points over the lamp and gathered nothing from the floor, though
    /// part of each sees it; the floor's light sent there was lost, and every
    /// surface came out too dark against the path tracer.
    ///
    /// `masks` says how the quadrature points' rays treat static geometry
    /// ([`RowMasks`]); the masks made are returned (`RowMasks::Make`; for
    /// `RowMasks::Move` the whole mask, what it knew and what it made: the
    /// corners' rays too), and the value is the same whichever it is. Third, what
    /// an interactive move's rows keep to know the entry unchanged at a later move
    /// ([`Solver::unchanged_part`]): for `RowMasks::Move`, the rays a moving object
    /// blocked (bit `i·m + j`: ray `j` of point `i`, quadrature points and corners
    /// as in [`move_mask`]) with [`move_mask::SEEN`] set, and
    /// [`move_mask::CORNERS_SEEN`] if the corners were looked at; 0 (nothing to
    /// keep) where a point's rays were cast without a mask (the finer rule, corners
    /// that do not fit in one) and for the other `masks`.
    ///
    /// With `rays`, the rays of the entry as its source's children take them
    /// ([`EntryRay`]), where it is partly hidden (left empty where every ray or
    /// none got through).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn hidden_row_coef(
        &self,
        leaf: ElementId,
        l: u32,
        s: u32,
        q: &oracle::Samples,
        n: DVec3,
        masks: RowMasks,
        rays: Option<&mut Vec<EntryRay>>,
    ) -> ((f64, f64), u64, u64) {
        let gs = &self.elems.geoms.as_slice()[s as usize];
        let g = &self.elems.geoms.as_slice()[leaf.ix()];
        let ps = oracle::poly(gs);
        let ns = DVec3::from_array(gs.normal);
        let ids = self.row_ray_ids(leaf, l, s);
        let m = self.opts.rays_per_point;
        let made = std::cell::Cell::new(match masks {
            RowMasks::Move(bits) => bits,
            _ => 0u64,
        });
        let ray_bits = |bits: u64, i: u64| bits >> (i as u32 * m) & ((1 << m) - 1);
        // The rays a moving object blocked (`hidden_row_coef`); `None` once a
        // point's rays were cast without a mask.
        let traced = std::cell::Cell::new(
            matches!(masks, RowMasks::Move(_) if move_mask::corners(m)).then_some(0u64),
        );
        // The factors at the quadrature points, taken once (the share below and
        // the integral).
        let fq: [f64; 4] = std::array::from_fn(|i| {
            if i < q.count {
                point_to_polygon(q.points[i], n, &ps)
            } else {
                0.0
            }
        });
        // Rays cast at everything (an end moves, in a move's rows): fewer for a
        // small entry ([`Solver::move_entry_rays`]); a static solve skips the
        // share.
        let m_all = if self.sys.move_rows && matches!(masks, RowMasks::None) {
            let u: f64 = (0..q.count).map(|i| q.weights[i] * fq[i].max(0.0)).sum();
            self.move_entry_rays(leaf, s, u, m)
        } else {
            m
        };
        let vis_at = |x: DVec3, i: u64| {
            let mut r = self.row_rays(ids, g, gs, &ps, ns, x, n, i);
            let mask = match masks {
                RowMasks::Make if i < 4 => None,
                RowMasks::Known(bits) if i < 4 => Some(ray_bits(bits, i)),
                // An interactive move: the quadrature points' and the corners'
                // masks, made where not known yet.
                RowMasks::Move(bits) if i < 4 => {
                    Some(ray_bits(bits, i)).filter(|_| bits >> move_mask::QUAD & 1 == 1)
                }
                RowMasks::Move(bits) if i < 8 && move_mask::corners(m) => {
                    let flag = move_mask::CORNER + (i as u32 - 4);
                    let known = bits >> flag & 1 == 1;
                    if !known {
                        made.set(made.get() | 1 << flag);
                    }
                    Some(ray_bits(bits, i)).filter(|_| known)
                }
                _ => {
                    traced.set(None);
                    r.m = m_all;
                    let (v, bits) = oracle::visible_rays(&self.bvh, &r);
                    return (v, r, (m_all <= 64).then_some(bits));
                }
            };
            let found = oracle::masked_rays(&self.bvh, &r, mask, true);
            if mask.is_none() {
                made.set(made.get() | found.mask << (i as u32 * m));
            }
            if let Some(t) = traced.get() {
                traced.set(Some(t | found.blocked << (i as u32 * m)));
            }
            r.m = r.m.min(64);
            (found.vis_now, r, Some(found.mask & !found.blocked))
        };
        // Each ray's share of the entry, where its source's children are to take
        // their own visibility ([`EntryRay`]): `w F(x → s)` shared by the rays'
        // kernel weights as `PointRays::weighted` shares it.
        let record = |r: &oracle::PointRays, wf: f64, bits: u64, out: &mut Vec<EntryRay>| {
            let at = out.len();
            let mut ksum = 0.0;
            for (j, su, sv) in oracle::ray_params(r.m, r.key) {
                let y = oracle::point_in(gs, &ps, su, sv);
                let k = point_to_point_kernel(r.x, r.n, y, ns);
                ksum += k;
                let w = if bits >> j & 1 == 1 { k } else { -k };
                out.push(EntryRay {
                    st: [su as f32, sv as f32],
                    w: w as f32,
                });
            }
            let scale = if ksum > 0.0 {
                wf / ksum
            } else {
                // Every kernel weight zero: the plain mean, as `weighted` takes it.
                for (j, e) in out[at..].iter_mut().enumerate() {
                    e.w = if bits >> j & 1 == 1 { 1.0 } else { -1.0 };
                }
                wf / r.m as f64
            };
            for e in &mut out[at..] {
                e.w = (f64::from(e.w) * scale) as f32;
            }
        };
        let integrate = |pts: &mut dyn Iterator<Item = (DVec3, f64, u64)>,
                         mut out: Option<&mut Vec<EntryRay>>| {
            let (mut f, mut unoccluded) = (0.0, 0.0);
            let (mut vmin, mut vmax) = (1.0f64, 0.0f64);
            if let Some(o) = out.as_deref_mut() {
                o.clear();
            }
            for (x, w, i) in pts {
                let fx = match fq.get(i as usize) {
                    Some(&f) if i < q.count as u64 => f,
                    _ => point_to_polygon(x, n, &ps),
                };
                if fx <= 0.0 {
                    continue;
                }
                let (v, r, bits) = vis_at(x, i);
                match (out.as_deref_mut(), bits) {
                    (Some(o), Some(bits)) => record(&r, w * fx, bits, o),
                    // A point with more rays than a mask holds: no child takes
                    // its own visibility.
                    _ => out = None,
                }
                unoccluded += w * fx;
                f += w * fx * v;
                vmin = vmin.min(v);
                vmax = vmax.max(v);
            }
            (f, unoccluded, vmin, vmax, out.is_some())
        };
        let mut found_rays = Vec::new();
        let want = rays.is_some();
        let (mut f, mut unoccluded, vmin, vmax, mut complete) = integrate(
            &mut (0..q.count).map(|i| (q.points[i], q.weights[i], i as u64)),
            Some(&mut found_rays).filter(|_| want),
        );
        if matches!(masks, RowMasks::Move(_)) {
            // Every quadrature point whose rays count was cast (the others face
            // away from the source at every move: both ends stand still).
            made.set(made.get() | 1 << move_mask::QUAD);
        }
        if unoccluded > ROW_CORNER_MIN_COEF && (vmax <= 0.0 || vmin >= 1.0) {
            if let Some(t) = traced.get() {
                traced.set(Some(t | 1 << move_mask::CORNERS_SEEN));
            }
            let centre = q.points[..q.count].iter().sum::<DVec3>() / q.count as f64;
            let corners = oracle::poly(g);
            let common = vmax;
            let disagree = corners.corners().iter().enumerate().any(|(i, &c)| {
                let x = c + CORNER_INSET * (centre - c);
                point_to_polygon(x, n, &ps) > 0.0
                    && (vis_at(x, 4 + i as u64).0 - common).abs() > 0.5
            });
            if disagree {
                traced.set(None);
                let fine = oracle::fine_samples(g);
                (f, unoccluded, _, _, complete) = integrate(
                    &mut fine
                        .iter()
                        .enumerate()
                        .map(|(i, &(x, w))| (x, w, 8 + i as u64)),
                    Some(&mut found_rays).filter(|_| want),
                );
            }
        }
        let vis = if unoccluded > 0.0 {
            f / unoccluded
        } else {
            0.0
        };
        if let Some(out) = rays {
            out.clear();
            if want && complete && vis > 0.0 && vis < 1.0 {
                out.extend_from_slice(&found_rays);
            }
        }
        let traced = traced.get().map_or(0, |t| t | 1 << move_mask::SEEN);
        ((f, vis), made.get(), traced)
    }

    /// The visible fraction of surface source `s` (geometry `gs`, polygon `ps`,
    /// normal `ns`) from point `x` (normal `n`) of leaf `leaf` (geometry `g`), for
    /// the row of chain link `l`; `i` numbers the point: the quadrature points
    /// (`i < 4`) keep the keys rows always had; corners and the finer rule (`i >= 4`)
    /// take their own, from the source element rather than the link (so they do not
    /// depend on the order the links were made in).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn row_point_visibility(
        &self,
        ids: RowRayIds,
        g: &Geom,
        gs: &Geom,
        ps: &crate::geometry::Poly,
        ns: DVec3,
        x: DVec3,
        n: DVec3,
        i: u64,
    ) -> f64 {
        oracle::visible_fraction(&self.bvh, &self.row_rays(ids, g, gs, ps, ns, x, n, i))
    }

    /// The rays of [`Solver::row_point_visibility`]: `rays_per_point` of them from
    /// point `i` at `x`, keyed by [`Solver::row_ray_key`], the leaf's and the
    /// source's patches skipped.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn row_rays<'a>(
        &self,
        ids: RowRayIds,
        g: &Geom,
        gs: &'a Geom,
        ps: &'a crate::geometry::Poly,
        ns: DVec3,
        x: DVec3,
        n: DVec3,
        i: u64,
    ) -> oracle::PointRays<'a> {
        oracle::PointRays {
            x,
            n,
            gs,
            pols: ps,
            ns,
            m: self.opts.rays_per_point,
            key: self.row_ray_key(ids, i),
            skip: [g.patch, gs.patch],
        }
    }

    /// The jitter key of the rays of [`Solver::row_point_visibility`] at point `i`.
    fn row_ray_key(&self, ids: RowRayIds, i: u64) -> u64 {
        if i < 4 {
            oracle::hash3(self.opts.seed ^ 0x1eaf, ids.link, ids.leaf << 3 | i)
        } else {
            oracle::hash3(self.opts.seed ^ 0x1eb0, ids.source, ids.leaf << 5 | (i - 4))
        }
    }

    /// Whether [`Solver::push_opened`] opens the entry of source `s` (coefficient
    /// `coef`) in the row of a leaf with quadrature `q`, and whether for its size
    /// (`true, true`) rather than its spread.
    fn row_opens(&self, q: &oracle::Samples, s: u32, coef: f64) -> (bool, bool) {
        let gs = &self.elems.geoms.as_slice()[s as usize];
        let node = self.elems.nodes.as_slice()[s as usize];
        if node.child_count == 0 || gs.patch == u32::MAX {
            return (false, false);
        }
        let ratio = self.opts.row_open_ratio;
        let (c, rad) = self.row_sphere(s as usize, gs);
        let near = (0..q.count)
            .map(|i| q.points[i].distance(c))
            .fold(f64::INFINITY, f64::min);
        let large = ratio > 0.0 && coef > ROW_OPEN_MIN_COEF && rad > ratio * near;
        // What the source's mean misses ([`ROW_OPEN_SPREAD`]).
        let spread = self.sys.row_spread.get(s as usize).copied().unwrap_or(0.0) as f64;
        (
            large || coef * (rad / near.max(rad)) * spread > self.sys.row_spread_limit,
            large,
        )
    }

    /// [`oracle::sphere`] of element `s` (geometry `g`): from the table
    /// [`Solver::compute_leaf_rows`] makes for its rows, or computed.
    ///
    /// Why: the rows ask it of an opened source's children three times each (its
    /// shares, whether each opens, and again as it is pushed), for every leaf
    /// that opens it: the centroids were 6% of the empty Cornell box's CPU at
    /// eps 0.1 (BENCHMARKS.md, "Static solver: error against run time").
    fn row_sphere(&self, s: usize, g: &Geom) -> (DVec3, f64) {
        self.sys
            .row_spheres
            .get(s)
            .copied()
            .unwrap_or_else(|| oracle::sphere(g))
    }

    /// Pushes a leaf's row entry for source `s` (coefficient `coef`, visible
    /// fraction `vis`), opening a surface source into its children while it looks
    /// large from the leaf ([`SolveOptions::row_open_ratio`]) or, in a static solve,
    /// while its mean misses more than [`ROW_OPEN_SPREAD`] of the light the entry
    /// carries (`coef · (r/d) · ΔB_s`, the spread as the last solve left it).
    ///
    /// Why: the leaf system gathers a source's *average* radiosity. Where a big
    /// source is linked whole to some receivers and in pieces to others (a floor
    /// linked whole to the ceiling, in pieces to the walls near its edges), each of
    /// its points hands on a share of its light that is not its own (the averaged
    /// form factors of its links do not sum to 1 point by point), and where the
    /// bright part hands on too little the solution loses energy (a closed room lit
    /// by a lamp flush in its ceiling, test `the_leaf_system_conserves_energy`); the
    /// loss grew as refinement mixed the levels more. Cost: more row entries (see
    /// [`ROW_OPEN_MIN_COEF`]).
    ///
    /// The children's exact polygon factors, with the link's visible fraction, sum
    /// to the parent's; each child brings its own radiosity. No ray is cast and no
    /// link is made. A source opened for its spread alone (not large) is shared
    /// among its children by the kernel taken linear across it ([`linear_shares`]:
    /// as close as the polygon factors on the Cornell box, 0.400% against 0.401%
    /// at eps 0.1, without a polygon factor per child and quadrature point), and a
    /// child that is not opened further moves its share from its area's by
    /// [`WITHIN_CHILD`] times that: it stands for a radiosity that goes on varying
    /// inside it. The shares sum to the parent's coefficient either way. Cluster sources are not opened: their children would take the
    /// cluster's visibility average, which measured worse on cluttered scenes.
    ///
    /// `memo`, for a static leaf in a window's frame, holds the factors to static
    /// base elements already computed in the window ([`Window::factors`]): they are
    /// taken from it, and the new ones handed back in it. `kept`, for a leaf of a
    /// static solve, the factors its row took in the round before
    /// ([`OpenedFactors`]), likewise.
    ///
    /// `rays`, where the entry is partly hidden, are its rays ([`EntryRay`]): each
    /// child takes the visible fraction of the rays that land on it, the entry's
    /// `vis` where none does. Why: the children sharing the link's fraction gather
    /// the mean of their radiosities times the mean of their visibilities, where
    /// what hides a part of the source may be what shades it (the floor under a
    /// head hung below a ceiling lamp, seen from the ceiling), and the mean of the
    /// products is then the larger.
    #[allow(clippy::too_many_arguments)]
    fn push_opened(
        &self,
        q: &oracle::Samples,
        n: DVec3,
        s: u32,
        coef: f64,
        vis: f64,
        rays: &[EntryRay],
        row: &mut Vec<(u32, f64)>,
        mut memo: Option<&mut FactorMemo>,
        mut kept: Option<&mut OpenedMemo>,
    ) {
        if coef <= 0.0 {
            return;
        }
        let geoms = self.elems.geoms.as_slice();
        let gs = &geoms[s as usize];
        let node = self.elems.nodes.as_slice()[s as usize];
        let (open, large) = self.row_opens(q, s, coef);
        if !open {
            row.push((s, coef));
            return;
        }
        // Each child's rays and visible fraction.
        let triangle = gs.n == 3;
        let mut on_child = Vec::new();
        let child_vis = |j: usize, on_child: &mut Vec<EntryRay>| {
            if rays.is_empty() {
                on_child.clear();
                return vis;
            }
            child_rays(rays, triangle, j, on_child);
            rays_visibility(on_child).unwrap_or(vis)
        };
        // Opened for its spread: shares by the kernel taken linear across the
        // source, no polygon factor per child.
        // The children's area centroids, as [`oracle::sphere`] takes them.
        let centroid = |ch: usize| self.row_sphere(ch, &geoms[ch]).0;
        if !large
            && let Some(mut shares) = linear_shares(
                q,
                n,
                geoms,
                gs,
                self.row_sphere(s as usize, gs),
                node,
                centroid,
            )
        {
            // A child that stays whole stands for a linear radiosity: its share
            // moves from its area's by the part within it too ([`WITHIN_CHILD`]).
            let k = node.child_count as usize;
            let sum = within_child_shares(&mut shares, geoms, node, |j, share| {
                !self
                    .row_opens(q, node.first_child + j as u32, coef * share)
                    .0
            });
            if sum > 0.0 && shares.iter().take(k).all(|&x| x >= 0.0) {
                for (j, share) in shares.iter().enumerate().take(k) {
                    let ch = node.first_child + j as u32;
                    let v = child_vis(j, &mut on_child);
                    let c = if rays.is_empty() || v == vis {
                        coef * share / sum
                    } else {
                        coef / vis * v * share / sum
                    };
                    self.push_opened(
                        q,
                        n,
                        ch,
                        c,
                        v,
                        &on_child,
                        row,
                        memo.as_deref_mut(),
                        kept.as_deref_mut(),
                    );
                }
                return;
            }
        }
        let base_len = self.st.window.as_ref().map_or(0, |w| w.frame.elems_len);
        for ch in node.first_child..node.first_child + node.child_count {
            // Rounded to `f32` as [`OpenedFactors`] keeps it, so a static solve
            // and a space-time window ([`Window::factors`], `f64`) open a source
            // into the same entries.
            let factor = || {
                let ps = oracle::poly(&self.elems.geoms.as_slice()[ch as usize]);
                (0..q.count)
                    .map(|i| q.weights[i] * point_to_polygon(q.points[i], n, &ps))
                    .sum::<f64>() as f32 as f64
            };
            // Asked only with a memo: a static scene or a moving leaf pays nothing.
            let steady = || (ch as usize) < base_len && !self.elem_moving(ElementId(ch));
            let f = match memo.as_deref_mut().filter(|_| steady()) {
                Some(m) => match m.kept.get(&(m.leaf, ch)) {
                    Some(&f) => f,
                    None => {
                        let f = factor();
                        m.fresh.push(((m.leaf, ch), f));
                        f
                    }
                },
                None => match kept.as_deref_mut() {
                    Some(k) => k.factor(ch, factor),
                    None => factor(),
                },
            };
            let v = child_vis((ch - node.first_child) as usize, &mut on_child);
            self.push_opened(
                q,
                n,
                ch,
                f * v,
                v,
                &on_child,
                row,
                memo.as_deref_mut(),
                kept.as_deref_mut(),
            );
        }
    }

    /// The key of a static leaf's row entry for chain link `l` from source `s` in
    /// the window's caches: `(leaf, link)` for a link of the window's base; a link
    /// a frame made is keyed by its source (a leaf's chain links have distinct
    /// sources), whose coefficient does not depend on the link's receiver
    /// ([`Solver::row_link_id`]). `None` outside a frame, for a moving leaf, or
    /// an element with no stable id.
    fn row_key(&self, leaf: ElementId, l: u32, s: u32) -> Option<(u32, u32)> {
        let w = self.st.window.as_ref().filter(|w| w.in_frame)?;
        if self.elem_moving(leaf) {
            return None;
        }
        let sl = self.stable_id(leaf.0);
        let lk = if (l as usize) < w.frame.links_len {
            l
        } else {
            let ss = self.stable_id(s);
            if ss == u32::MAX {
                return None;
            }
            1 << 31 | ss
        };
        (sl != u32::MAX).then_some((sl, lk))
    }

    /// What the row rays of leaf `leaf` to the source `s` of its chain link `l`
    /// hash their jitter from, worked out once for all the leaf's points.
    pub(super) fn row_ray_ids(&self, leaf: ElementId, l: u32, s: u32) -> RowRayIds {
        RowRayIds {
            leaf: self.ray_id(leaf.0),
            link: self.row_link_id(l, s),
            source: self.ray_id(s),
        }
    }

    /// What the row rays of chain link `l` (source `s`) hash their jitter from:
    /// for a link of the shared part (every link of a static solve), its ends'
    /// [`Solver::ray_id`]s, which do not change when a static solve drops its
    /// passive links and renumbers the rest ([`crate::pools::LinkPool::drop_passive`]), so a
    /// static solve casts the rays the space-time solve of the same scene casts;
    /// for a link a frame made, its source's (a leaf's chain links have distinct
    /// sources).
    fn row_link_id(&self, l: u32, s: u32) -> u64 {
        let shared = self.st.window.as_ref().map_or(0, |w| w.base.links_len);
        if shared == 0 || (l as usize) < shared {
            let r = self.links.ends.as_slice()[l as usize].receiver;
            oracle::hash3(self.ray_id(r), self.ray_id(s), 0x11e4)
        } else {
            self.ray_id(s) ^ 1 << 62
        }
    }

    /// True if no moving object's box (where it is now) meets the shaft between the
    /// surface elements `a` and `b` (Haines & Wallace; [`crate::shafts::Shaft`]),
    /// which holds every segment between them and so every ray of a leaf row
    /// between them: their rays then meet static geometry only
    /// ([`crate::shafts::clear_of_boxes`]: the box of both ends, the line between
    /// their centres, then the shaft, whose hull planes clear the leaves whose view
    /// of a lamp passes beside a moving object inside the box of both ends).
    pub(super) fn clear_of_moving(&self, a: &Geom, b: &Geom) -> bool {
        let corners =
            |g: &Geom| -> [DVec3; 4] { std::array::from_fn(|i| DVec3::from_array(g.corners[i])) };
        let (pa, pb) = (corners(a), corners(b));
        crate::shafts::clear_of_boxes(
            &pa[..a.n as usize],
            DVec3::from_array(a.normal),
            &pb[..b.n as usize],
            DVec3::from_array(b.normal),
            &self.motion.moving_now,
        )
    }

    /// True if opening a source again would give `entries` again: each is an
    /// element of the window's base (a frame's refinement appends after them) with
    /// no children the frame refined ([`Window::opened`]).
    pub(super) fn opened_settled(&self, entries: &[(u32, f64)]) -> bool {
        let base_len = self.st.window.as_ref().map_or(0, |w| w.frame.elems_len);
        let nodes = self.elems.nodes.as_slice();
        entries.iter().all(|&(e, _)| {
            let node = nodes[e as usize];
            (e as usize) < base_len
                && (node.child_count == 0 || (node.first_child as usize) < base_len)
        })
    }

    /// Leaf rows: every chain link's source with its coefficient re-integrated over
    /// the leaf.
    ///
    /// The link hierarchy decides *which* sources a leaf gathers from and at what
    /// level (the links of the leaf and of its ancestors, which cover the scene
    /// exactly once); each source's coefficient is then integrated over the leaf
    /// itself, `F = Σ_q w_q F(x_q → A_s) · V(x_q, s)` at its quadrature points with
    /// the exact inner factor, `V = 1` where a shaft proved the link clear and rays
    /// from the leaf's own points otherwise ([`Solver::hidden_row_coef`]). Pushing an
    /// ancestor's irradiance down instead would hand every leaf the ancestor's
    /// average coupling, far off for a small leaf beside a wall or a block, and
    /// `ρ → 1` amplifies a row's defect by `1/(1 − ρ)`. At every quadrature point the
    /// factors of a partition of a closed room sum to 1 exactly, so `B = E/(1 − ρ)`
    /// holds to round-off. The price: a GMRES step costs the sum of the leaves' chain
    /// lengths, not the link count. A static solve keeps the surface entries from
    /// round to round ([`KeptCoef`]); a cluster source's entry is its directional
    /// estimate at the leaf's points and orientation, recomputed once after each
    /// solve from the radiosity it depends on (`Solver::refresh_cluster_rows`).
    pub(super) fn compute_leaf_rows(&mut self) {
        self.intern_frame_elements();
        // A static solve opens sources by their spread too ([`ROW_OPEN_SPREAD`]),
        // as the last solve left them; so does a space-time window of one instant
        // (a static scene solved in space-time), which must equal it.
        // A window's frame passes go on while refinement changes links, where the
        // static solve's rounds stop: rows rebuilt over the same leaves keep the
        // spread they were built with, so that such a pass changes nothing.
        let same_leaves = self.st.window.is_some()
            && !self.sys.row_spread.is_empty()
            && self.sys.row_spread_leaves == self.sys.leaves.len();
        if self.has_motion() || self.window_spans_time() {
            self.sys.row_spread = Vec::new();
            self.sys.row_spread_limit = f64::INFINITY;
        } else if !same_leaves {
            self.sys.row_spread_leaves = self.sys.leaves.len();
            self.sys.row_spread = self.radiosity_spread();
            self.sys.row_spread_limit = ROW_OPEN_SPREAD * self.rms_radiosity();
        }
        // The elements stay as they are while the rows are made.
        self.sys.row_spheres = self
            .elems
            .geoms
            .as_slice()
            .par_iter()
            .map(oracle::sphere)
            .collect();
        let elems = &self.elems;
        let geoms = elems.geoms.as_slice();
        let ends = self.links.ends.as_slice();
        let tr = self.links.transports.as_slice();
        let cache = self.st.window.as_ref().map(|w| &w.rows);
        let opened = self.st.window.as_ref().map(|w| &w.opened);
        let hidden = self.st.window.as_ref().map(|w| &w.hidden);
        let entry_rays = self.st.window.as_ref().map(|w| &w.entry_rays);
        let masks = self.st.window.as_ref().map(|w| &w.masks);
        let rays_per_point = self.opts.rays_per_point;
        let factors = self
            .st
            .window
            .as_ref()
            .filter(|w| w.in_frame)
            .map(|w| (&w.factors, w.frame.elems_len));
        // A static scene keeps each leaf's coefficients from round to round.
        let keep_rows = !self.has_motion();
        // An interactive session's start-up (links kept, objects that move, no
        // window) records each row's entries by chain link for its first moves to
        // keep (`super::moves`; reused by no round of its own: the cluster parts'
        // rays follow the radiosity).
        let record = self.opts.keep_passive && self.has_motion() && self.st.window.is_none();
        self.sys.move_cluster_cache.clear();
        let mut parts_before = std::mem::take(&mut self.sys.cluster_cache);
        let mut factors_before = std::mem::take(&mut self.sys.opened_factors);
        // A window's frame records its entries with a moving end, and takes them
        // between the solved frames around it where they hold.
        let timed = self.st.window.as_ref().is_some_and(|w| w.in_frame);
        let passed = Some(&self.st.pass_rows).filter(|_| timed);
        let pass_rays = &self.st.pass_rays[..];
        let radiosities = self.elems.radiosities.as_slice();
        let inputs = RowInputs {
            geoms,
            ends,
            tr,
            cache,
            opened,
            hidden,
            entry_rays,
            pass_rays,
            masks,
            rays_per_point,
            factors,
            keep_rows,
            keep_clusters: record,
            patch: None,
            timed,
            passed,
            radiosities,
        };
        // The rows are made a chunk of leaves at a time, each chunk's kept parts
        // freed once read: the parts kept and the parts being kept are not held
        // whole at once (with the parts of the links walked again kept, the
        // 32 × 32 boxes of `the_clutter_keeps_its_light` peaked at 1.28 GB
        // instead of 1.01).
        //
        // Each chunk's rows go into the leaf system (CSR) and its kept records into
        // the new caches as soon as it is made, and the old caches' records of its
        // leaves are freed: a row's entries are held once, as the leaf system holds
        // them (12 bytes), not also as every leaf's `LeafRow` (16 bytes an entry)
        // until the last leaf is done, nor beside the last round's rows. On
        // `gen_furnished.py --detail 0.15 --static` the rows' entries were 374 MB
        // of `LeafRow`s beside the 335 MB system at the peak (BENCHMARKS.md, "Scale").
        self.sys.row_start = Vec::new();
        self.sys.row_sources = Vec::new();
        self.sys.row_coefs = Vec::new();
        let mut rows = LeafRows {
            start: vec![0],
            ..Default::default()
        };
        let mut row_cache = FastMap::default();
        let mut row_rays = FastMap::default();
        let mut part_rays = FastMap::default();
        let mut part_rays_before = std::mem::take(&mut self.sys.part_rays);
        let mut cluster_cache = FastMap::default();
        let mut opened_factors = FastMap::default();
        for chunk in self.sys.leaves.chunks(ROW_CHUNK) {
            let made: Vec<LeafRow> = chunk
                .par_iter()
                .map(|&leaf| {
                    let parts = parts_before.get(&leaf.0).map(Vec::as_slice);
                    let rays = part_rays_before.get(&leaf.0).map_or(&[][..], Vec::as_slice);
                    self.leaf_row(&inputs, leaf, parts, rays, factors_before.get(&leaf.0))
                })
                .collect();
            for (&leaf, mut out) in chunk.iter().zip(made) {
                parts_before.remove(&leaf.0);
                factors_before.remove(&leaf.0);
                self.sys.row_cache.remove(&leaf.0);
                self.sys.row_rays.remove(&leaf.0);
                part_rays_before.remove(&leaf.0);
                rows.push(&mut out.row);
                if keep_rows {
                    // Held to the next round: without the growth's spare room.
                    let mut kept = std::mem::take(&mut out.kept);
                    kept.shrink_to_fit();
                    row_cache.insert(leaf.0, kept);
                    let mut kept_rays = std::mem::take(&mut out.kept_rays);
                    if !kept_rays.is_empty() {
                        kept_rays.shrink_to_fit();
                        row_rays.insert(leaf.0, kept_rays);
                    }
                    let mut kept_parts = std::mem::take(&mut out.part_rays);
                    if !kept_parts.is_empty() {
                        kept_parts.shrink_to_fit();
                        part_rays.insert(leaf.0, kept_parts);
                    }
                    let mut clusters = std::mem::take(&mut out.clusters);
                    clusters.shrink_to_fit();
                    if !clusters.is_empty() {
                        cluster_cache.insert(leaf.0, clusters);
                    }
                    let factors = std::mem::take(&mut out.opened_factors);
                    if !factors.elems.is_empty() {
                        opened_factors.insert(leaf.0, factors);
                    }
                }
                if !out.is_spent() {
                    rows.rest.push((leaf, out));
                }
            }
        }
        self.sys.row_spheres = Vec::new();
        self.sys.row_cache = row_cache;
        self.sys.row_rays = row_rays;
        self.sys.part_rays = part_rays;
        self.sys.cluster_cache = cluster_cache;
        self.sys.opened_factors = opened_factors;
        self.store_leaf_rows(rows);
    }

    /// The rows of `leaves` alone, computed as [`Solver::compute_leaf_rows`]
    /// computes them outside a space-time window, reusing the surface entries
    /// kept in the row cache as a static solve does: an interactive move
    /// recomputes only the rows whose chain links it changed, and in them only the
    /// entries of those links (`super::moves`), and of those only the entries the
    /// move can have changed (`patch`, `super::row_patch`). Each row comes with the
    /// entries to keep for it.
    pub(super) fn rows_of(&self, leaves: &[ElementId], patch: &RowPatch) -> Vec<LeafRow> {
        let patch = Some(patch);
        let inputs = RowInputs {
            geoms: self.elems.geoms.as_slice(),
            ends: self.links.ends.as_slice(),
            tr: self.links.transports.as_slice(),
            cache: None,
            opened: None,
            hidden: None,
            entry_rays: None,
            pass_rays: &[],
            masks: None,
            rays_per_point: self.opts.rays_per_point,
            factors: None,
            keep_rows: true,
            keep_clusters: true,
            patch,
            timed: false,
            passed: None,
            radiosities: self.elems.radiosities.as_slice(),
        };
        leaves
            .par_iter()
            .map(|&leaf| self.leaf_row(&inputs, leaf, None, &[], None))
            .collect()
    }

    /// One leaf's row ([`Solver::compute_leaf_rows`]): each chain link's source
    /// opened at its coefficient over the leaf, from the caches where they hold
    /// (`parts_before`: the cluster parts an earlier round kept for the leaf;
    /// `factors_before`: the factors of the children its sources opened into;
    /// `part_rays_before`: the rays of its kept cluster parts, [`KeptRays`]).
    fn leaf_row(
        &self,
        inputs: &RowInputs,
        leaf: ElementId,
        parts_before: Option<&[ClusterPart]>,
        part_rays_before: &[KeptRays],
        factors_before: Option<&OpenedFactors>,
    ) -> LeafRow {
        let RowInputs {
            geoms,
            ends,
            tr,
            cache,
            opened,
            factors,
            keep_rows,
            keep_clusters,
            timed,
            patch,
            ..
        } = *inputs;
        let settled = |entries: &[(u32, f64)]| self.opened_settled(entries);
        let g = &geoms[leaf.ix()];
        let q = oracle::samples(g);
        let n = DVec3::from_array(g.normal);
        let leaf_moving = self.elem_moving(leaf);
        let leaf_near = patch.is_some_and(|p| {
            let (lo, hi) = geom_box(g);
            crate::shafts::meets_any(lo, hi, &p.near)
        });
        let mut out = LeafRow::default();
        let leaf_ray = self.ray_id(leaf.0);
        let rho_leaf = self.rho_of(leaf);
        let before = self.sys.row_cache.get(&leaf.0).filter(|_| keep_rows);
        let rays_before = self
            .sys
            .row_rays
            .get(&leaf.0)
            .filter(|_| keep_rows)
            .map_or(&[][..], Vec::as_slice);
        let mut fresh_rays = Vec::new();
        // A static solve reuses its cluster parts from round to round; an
        // interactive move (`keep_clusters`) the entries of the links it left.
        let clusters_before = parts_before.filter(|_| keep_rows && !keep_clusters);
        let moved_before = self
            .sys
            .move_cluster_cache
            .get(&leaf.0)
            .filter(|_| keep_clusters);
        // A static leaf (of the window's base or made again by this
        // frame) reuses the factors to the static base elements its
        // sources open into.
        let leaf_sid = Some(self.stable_id(leaf.0)).filter(|&x| !leaf_moving && x != u32::MAX);
        let mut memo = factors.zip(leaf_sid).map(|((kept, _), sid)| FactorMemo {
            leaf: sid,
            kept,
            fresh: Vec::new(),
        });
        // A static solve's leaf keeps the factors of the children it opens into
        // from round to round ([`OpenedFactors`]).
        let mut opened_memo =
            (keep_rows && !keep_clusters && self.st.window.is_none()).then(|| OpenedMemo {
                before: factors_before,
                used: Vec::with_capacity(factors_before.map_or(0, |b| b.elems.len())),
            });
        for l in self.chain_links(leaf) {
            let t = &tr[l as usize];
            let s = ends[l as usize].source;
            let gs = &geoms[s as usize];
            // An interactive move keeps every entry of the links it left, surface
            // sources' opened entries as well as clusters': a recomputed row pays
            // only for the links the move touched.
            let kept = moved_before
                .and_then(|c| c.binary_search_by_key(&l, |x| x.0).ok().map(|i| &c[i].1));
            // Those it evaluated again are updated in place where they can be
            // (`super::row_patch`).
            let stale = patch.is_some_and(|p| p.is_stale(l, leaf_near));
            let kept_rays = |l: u32| kept_rays_of(rays_before, l, s);
            let kept_coef = || {
                before
                    .filter(|_| gs.patch != u32::MAX)
                    .and_then(|p| p.binary_search_by_key(&l, |x| x.link).ok().map(|i| p[i]))
            };
            if let Some(entries) = kept {
                let at = out.row.len();
                let kept_all = !stale;
                if kept_all {
                    out.row.extend_from_slice(entries);
                }
                let patched = kept_all
                    || patch.is_some_and(|p| {
                        self.patch_entries(p, leaf, l, &q, n, entries, &mut out.row)
                    });
                if patched {
                    out.move_clusters.push((l, out.row[at..].into()));
                    out.kept.extend(kept_coef());
                    out.kept_rays.extend(kept_rays(l).cloned());
                    continue;
                }
            } else if let Some((p, c)) = patch.zip(moved_before) {
                // A child of a link the move split: its parent's entries.
                let at = out.row.len();
                if self.inherit_entries(p, leaf, l, &q, n, c, &mut out.row) {
                    out.move_clusters.push((l, out.row[at..].into()));
                    continue;
                }
            }
            let before = before.filter(|_| !stale);
            let at = out.row.len();
            if gs.patch == u32::MAX {
                let reused = clusters_before.map_or(KeptParts::None, |parts| {
                    self.push_kept_cluster(
                        &q,
                        n,
                        l,
                        parts,
                        &mut out.row,
                        &mut out.clusters,
                        part_rays_before,
                        &mut out.part_rays,
                    )
                });
                let known = match reused {
                    KeptParts::Used => None,
                    KeptParts::None => Some(&[][..]),
                    KeptParts::Walk(known) => Some(known),
                };
                if let Some(known) = known {
                    let keep = keep_rows && !keep_clusters;
                    let kept = Some(&mut out.clusters).filter(|_| keep);
                    let kept_rays = Some(&mut out.part_rays).filter(|_| keep);
                    self.push_cluster_known(
                        leaf,
                        l,
                        &q,
                        n,
                        s,
                        &mut out.row,
                        kept,
                        &mut |_| false,
                        known,
                        kept_rays,
                        part_rays_before,
                    );
                }
                if keep_clusters {
                    out.move_clusters.push((l, out.row[at..].into()));
                }
                continue;
            }
            if let Some(k) =
                before.and_then(|p| p.binary_search_by_key(&l, |x| x.link).ok().map(|i| p[i]))
            {
                out.kept.push(k);
                let rays = kept_rays(l).filter(|_| !stale);
                self.push_opened(
                    &q,
                    n,
                    s,
                    k.coef as f64,
                    k.vis as f64,
                    rays.map_or(&[][..], |r| &r.rays),
                    &mut out.row,
                    memo.as_mut(),
                    opened_memo.as_mut(),
                );
                out.kept_rays.extend(rays.cloned());
                if keep_clusters {
                    out.move_clusters.push((l, out.row[at..].into()));
                }
                continue;
            }
            // Constant link, static leaf: the coefficient of an earlier
            // frame of the window holds.
            // A static leaf in a frame, keyed as the window's caches key it
            // (a frame's own leaves and links by what they stand for).
            let key = self.row_key(leaf, l, s);
            let static_base = key.is_some();
            let cacheable = static_base && !t.varying();
            let key = key.unwrap_or_default();
            if let Some(&(c, v)) = cache.filter(|_| cacheable).and_then(|c| c.get(&key)) {
                if let Some(entries) = opened.and_then(|o| o.get(&key)).filter(|e| settled(e)) {
                    out.row.extend_from_slice(entries);
                    continue;
                }
                let at = out.row.len();
                let rays = inputs.entry_rays.and_then(|m| m.get(&key));
                self.push_opened(
                    &q,
                    n,
                    s,
                    c as f64,
                    v as f64,
                    rays.map_or(&[][..], |r| &r[..]),
                    &mut out.row,
                    memo.as_mut(),
                    opened_memo.as_mut(),
                );
                let entries = &out.row[at..];
                if entries.len() > 1 && settled(entries) {
                    out.opened.push((key, entries.into()));
                }
                continue;
            }
            // An entry with a moving end, keyed for the frames around.
            let tkey =
                (timed && gs.patch != u32::MAX && (leaf_moving || self.elem_moving(ElementId(s))))
                    .then(|| (leaf_ray, self.row_link_id(l, s)));
            let (coef, vis) = self.fresh_row_coef(
                inputs,
                leaf,
                l,
                s,
                &q,
                n,
                rho_leaf,
                key,
                static_base,
                cacheable,
                tkey,
                &mut out,
                &mut fresh_rays,
            );
            if cache.is_some() && cacheable {
                out.fresh.push((key, (coef as f32, vis as f32)));
                if !fresh_rays.is_empty() {
                    out.fresh_rays.push((key, fresh_rays.as_slice().into()));
                }
            }
            if let Some(k) = tkey {
                out.timed.push((k, (coef as f32, vis as f32)));
            }
            // Rounded once as every cache keeps them (`f32`), so a reused entry
            // equals the first: a space-time window's frames read both from its
            // caches, a static solve's later rounds from [`KeptCoef`], and a
            // static solve and the shared part of a space-time solve of the same
            // scene then build the same rows.
            let (coef, vis) = (coef as f32 as f64, vis as f32 as f64);
            if keep_rows {
                out.kept.push(KeptCoef {
                    link: l,
                    coef: coef as f32,
                    vis: vis as f32,
                });
                if !fresh_rays.is_empty() {
                    out.kept_rays.push(KeptRays {
                        link: l,
                        elem: s,
                        rays: fresh_rays.as_slice().into(),
                    });
                }
            }
            self.push_opened(
                &q,
                n,
                s,
                coef,
                vis,
                &fresh_rays,
                &mut out.row,
                memo.as_mut(),
                opened_memo.as_mut(),
            );
            let trace = std::mem::take(&mut out.trace);
            self.keep_move_trace(leaf, l, s, trace, &out.row[at..]);
            if keep_clusters {
                out.move_clusters.push((l, out.row[at..].into()));
            }
        }
        out.kept.sort_unstable_by_key(|x| x.link);
        out.kept_rays.sort_unstable_by_key(|x| (x.link, x.elem));
        out.part_rays.sort_unstable_by_key(|x| (x.link, x.elem));
        // Stable: a link's parts stay in the order its row took them.
        out.clusters.sort_by_key(|x| x.link);
        out.move_clusters.sort_unstable_by_key(|x| x.0);
        out.factors = memo.map(|m| m.fresh).unwrap_or_default();
        out.opened_factors = opened_memo.map(OpenedMemo::keep).unwrap_or_default();
        out
    }

    /// The coefficient and visibility of the entry of link `l` (source `s`) in the
    /// row of `leaf` (quadrature `q`, normal `n`) that no cache holds: taken between
    /// the solved frames around, from an earlier pass, integrated where a shaft
    /// proved the link clear, or cast from the leaf's points
    /// ([`Solver::hidden_row_coef`]). Records what the caches are to keep.
    #[allow(clippy::too_many_arguments)]
    fn fresh_row_coef(
        &self,
        inputs: &RowInputs,
        leaf: ElementId,
        l: u32,
        s: u32,
        q: &oracle::Samples,
        n: DVec3,
        rho_leaf: f64,
        key: (u32, u32),
        static_base: bool,
        cacheable: bool,
        tkey: Option<(u64, u64)>,
        out: &mut LeafRow,
        rays: &mut Vec<EntryRay>,
    ) -> (f64, f64) {
        rays.clear();
        let RowInputs {
            geoms,
            tr,
            hidden,
            entry_rays,
            pass_rays,
            masks,
            rays_per_point,
            timed,
            passed,
            radiosities,
            ..
        } = *inputs;
        let t = &tr[l as usize];
        let gs = &geoms[s as usize];
        let on_line = || {
            let (k, r) = tkey.zip(self.st.time_range.as_ref())?;
            let bs = radiosities[s as usize]
                .iter()
                .fold(0.0f32, |m, &x| m.max(x));
            r.value(&k, rho_leaf * f64::from(bs))
        };
        // What an earlier pass of this frame computed for this entry.
        let earlier = passed.and_then(|p| {
            let i = p.binary_search_by_key(&(leaf.0, l), |e| e.0).ok()?;
            Some(p[i].1)
        });
        if let Some(cv) = on_line() {
            // Decided again at each pass: the light it weighs moves.
            out.between += 1;
            cv
        } else if let Some(cv) = earlier {
            if let Ok(i) = pass_rays.binary_search_by_key(&(leaf.0, l), |e| e.0) {
                rays.extend_from_slice(&pass_rays[i].1);
            }
            cv
        } else if t.shaft_clear() {
            let ps = oracle::poly(gs);
            let f = (0..q.count)
                .map(|i| q.weights[i] * point_to_polygon(q.points[i], n, &ps))
                .sum();
            // Not what the window keeps anyway.
            if timed && !cacheable {
                out.passed.push(((leaf.0, l), (f, 1.0)));
            }
            (f, 1.0)
        } else {
            // Partly hidden: visibility from the leaf's own points, not
            // the ancestor's average. A varying link between static
            // ends, with no moving object's box in the shaft between
            // the ends now, casts only at static geometry with the same
            // keys as at any other such frame (`ray_id`).
            let static_ends = hidden.is_some() && static_base && !self.elem_moving(ElementId(s));
            let steady = static_ends && self.clear_of_moving(&geoms[leaf.ix()], gs);
            // Not steady: the static part of the rays at the leaf's
            // points holds over the window ([`Window::masks`]).
            let maskable = static_ends && !steady && rays_per_point * q.count as u32 <= 64;
            match hidden.filter(|_| steady).and_then(|h| h.get(&key)) {
                Some(&cv) => {
                    if let Some(r) = entry_rays.and_then(|m| m.get(&key)) {
                        rays.extend_from_slice(r);
                    }
                    cv
                }
                None => {
                    let known = masks.filter(|_| maskable).and_then(|m| m.get(&key));
                    let how = match known {
                        Some(&bits) => RowMasks::Known(bits),
                        None if maskable => RowMasks::Make,
                        None => RowMasks::None,
                    };
                    // An interactive move's rows: masks of their own.
                    let moved = match how {
                        RowMasks::None => self.move_row_masks(leaf, l, s, q),
                        _ => RowMasks::None,
                    };
                    let cast = if matches!(moved, RowMasks::None) {
                        how
                    } else {
                        moved
                    };
                    let (cv, made, trace) =
                        self.hidden_row_coef(leaf, l, s, q, n, cast, Some(&mut *rays));
                    out.trace = trace;
                    if matches!(how, RowMasks::Make) {
                        out.masks.push((key, made));
                    }
                    self.keep_move_mask(leaf, l, s, moved, made);
                    if steady {
                        out.hidden.push((key, cv));
                        if !rays.is_empty() {
                            out.fresh_rays.push((key, rays.as_slice().into()));
                        }
                    }
                    if timed && !cacheable && !steady {
                        out.passed.push(((leaf.0, l), cv));
                        if !rays.is_empty() {
                            out.passed_rays.push(((leaf.0, l), rays.as_slice().into()));
                        }
                    }
                    cv
                }
            }
        }
    }

    /// Installs the leaves' rows ([`Solver::compute_leaf_rows`]) and hands the
    /// space-time window's caches and the interactive moves' what they keep of them.
    fn store_leaf_rows(&mut self, rows: LeafRows) {
        let LeafRows {
            start,
            sources,
            coefs,
            rest,
        } = rows;
        self.sys.row_start = start;
        self.sys.row_sources = sources;
        self.sys.row_coefs = coefs;
        self.st.frame_rows.0.clear();
        self.st.rows_between = 0;
        for (leaf, out) in rest {
            let LeafRow {
                fresh,
                opened: fresh_opened,
                hidden: fresh_hidden,
                masks: fresh_masks,
                factors: fresh_factors,
                timed,
                between,
                passed,
                move_clusters,
                fresh_rays,
                passed_rays,
                ..
            } = out;
            if !move_clusters.is_empty() {
                self.sys.move_cluster_cache.insert(leaf.0, move_clusters);
            }
            self.st.frame_rows.0.extend(timed);
            self.st.rows_between += between;
            self.st.pass_rows.extend(passed);
            self.st.pass_rays.extend(passed_rays);
            if let Some(w) = &mut self.st.window
                && !(fresh.is_empty()
                    && fresh_opened.is_empty()
                    && fresh_hidden.is_empty()
                    && fresh_masks.is_empty()
                    && fresh_factors.is_empty())
            {
                let rows_bytes = w.rows_bytes();
                let points = w.points.get_mut().unwrap_or_else(|e| e.into_inner());
                if let Some(p) = points.as_mut() {
                    p.others = rows_bytes;
                }
                if points.as_ref().is_none_or(PointCache::admits) {
                    w.rows.extend(fresh);
                    w.hidden.extend(fresh_hidden);
                    w.entry_rays.extend(fresh_rays);
                    w.masks.extend(fresh_masks);
                    w.factors.extend(fresh_factors);
                    for (key, entries) in fresh_opened {
                        let n = entries.len();
                        if let Some(old) = w.opened.insert(key, entries) {
                            w.opened_entries -= old.len();
                        }
                        w.opened_entries += n;
                    }
                }
            }
        }
        self.st.pass_rows.sort_unstable_by_key(|e| e.0);
        self.st.pass_rows.shrink_to_fit();
        self.st.pass_rays.sort_unstable_by_key(|e| e.0);
        self.st.pass_rays.shrink_to_fit();
    }

    /// Applies `A = I − ρ·(rows ∘ pull)` to leaf radiosities `x` (3 per leaf), with
    /// the closed scene's row scales and source gains ([`Solver::balance_rows`]).
    fn apply(&self, x: &[f64], out: &mut [f64], scratch_b: &mut [[f64; 3]]) {
        let nodes = self.elems.nodes.as_slice();
        let geoms = self.elems.geoms.as_slice();
        // Pull.
        for (li, l) in self.sys.leaves.iter().enumerate() {
            let g = self.sys.leaf_gain.get(li).copied().unwrap_or(1.0);
            scratch_b[l.ix()] = [g * x[li * 3], g * x[li * 3 + 1], g * x[li * 3 + 2]];
        }
        pull(nodes, geoms, scratch_b);
        let mut fb = Vec::new();
        self.facets.pull(scratch_b, &mut fb);
        // Gather each leaf's row, then B − ρ H.
        let b = &*scratch_b;
        out.par_chunks_mut(3)
            .zip(x.par_chunks(3))
            .enumerate()
            .for_each(|(li, (o, xi))| {
                let (r0, r1) = (
                    self.sys.row_start[li] as usize,
                    self.sys.row_start[li + 1] as usize,
                );
                let mut h = [0.0; 3];
                for (s, c) in self.sys.row_sources[r0..r1]
                    .iter()
                    .zip(&self.sys.row_coefs[r0..r1])
                {
                    let bs = source_value(b, &fb, *s);
                    for k in 0..3 {
                        h[k] += c * bs[k];
                    }
                }
                let rho = self.patches.rhos[geoms[self.sys.leaves[li].ix()].patch as usize];
                let r = self.sys.row_scale.get(li).copied().unwrap_or(1.0);
                for k in 0..3 {
                    o[k] = xi[k] - rho[k] * r * h[k];
                }
            });
    }

    /// Builds the leaf rows and solves the leaf system; returns the residual. The
    /// rows depend on the geometry and the links only (a cluster's estimate on its
    /// vector area, not on its radiosity), so one build serves the solve.
    pub(super) fn solve_rows(&mut self) -> Result<f64> {
        self.compute_leaf_rows();
        if !self.st.balance_fixed {
            self.sys.balancing = false;
        }
        self.solve_balanced()
    }

    /// Solves the leaf system as the rows stand, balanced if the solve balances
    /// ([`Solver::balance_rows`]). Each round of a static solve decides afresh: a
    /// closed scene whose leaf system strays from the power it emits by more than
    /// [`BALANCE_TRIGGER`] is balanced and solved again, unless too much of it lies
    /// in rows balancing leaves unscaled ([`BALANCE_OUT_MAX`]). A space-time solve
    /// keeps what its shared part's last round decided for every frame and window
    /// (`balance_fixed`), so that the light does not jump from frame to frame.
    ///
    /// A leaf system within the trigger is solved as it stands: balancing it moves
    /// its answer both ways and no closer to the path tracer. What rows left
    /// unscaled miss is lost, and the error estimate and the CLI's warning say so
    /// (BENCHMARKS.md, "Stiff scenes").
    pub(super) fn solve_balanced(&mut self) -> Result<f64> {
        if !self.balance_rows() && !self.st.balance_fixed {
            self.sys.balancing = false;
        }
        let residual = self.solve_leaves()?;
        if self.sys.balancing || self.st.balance_fixed || self.closed != Some(true) {
            return Ok(residual);
        }
        // A `NaN` balance (nothing emits) balances nothing.
        let off = (self.power_balance() - 1.0).abs();
        if off.is_nan() || off <= BALANCE_TRIGGER {
            return Ok(residual);
        }
        self.sys.balancing = true;
        if !self.balance_rows() {
            self.sys.balancing = false;
            return Ok(residual);
        }
        self.solve_leaves()
    }

    /// Whether the last leaf solve was balanced (`Solver::balance_rows`; the solver
    /// module docs): the scene is closed, and its factors made or lost more than
    /// [`BALANCE_TRIGGER`] of the emitted power. Read from the scales that solve
    /// used, so a space-time frame that keeps the decision to balance but whose
    /// rows could not be (too many left unscaled) reads false.
    pub fn rows_balanced(&self) -> bool {
        !self.sys.row_scale.is_empty()
    }

    /// Frees the leaf system's rows and what a static solve keeps of them from
    /// round to round (the cluster parts, the opened children's factors), once the
    /// last round is done: the final gather ([`Solver::solution`]) walks the links,
    /// not the rows, and the rows were its largest company (on `gen_cubes 20`, 92
    /// of the 169 MB heap at the reconstruction's peak; BENCHMARKS.md, "Scale").
    /// The row cache (each row's kept coefficients and visibilities) stays: a leaf
    /// smaller than the power area takes its surface sources' visibility from it in
    /// the final gather (`Solver::gather_sum`), and `Solver::leaf_point_light`
    /// reads it (freed with it, the Cornell box with its blocks at eps 0.02 cast
    /// those rays again: 0.55% off the lamp for 0.34%, in 35% more time). Read
    /// [`Solver::power_balance`] first: it is NaN after. A solver whose rows are
    /// freed is not to be run again.
    pub fn release_rows(&mut self) {
        self.sys.row_start = Vec::new();
        self.sys.row_sources = Vec::new();
        self.sys.row_coefs = Vec::new();
        self.sys.cluster_cache = FastMap::default();
        self.sys.opened_factors = FastMap::default();
    }

    /// Balances the leaf system so that it conserves energy, once
    /// [`Solver::solve_balanced`] has found that it does not (else it clears the
    /// scales). In a closed scene ([`Solver::is_closed`]) two sums hold for exact
    /// factors:
    /// - each leaf gathers its whole hemisphere: `Σ_j F_ij = 1`;
    /// - each leaf's light arrives somewhere in full: `Σ_i A_i F_iℓ = A_ℓ` (the
    ///   first by reciprocity, `A_i F_iℓ = A_ℓ F_ℓi`).
    ///
    /// The quadrature and the cluster estimates miss both by a few percent a leaf
    /// (ACTOR's room: row sums 0.9–1.1). Rows summing to `λ` make the mean
    /// radiosity `(1 − ρ)/(1 − ρλ)` times the truth: ACTOR's room at `ρ = 0.99` was
    /// 40–73% too bright (BENCHMARKS.md, "Stiff scenes"). Scaling the rows alone
    /// leaves the columns off: the lamp was gathered too little, and the room came
    /// out up to 6% too dark at `ρ = 0.99`, 1.1% at its own reflectances.
    ///
    /// So both are made to hold, as Sinkhorn's alternating scaling does for a
    /// matrix: a scale `r_i` per row and a gain `g_ℓ` per leaf as a source, the
    /// system transporting `r_i K_ij (pull g B)_j`. A row pass sets `r_i = 1 / Σ_j
    /// K_ij (pull g)_j`. A column pass makes each leaf send what it gathers,
    /// `g_ℓ Σ_i A_i r_i K̃_iℓ = A_ℓ G_ℓ`, the row entries pushed down to the leaves
    /// with the weights the pull gives them (`K̃_iℓ = Σ_{j ⊇ ℓ} K_ij A_ℓ / A_j`,
    /// [`push_down`]) and `G_ℓ` what leaf ℓ gathers (1 where its row is scaled).
    /// The two sides then add up to the same total, and the power the leaves
    /// absorb is the power emitted but for what the rows left out miss. The
    /// passes stop when what the leaves send astray is below `(1 − ρ_max) / 1000`
    /// of what they gather (reflectance amplifies what is left), or when a pass no
    /// longer makes it smaller ([`BALANCE_STALL`]), a row pass last, so the rows
    /// are exact: 6–10 passes on ACTOR's frames and its room at `ρ = 0.999`,
    /// about 1 ms a solve.
    ///
    /// A row whose unscaled sum is below [`BALANCE_ROW_MIN`] or above its inverse
    /// keeps scale 1: it misses a part of its hemisphere, not a few percent of
    /// quadrature (a slot's floor missing its dark walls, a leaf partly inside a
    /// solid), and scaling it would give that part the row's mean light. It sends
    /// what it gathers all the same. A leaf inside a solid gathers nothing and so
    /// sends nothing (gain 0); a gain stays below [`BALANCE_GAIN_MAX`]. The stored
    /// radiosity is the physical one; the scales weigh the transport.
    fn balance_rows(&mut self) -> bool {
        self.sys.row_scale.clear();
        self.sys.leaf_gain.clear();
        if !self.sys.balancing || self.closed != Some(true) || self.sys.leaves.is_empty() {
            return false;
        }
        let nodes = self.elems.nodes.as_slice();
        let geoms = self.elems.geoms.as_slice();
        let nl = self.sys.leaves.len();
        let areas: Vec<f64> = self.sys.leaves.iter().map(|l| geoms[l.ix()].area).collect();
        let rows = |li: usize| {
            let (r0, r1) = (
                self.sys.row_start[li] as usize,
                self.sys.row_start[li + 1] as usize,
            );
            self.sys.row_sources[r0..r1]
                .iter()
                .zip(&self.sys.row_coefs[r0..r1])
        };
        // Row sums of `K` weighed by the pulled gains.
        let mut pulled = vec![[0.0; 3]; geoms.len()];
        let mut fb = Vec::new();
        let facets = &self.facets;
        let mut row_sums = |g: &[f64]| -> Vec<f64> {
            pulled.fill([0.0; 3]);
            for (&l, gl) in self.sys.leaves.iter().zip(g) {
                pulled[l.ix()] = [*gl, 0.0, 0.0];
            }
            pull(nodes, geoms, &mut pulled);
            facets.pull(&pulled, &mut fb);
            let (pulled, fb) = (&pulled, &fb);
            (0..nl)
                .into_par_iter()
                .map(|li| {
                    rows(li)
                        .map(|(s, c)| c * source_value(pulled, fb, *s)[0])
                        .sum()
                })
                .collect()
        };
        // Column masses `Σ_i A_i r_i K̃_iℓ`.
        let mut mass = vec![0.0; geoms.len()];
        let mut facet_mass = vec![0.0; facets.count()];
        let mut col_masses = |r: &[f64]| -> Vec<f64> {
            mass.fill(0.0);
            for li in 0..nl {
                let w = areas[li] * r[li];
                for (s, c) in rows(li) {
                    *source_slot(&mut mass, &mut facet_mass, *s) += w * c;
                }
            }
            facets.push_down(&mut facet_mass, &mut mass);
            push_down(nodes, geoms, &mut mass);
            self.sys.leaves.iter().map(|l| mass[l.ix()]).collect()
        };
        let rho_max = self
            .patches
            .rhos
            .iter()
            .flatten()
            .fold(0.0f64, |m, &r| m.max(r));
        let tol = 1e-3 * (1.0 - rho_max).max(1e-4);
        // Which rows are scaled, decided once from the unscaled sums.
        let mut g = vec![1.0; nl];
        let lam0 = row_sums(&g);
        let row_in: Vec<bool> = lam0
            .iter()
            .map(|&l| (BALANCE_ROW_MIN..=1.0 / BALANCE_ROW_MIN).contains(&l))
            .collect();
        // Rows left unscaled that still see something lose what they miss once the
        // others are balanced; past a share of the area, leave the system as it is.
        let total: f64 = areas.iter().sum();
        let unscaled: f64 = (0..nl)
            .filter(|&li| !row_in[li] && lam0[li] > BALANCE_HIDDEN)
            .map(|li| areas[li])
            .sum();
        if unscaled > BALANCE_OUT_MAX * total {
            return false;
        }
        let mut r: Vec<f64> = lam0
            .iter()
            .zip(&row_in)
            .map(|(l, &i)| if i { 1.0 / l } else { 1.0 })
            .collect();
        // What each leaf gathers, `r_i Σ_j K_ij (pull g)_j`.
        let mut gathers: Vec<f64> = lam0.iter().zip(&r).map(|(l, r)| l * r).collect();
        let mut last = f64::INFINITY;
        for _ in 1..BALANCE_PASSES {
            // Columns: each leaf sends what it gathers. What the leaves send astray,
            // over what they gather, is the light a bounce makes or loses.
            let m = col_masses(&r);
            let (mut astray, mut flow) = (0.0, 0.0);
            for li in 0..nl {
                let target = areas[li] * gathers[li];
                astray += (g[li] * m[li] - target).abs();
                flow += target;
            }
            // Done when it is small enough, or when a pass no longer makes it
            // smaller (what is left is what the capped gains cannot send).
            if astray.is_nan() || astray <= tol * flow || astray > BALANCE_STALL * last {
                break;
            }
            last = astray;
            for li in 0..nl {
                g[li] = if m[li] > 0.0 {
                    (areas[li] * gathers[li] / m[li]).min(BALANCE_GAIN_MAX)
                } else {
                    1.0
                };
            }
            // Rows.
            let lam = row_sums(&g);
            for li in 0..nl {
                if row_in[li] {
                    r[li] = 1.0 / lam[li];
                }
                gathers[li] = r[li] * lam[li];
            }
        }
        self.sys.row_scale = r;
        self.sys.leaf_gain = g;
        true
    }

    /// The power the leaves absorb over the power the scene emits (`NaN` with no
    /// emission or no leaf system yet), from the leaf system as last solved:
    /// `Σ_i A_i (1 − ρ_i) H_i` over `Σ_i A_i E_i`, summed over the channels,
    /// `H_i = Σ_j K_ij B_j` the leaf's row. At most 1 for any exact answer, 1 in a
    /// closed scene; above 1, the factors make light (`Solver::run`'s error
    /// estimate counts it, `with_power_error`).
    pub fn power_balance(&self) -> f64 {
        if !self.has_leaf_rows() {
            return f64::NAN;
        }
        let geoms = self.elems.geoms.as_slice();
        let (b, fb) = self.gained(self.plain_radiosities());
        let (mut absorbed, mut emitted) = (0.0, 0.0);
        for (li, &leaf) in self.sys.leaves.iter().enumerate() {
            let g = &geoms[leaf.ix()];
            let p = g.patch as usize;
            let h = self.row_gather(li, &b, &fb);
            for ((hk, rho), e) in h
                .iter()
                .zip(self.patches.rhos[p])
                .zip(self.patches.emissions[p])
            {
                absorbed += g.area * (1.0 - rho) * hk;
                emitted += g.area * e;
            }
        }
        if emitted > 0.0 {
            absorbed / emitted
        } else {
            f64::NAN
        }
    }

    /// Every element's radiosity as the pool holds it, in `f64`: the solved field
    /// the row checks and the row excess read.
    pub(super) fn plain_radiosities(&self) -> Vec<[f64; 3]> {
        self.elems
            .radiosities
            .as_slice()
            .iter()
            .map(|v| v.map(f64::from))
            .collect()
    }

    /// Whether the leaf system holds a row for every leaf (the rows are made and
    /// not released).
    pub(super) fn has_leaf_rows(&self) -> bool {
        self.sys.row_start.len() == self.sys.leaves.len() + 1
    }

    /// A field over the elements (`b`, the leaves' values) as the leaf system
    /// pulls it: each leaf's value times its gain ([`Solver::balance_rows`]),
    /// pulled to the inner elements when there are gains, and the facets' values.
    pub(super) fn gained(&self, mut b: Vec<[f64; 3]>) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        if !self.sys.leaf_gain.is_empty() {
            for (&l, g) in self.sys.leaves.iter().zip(&self.sys.leaf_gain) {
                b[l.ix()] = b[l.ix()].map(|v| v * g);
            }
            pull(
                self.elems.nodes.as_slice(),
                self.elems.geoms.as_slice(),
                &mut b,
            );
        }
        let mut fb = Vec::new();
        self.facets.pull(&b, &mut fb);
        (b, fb)
    }

    /// What leaf `li`'s row (scaled as solved) gathers of the field `b` (with its
    /// facets' values `fb`, [`Solver::gained`]): `Σ_j K_ij b_j`.
    pub(super) fn row_gather(&self, li: usize, b: &[[f64; 3]], fb: &[[f64; 3]]) -> [f64; 3] {
        let (r0, r1) = (
            self.sys.row_start[li] as usize,
            self.sys.row_start[li + 1] as usize,
        );
        let r = self.sys.row_scale.get(li).copied().unwrap_or(1.0);
        let mut h = [0.0; 3];
        for (s, c) in self.sys.row_sources[r0..r1]
            .iter()
            .zip(&self.sys.row_coefs[r0..r1])
        {
            let bs = source_value(b, fb, *s);
            for k in 0..3 {
                h[k] += r * c * bs[k];
            }
        }
        h
    }

    /// The relative RMS error that rows summing above 1 put into the leaves'
    /// answer (`NaN` without a leaf system or light): a leaf whose row (scaled as
    /// solved) sums to `S > 1` gathers its irradiance `H` with factors that
    /// together see more than its hemisphere, so `ρ H (S − 1) / S` of its
    /// reflected light is light no exact answer has. Summed as the estimate's
    /// other terms, `sqrt(Σ_i A_i |ρ_i H_i (S_i − 1)_+ / S_i|² / Σ_i A_i |B_i|²)`
    /// over the channels: a lower bound of what that light adds (the excess is
    /// reflected again, `1/(1 − ρ)` times, before it is all absorbed).
    ///
    /// Why: a leaf system can absorb about what it emits while some of its rows
    /// sum to 1.3–1.5 and others lose light (the Blender Cornell box: 750 rows
    /// over 1.01, the largest 1.52, 12% too bright on the walls), and the change
    /// between levels does not see a bias no refinement removes.
    pub fn row_excess_error(&self) -> f64 {
        if !self.has_leaf_rows() {
            return f64::NAN;
        }
        let geoms = self.elems.geoms.as_slice();
        let plain = self.plain_radiosities();
        // The sources as the leaf system pulls them, and the gains alone pulled the
        // same way for the rows' sums (a balanced system's rows sum to 1 with them).
        let (b, fb) = self.gained(plain.clone());
        let (gain, fgain) = self.gained(vec![[1.0, 0.0, 0.0]; geoms.len()]);
        let (mut num, mut den) = (0.0, 0.0);
        for (li, &leaf) in self.sys.leaves.iter().enumerate() {
            let g = &geoms[leaf.ix()];
            let sum = self.row_gather(li, &gain, &fgain)[0];
            let bl = plain[leaf.ix()];
            den += g.area * bl.iter().map(|x| x * x).sum::<f64>();
            if sum <= 1.0 {
                continue;
            }
            let h = self.row_gather(li, &b, &fb);
            let rho = self.patches.rhos[g.patch as usize];
            let share = (sum - 1.0) / sum;
            num += g.area * (0..3).map(|k| (rho[k] * h[k] * share).powi(2)).sum::<f64>();
        }
        if den > 0.0 {
            (num / den).sqrt()
        } else {
            f64::NAN
        }
    }

    /// The leaf rows' factor sums `Σ_j K_ij` (unscaled), with each leaf's area, in
    /// leaf order: at most 1 for exact factors, 1 in a closed scene seen whole.
    pub fn row_sums(&self) -> Vec<(f64, f64)> {
        let geoms = self.elems.geoms.as_slice();
        self.sys
            .leaves
            .iter()
            .enumerate()
            .map(|(li, &leaf)| {
                let (r0, r1) = (
                    self.sys.row_start[li] as usize,
                    self.sys.row_start[li + 1] as usize,
                );
                (
                    geoms[leaf.ix()].area,
                    self.sys.row_coefs[r0..r1].iter().sum(),
                )
            })
            .collect()
    }

    /// Solves the leaf system with GMRES from the current radiosities; writes the
    /// result into the pool (leaves and pulled inner elements). Returns the residual.
    pub(super) fn solve_leaves(&mut self) -> Result<f64> {
        let nl = self.sys.leaves.len();
        let n = self.elems.len();
        let mut rhs = vec![0.0; nl * 3];
        let mut x = vec![0.0; nl * 3];
        for (li, &l) in self.sys.leaves.iter().enumerate() {
            let p = self.elems.geoms.as_slice()[l.ix()].patch as usize;
            let b = self.elems.radiosities.as_slice()[l.ix()];
            for k in 0..3 {
                rhs[li * 3 + k] = self.patches.emissions[p][k];
                x[li * 3 + k] = b[k] as f64;
            }
        }
        let mut sb = vec![[0.0; 3]; n];
        let outcome = gmres::solve(
            |v, out| self.apply(v, out, &mut sb),
            &rhs,
            &mut x,
            self.opts.tolerance,
            40,
            2000,
        );
        for (li, &l) in self.sys.leaves.iter().enumerate() {
            let out = &mut self.elems.radiosities.as_mut_slice()[l.ix()];
            for k in 0..3 {
                // Radiosity is never negative; clamp round-off of the Krylov solve.
                out[k] = x[li * 3 + k].max(0.0) as f32;
            }
        }
        self.pull_pool();
        Ok(outcome.residual)
    }
}

/// The shares of a source's coefficient that its children take, seen from a
/// leaf's quadrature points `q` (normal `n`), with the kernel linear across the
/// source: child `c` of area `A_c` and centroid `y_c` takes `A_c/A_s · (1 + g ·
/// (y_c − ȳ))`, `g` the gradient of `ln K(x, y)` over the source at its centroid
/// `ȳ`, `K = cos θ_x cos θ_y / r²`, averaged over the points weighted by `K`.
/// The shares sum to 1, so the row keeps its sum. `None` where the linear kernel
/// does not hold: a source near a point's horizon or seen edge-on, or a share
/// moving more than half from its area's. `(c, rad)` is the source's
/// [`oracle::sphere`], `centroid` a child's area centroid (the final gather has
/// both computed once per reconstruction).
#[allow(clippy::too_many_arguments)]
pub(super) fn linear_shares(
    q: &oracle::Samples,
    n: DVec3,
    geoms: &[Geom],
    gs: &Geom,
    (c, rad): (DVec3, f64),
    node: Node,
    centroid: impl Fn(usize) -> DVec3,
) -> Option<[f64; 4]> {
    let k = node.child_count as usize;
    if k == 0 || k > 4 {
        return None;
    }
    let ns = DVec3::from_array(gs.normal);
    let mut g = DVec3::ZERO;
    let mut wsum = 0.0;
    for i in 0..q.count {
        let d = c - q.points[i];
        let r2 = d.length_squared();
        let r = r2.sqrt();
        let (cx, cy) = (n.dot(d), -ns.dot(d));
        // The whole source in front of the point and facing it, away from grazing.
        if cx < 2.0 * rad || cy < 2.0 * rad || cx < 0.2 * r || cy < 0.2 * r {
            return None;
        }
        let w = q.weights[i] * cx * cy / (r2 * r2);
        g += w * (n / cx - ns / cy - 4.0 * d / r2);
        wsum += w;
    }
    if wsum <= 0.0 {
        return None;
    }
    g /= wsum;
    let mut area = 0.0;
    let mut ybar = DVec3::ZERO;
    let mut a = [0.0; 4];
    let mut y = [DVec3::ZERO; 4];
    for j in 0..k {
        let ch = node.first_child as usize + j;
        a[j] = geoms[ch].area;
        y[j] = centroid(ch);
        area += a[j];
        ybar += a[j] * y[j];
    }
    if area <= 0.0 {
        return None;
    }
    ybar /= area;
    let mut out = [0.0; 4];
    for j in 0..k {
        let t = g.dot(y[j] - ybar);
        if t.abs() > 0.5 {
            return None;
        }
        out[j] = a[j] / area * (1.0 + t);
    }
    Some(out)
}

/// The shares of [`linear_shares`] with each child that stays whole moved from
/// its area's share by [`WITHIN_CHILD`] times the difference (it stands for a
/// radiosity that goes on varying inside it); their sum is returned, for the
/// caller to normalise by. `stays_whole(j, share)`: whether child `j` (of
/// `node`), with its unmoved share, stays whole. One step for the leaf rows
/// ([`Solver::push_opened`]) and the final gather ([`Solver::open_shared`]).
pub(super) fn within_child_shares(
    shares: &mut [f64; 4],
    geoms: &[Geom],
    node: Node,
    mut stays_whole: impl FnMut(usize, f64) -> bool,
) -> f64 {
    let k = (node.child_count as usize).min(4);
    let child_area: f64 = (0..k)
        .map(|j| geoms[node.first_child as usize + j].area)
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let mut sum = 0.0;
    for (j, share) in shares.iter_mut().enumerate().take(k) {
        if stays_whole(j, *share) {
            let a = geoms[node.first_child as usize + j].area / child_area;
            *share = a + WITHIN_CHILD * (*share - a);
        }
        sum += *share;
    }
    sum
}
