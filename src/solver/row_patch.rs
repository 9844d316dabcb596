//! An interactive move's leaf rows updated in place: of a chain link the move
//! evaluated again, only the row entries the move can have changed are computed
//! again, the others kept from the move before (issue 49; paper 000 section 2: an
//! update touches what the move affects, here down to the row entries).
//!
//! How it works: a leaf row holds, per chain link, the entries its source opened
//! into ([`super::Solver`]'s `cluster_parts` for a cluster source: parts taken
//! whole, or surfaces opened further), kept by link from the session's start-up
//! on. An entry depends on the leaf's and the part's geometry and on the
//! visibility rays between them, which all lie in the hull of the leaf's box and
//! the part's. So for a stale link's entries:
//! - a surface source that holds no moved patch, seen from a leaf that holds none,
//!   keeps its entries when no moved object's box (before or after) meets the
//!   shaft between the leaf's box and the source's ([`crate::shafts::box_shaft_misses`]);
//! - a cluster source is opened again as `cluster_parts` opens it, but each part
//!   it comes to that holds no moved patch ([`RowPatch::holding`]) stands where it
//!   stood and opens as it did: where the shaft between the leaf and the part
//!   misses the moved boxes, its old entries (those under it; none if its parent
//!   was opened and it gave nothing) are kept instead of opened. Only the parts
//!   that hold a moved patch (their boxes moved) and those the moved boxes shade
//!   are computed again, down to the parts the shafts clear.
//!
//! What this does not redo: the fallback visibility of a cluster part from which
//! no ray is cast (the link's fraction, which the move evaluated again) in entries
//! that are kept. Where the geometry and the rays are the same, the kept entries
//! are the ones a recomputation gives, bit for bit (the rays' jitter is keyed by
//! the leaf, the part and the point).
//!
//! The entries computed again cast fewer rays: a surface entry whose leaf and
//! source both stand still casts the same rays at every move (same keys, same
//! ends), and the static scene blocks the same of them, so the first move that
//! computes it keeps which rays the static scene leaves clear (a mask, as a
//! space-time window keeps them, [`RowMasks`]) and the later moves cast only those,
//! at the moving objects alone ([`Solver::move_row_masks`]): the same answer, bit
//! for bit, for a ray that misses the moved object's box at the cost of a box test.
//!
//! Nor is every entry whose shaft meets a moved box computed again: a surface entry
//! between a leaf and a part that both stand still depends on the moving objects
//! only through which of its rays they block. The move that computes it keeps that
//! set (a bit a ray, beside the masks) and a print of the entries it gave
//! ([`Solver::keep_move_trace`]); a later move casts the same rays at the moving
//! objects alone and, where they block the same rays and the old entries are the
//! printed ones, keeps them ([`Solver::unchanged_part`]): what a recomputation
//! would give, bit for bit, without its form factors, kernel weights and opening.
//! A chair moved 1 cm leaves most of the rays of the entries its box shades as
//! they were (blocked or not): only the entries its shadow edges cross change.

use super::rows::{RowMasks, move_mask};
use super::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The share of its row (factor before visibility) from which an entry with a
/// moving end casts every ray in an interactive move's rows
/// ([`Solver::move_entry_rays`]); smaller entries cast fewer, in proportion.
pub(super) const MOVE_FULL_SHARE: f64 = 0.01;

/// How far a move dirtied the rows of the leaves under an element or the entries of
/// a link ([`Solver::settle_local`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Dirty {
    /// Kept.
    Clean,
    /// In the rows of the leaves that meet a box near the moved objects.
    Near,
    /// In every row under it.
    All,
}

/// What the rows of one pass of [`Solver::settle_local`] update in place
/// (module docs).
pub(super) struct RowPatch {
    /// Per element: a patch of a moved object lies under it (itself for a surface).
    pub(super) holding: Vec<bool>,
    /// The moved objects' boxes before and after the move.
    pub(super) boxes: Vec<(DVec3, DVec3)>,
    /// The boxes near the moved objects, where a [`Dirty::Near`] link's entries
    /// are stale.
    pub(super) near: Vec<(DVec3, DVec3)>,
    /// The links the move evaluated again or added, by how far their kept entries
    /// are stale.
    pub(super) stale: FastMap<u32, Dirty>,
    /// Each element's place in the element tree ([`tree_order`]).
    pub(super) order: Vec<(u32, u32)>,
}

/// How many static surface parts an interactive move's rows kept by their
/// traces ([`Solver::unchanged_part`]), counted from the session's start; and,
/// while [`Solver::check_kept_parts`] is on, how many of those kept in a
/// cluster walk were computed again beside and how many came out otherwise.
#[derive(Default)]
pub(super) struct KeptTally {
    surface: AtomicU64,
    check: AtomicBool,
    checked: AtomicU64,
    differ: AtomicU64,
}

/// [`Solver::kept_parts`]: the static parts an interactive session's moves kept
/// by the rays a moving object blocked (`row_patch`), from the session's start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KeptByTrace {
    /// Surface parts and surface sources kept (`Solver::unchanged_part`).
    pub surface: u64,
    /// Of the parts kept in a cluster walk while [`Solver::check_kept_parts`]
    /// was on, how many were computed again to compare.
    pub checked: u64,
    /// Of those, how many the recomputation gave otherwise (bit for bit, in
    /// order): 0 if keeping is exact.
    pub differ: u64,
}

impl Solver<'_> {
    /// The static parts the interactive moves' rows kept by their traces so far
    /// ([`KeptByTrace`]).
    pub fn kept_parts(&self) -> KeptByTrace {
        let t = &self.sys.move_kept;
        KeptByTrace {
            surface: t.surface.load(Ordering::Relaxed),
            checked: t.checked.load(Ordering::Relaxed),
            differ: t.differ.load(Ordering::Relaxed),
        }
    }

    /// While `on`, every part an interactive move's rows keep in a cluster walk
    /// by its trace is also computed again as the walk would compute it, and
    /// compared with the kept entries ([`KeptByTrace::differ`]): for tests; it
    /// costs what keeping spares.
    pub fn check_kept_parts(&self, on: bool) {
        self.sys.move_kept.check.store(on, Ordering::Relaxed);
    }

    /// Counts part `e` of chain link `l`, kept by its trace with the entries
    /// `group` of `old` in the row of `leaf` in a cluster walk, and, while
    /// [`Solver::check_kept_parts`] is on, computes it again to compare.
    #[allow(clippy::too_many_arguments)]
    fn tally_kept(
        &self,
        leaf: ElementId,
        l: u32,
        e: u32,
        q: &oracle::Samples,
        n: DVec3,
        old: &[(u32, f64)],
        group: &[u32],
    ) {
        let t = &self.sys.move_kept;
        t.surface.fetch_add(1, Ordering::Relaxed);
        if !t.check.load(Ordering::Relaxed) {
            return;
        }
        // The walk takes the part as the source of its own: the same factors,
        // rays and opening.
        let mut fresh = Vec::new();
        self.push_cluster(leaf, l, q, n, e, &mut fresh, None, &mut |_| false);
        let same = fresh.len() == group.len()
            && fresh.iter().zip(group).all(|(a, &i)| {
                let b = old[i as usize];
                a.0 == b.0 && a.1.to_bits() == b.1.to_bits()
            });
        t.checked.fetch_add(1, Ordering::Relaxed);
        if !same {
            t.differ.fetch_add(1, Ordering::Relaxed);
        }
    }
}

impl RowPatch {
    /// True if the entries of link `l` in the row of a leaf are stale; `near`: the
    /// leaf meets a box of [`RowPatch::near`].
    pub(super) fn is_stale(&self, l: u32, near: bool) -> bool {
        match self.stale.get(&l) {
            Some(Dirty::All) => true,
            Some(Dirty::Near) => near,
            _ => false,
        }
    }

    /// True if every segment between boxes `a` and `b` misses every moved box.
    fn clear(&self, a: (DVec3, DVec3), b: (DVec3, DVec3)) -> bool {
        crate::shafts::box_shaft_misses_all(a, b, &self.boxes)
    }

    /// The old entries of a link to source `s` (all under it), sorted by where
    /// they lie in the element tree ([`RowPatch::order`]), to find those under an
    /// element ([`Groups::under`]) and the elements that were opened
    /// ([`Groups::opened`]) by binary search.
    fn groups(&self, old: &[(u32, f64)]) -> Groups {
        let mut by_order: Vec<(u32, u32)> = old
            .iter()
            .enumerate()
            .map(|(i, &(x, _))| (self.order[x as usize].0, i as u32))
            .collect();
        by_order.sort_unstable();
        Groups { by_order }
    }
}

/// Each element's place in a depth-first walk of the element tree: `(first, end)`,
/// its own number and one past its last descendant's, so that `y` lies under `x`
/// (or is `x`) exactly when `first(x) ≤ first(y) < end(x)`.
pub(super) fn tree_order(nodes: &[Node]) -> Vec<(u32, u32)> {
    let mut order = vec![(0u32, 0u32); nodes.len()];
    let mut next = 0u32;
    // (element, children entered yet)
    let mut stack: Vec<(u32, bool)> = Vec::new();
    for root in 0..nodes.len() as u32 {
        if nodes[root as usize].parent != u32::MAX {
            continue;
        }
        stack.push((root, false));
        while let Some((e, entered)) = stack.pop() {
            let node = nodes[e as usize];
            if entered {
                order[e as usize].1 = next;
                continue;
            }
            order[e as usize].0 = next;
            next += 1;
            stack.push((e, true));
            // Children pushed last first: entered in order.
            for c in (node.first_child..node.first_child + node.child_count).rev() {
                stack.push((c, false));
            }
        }
    }
    order
}

/// A stale link's old entries by where they lie in the element tree
/// ([`RowPatch::groups`]).
struct Groups {
    /// `(first(x), index into the old entries)` of each old entry `x`, sorted.
    by_order: Vec<(u32, u32)>,
}

impl Groups {
    /// The old entries under element `c` (or `c` itself), in the order of the old
    /// entries; `c` must hold no moved patch (then neither does any entry under it).
    /// Written to `out`, which is cleared first.
    fn under(&self, (first, end): (u32, u32), out: &mut Vec<u32>) {
        let lo = self.by_order.partition_point(|x| x.0 < first);
        let hi = self.by_order.partition_point(|x| x.0 < end);
        out.clear();
        out.extend(self.by_order[lo..hi].iter().map(|x| x.1));
        out.sort_unstable();
    }

    /// True if an old entry lies strictly under element `(first, end)`: it was
    /// opened.
    fn opened(&self, (first, end): (u32, u32)) -> bool {
        let lo = self.by_order.partition_point(|x| x.0 <= first);
        self.by_order.get(lo).is_some_and(|x| x.0 < end)
    }
}

impl Solver<'_> {
    /// The rays a point of the row entry of `leaf` for part `e` casts in an
    /// interactive move's rows where an end moves (no mask can keep their static
    /// part): `full` scaled by the entry's share `u` of the row (its factor
    /// before visibility, at most 1 over a leaf's row) against [`MOVE_FULL_SHARE`],
    /// at least 1; elsewhere `full`. Why: the rows of the moved object's own
    /// leaves and the moved object's parts seen from far rows are cast afresh
    /// at every move, and most of their entries are small (a chair's leaf of
    /// the 889-polygon room has ~330 surface entries): the visibility noise an
    /// entry adds to its row grows with `u / sqrt(rays)`, so rays in proportion
    /// to `u` put them where they count.
    pub(super) fn move_entry_rays(&self, leaf: ElementId, e: u32, u: f64, full: u32) -> u32 {
        if !self.sys.move_rows
            || !(self.elem_moving(leaf) || e & FACET_BIT == 0 && self.elem_moving(ElementId(e)))
        {
            return full;
        }
        let share = (u / MOVE_FULL_SHARE).clamp(0.0, 1.0);
        ((full as f64 * share).ceil() as u32).clamp(1, full)
    }

    /// How the rays of the row entry of `leaf` (quadrature `q`) for surface `e`,
    /// reached by chain link `l`, treat static geometry: in an interactive move's
    /// rows, where neither end moves, by the masks an earlier move made
    /// ([`RowMasks::Move`]: the rays the static scene leaves clear are cast at the
    /// moving objects alone, to the same answer; those of the quadrature points
    /// and, since, of the leaf's corners), making those not known yet; elsewhere
    /// [`RowMasks::None`]. The rays' keys and ends
    /// are those of any other move (the leaf, the link's receiver and `e` key
    /// them, [`Solver::row_ray_ids`]), and the static scene stands: the masks hold.
    pub(super) fn move_row_masks(
        &self,
        leaf: ElementId,
        l: u32,
        e: u32,
        q: &oracle::Samples,
    ) -> RowMasks {
        if !self.sys.move_rows
            || self.opts.rays_per_point * q.count as u32 > 64
            || self.elem_moving(leaf)
            || self.elem_moving(ElementId(e))
        {
            return RowMasks::None;
        }
        let r = self.links.ends.as_slice()[l as usize].receiver;
        RowMasks::Move(self.sys.move_masks.get(&(leaf.0, r, e)).unwrap_or(0))
    }

    /// [`Solver::part_visibility`] from the `i`-th quadrature point `x` of `leaf`
    /// (normal `n`, patch `patch`) to cluster part `e` by `m` rays, in an
    /// interactive move's rows where both stand still by the static masks an
    /// earlier move made ([`oracle::point_cluster_visibility_masked`]: the rays the
    /// static scene leaves clear are cast at the moving objects alone, while the
    /// points drawn by power are those the masks were made with), making them
    /// where there are none: the same answer. Elsewhere (a facet, a moving end,
    /// outside a move's rows, over 64 rays) [`Solver::part_visibility`] itself.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn row_part_visibility(
        &self,
        leaf: ElementId,
        x: DVec3,
        n: DVec3,
        patch: u32,
        e: u32,
        m: u32,
        i: u64,
    ) -> (f64, u32) {
        if !self.sys.move_rows
            || e & FACET_BIT != 0
            || !SOURCES_BY_POWER
            || m > 64
            || i > 0xff_ffff
            || self.elem_moving(leaf)
            || self.elem_moving(ElementId(e))
        {
            return self.part_visibility(x, n, patch, e, m, i);
        }
        let key = (leaf.0, e, (i as u32) << 8 | m);
        let known = self.sys.move_part_masks.get(&key);
        let h = self.part_ray_key(e, patch, i);
        let (seen, made) = oracle::point_cluster_visibility_masked(
            &self.elems,
            &self.bvh,
            x,
            n,
            patch,
            ElementId(e),
            m,
            h,
            known,
        );
        if let Some(made) = made
            && let Ok(mut v) = self.sys.move_part_masks_made.lock()
        {
            v.push((key, made));
        }
        seen
    }

    /// Hands the masks `made` to the next moves where they hold more than `how`
    /// knew ([`Solver::move_row_masks`]).
    pub(super) fn keep_move_mask(&self, leaf: ElementId, l: u32, e: u32, how: RowMasks, made: u64) {
        if !matches!(how, RowMasks::Move(known) if known != made) {
            return;
        }
        let r = self.links.ends.as_slice()[l as usize].receiver;
        if let Ok(mut v) = self.sys.move_masks_made.lock() {
            v.push(((leaf.0, r, e), made));
        }
    }

    /// Hands the next moves the rays a moving object blocked in the entries
    /// `entries` that surface part `e` of chain link `l` gave the row of `leaf`
    /// (`traced`, [`Solver::hidden_row_coef`]; 0: nothing to hand), with a
    /// print of the entries ([`entries_print`]), for [`Solver::unchanged_part`].
    pub(super) fn keep_move_trace(
        &self,
        leaf: ElementId,
        l: u32,
        e: u32,
        traced: u64,
        entries: &[(u32, f64)],
    ) {
        if traced == 0 || !self.sys.move_rows {
            return;
        }
        let r = self.links.ends.as_slice()[l as usize].receiver;
        if let Ok(mut v) = self.sys.move_traces_made.lock() {
            v.push(((leaf.0, r, e), (traced, entries_print(entries.iter()))));
        }
    }

    /// True if the entries of surface part `e` of chain link `l` in the row of
    /// `leaf` (quadrature `q`, normal `n`), where neither moves, are those under it
    /// in `old` (indices `group`; `None`: all of `old`) and a recomputation would give them again: the
    /// move that computed them last kept which of their rays a moving object
    /// blocked ([`Solver::keep_move_trace`]), the old entries are the ones it gave
    /// (their print), and the same rays, cast again at the moving objects alone
    /// through the static masks, are blocked the same now. The entry depends on
    /// the two ends' geometry and on those rays' answers only (the static part of
    /// each is its mask), so it comes out bit for bit as it did: its form factors,
    /// kernel weights and opening are not taken again. Where a moving object
    /// blocks other rays than it did (it moved over the entry's shadow edge),
    /// false: the entry is computed again.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn unchanged_part(
        &self,
        leaf: ElementId,
        l: u32,
        e: u32,
        q: &oracle::Samples,
        n: DVec3,
        old: &[(u32, f64)],
        group: Option<&[u32]>,
    ) -> bool {
        let RowMasks::Move(bits) = self.move_row_masks(leaf, l, e, q) else {
            return false;
        };
        let r = self.links.ends.as_slice()[l as usize].receiver;
        let Some((traced, print)) = self.sys.move_traces.get(&(leaf.0, r, e)) else {
            return false;
        };
        let m = self.opts.rays_per_point;
        if traced >> move_mask::SEEN & 1 == 0
            || bits >> move_mask::QUAD & 1 == 0
            || !move_mask::corners(m)
            || print
                != match group {
                    Some(g) => entries_print(g.iter().map(|&i| &old[i as usize])),
                    None => entries_print(old.iter()),
                }
        {
            return false;
        }
        let geoms = self.elems.geoms.as_slice();
        let (g, gs) = (&geoms[leaf.ix()], &geoms[e as usize]);
        let ps = oracle::poly(gs);
        let ns = DVec3::from_array(gs.normal);
        let ids = self.row_ray_ids(leaf, l, e);
        let mut now = 0u64;
        let mut cast = |x: DVec3, i: u64| {
            let mask = bits >> (i as u32 * m) & ((1 << m) - 1);
            if mask != 0 {
                let rays = self.row_rays(ids, g, gs, &ps, ns, x, n, i);
                now |= oracle::moving_blocked(&self.bvh, &rays, mask) << (i as u32 * m);
            }
        };
        for i in 0..q.count {
            cast(q.points[i], i as u64);
        }
        if traced >> move_mask::CORNERS_SEEN & 1 == 1 {
            // The corners the last computation looked at had their masks made then.
            let centre = q.points[..q.count].iter().sum::<DVec3>() / q.count as f64;
            for (c, &x) in oracle::poly(g).corners().iter().enumerate() {
                if bits >> (move_mask::CORNER + c as u32) & 1 == 1 {
                    cast(x + CORNER_INSET * (centre - x), 4 + c as u64);
                }
            }
        }
        now == traced & ((1 << (8 * m)) - 1)
    }

    /// Keeps the old entries `old` of stale link `l` (source `s`) in the row of
    /// `leaf` where the move cannot have changed them, computing the rest again
    /// into `row` (module docs). Returns false, having pushed nothing, where
    /// nothing can be kept: the caller computes the link's entries in full.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn patch_entries(
        &self,
        patch: &RowPatch,
        leaf: ElementId,
        l: u32,
        q: &oracle::Samples,
        n: DVec3,
        old: &[(u32, f64)],
        row: &mut Vec<(u32, f64)>,
    ) -> bool {
        let geoms = self.elems.geoms.as_slice();
        let s = self.links.ends.as_slice()[l as usize].source;
        if patch.holding[leaf.ix()] {
            return false;
        }
        let leaf_box = super::geom_box(&geoms[leaf.ix()]);
        let gs = &geoms[s as usize];
        if gs.patch != u32::MAX {
            let keep = !patch.holding[s as usize]
                && (patch.clear(leaf_box, super::geom_box(gs))
                    // (A link a shaft proved clear casts no ray: integrated.)
                    || !self.links.transports.as_slice()[l as usize].shaft_clear()
                        && self.unchanged_part(leaf, l, s, q, n, old, None) && {
                            self.sys.move_kept.surface.fetch_add(1, Ordering::Relaxed);
                            true
                        });
            if keep {
                row.extend_from_slice(old);
            }
            return keep;
        }
        // A cluster source that holds no moved patch, the shaft from the leaf to
        // its box clear of the moved boxes: every entry kept, as the walk below
        // would keep them at its first step (`reuse(s)`), without grouping them.
        if !patch.holding[s as usize] && patch.clear(leaf_box, super::geom_box(gs)) {
            row.extend_from_slice(old);
            return true;
        }
        let nodes = self.elems.nodes.as_slice();
        let groups = patch.groups(old);
        let mut kept = Vec::new();
        let mut group = Vec::new();
        let mut reuse = |c: u32| -> bool {
            // A part that holds a moved patch is computed again (so is every
            // element above one: none under a part that holds none does).
            if patch.holding[c as usize] {
                return false;
            }
            groups.under(patch.order[c as usize], &mut group);
            // A part that gave nothing before: its parent was opened.
            let was_empty =
                || c == s || groups.opened(patch.order[nodes[c as usize].parent as usize]);
            let known = !group.is_empty() || was_empty();
            // Its shaft clear of the moved boxes, or (a surface) its rays blocked
            // by the moving objects as at the move that computed its entries.
            let same = known && patch.clear(leaf_box, super::geom_box(&geoms[c as usize]))
                || geoms[c as usize].patch != u32::MAX
                    && self.unchanged_part(leaf, l, c, q, n, old, Some(&group))
                    && {
                        self.tally_kept(leaf, l, c, q, n, old, &group);
                        true
                    };
            if same {
                kept.extend(group.iter().map(|&i| old[i as usize]));
            }
            same
        };
        if !reuse(s) {
            self.push_cluster(leaf, l, q, n, s, row, None, &mut reuse);
        }
        row.extend_from_slice(&kept);
        true
    }

    /// The entries of chain link `l`, which the leaf's kept row `kept` does not
    /// hold (a child of a link the move split), taken from the kept entries of
    /// its parent: the link of `kept` whose ends lie over `l`'s, now passive.
    /// A row entry depends on the leaf, the part and the rays between them, not
    /// on the link that reached the part, so the parent's entries under `l`'s
    /// source are the child's, updated in place as a stale link's are
    /// ([`Solver::patch_entries`]). Taken only where the parent's row reached
    /// `l`'s source as a part (the source itself, or a child of an opened
    /// cluster), not where a surface was opened into it at the surface's own
    /// visibility. Returns false, having pushed nothing, where there is nothing
    /// to take (or, at a surface receiver, where `l` sees nothing: its row takes
    /// nothing from it). Where the parent was split at its receiver the rays of its
    /// surface parts were keyed by the parent's receiver
    /// ([`Solver::row_ray_ids`]): the entries are as a fresh row gives them up to
    /// the rays' jitter.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn inherit_entries(
        &self,
        patch: &RowPatch,
        leaf: ElementId,
        l: u32,
        q: &oracle::Samples,
        n: DVec3,
        kept: &[(u32, RowEntries)],
        row: &mut Vec<(u32, f64)>,
    ) -> bool {
        let ends = self.links.ends.as_slice();
        let tr = self.links.transports.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let geoms = self.elems.geoms.as_slice();
        let under = |mut a: u32, top: u32| loop {
            if a == top {
                return true;
            }
            a = match nodes.get(a as usize) {
                Some(x) => x.parent,
                None => return false,
            };
            if a == u32::MAX {
                return false;
            }
        };
        let e = ends[l as usize];
        let Some((p, old)) = kept.iter().find(|(p, _)| {
            let pe = ends[*p as usize];
            *p != l
                && tr[*p as usize].state() != LinkState::Active
                && under(e.receiver, pe.receiver)
                && under(e.source, pe.source)
        }) else {
            return false;
        };
        let s = e.source;
        // A surface receiver takes nothing from a link that sees nothing
        // ([`Solver::push_cluster`]): computed in full, to nothing.
        let t = &tr[l as usize];
        let gated =
            geoms[e.receiver as usize].patch != u32::MAX && (t.f <= 0.0 || t.visibility <= 0.0);
        if old.is_empty() || gated {
            return false;
        }
        if ends[*p as usize].source == s {
            return self.patch_entries(patch, leaf, l, q, n, old, row);
        }
        let up = nodes[s as usize].parent;
        if up == u32::MAX || geoms[up as usize].patch != u32::MAX {
            return false;
        }
        let sub: Vec<(u32, f64)> = old.iter().copied().filter(|&(x, _)| under(x, s)).collect();
        !sub.is_empty() && self.patch_entries(patch, leaf, l, q, n, &sub, row)
    }
}

/// A print of row entries `(source, coefficient)`, bit for bit and in order
/// ([`Solver::keep_move_trace`]).
fn entries_print<'a>(entries: impl Iterator<Item = &'a (u32, f64)>) -> u64 {
    entries.fold(0x5eed_0e17, |h, &(x, c)| {
        oracle::hash3(h, u64::from(x), c.to_bits())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two trees: 0 → {1, 2}, 1 → {3, 4}, 4 → {5}; and 6 → {7}. `tree_order`'s
    /// "under" (`first(x) ≤ first(y) < end(x)`) is the parent walk's for every pair.
    #[test]
    fn tree_order_puts_each_subtree_in_one_range() {
        let node = |parent: u32, first_child: u32, child_count: u32| Node {
            parent,
            first_child,
            child_count,
            kind: 0,
            depth: 0,
            pad: [0; 2],
        };
        let nodes = [
            node(u32::MAX, 1, 2),
            node(0, 3, 2),
            node(0, 0, 0),
            node(1, 0, 0),
            node(1, 5, 1),
            node(4, 0, 0),
            node(u32::MAX, 7, 1),
            node(6, 0, 0),
        ];
        let order = tree_order(&nodes);
        let walk_under = |mut y: u32, x: u32| loop {
            if y == x {
                return true;
            }
            y = nodes[y as usize].parent;
            if y == u32::MAX {
                return false;
            }
        };
        for x in 0..nodes.len() as u32 {
            for y in 0..nodes.len() as u32 {
                let (f, e) = order[x as usize];
                let fy = order[y as usize].0;
                assert_eq!(f <= fy && fy < e, walk_under(y, x), "{y} under {x}");
            }
        }
        let old = [(5, 0.5), (2, 0.25), (3, 0.125), (7, 1.0)];
        let groups = Groups {
            by_order: {
                let mut v: Vec<(u32, u32)> = old
                    .iter()
                    .enumerate()
                    .map(|(i, &(x, _))| (order[x as usize].0, i as u32))
                    .collect();
                v.sort_unstable();
                v
            },
        };
        let mut out = Vec::new();
        groups.under(order[1], &mut out);
        assert_eq!(out, [0, 2]);
        groups.under(order[0], &mut out);
        assert_eq!(out, [0, 1, 2]);
        // 4 was opened (5 lies under it), 5 itself and 2 were not.
        assert!(groups.opened(order[4]) && groups.opened(order[0]));
        assert!(!groups.opened(order[5]) && !groups.opened(order[2]));
    }
}
