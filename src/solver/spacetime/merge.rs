//! The merge of cells over time: consecutive frames' reconstruction cells whose
//! corners hold within a tolerance of their running mean become one leaf with a
//! longer time range (Damez & Sillion, paper 001, §4.3 eq. 8–9: an element not
//! split in time holds one value over its range), and a window's leaves are put in
//! the order the file keeps them ([`in_file_order`]).

use bytemuck::Zeroable;

use crate::Result;
use crate::pools::Column;
use crate::solution::Leaf;

/// A leaf being extended over consecutive frames, 112 bytes (its patch and corners
/// are its key in [`TimeMerge::runs`]: a window keeps thousands open).
struct OpenLeaf {
    sum: [[f64; 3]; 4],
    /// Start of its time range.
    start: f32,
    corners: u32,
    frames: u32,
    /// Frame (within the window) it was last extended at.
    last: u32,
}

const _: () = assert!(std::mem::size_of::<OpenLeaf>() == 112);

impl OpenLeaf {
    fn mean(&self) -> [[f64; 3]; 4] {
        self.sum.map(|c| c.map(|v| v / self.frames.max(1) as f64))
    }

    fn close(self, key: &CellKey, end: f64) -> Leaf {
        Leaf {
            patch: key.0,
            corners: self.corners,
            time: [self.start, end as f32],
            uv: key.1.map(|c| c.map(f32::from_bits)),
            b: self.mean().map(|c| c.map(|x| x as f32)),
        }
    }
}

type CellKey = (u32, [[u32; 2]; 4]);

/// Consecutive frames' cells merged into leaves with longer time ranges while their
/// corners hold within `tol` of the running mean (the module docs): where nothing changes, a window stores each cell once.
pub(super) struct TimeMerge {
    runs: crate::solver::FastMap<CellKey, OpenLeaf>,
    /// Closed leaves, in the order their runs closed: on the pools' storage, so out
    /// of core on `--storage mmap` ([`in_file_order`] sorts them).
    done: Column<Leaf>,
    tol: f64,
}

impl TimeMerge {
    /// An empty merge at tolerance `tol` whose closed leaves go to a column on
    /// `storage`.
    pub(super) fn new(storage: &crate::pools::Storage, tol: f64) -> Result<Self> {
        Ok(TimeMerge {
            runs: Default::default(),
            done: Column::new(storage, "window-leaves")?,
            tol,
        })
    }

    /// Hands the closed leaves' pages back (out of core, to the scratch file).
    pub(super) fn release_resident(&self) {
        self.done.release_resident();
    }

    /// Adds the cells of frame `k` of the window (frames in time order), whose time
    /// range starts at `f0`.
    pub(super) fn push_frame(&mut self, cells: &[Leaf], k: u32, f0: f64) -> Result<()> {
        // Cells absent from this frame end where it begins; they are closed first,
        // so the map never holds more than one frame's cells (its table doubles
        // past 7/8 full and never shrinks: 2.5 MB instead of 1.2 on LIGHT).
        for cell in cells {
            if let Some(r) = self.runs.get_mut(&cell_key(cell)) {
                r.last = k;
            }
        }
        let gone: Vec<CellKey> = self
            .runs
            .iter()
            .filter(|(_, r)| r.last != k)
            .map(|(key, _)| *key)
            .collect();
        for key in gone {
            if let Some(r) = self.runs.remove(&key) {
                self.done.push(r.close(&key, f0))?;
            }
        }
        let tol = self.tol;
        for cell in cells {
            let key = cell_key(cell);
            let vals = cell.b.map(|c| c.map(f64::from));
            let fresh = OpenLeaf {
                sum: vals,
                start: f0 as f32,
                corners: cell.corners,
                frames: 1,
                last: k,
            };
            match self.runs.get_mut(&key) {
                Some(r) => {
                    let m = r.mean();
                    let holds = (0..cell.corners as usize)
                        .all(|i| (0..3).all(|c| (vals[i][c] - m[i][c]).abs() <= tol));
                    if holds {
                        for (s, v) in r.sum.iter_mut().zip(vals) {
                            for c in 0..3 {
                                s[c] += v[c];
                            }
                        }
                        r.frames += 1;
                    } else {
                        let closed = std::mem::replace(r, fresh);
                        self.done.push(closed.close(&key, f0))?;
                    }
                }
                None => {
                    self.runs.insert(key, fresh);
                }
            }
        }
        Ok(())
    }

    /// Closes the runs still open at the window's end `end` and returns every leaf.
    pub(super) fn finish(mut self, end: f64) -> Result<Column<Leaf>> {
        for (key, r) in self.runs.drain() {
            self.done.push(r.close(&key, end))?;
        }
        Ok(self.done)
    }
}

/// The leaves of a window, closed in merge order, in the order the file keeps them:
/// by start time, then patch and corners (a total order: cells of one patch
/// starting at one time are one frame's, and differ in their corners), so that the
/// hash map's order never reaches the file and neighbours in the file are
/// neighbours on the surface (zstd packs them better: 1.3% smaller on LIGHT than
/// in the order they closed).
///
/// A counting sort on the start time (a window has one per frame): one pass
/// counts each start's leaves, one scatters them into their bucket of a column on
/// `storage`, then each bucket (at most one frame's cells) is sorted in place.
/// Every pass hands the pages of both columns back as it goes, so out of core a
/// window's leaves are never resident at once; the work is linear in the leaves
/// whatever the window's length.
pub(super) fn in_file_order(
    closed: Column<Leaf>,
    storage: &crate::pools::Storage,
) -> Result<Column<Leaf>> {
    let block = crate::solution::LEAF_BLOCK;
    let mut starts: Vec<(f32, usize)> = Vec::new();
    for l in closed.iter() {
        match starts.binary_search_by(|(t, _)| t.total_cmp(&l.time[0])) {
            Ok(i) => starts[i].1 += 1,
            Err(i) => starts.insert(i, (l.time[0], 1)),
        }
    }
    closed.release_resident();
    let mut out = Column::new(storage, "window-leaves")?;
    let zeros = vec![Leaf::zeroed(); block.min(closed.len())];
    while out.len() < closed.len() {
        let k = (closed.len() - out.len()).min(zeros.len());
        out.extend_from_slice(&zeros[..k])?;
        out.release_resident();
    }
    // Each bucket's next slot, then its range once filled.
    let mut next: Vec<usize> = starts
        .iter()
        .scan(0, |at, &(_, count)| {
            let first = *at;
            *at += count;
            Some(first)
        })
        .collect();
    for (k, l) in closed.iter().enumerate() {
        let i = starts
            .binary_search_by(|(t, _)| t.total_cmp(&l.time[0]))
            .expect("the first pass counted every start");
        out.as_mut_slice()[next[i]] = *l;
        next[i] += 1;
        if (k + 1) % block == 0 {
            closed.release_resident();
            out.release_resident();
        }
    }
    drop(closed);
    for (&end, &(_, count)) in next.iter().zip(&starts) {
        // A cell's key is its patch, then its corners' bits.
        out.as_mut_slice()[end - count..end].sort_unstable_by_key(cell_key);
        out.release_resident();
    }
    Ok(out)
}

fn cell_key(l: &Leaf) -> CellKey {
    (l.patch, l.uv.map(|c| c.map(f32::to_bits)))
}
