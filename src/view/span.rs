//! Spans: stretches of time that the page draws from one mesh, so that a space-time
//! file, whose live leaves change at every frame, sends its corner positions once per
//! span and only its colours per frame; and the live leaves at a time found from the
//! span alone, without reading the rest of the chunks.
//!
//! How it works: a span lies inside one chunk range of the file (the times at which
//! [`crate::store::Reader::chunks_for`] looks at the same chunks, the `part` of a
//! [`crate::store::Stretch`]), and holds every leaf of those chunks that is live
//! anywhere in it: `t0 < hi` and `t1 >= lo` in `f32` (a few more than
//! [`Leaf::is_live`] would ever draw, never fewer). [`boundaries`] cuts a chunk range
//! greedily at leaf starts: a span begins with the leaves live at its start and takes
//! in leaves as they start until it holds [`GROWTH`] times that many (at least
//! [`MIN_LEAVES`]); a range whose leaves all start together (a static or rigidly
//! moving scene) is one span. A [`Plan`] is a chunk range's boundaries with its
//! leaves sorted once in [`canonical_order`], so that building a span filters that
//! order by time (no sort). Each leaf keeps its `f32` time range in the mesh
//! (formats/view.md), and the page draws the leaves live at the shown time, by the
//! same test as [`Leaf::is_live`].
//!
//! A span's leaves are in mesh order: by object, then the frame's order
//! ([`canonical_order`], total); the leaves live at a time, in the frame's order
//! grouped by object, are in the same order ([`crate::view::wire::color_section`]).
//! [`Span::live`] gives the leaves live at a time in the span with their stretch:
//! no leaf outside the span is live in it, so the span's bounds and its own leaves'
//! times cut the stretch ([`Stretch::cut`]) as all the chunks' leaves would.

use std::sync::Arc;

use crate::solution::{Leaf, PatchGeometry};
use crate::store::live::canonical_order;
use crate::store::{Live, Stretch};

/// A span takes in starting leaves until it holds this many times the leaves live
/// at its start.
pub const GROWTH: usize = 4;
/// ... and at least this many leaves.
pub const MIN_LEAVES: usize = 4096;

/// The span boundaries of a chunk range `[lo, hi)` (`f32` times) holding the leaves
/// of `chunks` (its chunks'): `lo`, the cuts in increasing order, then `hi`.
pub fn boundaries(chunks: &[&[Leaf]], lo: f32, hi: f32) -> Vec<f32> {
    let leaves = || chunks.iter().flat_map(|c| c.iter());
    let mut starts: Vec<f32> = leaves()
        .map(|l| l.time[0])
        .filter(|&s| s > lo && s < hi)
        .collect();
    starts.sort_by(f32::total_cmp);
    // Distinct starts and how many leaves start at each.
    let mut at: Vec<(f32, usize)> = Vec::new();
    for s in starts {
        match at.last_mut() {
            Some((x, n)) if *x == s => *n += 1,
            _ => at.push((s, 1)),
        }
    }
    let mut out = vec![lo];
    let (mut a, mut k) = (lo, 0);
    loop {
        // The span from `a` to the next start holds the leaves begun by then and not
        // ended before `a`.
        let next = at.get(k).map_or(hi, |x| x.0);
        let base = leaves()
            .filter(|l| l.time[0] < next && l.time[1] >= a)
            .count();
        let budget = (GROWTH * base).max(MIN_LEAVES);
        let mut count = base;
        while k < at.len() && count + at[k].1 <= budget {
            count += at[k].1;
            k += 1;
        }
        if k >= at.len() {
            break;
        }
        a = at[k].0;
        out.push(a);
        k += 1;
    }
    out.push(hi);
    out
}

/// A chunk range indexed for span builds: its span boundaries and its leaves in
/// [`canonical_order`].
pub struct Plan {
    /// The chunk range's index (a [`Stretch`]'s `part`).
    pub part: u32,
    /// The span boundaries ([`boundaries`]): `lo`, the cuts, `hi`.
    pub cuts: Vec<f32>,
    /// The range's chunks' leaves, held while the plan is.
    chunks: Vec<Arc<Vec<Leaf>>>,
    /// Every leaf of the range in canonical order: (chunk, index in it).
    order: Vec<(u32, u32)>,
    /// Their time ranges, in that order.
    times: Vec<[f32; 2]>,
}

impl Plan {
    /// The plan of chunk range `part`, `[lo, hi)` in `f32` times, of the leaves of
    /// `chunks` (the chunks [`crate::store::Reader::chunks_for`] looks at in it).
    pub fn new(part: u32, (lo, hi): (f32, f32), chunks: Vec<Arc<Vec<Leaf>>>) -> Plan {
        let all: Vec<&[Leaf]> = chunks.iter().map(|c| &c[..]).collect();
        let cuts = boundaries(&all, lo, hi);
        let mut order: Vec<(u32, u32)> = chunks
            .iter()
            .enumerate()
            .flat_map(|(c, l)| (0..l.len() as u32).map(move |k| (c as u32, k)))
            .collect();
        let leaf = |&(c, k): &(u32, u32)| &chunks[c as usize][k as usize];
        order.sort_unstable_by(|a, b| canonical_order(leaf(a), leaf(b)));
        let times = order.iter().map(|x| leaf(x).time).collect();
        Plan {
            part,
            cuts,
            chunks,
            order,
            times,
        }
    }

    /// The index of the span holding `f32` time `tf`, and its bounds.
    pub fn span_of(&self, tf: f32) -> (u32, (f32, f32)) {
        let j = self.cuts.partition_point(|&b| b <= tf).saturating_sub(1);
        let hi = self.cuts.get(j + 1).copied().unwrap_or(f32::INFINITY);
        (j as u32, (self.cuts[j], hi))
    }

    /// Span `j` of the range ([`Plan::span_of`]), its leaves on `patches`.
    pub fn span(&self, j: u32, patches: &[PatchGeometry]) -> Span {
        let lo = self.cuts.get(j as usize).copied().unwrap_or(f32::INFINITY);
        let hi = self
            .cuts
            .get(j as usize + 1)
            .copied()
            .unwrap_or(f32::INFINITY);
        let held: Vec<Leaf> = self
            .order
            .iter()
            .zip(&self.times)
            .filter(|(_, t)| t[0] < hi && t[1] >= lo)
            .map(|(&(c, k), _)| self.chunks[c as usize][k as usize])
            .collect();
        Span::from_canonical((self.part, j), (lo, hi), held, patches)
    }
}

/// One span's leaves, in mesh order, grouped by object.
#[derive(Clone, Debug)]
pub struct Span {
    /// The mesh key: the chunk range (high 32 bits) and the span's index in it.
    pub key: u64,
    /// First `f32` time of the span.
    pub lo: f32,
    /// First `f32` time after it.
    pub hi: f32,
    /// The leaves, by object then [`canonical_order`].
    pub leaves: Vec<Leaf>,
    /// Each leaf's object (the order's first key).
    pub objects: Vec<u32>,
    /// The leaves in [`canonical_order`]: indices into `leaves`.
    pub canonical: Vec<u32>,
}

impl Span {
    /// The span `[lo, hi)` of chunk range `part`, index `index`, of the leaves of
    /// the range's `chunks` on `patches`.
    pub fn new(
        (part, index): (u32, u32),
        (lo, hi): (f32, f32),
        chunks: &[&[Leaf]],
        patches: &[PatchGeometry],
    ) -> Span {
        let mut held: Vec<Leaf> = chunks
            .iter()
            .flat_map(|c| c.iter())
            .filter(|l| l.time[0] < hi && l.time[1] >= lo)
            .copied()
            .collect();
        held.sort_by(canonical_order);
        Span::from_canonical((part, index), (lo, hi), held, patches)
    }

    /// The span `[lo, hi)` of chunk range `part`, index `index`, holding `held`
    /// (in [`canonical_order`]) on `patches`.
    fn from_canonical(
        (part, index): (u32, u32),
        (lo, hi): (f32, f32),
        held: Vec<Leaf>,
        patches: &[PatchGeometry],
    ) -> Span {
        let object = |l: &Leaf| patches.get(l.patch as usize).map_or(0, |p| p.object);
        // Mesh order: canonical order stably sorted by object.
        let mut by_object: Vec<u32> = (0..held.len() as u32).collect();
        by_object.sort_by_key(|&k| object(&held[k as usize]));
        let mut canonical = vec![0u32; held.len()];
        for (m, &k) in by_object.iter().enumerate() {
            canonical[k as usize] = m as u32;
        }
        Span {
            key: ((part as u64) << 32) | index as u64,
            lo,
            hi,
            objects: by_object
                .iter()
                .map(|&k| object(&held[k as usize]))
                .collect(),
            leaves: by_object.iter().map(|&k| held[k as usize]).collect(),
            canonical,
        }
    }

    /// True if `t` (seconds) is in the span.
    pub fn contains(&self, t: f64) -> bool {
        let tf = t as f32;
        self.lo <= tf && tf < self.hi
    }

    /// The leaves live at `t` (in the span) in a domain ending at `t_end`, in
    /// canonical order, and their stretch, cut by the span's bounds and its leaves
    /// ([`Live::scan`] over the span): what [`crate::store::Reader::live_at`] finds
    /// from every leaf of the chunks.
    pub fn live(&self, t: f64, t_end: f64) -> Live {
        let tf = t as f32;
        let mut stretch = Stretch {
            part: (self.key >> 32) as u32,
            lo: f32::NEG_INFINITY,
            hi: f32::INFINITY,
        };
        stretch.cut_start(tf, self.lo);
        stretch.cut_start(tf, self.hi);
        let leaves = self.canonical.iter().map(|&k| &self.leaves[k as usize]);
        Live::scan_from(stretch, leaves, t, t_end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(patch: u32, t0: f32, t1: f32) -> Leaf {
        Leaf {
            patch,
            corners: 4,
            time: [t0, t1],
            uv: [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            b: [[0.0; 3]; 4],
        }
    }

    #[test]
    fn leaves_starting_together_are_one_span() {
        let leaves: Vec<Leaf> = (0..10_000).map(|p| leaf(p, 0.0, 2.0)).collect();
        assert_eq!(boundaries(&[&leaves], 0.0, 2.5), vec![0.0, 2.5]);
    }

    #[test]
    fn a_span_grows_to_its_budget_of_starting_leaves() {
        // 5 000 leaves live at a time, each lasting 0.1 s, 1 000 starting every
        // 0.02 s: a span starts with 5 000 (plus those starting at its start) and
        // may hold 4 times that many.
        let mut leaves = Vec::new();
        for k in 0..100 {
            let t0 = k as f32 * 0.02;
            leaves.extend((0..1000).map(|p| leaf(p, t0, t0 + 0.1)));
        }
        let b = boundaries(&[&leaves[..500], &leaves[500..]], 0.0, 2.0);
        assert!(b.len() > 3 && b[0] == 0.0 && b[b.len() - 1] == 2.0, "{b:?}");
        for w in b.windows(2) {
            let held = leaves
                .iter()
                .filter(|l| l.time[0] < w[1] && l.time[1] >= w[0])
                .count();
            let at_start = leaves
                .iter()
                .filter(|l| l.time[0] <= w[0] && l.time[1] >= w[0])
                .count();
            assert!(held <= (GROWTH * at_start).max(MIN_LEAVES), "{w:?}: {held}");
        }
        // Full spans are not cut short: the next start would have overrun.
        let first = leaves
            .iter()
            .filter(|l| l.time[0] < b[1] && l.time[1] >= b[0])
            .count();
        assert!(first + 1000 > GROWTH * 1000, "{first}");
    }

    #[test]
    fn a_span_holds_the_leaves_live_in_it_by_object_then_frame_order() {
        let mut leaves = Vec::new();
        for k in 0..50 {
            leaves.push(leaf(k % 7, k as f32 * 0.1, k as f32 * 0.1 + 0.3));
        }
        let patches: Vec<PatchGeometry> = Vec::new();
        let span = Span::new((1, 2), (1.0, 2.0), &[&leaves], &patches);
        assert_eq!(span.key, (1 << 32) | 2);
        let mut held: Vec<Leaf> = leaves
            .iter()
            .filter(|l| l.time[0] < 2.0 && l.time[1] >= 1.0)
            .copied()
            .collect();
        held.sort_by(canonical_order);
        assert_eq!(span.leaves, held);
        assert!(held.len() > 10 && held.len() < 50);
    }

    #[test]
    fn a_plan_builds_each_span_and_a_span_finds_the_live_leaves_of_all() {
        // 30 000 leaves of 9 patches starting at scattered times and lasting
        // 0.01-0.05 s (about 450 live at a time: spans of MIN_LEAVES), over two
        // chunks: a plan's spans are those built from every leaf, and the leaves
        // live at a time in a span, with their stretch, are those every leaf gives,
        // the stretch cut to the span.
        let mut leaves = Vec::new();
        for k in 0..30_000u32 {
            let t0 = (k.wrapping_mul(2_654_435_761) % 2000) as f32 * 0.001;
            let t1 = t0 + 0.01 + (k % 5) as f32 * 0.01;
            leaves.push(leaf(k % 9, t0, t1.min(2.0)));
        }
        let (a, b) = leaves.split_at(12_000);
        let chunks = vec![Arc::new(a.to_vec()), Arc::new(b.to_vec())];
        let patches: Vec<PatchGeometry> = Vec::new();
        let plan = Plan::new(3, (0.0, 2.5), chunks);
        assert!(plan.cuts.len() > 3, "{:?}", plan.cuts);
        for j in 0..plan.cuts.len() as u32 - 1 {
            let span = plan.span(j, &patches);
            let direct = Span::new((3, j), (span.lo, span.hi), &[a, b], &patches);
            assert_eq!(span.leaves, direct.leaves, "span {j}");
            assert_eq!(span.key, (3 << 32) | j as u64);
            for s in 0..40 {
                let t = span.lo as f64 + (span.hi - span.lo) as f64 * s as f64 / 40.0;
                assert_eq!(plan.span_of(t as f32).0, j);
                let got = span.live(t, 2.0);
                let all = Live::scan(&leaves, t, 2.0);
                assert_eq!(got.leaves, all.leaves, "t = {t}");
                assert_eq!(got.stretch.lo, all.stretch.lo.max(span.lo), "t = {t}");
                assert_eq!(got.stretch.hi, all.stretch.hi.min(span.hi), "t = {t}");
                assert_eq!(got.stretch.part, 3);
            }
        }
    }
}
