//! The final-gather terms a space-time window keeps at its reconstruction points,
//! in three flat arenas (paper 001 §5.2's shortcut applied to the final gather: a
//! static point's transfer from a static source does not change while no moving
//! object can come between them).
//!
//! **What is kept.** For each point, per source of the point's chain (keyed
//! `source << 1 | clear`, see [`crate::solver::Solver::gather_point`]): the terms whose
//! visibility holds over the window ([`FixedTerm`]: element and factor, visibility
//! included) and the terms whose rays a moving object may cross ([`MaskedTerm`]: the
//! static part of each ray's visibility as a mask, re-cast against the moving
//! objects only when one is near).
//!
//! **Layout.** Three [`Column`] arenas on the solver's storage (RAM or a mapped
//! scratch file): one [`TermIndex`] per source (8 bytes: the key and the offsets of
//! its terms from the point's first), the fixed terms (8 bytes) and the masked terms
//! (24 bytes). A point's records are contiguous in each arena ([`PointSpan`]); a
//! point that gains sources is rewritten at the arenas' ends, and the dead records
//! are reclaimed by compacting in place (live spans slide down in arena order)
//! once they make up a quarter of an arena. No per-point heap allocation:
//! what the cache costs is what its arenas hold, and a mapped arena's pages can be
//! handed back to the system after each batch of gathers ([`PointCache::release_resident`]).
//!
//! **Collection.** After each reconstruction the points it registered are stamped;
//! points no reconstruction has registered for [`STALE_AFTER`] reconstructions are
//! dropped (the cells a moving object re-meshes move on with it, and a window
//! would otherwise keep every point any frame ever made). Under a byte budget, the points the last
//! reconstruction did not register are dropped too and no new point is admitted
//! while over it. Dropping changes the work and, a little, the values: a point
//! gathered afresh opens its sources as the frame's hierarchy and radiosity have
//! them now, not as they were when its terms were kept (so the budget is one of the
//! settings a resume journal is keyed by).
//!
//! **One window's.** The cache lives and dies with its window
//! (`Solver::release_window`): a window's values do not depend on the windows
//! solved before it, so shards and resumed solves write what one run writes.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use crate::Result;
use crate::pools::{Column, Storage};
use crate::solver::gather::Terms;
use crate::solver::{FastMap, PointKey};

/// A point whose terms are kept: its place, and the leaf it is gathered from
/// inside where a reconstruction gathers a point once per leaf that has it (the
/// static solve's, and a window of one instant's: each leaf's gather is made at
/// another point, a hair inside that leaf, and takes that leaf's links); [`ANY_LEAF`]
/// where it is gathered once, whichever leaf registered it first.
pub type KeptKey = (PointKey, u32);

/// The leaf of a [`KeptKey`] gathered once, whichever leaf has it.
pub const ANY_LEAF: u32 = u32::MAX;

/// Reconstructions (frames) after which a point no reconstruction registered is
/// dropped. A reconstruction registers every point it meshes, gathered or
/// interpolated, so what goes is the points of cells no frame has meshed for that
/// long (where a moving shadow was). Frames are solved keyframe first, then the
/// frames between (see `spacetime::solve_order`): 8 is ACTOR's key interval, and a
/// longer wait keeps more points without making the frames faster.
pub const STALE_AFTER: u32 = 8;

/// Bytes a compaction slides before it hands the pages of mapped arenas back
/// (each slide touches its source and its destination pages, so a longer slide
/// puts more of them in the peak resident size).
const RELEASE_EVERY: usize = 1 << 20;

/// A final-gather term from a static source to a static point whose rays a moving
/// object may cross: the static part of each ray's visibility is kept as a mask (see
/// [`crate::oracle::static_clear_mask`]), and the visibility that mask gives on its
/// own (the value while no moving object is between the point and the source, used
/// without casting or weighting anything). 24 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct MaskedTerm {
    /// Rays the static part leaves clear.
    pub mask: u64,
    /// Jitter key of the rays (32 bits are plenty for jitter; see
    /// `Solver::point_terms`).
    pub key: u32,
    /// Source element.
    pub elem: u32,
    /// Unoccluded point-to-element factor.
    pub f: f32,
    /// Kernel-weighted fraction of the rays `mask` leaves clear: the visibility while
    /// no moving object is near.
    pub vis_static: f32,
}

const _: () = assert!(std::mem::size_of::<MaskedTerm>() == 24);

/// A kept term whose visibility holds over the window: source element and factor,
/// visibility included. 8 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct FixedTerm {
    /// Source element.
    pub elem: u32,
    /// Point-to-element factor times visibility.
    pub f: f32,
}

const _: () = assert!(std::mem::size_of::<FixedTerm>() == 8);

/// One source of a point's kept terms: its key and where its terms start, counted
/// from the point's first fixed and masked term (they end where the next source's
/// start, or at the point's end). 8 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
#[repr(C)]
pub struct TermIndex {
    /// `source << 1 | clear`.
    pub key: u32,
    /// First fixed term, from the point's first.
    pub fixed: u16,
    /// First masked term, from the point's first.
    pub masked: u16,
}

const _: () = assert!(std::mem::size_of::<TermIndex>() == 8);

/// Where one point's records lie in the arenas, and when it was last registered.
/// 28 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct PointSpan {
    index: u32,
    n_index: u32,
    fixed: u32,
    n_fixed: u32,
    masked: u32,
    n_masked: u32,
    /// Reconstruction that last registered the point.
    stamp: u32,
}

/// One point's kept terms, borrowed from the arenas.
#[derive(Clone, Copy, Debug)]
pub struct PointView<'a> {
    index: &'a [TermIndex],
    fixed: &'a [FixedTerm],
    masked: &'a [MaskedTerm],
}

impl<'a> PointView<'a> {
    /// The fixed and masked terms of source key `key`, if the point keeps them.
    pub fn get(&self, key: u32) -> Option<(&'a [FixedTerm], &'a [MaskedTerm])> {
        let i = self.index.binary_search_by_key(&key, |e| e.key).ok()?;
        let (f, m) = self.ranges(i);
        Some((&self.fixed[f], &self.masked[m]))
    }

    /// Where the terms of the point's `i`-th source lie in its fixed and masked
    /// terms: from its index record's offsets to the next record's (or the end).
    fn ranges(&self, i: usize) -> (Range<usize>, Range<usize>) {
        let e = self.index[i];
        let next = self.index.get(i + 1);
        let f1 = next.map_or(self.fixed.len(), |n| n.fixed as usize);
        let m1 = next.map_or(self.masked.len(), |n| n.masked as usize);
        (e.fixed as usize..f1, e.masked as usize..m1)
    }
}

/// One point's records as the arenas will hold them, made off the cache by
/// [`PointCache::prepare`] and written by [`PointCache::commit`].
pub struct PreparedPoint {
    pk: KeptKey,
    /// The point's slot when prepared (`None`: a new point).
    slot: Option<u32>,
    /// Where that slot's records lay then (index, fixed and masked starts).
    from: [u32; 3],
    index: Vec<TermIndex>,
    fixed: Vec<FixedTerm>,
    masked: Vec<MaskedTerm>,
}

/// The kept final-gather terms of a window (module docs).
pub struct PointCache {
    slots: FastMap<KeptKey, u32>,
    spans: Vec<PointSpan>,
    index: Column<TermIndex>,
    fixed: Column<FixedTerm>,
    masked: Column<MaskedTerm>,
    /// Records of the arenas no span refers to (index, fixed, masked).
    dead: [usize; 3],
    /// Reconstructions collected so far.
    seq: u32,
    /// Bytes of the window's other kept coefficients (leaf rows), counted against
    /// the same budget.
    pub others: usize,
    /// Most bytes to keep (`None`: no bound).
    budget: Option<usize>,
    /// False once an arena could not grow (a full scratch disk): nothing more is
    /// kept, points are gathered afresh instead.
    healthy: bool,
}

impl PointCache {
    /// An empty cache on `storage`, keeping at most `budget` bytes.
    pub fn new(storage: &Storage, budget: Option<usize>) -> Result<Self> {
        Ok(PointCache {
            slots: FastMap::default(),
            spans: Vec::new(),
            index: Column::new(storage, "kept-index")?,
            fixed: Column::new(storage, "kept-fixed")?,
            masked: Column::new(storage, "kept-masked")?,
            dead: [0; 3],
            seq: 0,
            others: 0,
            budget,
            healthy: true,
        })
    }

    /// Bytes one point costs besides its records (the slot map's key, value and
    /// control byte, and its span).
    const POINT: usize = std::mem::size_of::<KeptKey>() + 4 + 1 + std::mem::size_of::<PointSpan>();

    /// Bytes held: the arenas (live and dead records) and the per-point overhead.
    pub fn bytes(&self) -> usize {
        self.index.reserved_bytes()
            + self.fixed.reserved_bytes()
            + self.masked.reserved_bytes()
            + self.spans.len() * Self::POINT
    }

    /// True if a new point's terms may be kept.
    pub fn admits(&self) -> bool {
        self.healthy && self.budget.is_none_or(|b| self.bytes() + self.others < b)
    }

    /// The kept terms of point `pk`.
    pub fn get(&self, pk: &KeptKey) -> Option<PointView<'_>> {
        let s = self.spans[*self.slots.get(pk)? as usize];
        let at = |start: u32, n: u32| start as usize..(start + n) as usize;
        Some(PointView {
            index: &self.index.as_slice()[at(s.index, s.n_index)],
            fixed: &self.fixed.as_slice()[at(s.fixed, s.n_fixed)],
            masked: &self.masked.as_slice()[at(s.masked, s.n_masked)],
        })
    }

    /// Adds the terms gathered afresh at point `pk` (sources it keeps already are
    /// left as they are). A point whose terms would not fit the 16-bit offsets is
    /// not kept. [`PointCache::prepare`] then [`PointCache::commit`] (which the
    /// reconstruction calls apart).
    #[cfg(test)]
    pub fn add(&mut self, pk: KeptKey, links: Vec<(u32, Terms)>) {
        if let Some(p) = self.prepare(pk, links) {
            self.commit(p);
        }
    }

    /// Lays out point `pk`'s kept sources and the new ones among `links` (the
    /// first of each key; those it keeps already are left as they are) as the
    /// arenas hold them, in key order: `None` if nothing is new or nothing new may
    /// be kept. Reads the cache only, so the parallel gathers of a batch make
    /// their points' records themselves and the thread between batches only
    /// copies them in ([`PointCache::commit`]; on ACTOR this was a quarter of
    /// the serial time between batches).
    pub fn prepare(&self, pk: KeptKey, links: Vec<(u32, Terms)>) -> Option<PreparedPoint> {
        let slot = self.slots.get(&pk).copied();
        if !self.healthy || (slot.is_none() && !self.admits()) {
            return None;
        }
        let from = slot.map_or([u32::MAX; 3], |s| self.starts(s));
        let old = slot.and_then(|_| self.get(&pk));
        let old_index = old.map_or(&[][..], |v| v.index);
        let mut new: Vec<(u32, Terms)> = links
            .into_iter()
            .filter(|(key, _)| old_index.binary_search_by_key(key, |e| e.key).is_err())
            .collect();
        // Stable, so the first of each key comes first and stays.
        new.sort_by_key(|s| s.0);
        new.dedup_by_key(|s| s.0);
        if new.is_empty() {
            return None;
        }
        let n = old_index.len() + new.len();
        let mut p = PreparedPoint {
            pk,
            slot,
            from,
            index: Vec::with_capacity(n),
            fixed: Vec::new(),
            masked: Vec::new(),
        };
        // Merges the two key-ordered lists (their keys are disjoint).
        let (mut i, mut j) = (0, 0);
        while i < old_index.len() || j < new.len() {
            let take_old = j == new.len() || (i < old_index.len() && old_index[i].key < new[j].0);
            let key = if take_old { old_index[i].key } else { new[j].0 };
            p.index.push(TermIndex {
                key,
                fixed: p.fixed.len() as u16,
                masked: p.masked.len() as u16,
            });
            if take_old {
                let v = old.expect("old keys come from a kept point");
                let (f, m) = v.ranges(i);
                p.fixed.extend_from_slice(&v.fixed[f]);
                p.masked.extend_from_slice(&v.masked[m]);
                i += 1;
            } else {
                let t = &new[j].1;
                p.fixed.extend(
                    t.fixed
                        .iter()
                        .map(|&(elem, f)| FixedTerm { elem, f: f as f32 }),
                );
                p.masked.extend(t.masked.iter().map(|(m, _)| *m));
                j += 1;
            }
        }
        Some(p)
    }

    /// Writes what [`PointCache::prepare`] made, if the point's records are still
    /// the ones it was made from and it may still be kept (a batch's points are
    /// distinct and the cache changes between batches only, so they are; if not,
    /// nothing is written and the terms are gathered again when next needed).
    pub fn commit(&mut self, p: PreparedPoint) {
        let slot = self.slots.get(&p.pk).copied();
        let same = slot == p.slot && slot.is_none_or(|s| self.starts(s) == p.from);
        if !same || !self.healthy || (slot.is_none() && !self.admits()) {
            return;
        }
        self.append(p.pk, slot, &p.index, &p.fixed, &p.masked);
    }

    /// Writes point `pk`'s records at the arenas' ends, in place of slot `slot`'s
    /// records if it has one. A point whose terms would not fit the 16-bit offsets
    /// is not kept.
    fn append(
        &mut self,
        pk: KeptKey,
        slot: Option<u32>,
        index: &[TermIndex],
        fixed: &[FixedTerm],
        masked: &[MaskedTerm],
    ) {
        let (n_fixed, n_masked) = (fixed.len(), masked.len());
        if n_fixed > usize::from(u16::MAX) || n_masked > usize::from(u16::MAX) {
            if let Some(s) = slot {
                self.forget(s);
                self.slots.remove(&pk);
            }
            return;
        }
        let span = PointSpan {
            index: self.index.len() as u32,
            n_index: index.len() as u32,
            fixed: self.fixed.len() as u32,
            n_fixed: n_fixed as u32,
            masked: self.masked.len() as u32,
            n_masked: n_masked as u32,
            stamp: self.seq,
        };
        let appended = self
            .index
            .extend_from_slice(index)
            .and_then(|()| self.fixed.extend_from_slice(fixed))
            .and_then(|()| self.masked.extend_from_slice(masked));
        if let Err(e) = appended {
            // What was appended is dead; the point keeps its old span.
            eprintln!(
                "rhier: warning: kept final-gather terms: {e}; points are gathered afresh from now on"
            );
            self.healthy = false;
            self.index.truncate(span.index as usize);
            self.fixed.truncate(span.fixed as usize);
            self.masked.truncate(span.masked as usize);
            return;
        }
        match slot {
            Some(s) => {
                self.forget(s);
                self.spans[s as usize] = span;
            }
            None => {
                self.slots.insert(pk, self.spans.len() as u32);
                self.spans.push(span);
            }
        }
    }

    /// Where slot `s`'s records start in the three arenas.
    fn starts(&self, s: u32) -> [u32; 3] {
        let sp = self.spans[s as usize];
        [sp.index, sp.fixed, sp.masked]
    }

    /// Counts slot `s`'s records as dead.
    fn forget(&mut self, s: u32) {
        let sp = self.spans[s as usize];
        self.dead[0] += sp.n_index as usize;
        self.dead[1] += sp.n_fixed as usize;
        self.dead[2] += sp.n_masked as usize;
    }

    /// Ends a reconstruction that registered the points `used`: stamps them, drops
    /// the points unregistered for [`STALE_AFTER`] reconstructions (and, over the
    /// budget, every point not in `used`), and compacts the arenas when dead records
    /// (of rewritten or dropped points) make up a quarter of one, or, over the
    /// budget, when there are any.
    pub fn collect(&mut self, used: &FastMap<KeptKey, usize>) {
        self.seq += 1;
        let seq = self.seq;
        for pk in used.keys() {
            if let Some(&s) = self.slots.get(pk) {
                self.spans[s as usize].stamp = seq;
            }
        }
        let over = self.budget.is_some_and(|b| self.bytes() + self.others > b);
        let spans = &self.spans;
        let mut dropped = Vec::new();
        self.slots.retain(|_, s| {
            let stamp = spans[*s as usize].stamp;
            let keep = stamp == seq || (!over && stamp + STALE_AFTER > seq);
            if !keep {
                dropped.push(*s);
            }
            keep
        });
        for s in dropped {
            self.forget(s);
        }
        let live = [self.index.len(), self.fixed.len(), self.masked.len()];
        if self
            .dead
            .iter()
            .zip(live)
            .any(|(&d, l)| d > 0 && (over || 4 * d >= l))
        {
            self.compact();
        }
    }

    /// Slides the live spans down over the dead records, in arena order.
    fn compact(&mut self) {
        let mut live: Vec<u32> = self.slots.values().copied().collect();
        // New slots in arena order (a point's records are appended together, so
        // the order is the same in the three arenas).
        live.sort_unstable_by_key(|&s| self.spans[s as usize].index);
        let mut remap = vec![u32::MAX; self.spans.len()];
        let mut spans = Vec::with_capacity(live.len());
        let (mut i, mut f, mut m) = (0u32, 0u32, 0u32);
        let mut moved = 0;
        for &s in &live {
            let old = self.spans[s as usize];
            let slide = |col: &mut [u8], size: usize, from: u32, n: u32, to: u32| {
                let (from, n, to) = (from as usize * size, n as usize * size, to as usize * size);
                col.copy_within(from..from + n, to);
            };
            slide(
                bytemuck::cast_slice_mut(self.index.as_mut_slice()),
                8,
                old.index,
                old.n_index,
                i,
            );
            slide(
                bytemuck::cast_slice_mut(self.fixed.as_mut_slice()),
                8,
                old.fixed,
                old.n_fixed,
                f,
            );
            slide(
                bytemuck::cast_slice_mut(self.masked.as_mut_slice()),
                24,
                old.masked,
                old.n_masked,
                m,
            );
            remap[s as usize] = spans.len() as u32;
            spans.push(PointSpan {
                index: i,
                fixed: f,
                masked: m,
                ..old
            });
            i += old.n_index;
            f += old.n_fixed;
            m += old.n_masked;
            // Out of core, the pages slid over go back as it goes.
            moved += (old.n_index + old.n_fixed) as usize * 8 + old.n_masked as usize * 24;
            if moved > RELEASE_EVERY {
                moved = 0;
                self.release_resident();
            }
        }
        self.release_resident();
        self.index.truncate(i as usize);
        self.fixed.truncate(f as usize);
        self.masked.truncate(m as usize);
        for s in self.slots.values_mut() {
            *s = remap[*s as usize];
        }
        self.spans = spans;
        self.dead = [0; 3];
        self.index.shrink();
        self.fixed.shrink();
        self.masked.shrink();
    }

    /// Hands the pages of mapped arenas back to the system (they stay in the
    /// scratch file and are read again when next needed): what bounds the resident
    /// size of an out-of-core window. Nothing for RAM arenas.
    pub fn release_resident(&self) {
        self.index.release_resident();
        self.fixed.release_resident();
        self.masked.release_resident();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn terms(fixed: &[(u32, f64)], masked: &[u32]) -> Terms {
        Terms {
            fixed: fixed.to_vec(),
            masked: masked
                .iter()
                .map(|&elem| {
                    (
                        MaskedTerm {
                            mask: u64::from(elem) * 3,
                            key: elem + 1,
                            elem,
                            f: 0.25,
                            vis_static: 0.5,
                        },
                        0.5,
                    )
                })
                .collect(),
        }
    }

    fn check(cache: &PointCache, pk: KeptKey, key: u32, fixed: &[u32], masked: &[u32]) {
        let view = cache.get(&pk).expect("point kept");
        let (f, m) = view.get(key).expect("source kept");
        assert_eq!(f.iter().map(|t| t.elem).collect::<Vec<_>>(), fixed);
        assert_eq!(m.iter().map(|t| t.elem).collect::<Vec<_>>(), masked);
        assert!(
            m.iter()
                .all(|t| t.mask == u64::from(t.elem) * 3 && t.key == t.elem + 1)
        );
    }

    fn caches() -> Vec<(PointCache, tempfile::TempDir)> {
        let dir = tempfile::tempdir().expect("temp dir");
        let ram = PointCache::new(&Storage::Ram, None).expect("ram");
        let mapped = PointCache::new(&Storage::Mmap(dir.path().to_path_buf()), None).expect("mmap");
        let dir2 = tempfile::tempdir().expect("temp dir");
        vec![(ram, dir2), (mapped, dir)]
    }

    #[test]
    fn a_point_keeps_each_source_once_in_key_order_across_adds() {
        for (mut c, _dir) in caches() {
            let pk = ((3, 10, 20), 0);
            c.add(
                pk,
                vec![
                    (9, terms(&[(1, 0.5), (2, 0.25)], &[7])),
                    (4, terms(&[(5, 1.0)], &[])),
                ],
            );
            // A second add brings a new source and repeats a known one (ignored).
            c.add(
                pk,
                vec![(6, terms(&[], &[8, 11])), (9, terms(&[(99, 1.0)], &[]))],
            );
            check(&c, pk, 4, &[5], &[]);
            check(&c, pk, 6, &[], &[8, 11]);
            check(&c, pk, 9, &[1, 2], &[7]);
            assert!(c.get(&pk).and_then(|v| v.get(5)).is_none());
            // The first span is dead now: 2 of 3 index records, 3 of 4 fixed.
            assert_eq!(c.dead, [2, 3, 1]);
            let f = c.get(&pk).and_then(|v| v.get(9)).map(|(f, _)| f[1].f);
            assert_eq!(f, Some(0.25));
        }
    }

    #[test]
    fn a_key_twice_in_one_gather_keeps_its_first_terms() {
        for (mut c, _dir) in caches() {
            let pk = ((0, 1, 2), 0);
            c.add(
                pk,
                vec![
                    (7, terms(&[(1, 0.5)], &[2])),
                    (3, terms(&[(4, 1.0)], &[])),
                    (7, terms(&[(99, 1.0)], &[98])),
                ],
            );
            check(&c, pk, 3, &[4], &[]);
            check(&c, pk, 7, &[1], &[2]);
            assert_eq!((c.index.len(), c.fixed.len(), c.masked.len()), (2, 2, 1));
        }
    }

    #[test]
    fn records_prepared_for_a_slot_since_rewritten_are_not_written() {
        for (mut c, _dir) in caches() {
            let pk = ((2, 0, 0), 0);
            c.add(pk, vec![(2, terms(&[(1, 0.5)], &[]))]);
            // PreparedPoint from the point as it was, then the point is rewritten.
            let stale = c.prepare(pk, vec![(4, terms(&[(5, 0.5)], &[]))]);
            let fresh = c.prepare(pk, vec![(6, terms(&[(7, 0.5)], &[]))]);
            assert!(stale.is_some() && fresh.is_some());
            c.commit(fresh.expect("prepared"));
            let before = (c.index.len(), c.fixed.len(), c.masked.len());
            c.commit(stale.expect("prepared"));
            // Same slot, but the span it was made from is dead: writing it would
            // drop source 6, so nothing is written (only work is lost).
            assert_eq!((c.index.len(), c.fixed.len(), c.masked.len()), before);
            check(&c, pk, 2, &[1], &[]);
            check(&c, pk, 6, &[7], &[]);
            // Nothing new: nothing to write.
            assert!(c.prepare(pk, vec![(6, terms(&[(9, 1.0)], &[]))]).is_none());
        }
    }

    #[test]
    fn stale_points_are_dropped_and_the_rest_survive_compaction() {
        for (mut c, _dir) in caches() {
            let a = ((1, 0, 0), 0);
            let b = ((1, 0, 0), 1);
            c.add(a, vec![(2, terms(&[(1, 0.5)], &[3]))]);
            c.add(b, vec![(2, terms(&[(4, 0.5), (5, 0.125)], &[6]))]);
            // `a` gains a source (its first span dies), both registered.
            c.add(a, vec![(8, terms(&[(9, 1.0)], &[]))]);
            let both: FastMap<KeptKey, usize> = [(a, 0), (b, 1)].into_iter().collect();
            let only_b: FastMap<KeptKey, usize> = [(b, 1)].into_iter().collect();
            c.collect(&both);
            for round in 0..STALE_AFTER {
                assert!(c.get(&a).is_some(), "round {round}");
                c.collect(&only_b);
            }
            assert!(c.get(&a).is_none());
            assert_eq!(c.slots.len(), 1);
            // Compacted: `b` alone is left, first in each arena.
            assert_eq!(c.dead, [0; 3]);
            assert_eq!((c.index.len(), c.fixed.len(), c.masked.len()), (1, 2, 1));
            check(&c, b, 2, &[4, 5], &[6]);
        }
    }

    #[test]
    fn over_budget_only_the_points_just_registered_are_kept_and_none_admitted() {
        let mut c = PointCache::new(&Storage::Ram, Some(200)).expect("ram");
        let (a, b) = (((0, 0, 0), 0), ((0, 0, 1), 0));
        c.add(a, vec![(2, terms(&[(1, 0.5); 8], &[3, 4]))]);
        assert!(c.bytes() > 100);
        c.add(b, vec![(2, terms(&[(1, 0.5); 8], &[3, 4]))]);
        assert!(c.bytes() > 200);
        assert!(!c.admits());
        c.add(((0, 0, 2), 0), vec![(2, terms(&[(1, 0.5)], &[]))]);
        assert!(c.get(&((0, 0, 2), 0)).is_none());
        c.collect(&[(b, 0)].into_iter().collect());
        assert!(c.get(&a).is_none());
        check(&c, b, 2, &[1; 8], &[3, 4]);
        assert!(c.admits());
    }
}
