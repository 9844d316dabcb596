//! The leaves live at a time and their stretch (src/store/live.rs): a reader that keeps
//! the sets it found gives, at every time, exactly the leaves a brute-force scan of
//! the whole solution gives, whatever order the times are asked in; a stretch holds
//! its time, names one set, and ends where the set changes.

use std::collections::HashMap;
use std::sync::Arc;

use rhier::solution::{Leaf, Solution};
use rhier::store::samples::box_solution;
use rhier::store::{Live, Reader, SolutionHeader, WriteOptions, Writer};

fn lcg(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    rhier::oracle::unit(*s)
}

/// The `f32` next to `x` on the side of `dir` (`f32::next_up` is past the MSRV).
fn step32(x: f32, dir: f32) -> f32 {
    let grow = (dir > 0.0) == (x >= 0.0);
    if x == 0.0 {
        return f32::from_bits(1) * dir;
    }
    f32::from_bits(if grow {
        x.to_bits() + 1
    } else {
        x.to_bits() - 1
    })
}

/// The `f64` next to positive `x` on the side of `dir`.
fn step64(x: f64, dir: f64) -> f64 {
    f64::from_bits(if dir > 0.0 {
        x.to_bits() + 1
    } else {
        x.to_bits() - 1
    })
}

/// Chunk boundaries of the file.
const CUTS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];

/// The static box over `[0, 1]` s, each of its leaves cut in time at 0–5 random
/// times (some on a chunk boundary, some spanning several chunks), each piece with
/// its own radiosity; leaves in start order.
fn space_time_box() -> Solution {
    let mut sol = box_solution(2);
    sol.scene.time.start = 0.0;
    sol.scene.time.end = 1.0;
    let mut s = 7u64;
    let mut leaves = Vec::new();
    for (k, l) in sol.leaves.iter().enumerate() {
        let cuts = (lcg(&mut s) * 6.0) as usize;
        let mut times: Vec<f32> = (0..cuts)
            .map(|_| {
                if lcg(&mut s) < 0.3 {
                    CUTS[1 + (lcg(&mut s) * 3.0) as usize] as f32
                } else {
                    lcg(&mut s) as f32
                }
            })
            .collect();
        times.extend([0.0, 1.0]);
        times.sort_by(f32::total_cmp);
        times.dedup();
        for (j, w) in times.windows(2).enumerate() {
            let mut piece = *l;
            piece.time = [w[0], w[1]];
            for b in piece.b.iter_mut().flatten() {
                *b *= 1.0 + (k * 7 + j) as f32 / 64.0;
            }
            leaves.push(piece);
        }
    }
    leaves.sort_by(|a, b| a.time[0].total_cmp(&b.time[0]));
    sol.leaves = leaves;
    sol
}

/// Writes `sol` in the chunks of [`CUTS`], each leaf in the chunk where it starts.
fn write_chunked(sol: &Solution, path: &std::path::Path) {
    let mut w = Writer::create(path, &SolutionHeader::of(sol), WriteOptions::default()).unwrap();
    for c in CUTS.windows(2) {
        let last = c[1] == 1.0;
        let leaves: Vec<Leaf> = sol
            .leaves
            .iter()
            .filter(|l| {
                let t0 = l.time[0] as f64;
                t0 >= c[0] && (t0 < c[1] || last)
            })
            .copied()
            .collect();
        w.write_chunk(c[0], c[1], &leaves).unwrap();
    }
    w.finish(&sol.stats).unwrap();
}

/// Times at and around every leaf boundary and chunk boundary (one f32 step either
/// side, and f64 times that round to the boundary), and a grid, inside `[0, 1]`.
fn probe_times(sol: &Solution) -> Vec<f64> {
    let mut out: Vec<f64> = (0..=100).map(|k| k as f64 / 100.0).collect();
    let edges = sol
        .leaves
        .iter()
        .flat_map(|l| l.time)
        .chain(CUTS.iter().map(|&c| c as f32));
    for e in edges {
        for f in [step32(e, -1.0), e, step32(e, 1.0)] {
            let x = f as f64;
            out.extend([x, x - 1e-12, x + 1e-12]);
        }
    }
    for c in CUTS {
        if c > 0.0 {
            out.extend([step64(c, -1.0), step64(c, 1.0)]);
        }
    }
    out.retain(|t| (0.0..=1.0).contains(t));
    out
}

#[test]
fn kept_sets_are_the_brute_force_sets_in_any_order() {
    let sol = space_time_box();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stretches.rhier");
    write_chunked(&sol, &path);
    let mut times = probe_times(&sol);
    // Leaves carried over chunk boundaries: the reader's chunk choice is exercised.
    let r = Reader::open(&path).unwrap();
    assert!(r.chunks().iter().any(|c| c.reach > c.t1), "no carried leaf");
    // A random order, so that kept sets are asked for from anywhere in their stretch.
    let mut s = 11u64;
    for i in (1..times.len()).rev() {
        times.swap(i, (lcg(&mut s) * (i + 1) as f64) as usize);
    }
    let mut by_id: HashMap<u64, Arc<[Leaf]>> = HashMap::new();
    for &t in &times {
        let got = r.live_at(t).unwrap();
        let want = Live::scan(&sol.leaves, t, 1.0);
        assert_eq!(got.leaves, want.leaves, "t = {t}");
        assert!(!got.leaves.is_empty(), "t = {t}");
        // A reader that keeps nothing reads the same.
        let fresh = Reader::open(&path).unwrap().live_at(t).unwrap();
        assert_eq!(fresh.leaves, got.leaves, "t = {t}");
        assert_eq!(fresh.stretch, got.stretch, "t = {t}");
        assert!(got.stretch.contains(t), "t = {t}: {:?}", got.stretch);
        // One id, one set.
        let same = by_id.entry(got.stretch.id()).or_insert(got.leaves.clone());
        assert_eq!(*same, got.leaves, "t = {t}: id {:#x}", got.stretch.id());
        // Asked again inside its stretch, the kept set itself is handed out.
        let again = r.live_at(t).unwrap();
        assert!(Arc::ptr_eq(&again.leaves, &got.leaves), "t = {t}");
    }
    // Fewer stretches than times: sets are shared between frames.
    assert!(by_id.len() < times.len() / 3, "{} ids", by_id.len());
}

#[test]
fn a_stretch_holds_one_set_and_ends_where_it_changes() {
    let sol = space_time_box();
    let times = probe_times(&sol);
    let mut by_id: HashMap<u64, Live> = HashMap::new();
    for &t in &times {
        let live = Live::scan(&sol.leaves, t, 1.0);
        let s = live.stretch;
        assert!(s.contains(t), "t = {t}: {s:?}");
        if let Some(other) = by_id.get(&s.id()) {
            assert_eq!(other.leaves, live.leaves, "t = {t}");
            assert_eq!(other.stretch, s, "t = {t}");
        }
        // Its ends are changes: just before `lo` and at `hi` the set differs.
        if s.hi as f64 <= 1.0 {
            let after = Live::scan(&sol.leaves, s.hi as f64, 1.0);
            assert_ne!(after.leaves, live.leaves, "t = {t}: at hi of {s:?}");
        }
        if s.lo as f64 > 0.0 {
            let before = Live::scan(&sol.leaves, step32(s.lo, -1.0) as f64, 1.0);
            assert_ne!(before.leaves, live.leaves, "t = {t}: before lo of {s:?}");
        }
        by_id.insert(s.id(), live);
    }
}
