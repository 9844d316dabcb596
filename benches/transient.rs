//! Transient blockers: the space-time solver's swept-box shaft test against the
//! paper's time sampling, on the links where it matters (two static elements, a
//! moving object possibly passing between them during a window).
//! `cargo bench --bench transient [-- WINDOW_SECONDS...]` (default windows 1 s and
//! 0.32 s; one thread; prints a Markdown table per scene and window length).
//!
//! Damez & Sillion (paper 001) §5.2 item 1 find transient blockers of a link whose
//! ends share a motion by testing the other objects against the link's shaft, and
//! otherwise sample visibility with rays distributed in time; §6 reports that cutting
//! the number of time samples "damages the solution since occlusions can be missed,
//! creating holes in moving shadows", and §7 item 1 asks for swept volumes instead.
//! rhier tests the shaft once per window against the box each moving object sweeps
//! over it ([`rhier::solver::spacetime::swept_boxes`]). This bench measures, over
//! every front-facing pair of static elements of ACTOR and LIGHT (the room's patches
//! cut into cells of at most 0.5 m), for each window:
//!
//! - **truth**: the visibility of the pair varies over the window: the set of its 16
//!   rays (4 × 4 stratified on each element; rays blocked by static geometry left
//!   out) that a moving object blocks is not the same at all of 257 evenly spaced
//!   times. Computed on the pairs whose shaft meets a moving object's box at one of
//!   those times (a blocked ray lies in the shaft and meets the object, so no other
//!   pair is ever blocked);
//! - **swept box (rhier)**: the shaft meets a swept box: one box test per moving
//!   object. It must flag every truth pair (it is conservative by construction; the
//!   bench asserts it); its false alarms (visibility constant) cost time splits that
//!   find nothing, so they are counted;
//! - **swept box, 4 sub-windows**: the same with the boxes swept over each quarter
//!   of the window (still sound, tighter, four tests per object);
//! - **rays@N**: the paper's sampling, the same 16 rays cast at N evenly spaced
//!   times (the window's ends included); flagged if the blocked set is not the same
//!   at all N;
//! - **box@N**: the shaft tested against each moving object's box at N times, as the
//!   paper's shaft test would be if run at sampled times.
//!
//! For each method: pairs flagged, truth pairs missed (the holes: a blocker the
//! samples do not see), the longest a missed pair's visibility differs from what the
//! samples saw (ms), pairs flagged whose visibility is constant, and the cost per
//! pair and window (the shaft methods include building the shaft, once per pair).

use std::time::Instant;

use glam::DVec3;
use rhier::geometry::{Parts, Patches, SceneBvh};
use rhier::oracle::point_at;
use rhier::scene::Scene;
use rhier::scene::builtin;
use rhier::shafts::Shaft;
use rhier::solver::spacetime::swept_boxes;

/// Largest side of the cells the static patches are cut into (m).
const CELL: f64 = 0.5;
/// Rays per pair (4 × 4).
const RAYS: usize = 16;
/// Times of the dense reference sampling per window.
const DENSE: usize = 257;
/// Time samples of the paper-style methods.
const SAMPLES: [usize; 6] = [2, 3, 5, 9, 17, 33];

/// A static element: a cell of a patch.
struct Cell {
    patch: u32,
    corners: Vec<DVec3>,
    normal: DVec3,
}

impl Cell {
    /// Point at `(u, v)` of the cell (bilinear over a quad, affine over a triangle).
    fn point(&self, u: f64, v: f64) -> DVec3 {
        point_at(&self.corners, self.corners.len() == 3, u, v)
    }
}

/// The static patches of `scene` cut into cells of at most [`CELL`] a side.
fn cells(scene: &Scene, patches: &Patches) -> Vec<Cell> {
    let mut out = Vec::new();
    for i in 0..patches.len() {
        if scene.objects[patches.objects[i] as usize].is_moving() {
            continue;
        }
        let c = patches.polys[i].corners();
        let normal = patches.normals[i];
        if c.len() != 4 {
            out.push(Cell {
                patch: i as u32,
                corners: c.to_vec(),
                normal,
            });
            continue;
        }
        let nu = ((c[1] - c[0]).length() / CELL).ceil().max(1.0) as usize;
        let nv = ((c[3] - c[0]).length() / CELL).ceil().max(1.0) as usize;
        for a in 0..nu {
            for b in 0..nv {
                let (u0, u1) = (a as f64 / nu as f64, (a + 1) as f64 / nu as f64);
                let (v0, v1) = (b as f64 / nv as f64, (b + 1) as f64 / nv as f64);
                out.push(Cell {
                    patch: i as u32,
                    corners: vec![
                        patches.point(i, u0, v0),
                        patches.point(i, u1, v0),
                        patches.point(i, u1, v1),
                        patches.point(i, u0, v1),
                    ],
                    normal,
                });
            }
        }
    }
    out
}

/// A front-facing pair of cells, its shaft and the rays nothing static blocks.
struct Pair {
    shaft: Shaft,
    skip: [u32; 2],
    rays: Vec<(DVec3, DVec3)>,
}

impl Pair {
    /// True if the pair's shaft may meet one of `boxes`.
    fn meets(&self, boxes: &[(DVec3, DVec3)]) -> bool {
        boxes.iter().any(|&(lo, hi)| !self.shaft.misses_box(lo, hi))
    }
}

/// The pairs of `cells`, and the seconds spent building their shafts.
fn pairs(cells: &[Cell], bvh: &SceneBvh) -> (Vec<Pair>, f64) {
    let (mut out, mut shaft_secs) = (Vec::new(), 0.0);
    for (i, a) in cells.iter().enumerate() {
        for b in &cells[i + 1..] {
            if a.patch == b.patch {
                continue;
            }
            let faces = |p: &Cell, q: &Cell| {
                q.corners
                    .iter()
                    .any(|&c| p.normal.dot(c - p.corners[0]) > 1e-9)
            };
            if !faces(a, b) || !faces(b, a) {
                continue;
            }
            let skip = [a.patch, b.patch];
            let mut rays = Vec::with_capacity(RAYS);
            for k in 0..RAYS {
                let (i, j) = ((k % 4) as f64, (k / 4) as f64);
                let x = a.point((i + 0.5) / 4.0, (j + 0.37) / 4.0);
                let y = b.point((j + 0.61) / 4.0, (i + 0.5) / 4.0);
                if !bvh.occluded_by(x, y, skip, Parts::Static) {
                    rays.push((x, y));
                }
            }
            if rays.is_empty() {
                continue;
            }
            let t = Instant::now();
            let shaft = Shaft::new(&a.corners, a.normal, &b.corners, b.normal);
            shaft_secs += t.elapsed().as_secs_f64();
            out.push(Pair { shaft, skip, rays });
        }
    }
    (out, shaft_secs)
}

/// `n` evenly spaced times of `[t0, t1]`, both ends included.
fn times(t0: f64, t1: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| t0 + (t1 - t0) * k as f64 / (n - 1) as f64)
        .collect()
}

/// Pairs whose shaft meets a moving object's box at one of `ts` (as flags).
fn box_flags(scene: &Scene, bvh: &mut SceneBvh, pairs: &[Pair], ts: &[f64]) -> Vec<bool> {
    let mut flags = vec![false; pairs.len()];
    for &t in ts {
        bvh.place(scene, t);
        let boxes = bvh.moving_boxes();
        for (f, p) in flags.iter_mut().zip(pairs) {
            *f = *f || p.meets(&boxes);
        }
    }
    flags
}

/// For each pair among `which`, the number of times of `ts` at which the set of its
/// rays a moving object blocks differs from the set at `ts[0]` (others 0): nonzero
/// iff its visibility varies over the sampled times.
fn changes(
    scene: &Scene,
    bvh: &mut SceneBvh,
    pairs: &[Pair],
    which: &[bool],
    ts: &[f64],
) -> Vec<u32> {
    let mut first = vec![0u32; pairs.len()];
    let mut counts = vec![0u32; pairs.len()];
    for (k, &t) in ts.iter().enumerate() {
        bvh.place(scene, t);
        for (i, p) in pairs.iter().enumerate() {
            if !which[i] {
                continue;
            }
            let mut blocked = 0u32;
            for (j, &(x, y)) in p.rays.iter().enumerate() {
                if bvh.occluded_by(x, y, p.skip, Parts::Moving) {
                    blocked |= 1 << j;
                }
            }
            if k == 0 {
                first[i] = blocked;
            } else if blocked != first[i] {
                counts[i] += 1;
            }
        }
    }
    counts
}

/// One row of the table; `truth`: for each pair-window, the milliseconds its
/// visibility differs from what it is at the window's start (0: constant).
fn row(name: &str, flags: &[bool], truth: &[f64], secs: f64) {
    let flagged = flags.iter().filter(|&&f| f).count();
    let missed: Vec<f64> = flags
        .iter()
        .zip(truth)
        .filter(|&(&f, &ms)| !f && ms > 0.0)
        .map(|(_, &ms)| ms)
        .collect();
    let true_n = truth.iter().filter(|&&ms| ms > 0.0).count();
    let false_n = flags
        .iter()
        .zip(truth)
        .filter(|&(&f, &ms)| f && ms == 0.0)
        .count();
    let longest = missed.iter().copied().fold(0.0, f64::max);
    println!(
        "| {name} | {flagged} | {} ({:.1}%) | {longest:.0} | {false_n} | {:.2} |",
        missed.len(),
        100.0 * missed.len() as f64 / true_n.max(1) as f64,
        secs * 1e6 / flags.len() as f64,
    );
}

fn main() {
    let mut windows: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    if windows.is_empty() {
        windows = vec![1.0, 0.32];
    }
    for name in ["actor", "light"] {
        let Some(scene) = builtin(name) else {
            panic!("no builtin scene {name}");
        };
        let patches = Patches::at_time(&scene, 0.0);
        let mut bvh = SceneBvh::build(&scene, &patches, 0.0);
        let cells = cells(&scene, &patches);
        let t = Instant::now();
        let (pairs, shaft_secs) = pairs(&cells, &bvh);
        let static_secs = t.elapsed().as_secs_f64() - shaft_secs;
        let shaft_us = shaft_secs * 1e6 / pairs.len() as f64;
        let rays: usize = pairs.iter().map(|p| p.rays.len()).sum();
        let (t_start, t_end) = (scene.time.start, scene.time.end);
        for &w in &windows {
            let n_windows = ((t_end - t_start) / w - 1e-9).ceil().max(1.0) as usize;
            println!(
                "\n## {name}: {} static cells, {} front-facing pairs with a statically clear ray ({rays} rays, {:.2} µs/pair to cast them against the static part, once; {shaft_us:.2} µs/pair to build the shaft, once, counted in the shaft methods' cost below), {n_windows} windows of {w} s\n",
                cells.len(),
                pairs.len(),
                static_secs * 1e6 / pairs.len() as f64,
            );
            let mut sums: Vec<(String, Vec<bool>, f64)> = Vec::new();
            let mut truth_all: Vec<f64> = Vec::new();
            for k in 0..n_windows {
                let (t0, t1) = (
                    t_start + k as f64 * w,
                    (t_start + (k + 1) as f64 * w).min(t_end),
                );
                let dense = times(t0, t1, DENSE);
                let dense_ms = (t1 - t0) / (DENSE - 1) as f64 * 1e3;
                let near = box_flags(&scene, &mut bvh, &pairs, &dense);
                let truth = changes(&scene, &mut bvh, &pairs, &near, &dense);
                let mut results: Vec<(String, Vec<bool>, f64)> = Vec::new();
                let t = Instant::now();
                let swept = swept_boxes(&scene, t0, t1);
                let flags: Vec<bool> = pairs.iter().map(|p| p.meets(&swept)).collect();
                results.push(("swept box (rhier)".into(), flags, t.elapsed().as_secs_f64()));
                // The same, the window cut in 4: tighter boxes, 4 tests.
                let t = Instant::now();
                let quarters: Vec<(DVec3, DVec3)> = (0..4)
                    .flat_map(|q| {
                        let at = |q: f64| t0 + (t1 - t0) * q / 4.0;
                        swept_boxes(&scene, at(q as f64), at(q as f64 + 1.0))
                    })
                    .collect();
                let flags: Vec<bool> = pairs.iter().map(|p| p.meets(&quarters)).collect();
                results.push((
                    "swept box, 4 sub-windows".into(),
                    flags,
                    t.elapsed().as_secs_f64(),
                ));
                for n in SAMPLES {
                    let ts = times(t0, t1, n);
                    let all = vec![true; pairs.len()];
                    let t = Instant::now();
                    let c = changes(&scene, &mut bvh, &pairs, &all, &ts);
                    let secs = t.elapsed().as_secs_f64();
                    results.push((
                        format!("rays@{n}"),
                        c.iter().map(|&c| c > 0).collect(),
                        secs,
                    ));
                }
                for n in SAMPLES {
                    let ts = times(t0, t1, n);
                    let t = Instant::now();
                    let f = box_flags(&scene, &mut bvh, &pairs, &ts);
                    results.push((format!("box@{n}"), f, t.elapsed().as_secs_f64()));
                }
                // Soundness of the swept box against the dense truth.
                for (f, &c) in results[0].1.iter().zip(&truth) {
                    assert!(*f || c == 0, "the swept box missed a transient blocker");
                }
                if sums.is_empty() {
                    sums = results;
                } else {
                    for (s, r) in sums.iter_mut().zip(results) {
                        s.1.extend(r.1);
                        s.2 += r.2;
                    }
                }
                truth_all.extend(truth.iter().map(|&c| c as f64 * dense_ms));
            }
            let true_n = truth_all.iter().filter(|&&ms| ms > 0.0).count();
            println!(
                "pair-windows: {}; truth (visibility varies over {DENSE} times): {true_n}\n",
                truth_all.len()
            );
            println!(
                "| method | flagged | truth missed (holes) | longest missed change (ms) | flagged, visibility constant | µs per pair-window |"
            );
            println!("|---|---|---|---|---|---|");
            for (name, flags, secs) in &sums {
                // The shaft methods need the shaft: once per pair, over all windows.
                let shafts = if name.starts_with("rays") {
                    0.0
                } else {
                    shaft_secs
                };
                row(name, flags, &truth_all, secs + shafts);
            }
        }
    }
}
