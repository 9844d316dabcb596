//! The L-shaped room of `enclosures.rs` ([`shapes::l_room`]: 6 × 6 m less the
//! quarter `[3, 6] × [3, 6]`, 2.5 m high, walls of reflectance 0.7) lit by one
//! 1 m² lamp hung 1 cm under the ceiling at the end of one arm, `[4.5, 5.5] × [1,
//! 2]`. The probes are in the other arm and on the ceiling around the re-entrant
//! corner `(3, ·, 3)`, where the lamp is hidden (the ceiling is above the lamp's
//! plane; the floor and wall points are behind the corner's walls from every
//! point of the lamp): all their light comes from non-emitting surfaces, and the
//! lit ones (the first arm's floor and walls) are seen partly hidden by the
//! corner's walls. What the final gather does with a partly hidden non-emitting
//! source (`gather::recast_rays`) is what this room measures; the closed
//! enclosures cannot, every surface of theirs emits.
//!
//! The solve is held against the path tracer, and the room tiled three ways
//! (quads, the same quads each cut into four unequal triangles, triangles of
//! unequal sizes) must give the same answer.

use crate::common::shapes::{self, Tiling};
use glam::DVec3;
use rhier::playback::probe::{ProbePoint, probe};
use rhier::scene::{MaterialId, Object, Scene};
use rhier::solver::{SolveOptions, solve};

/// The room's walls tiled as `tiling` says (or, with `fan`, in quads each cut
/// into four unequal triangles, [`shapes::fan_quads`]) and the lamp.
fn lit_l_room(tiling: Tiling, fan: bool) -> Scene {
    let (white, lamp) = (MaterialId(0), MaterialId(1));
    let mut room = shapes::l_room(3.0, 2.5, tiling, white);
    if fan {
        room = shapes::fan_quads(&room);
    }
    room.extend(shapes::tiled_rect(
        DVec3::new(4.5, 2.49, 1.0),
        DVec3::X,
        DVec3::Z,
        Tiling::Quads(1),
        lamp,
    ));
    Scene {
        materials: shapes::lit_room_materials([0.7; 3]),
        objects: vec![Object::still("room", room)],
        ..Default::default()
    }
}

/// 39 points the lamp does not light: on the ceiling of the dark arm and around
/// the re-entrant corner, on the corner's wall `x = 3` on the dark arm's side, on
/// the dark arm's floor behind that wall and on its end wall `z = 6`. None on a
/// tile edge of the tilings used here.
fn points() -> Vec<ProbePoint> {
    let mut p = Vec::new();
    for (x, z) in [
        (0.4, 3.3),
        (1.3, 3.3),
        (2.4, 3.3),
        (2.8, 3.7),
        (0.7, 4.3),
        (1.7, 4.7),
        (2.5, 4.2),
        (0.7, 5.6),
        (1.8, 5.5),
        (2.6, 5.7),
        (2.6, 2.6),
        (2.85, 2.2),
        (1.3, 2.5),
        (3.4, 2.8),
        (2.8, 0.7),
    ] {
        p.push((DVec3::new(x, 2.5, z), -DVec3::Y));
    }
    for y in [0.35, 1.1, 2.2] {
        for z in [3.2, 3.8, 4.7, 5.7] {
            p.push((DVec3::new(3.0, y, z), -DVec3::X));
        }
        for x in [1.8, 2.4, 2.85] {
            p.push((DVec3::new(x, y, 6.0), -DVec3::Z));
        }
    }
    for (x, z) in [(2.9, 3.3), (2.7, 3.9), (2.2, 4.7), (1.8, 5.3), (2.8, 5.3)] {
        p.push((DVec3::new(x, 0.0, z), DVec3::Y));
    }
    p.into_iter().map(|(p, n)| ProbePoint { p, n }).collect()
}

/// The default solve of `scene`, probed.
fn radiosity(scene: &Scene) -> Vec<f64> {
    let (sol, _) = solve(scene, SolveOptions::default()).expect("solve");
    probe(&sol, &points(), 0.0)
        .expect("probe")
        .iter()
        .map(|b| b[0])
        .collect()
}

/// Relative RMS and worst point of `b` against `reference`, with the worst
/// point's index.
fn error(b: &[f64], reference: &[f64]) -> (f64, f64, usize) {
    let (mut sum, mut worst, mut at) = (0.0, 0.0f64, 0);
    for (i, (b, r)) in b.iter().zip(reference).enumerate() {
        let e = (b - r) / r;
        sum += e * e;
        if e.abs() > worst {
            (worst, at) = (e.abs(), i);
        }
    }
    ((sum / b.len() as f64).sqrt(), worst, at)
}

/// The light that reaches the dark arm through partly hidden non-emitting
/// surfaces: in each tiling the solve within [`RMS_BAR`] and [`WORST_BAR`] of
/// the path tracer, and the tilings within [`TILING_BAR`] of the quads at every
/// point.
///
/// Measured 2026-12-03 (reference 400 000 paths, its noise 0.46% RMS, 0.58% at
/// worst), solve seeds 0x5eed, 1 and 2, quads / fanned quads / unequal
/// triangles: with the factor rule and its 2m floor (main 7f6e3cf) RMS
/// 1.45–1.80%, worst point 3.1–5.0%; with the emitters' weight-at-tolerance
/// rule, no floor (h48rays3), RMS 1.45–1.78%, worst 3.1–5.1%, each pair within
/// 0.09 points. The tilings differ by up to 6.5% (main) and 6.4% at one point
/// (the corner's wall by the floor, (3, 0.35, 3.8), or the ceiling by the
/// corner, (2.4, 2.5, 3.3), unequal triangles against quads), the fanned quads
/// by 2.7% and 2.5%. The rule hardly acts here: of the about 12 000 partly
/// hidden non-emitting terms of the quads' final gather, 97% weigh less than
/// the tolerance and none the 6.7 tolerances where it casts again; keeping
/// every one's first 8 rays gives the same errors to 0.01 points. The factor
/// rule cast 2.6× the rays on them for 0.01–0.09 points of RMS.
#[test]
fn light_through_partly_hidden_surfaces_matches_the_path_tracer_in_every_tiling() {
    let pts: Vec<(DVec3, DVec3)> = points().iter().map(|p| (p.p, p.n)).collect();
    let estimates = rhier::reference::radiosity_at(
        &lit_l_room(Tiling::Quads(1), false),
        &pts,
        REFERENCE_PATHS,
        17,
    );
    let reference: Vec<f64> = estimates.iter().map(|e| e.b[0]).collect();
    let noise = estimates
        .iter()
        .map(|e| e.std_error[0] / e.b[0])
        .fold(0.0, f64::max);
    let noise_rms = (estimates
        .iter()
        .map(|e| (e.std_error[0] / e.b[0]).powi(2))
        .sum::<f64>()
        / estimates.len() as f64)
        .sqrt();
    eprintln!(
        "reference: {REFERENCE_PATHS} paths, relative standard error RMS {:.2}%, worst {:.2}%",
        100.0 * noise_rms,
        100.0 * noise
    );
    assert!(
        noise < WORST_BAR / 4.0 && noise_rms < RMS_BAR / 4.0,
        "the reference's noise ({noise}, RMS {noise_rms}) is not well below the bars"
    );
    let mut answers = Vec::new();
    let mut failed = Vec::new();
    for (tiling, fan) in [
        (Tiling::Quads(3), false),
        (Tiling::Quads(3), true),
        (Tiling::UnequalTriangles(3), false),
    ] {
        let b = radiosity(&lit_l_room(tiling, fan));
        let (rms, worst, at) = error(&b, &reference);
        eprintln!(
            "{tiling:?} fan {fan}: relative RMS {:.2}%, worst {:.2}% at {:?} ({:.5} for {:.5})",
            100.0 * rms,
            100.0 * worst,
            points()[at].p,
            b[at],
            reference[at]
        );
        if rms >= RMS_BAR || worst >= WORST_BAR {
            failed.push(format!(
                "{tiling:?} fan {fan}: RMS {rms:.4}, worst {worst:.4} at {:?}",
                points()[at].p
            ));
        }
        answers.push(((tiling, fan), b));
    }
    let base = &answers[0].1;
    for (t, b) in &answers[1..] {
        let (rms, worst, at) = error(b, base);
        eprintln!(
            "{t:?} against quads: RMS {:.2}%, worst {:.2}% at {:?}",
            100.0 * rms,
            100.0 * worst,
            points()[at].p
        );
        if worst >= TILING_BAR {
            failed.push(format!(
                "{t:?}: {worst:.4} from the quads at {:?}",
                points()[at].p
            ));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}

/// Paths per point of the reference: 0.46% RMS relative standard error
/// (0.91% at 100 000).
const REFERENCE_PATHS: u32 = 400_000;

/// The bar on the relative RMS error against the path tracer: main's worst of
/// the nine solves (1.80%) plus 0.4 points: the seeds move one tiling's RMS by
/// up to 0.25 points, and the reference's own noise is 0.46% RMS.
const RMS_BAR: f64 = 0.022;

/// The bar on the worst point's relative error against the path tracer: main's
/// worst (5.0%) plus 1.5 points, 2.5 times the reference's noise at its worst
/// point (the seeds move a tiling's worst point by up to 0.7 points).
const WORST_BAR: f64 = 0.065;

/// The bar on the worst relative difference between the quads and another
/// tiling at one point: main's 6.5% plus 1.5 points.
const TILING_BAR: f64 = 0.08;
