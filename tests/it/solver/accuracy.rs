//! End-to-end accuracy guard: the default solve of the Cornell box (empty and with
//! blocks), probed at a 2 × 2 grid on every polygon, against the independent path
//! tracer with 20 000 paths per point (relative noise ≈ 0.1%). Measured here: 0.04% and
//! 0.21% (0.23% and 0.39% while the grid put triangle points on the long edge, in the
//! corners of two walls); the tolerances 0.2% / 0.8% sit about 4× above, and well
//! under a broken solver's error (≥ 1.5% in every regression seen while building it).
//! This error is dominated by the lamp's own points (`B ≈ E`); the mean-bias test
//! below measures the indirectly lit ceiling alone.

use glam::DVec3;
use rhier::geometry::Patches;
use rhier::playback::{ProbePoint, probe};
use rhier::solver::{SolveOptions, solve};

use crate::common;

fn error_against_reference(blocks: bool) -> f64 {
    let scene = rhier::scene::cornell_box(blocks);
    let patches = Patches::at_time(&scene, 0.0);
    let pts = common::probe::grid_points(&patches, 2);
    let reference: Vec<[f64; 3]> = rhier::reference::radiosity_at(&scene, &pts, 20_000, 11)
        .iter()
        .map(|e| e.b)
        .collect();
    let (sol, _) = solve(&scene, SolveOptions::default()).unwrap();
    let points: Vec<ProbePoint> = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
    let b = probe(&sol, &points, 0.0).unwrap();
    rhier::solution::relative_rms(&b, &reference)
}

#[test]
fn empty_cornell_box_within_point_two_percent() {
    let e = error_against_reference(false);
    eprintln!("empty: {e}");
    assert!(e < 0.002, "relative RMS error {e}");
}

#[test]
fn cornell_box_with_blocks_within_point_eight_percent() {
    let e = error_against_reference(true);
    eprintln!("blocks: {e}");
    assert!(e < 0.008, "relative RMS error {e}");
}

/// A `k × k` grid on every non-emitting patch whose normal `select` takes, each point
/// with its patch's area as weight.
fn lit_grid(
    patches: &Patches,
    k: usize,
    select: impl Fn(DVec3) -> bool,
) -> (Vec<(DVec3, DVec3)>, Vec<f64>) {
    common::probe::grid_points(patches, k)
        .into_iter()
        .zip((0..patches.len()).flat_map(|i| std::iter::repeat_n(i, k * k)))
        .filter(|&((_, n), i)| select(n) && patches.emissions[i].iter().all(|&e| e == 0.0))
        .map(|(pn, i)| (pn, patches.areas[i]))
        .unzip()
}

/// Area-weighted mean radiosity bias of a solve against the path tracer over the
/// non-emitting patches `select` picks (by normal): an 8 × 8 grid on each patch, each
/// point weighted by its patch's area; `(mean B − mean B_ref) / mean B_ref`.
fn mean_bias(opts: SolveOptions, select: impl Fn(DVec3) -> bool) -> f64 {
    let scene = rhier::scene::cornell_box(false);
    let patches = Patches::at_time(&scene, 0.0);
    let (pts, weights) = lit_grid(&patches, 8, select);
    assert!(pts.len() >= 32, "{} points", pts.len());
    let reference = rhier::reference::radiosity_at(&scene, &pts, 20_000, 5);
    let (sol, _) = solve(&scene, opts).unwrap();
    let points: Vec<ProbePoint> = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
    let b = probe(&sol, &points, 0.0).unwrap();
    let mean = |v: &mut dyn Iterator<Item = [f64; 3]>| -> f64 {
        v.zip(&weights)
            .map(|(b, w)| w * b.iter().sum::<f64>())
            .sum()
    };
    let ours = mean(&mut b.iter().copied());
    let theirs = mean(&mut reference.iter().map(|e| e.b));
    (ours - theirs) / theirs
}

#[test]
fn the_ceiling_lit_only_by_the_walls_is_not_darkened() {
    // The ceiling gets no direct light: all of it comes from the floor and walls,
    // whose radiosity peaks under the lamp. Gathering a big wall or floor element's
    // average radiosity with the exact factor of the whole element made it 3.8% too
    // dark; opening sources whose radiosity varies (`SolveOptions::open_spread`)
    // leaves 1.9% (the rest: the hierarchy at eps 0.5 and the bilinear
    // reconstruction between gathered corners). The walls, lit mostly directly,
    // are 0.8% too dark. Reference noise ≈ 0.1%.
    let ceiling = mean_bias(SolveOptions::default(), |n| n.y < -0.9);
    let walls = mean_bias(SolveOptions::default(), |n| n.y.abs() < 0.1);
    eprintln!(
        "bias: ceiling {:.2}%, walls {:.2}%",
        ceiling * 100.0,
        walls * 100.0
    );
    assert!(
        ceiling.abs() < 0.03,
        "ceiling mean off by {:.2}%",
        ceiling * 100.0
    );
    assert!(
        walls.abs() < 0.015,
        "walls mean off by {:.2}%",
        walls * 100.0
    );
}

/// The solve's estimated error and its true error, relative RMS of the reflected
/// radiosity over a 4 × 4 grid on every non-emitting patch weighted by area (what
/// the estimate samples), against the path tracer.
fn estimated_and_true(blocks: bool, opts: SolveOptions) -> (f64, f64, u32) {
    let scene = rhier::scene::cornell_box(blocks);
    let patches = Patches::at_time(&scene, 0.0);
    let (pts, weights) = lit_grid(&patches, 4, |_| true);
    let reference = rhier::reference::radiosity_at(&scene, &pts, 20_000, 3);
    let (sol, records) = solve(&scene, opts).unwrap();
    let points: Vec<ProbePoint> = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
    let b = probe(&sol, &points, 0.0).unwrap();
    let (mut num, mut den) = (0.0, 0.0);
    for ((v, r), w) in b.iter().zip(&reference).zip(&weights) {
        // Points inside the blocks (the path tracer finds no light there) left out.
        if r.b.iter().all(|&x| x == 0.0) {
            continue;
        }
        for (x, y) in v.iter().zip(&r.b) {
            num += w * (x - y).powi(2);
            den += w * y * y;
        }
    }
    (
        sol.stats.estimated_error,
        (num / den).sqrt(),
        records.len() as u32,
    )
}

#[test]
fn the_estimated_error_is_within_three_times_the_true_error() {
    // The estimate is the final gather's change since the level at twice the eps,
    // plus the reconstruction's interpolation error: it overestimates at coarse eps
    // (the change is mostly the coarser level's error) and underestimates at fine
    // eps (a bias of about 1% no refinement changes). Measured here (estimate /
    // true): empty eps 0.25 1.11% / 1.03%, eps 0.1 0.55% / 0.80%; blocks eps 0.25
    // 1.11% / 1.73%. At the default eps 0.5 it reads 6.7% for a true 1.4%.
    for (blocks, eps) in [(false, 0.25), (true, 0.25), (false, 0.1)] {
        let opts = SolveOptions {
            eps,
            ..SolveOptions::default()
        };
        let (est, truth, _) = estimated_and_true(blocks, opts);
        eprintln!("blocks {blocks}, eps {eps}: estimated {est:.4}, true {truth:.4}");
        assert!(
            est > truth / 3.0 && est < truth * 3.0,
            "blocks {blocks}, eps {eps}: estimated {est}, true {truth}"
        );
    }
}

#[test]
fn a_target_error_refines_until_the_estimate_reaches_it() {
    // From the default eps 0.5, a target of half the default's estimate halves eps
    // until the change between levels is under it, and the true error falls with
    // it. (Measured on 2026-11-29: the default estimates 0.77% and a 0.39% target
    // is met in more rounds; before the cluster estimate was confined to clusters
    // facing the point whole, the default estimated 6.7% for a true 1.4%.)
    let (est0, true0, rounds0) = estimated_and_true(false, SolveOptions::default());
    assert!(
        est0 > 0.004,
        "the default's estimate leaves nothing to reach: {est0}"
    );
    let target = 0.5 * est0;
    let opts = SolveOptions {
        target_error: Some(target),
        ..SolveOptions::default()
    };
    let (est, truth, rounds) = estimated_and_true(false, opts);
    eprintln!(
        "default: {est0:.4} / {true0:.4} in {rounds0} rounds; target {target:.4}: {est:.4} / {truth:.4} in {rounds} rounds"
    );
    // The rounds stop at a change under the target; the final estimate adds the
    // reconstruction's interpolation error (about 0.4% here) in quadrature.
    assert!(est < target.hypot(0.005), "final estimate {est}");
    assert!(rounds > rounds0);
    assert!(
        truth < true0,
        "true error {truth} against {true0} without the target"
    );
}
