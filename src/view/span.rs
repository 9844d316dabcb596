//! Spans: stretches of time that the page draws from one mesh, so that a space-time
//! file, whose live leaves change at every frame, sends its corner positions once per
//! span and only its colours per frame.
//!
//! How it works: a span lies inside one chunk range of the file (the times at which
//! [`crate::store::Reader::chunks_for`] looks at the same chunks, the `part` of a
//! [`crate::store::Stretch`]), and holds every leaf of those chunks that is live
//! anywhere in it: `t0 < hi` and `t1 >= lo` in `f32` (a few more than
//! [`Leaf::is_live`] would ever draw, never fewer). [`boundaries`] cuts a chunk range
//! greedily at leaf starts: a span begins with the leaves live at its start and takes
//! in leaves as they start until it holds [`GROWTH`] times that many (at least
//! [`MIN_LEAVES`]); a range whose leaves all start together (a static or rigidly
//! moving scene) is one span. Each leaf keeps its `f32` time range in the mesh
//! (formats/view.md), and the page draws the leaves live at the shown time, by the
//! same test as [`Leaf::is_live`].
//!
//! A span's leaves are in mesh order: by object, then the frame's order
//! ([`canonical_order`], total); the leaves live at a time, in the frame's order
//! grouped by object, are in the same order ([`crate::view::wire::color_section`]).

use crate::solution::{Leaf, PatchGeometry};
use crate::store::live::canonical_order;

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
        let object = |l: &Leaf| patches.get(l.patch as usize).map_or(0, |p| p.object);
        let mut held: Vec<(u32, Leaf)> = chunks
            .iter()
            .flat_map(|c| c.iter())
            .filter(|l| l.time[0] < hi && l.time[1] >= lo)
            .map(|l| (object(l), *l))
            .collect();
        held.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| canonical_order(&a.1, &b.1)));
        Span {
            key: ((part as u64) << 32) | index as u64,
            lo,
            hi,
            objects: held.iter().map(|x| x.0).collect(),
            leaves: held.into_iter().map(|x| x.1).collect(),
        }
    }

    /// True if `t` (seconds) is in the span.
    pub fn contains(&self, t: f64) -> bool {
        let tf = t as f32;
        self.lo <= tf && tf < self.hi
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
}
