//! The leaves live at a time, and the stretch of time over which exactly those stay
//! live, so that frames in one stretch share one set instead of each finding it anew.
//!
//! How it works: a leaf is live at `t` by [`Leaf::is_live`], which compares `t` rounded
//! to `f32` with the leaf's `f32` start and end. So the set only changes where `t as
//! f32` crosses a start (live from `t0` on) or an end (dead from `t1` on, or just after
//! `t1` when `t1` is the domain's end). [`Stretch::cut`] narrows an interval `[lo, hi)`
//! of `f32` times around `t as f32` by one such crossing; cut by every leaf considered,
//! it holds the times at which each of them is live exactly when it is at `t`. A
//! reader also considers only some chunks, chosen by `t as f32` too
//! ([`crate::store::Reader::chunks_for`]): the chunk range's start and the next
//! chunk's cut like leaf starts, and a chunk dropped by its reach like a leaf ending
//! at that reach; so a stretch never outlives the set its chunks give.
//!
//! [`Live`] is a set with its stretch, its leaves in the one canonical order that
//! frames use ([`canonical_order`]: sorted once here, not per frame) and shared
//! (`Arc`). Its [`Stretch::id`], the chunk range's index and `lo`, is the same for every time
//! of the stretch and differs between stretches, so it names the set: `rhier view`
//! sends it as the mesh key instead of a checksum of the leaves.

use std::cmp::Ordering;
use std::sync::Arc;

use crate::solution::Leaf;

/// Times around one time at which the live leaves are the same: those with
/// `lo <= t as f32 < hi`, in chunk range `part`. 12 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stretch {
    /// Which chunk range of the source (a reader's chunk partition; 0 for all leaves).
    pub part: u32,
    /// First `f32` time of the stretch.
    pub lo: f32,
    /// First `f32` time after it.
    pub hi: f32,
}

const _: () = assert!(std::mem::size_of::<Stretch>() == 12);

impl Stretch {
    /// The stretch of a time in chunk range `part` before any cut: every time.
    pub fn whole(part: u32) -> Stretch {
        Stretch {
            part,
            lo: f32::NEG_INFINITY,
            hi: f32::INFINITY,
        }
    }

    /// True if the live set at `t` is this stretch's.
    pub fn contains(&self, t: f64) -> bool {
        let tf = t as f32;
        self.lo <= tf && tf < self.hi
    }

    /// Narrows the stretch of `tf` (`t as f32`) to one side of `at`, where something
    /// changes between `tf < at` and `tf >= at` (a leaf's or a chunk's start).
    pub fn cut_start(&mut self, tf: f32, at: f32) {
        if tf < at {
            self.hi = self.hi.min(at);
        } else {
            self.lo = self.lo.max(at);
        }
    }

    /// Narrows the stretch of `tf` (`t as f32`) to where a leaf of `f32` time range
    /// `[t0, t1]` in a domain ending at `t_end` is live if and only if it is at `tf`
    /// ([`Leaf::is_live`]).
    pub fn cut(&mut self, tf: f32, [t0, t1]: [f32; 2], t_end: f32) {
        self.cut_start(tf, t0);
        self.cut_end(tf, t1, t_end);
    }

    /// The end half of [`Stretch::cut`]: something that holds while `tf < t1`, or
    /// while `tf <= t1` when `t1` reaches the domain's end `t_end` (a leaf's end, or
    /// a chunk's reach).
    pub fn cut_end(&mut self, tf: f32, t1: f32, t_end: f32) {
        self.cut_start(tf, if t1 >= t_end { next_up(t1) } else { t1 });
    }

    /// A name of the stretch: the same for each time in it, different for times in
    /// different stretches of the same source: its chunk range (high 32 bits), then
    /// `lo` (two stretches of one range are disjoint, so they start apart).
    pub fn id(&self) -> u64 {
        ((self.part as u64) << 32) | self.lo.to_bits() as u64
    }
}

/// The least `f32` above `x` (`f32::next_up`, stable only after the crate's MSRV).
fn next_up(x: f32) -> f32 {
    if x.is_nan() || x == f32::INFINITY {
        x
    } else if x == 0.0 {
        f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        f32::from_bits(x.to_bits() - 1)
    }
}

/// The order of leaves in a frame: patch, start time, then corner parameters, so that
/// a solution and its file pick the same leaf where two domains touch; then end time,
/// corner count and every other parameter, so that no two leaves tie (`rhier view`
/// sends a frame's colours in this order, grouped by object, for a mesh of more
/// leaves in the same order).
pub fn canonical_order(a: &Leaf, b: &Leaf) -> Ordering {
    a.patch
        .cmp(&b.patch)
        .then(a.time[0].total_cmp(&b.time[0]))
        .then(a.uv[0][1].total_cmp(&b.uv[0][1]))
        .then(a.uv[0][0].total_cmp(&b.uv[0][0]))
        .then(a.uv[1][0].total_cmp(&b.uv[1][0]))
        .then(a.uv[2][1].total_cmp(&b.uv[2][1]))
        .then(a.time[1].total_cmp(&b.time[1]))
        .then(a.corners.cmp(&b.corners))
        .then_with(|| {
            a.uv.iter()
                .flatten()
                .zip(b.uv.iter().flatten())
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(Ordering::Equal)
        })
}

/// The leaves live at some time, in [`canonical_order`], and the stretch over which
/// they are the live ones. Cloning shares the leaves.
#[derive(Clone, Debug)]
pub struct Live {
    /// Where these leaves are the live ones.
    pub stretch: Stretch,
    /// The leaves, in [`canonical_order`].
    pub leaves: Arc<[Leaf]>,
}

impl Live {
    /// The set of `leaves` (in any order) over `stretch`.
    pub fn new(stretch: Stretch, mut leaves: Vec<Leaf>) -> Live {
        leaves.sort_by(canonical_order);
        Live {
            stretch,
            leaves: leaves.into(),
        }
    }

    /// The leaves of `all` live at `t` in a domain ending at `t_end`, and their
    /// stretch: every leaf of `all` cuts it (`all` is every leaf there is, as in a
    /// solution in memory).
    pub fn scan(all: &[Leaf], t: f64, t_end: f64) -> Live {
        Live::scan_from(Stretch::whole(0), all, t, t_end)
    }

    /// [`Live::scan`] of the leaves `all` yields, the stretch starting as `stretch`
    /// (already cut by what else bounds it, as `rhier view`'s spans are).
    pub fn scan_from<'a>(
        mut stretch: Stretch,
        all: impl IntoIterator<Item = &'a Leaf>,
        t: f64,
        t_end: f64,
    ) -> Live {
        let (tf, end) = (t as f32, t_end as f32);
        let leaves = all
            .into_iter()
            .filter(|l| {
                stretch.cut(tf, l.time, end);
                l.is_live(t, t_end)
            })
            .copied()
            .collect();
        Live::new(stretch, leaves)
    }
}
