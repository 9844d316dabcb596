//! A 6 × 3 × 6 m room lit by a 1 m² lamp hung 1 cm under its ceiling, its walls
//! one quad each or tiled (quads, triangles of unequal sizes, T-junctions): the
//! answer must not depend on the tiling, and it must approach the path tracer as
//! `eps` falls. Errors are measured off the lamp.

use crate::common::shapes::{self, Tiling};
use glam::DVec3;
use rhier::playback::probe::{ProbePoint, probe};
use rhier::scene::{Material, MaterialId, Object, Scene};
use rhier::solver::{SolveOptions, Solver, StopReason, solve};

/// The room with its walls tiled by `tiling`.
fn lamp_room(tiling: Tiling) -> Scene {
    lamp_room_at(tiling, 0.01)
}

/// The room with its walls tiled by `tiling`, the lamp hung `gap` under its ceiling.
fn lamp_room_at(tiling: Tiling, gap: f64) -> Scene {
    lamp_room_tilted(tiling, gap, 0.0)
}

/// [`lamp_room_at`] with the lamp turned `degrees` about its x axis (its centre
/// `gap` under the ceiling).
fn lamp_room_tilted(tiling: Tiling, gap: f64, degrees: f64) -> Scene {
    let (white, lamp) = (MaterialId(0), MaterialId(1));
    let mut polygons =
        shapes::tiled_box(DVec3::ZERO, DVec3::new(6.0, 3.0, 6.0), tiling, true, white);
    let (s, c) = degrees.to_radians().sin_cos();
    let v = DVec3::new(0.0, s, c);
    polygons.extend(shapes::tiled_rect(
        DVec3::new(3.0, 3.0 - gap, 3.0) - 0.5 * DVec3::X - 0.5 * v,
        DVec3::X,
        v,
        Tiling::Quads(1),
        lamp,
    ));
    Scene {
        materials: vec![
            Material::diffuse("white", [0.7; 3]),
            Material {
                name: "lamp".into(),
                rho: [0.0; 3],
                emission: [30.0; 3],
            },
        ],
        objects: vec![Object::still("room", polygons)],
        ..Default::default()
    }
}

/// 19 points on the floor, the walls and the ceiling, none on the lamp, none on a
/// tile edge of the tilings used here.
fn points() -> Vec<ProbePoint> {
    let mut p = Vec::new();
    for (x, z) in [
        (3.1, 3.1),
        (1.1, 1.3),
        (4.9, 1.2),
        (1.2, 4.7),
        (4.6, 4.9),
        (3.1, 0.4),
    ] {
        p.push((DVec3::new(x, 0.0, z), DVec3::Y));
    }
    for (x, z) in [(1.1, 1.3), (4.9, 4.7), (3.1, 1.2), (0.3, 3.1)] {
        p.push((DVec3::new(x, 3.0, z), -DVec3::Y));
    }
    for (y, t) in [(0.3, 1.1), (1.6, 3.1), (2.7, 4.9)] {
        p.push((DVec3::new(0.0, y, t), DVec3::X));
        p.push((DVec3::new(6.0, y, 6.0 - t), -DVec3::X));
        p.push((DVec3::new(t, y, 0.0), DVec3::Z));
    }
    p.into_iter().map(|(p, n)| ProbePoint { p, n }).collect()
}

fn radiosity(scene: &Scene, eps: f64) -> Vec<f64> {
    radiosity_with(
        scene,
        SolveOptions {
            eps,
            ..SolveOptions::default()
        },
    )
}

/// [`radiosity`] under `opts`.
fn radiosity_with(scene: &Scene, opts: SolveOptions) -> Vec<f64> {
    let (sol, _) = solve(scene, opts).expect("solve");
    probe(&sol, &points(), 0.0)
        .expect("probe")
        .iter()
        .map(|b| b[0])
        .collect()
}

/// The one-quad room's leaf system absorbs what the lamp emits (within 1%): the
/// ceiling is cut along the outline of the lamp hung 1 cm under it, so no leaf
/// sends its mean radiosity into the lamp's back (measured 2026-11-29: 0.998 at
/// eps 0.5; 0.962 with the ceiling whole). Judged open or closed, the room is not
/// balanced (balancing would hide the loss), so this is the factors' own sum.
#[test]
fn the_one_quad_room_loses_no_light_into_the_lamps_back() {
    let scene = lamp_room(Tiling::Quads(1));
    let mut s = Solver::new(&scene, SolveOptions::default()).expect("solver");
    s.run(|_, _| {}).expect("run");
    let balance = s.power_balance();
    eprintln!(
        "absorbed / emitted {balance:.4}, closed {:?}, balanced {}",
        s.is_closed(),
        s.rows_balanced()
    );
    assert!(!s.rows_balanced());
    assert!((balance - 1.0).abs() < 0.01, "{balance}");
}

/// The worst relative difference between the room tiled by `base` and by each of
/// `others`, at eps 0.5, printed.
fn worst_apart(base: Tiling, others: &[Tiling]) -> f64 {
    worst_apart_at(0.01, base, others)
}

/// [`worst_apart`] with the lamp hung `gap` under the ceiling.
fn worst_apart_at(gap: f64, base: Tiling, others: &[Tiling]) -> f64 {
    worst_apart_with(gap, base, others, SolveOptions::default())
}

/// [`worst_apart_at`] under `opts` (at eps 0.5).
fn worst_apart_with(gap: f64, base: Tiling, others: &[Tiling], opts: SolveOptions) -> f64 {
    let opts = SolveOptions { eps: 0.5, ..opts };
    let a = radiosity_with(&lamp_room_at(base, gap), opts.clone());
    let mut worst = 0.0f64;
    for &tiling in others {
        let b = radiosity_with(&lamp_room_at(tiling, gap), opts.clone());
        let (i, w) = a
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs() / a)
            .enumerate()
            .fold(
                (0, 0.0),
                |(i, w), (j, x)| if x > w { (j, x) } else { (i, w) },
            );
        eprintln!(
            "gap {gap}: {tiling:?}: worst point {:.2}% from {base:?}, at {:?}: {:.4} against {:.4}",
            100.0 * w,
            points()[i].p,
            b[i],
            a[i]
        );
        worst = worst.max(w);
    }
    worst
}

/// The room tiled three ways gives the same light at every point, within 1%
/// (measured 2026-11-29: unequal triangles 0.74% and T-junctions 0.76% from equal
/// quads at their worst point; 0.95% and 2.09% before the reconstruction welded
/// the points gathered from either side of a seam, `Solver::weld`: the T-junction
/// tiling gathered the point of a wall by the floor at x = 1 m once, from the leaf
/// on its left, and the quads gathered it on each side, 2.8% apart).
#[test]
fn the_tiling_of_the_walls_changes_little() {
    let worst = worst_apart(
        Tiling::Quads(6),
        &[Tiling::UnequalTriangles(4), Tiling::TJunctions(3)],
    );
    assert!(worst < 0.01, "{worst}");
}

/// One quad per wall against the tiled room, within 1% at every point (measured
/// 2026-11-29: 0.65% at worst, ceiling point (3.1, 3, 1.2), 0.71% with the seams
/// welded; 4.3% before). What
/// made the one-quad room 2–5% dark: its ceiling leaves straddled the outline of
/// the lamp hung 1 cm under it (edges at 2.5 and 3.5 m, never a split of the one
/// 6 m quad; the tiled room's half-tile splits fall on them), handed their mean
/// radiosity, dark covered part included, to receivers that see only the lit part,
/// and sent the covered part's share into the lamp's back (the leaf system absorbed
/// 0.962 of the emitted power). Contact meshing cuts a ceiling along the outline of
/// a lamp hung this close, but its gap rule also asked for 1e-3 of the scene's
/// diameter (9 mm here), and 1 cm is exactly 1% of the lamp's size, where the gap
/// rule stopped: the one-quad ceiling stayed whole. The rule is now the gap against
/// the lamp's size alone, up to 25% (`geometry::contact::NEAR_GAP_OF_SIZE`); a lamp
/// hung lower is `a_lamp_hung_lower_lights_one_quad_and_tiled_rooms_alike`.
#[test]
fn one_quad_per_wall_agrees_with_the_tiled_room() {
    let worst = worst_apart(Tiling::Quads(6), &[Tiling::Quads(1)]);
    assert!(worst < 0.01, "{worst}");
}

/// The near field refined to three fields (`SolveOptions::near_fields`) keeps
/// the rooms of [`the_tiling_of_the_walls_changes_little`] and
/// [`one_quad_per_wall_agrees_with_the_tiled_room`] within 1% at every point.
/// Measured 2026-12-03: one quad 0.57% from the tiled room at worst, unequal
/// triangles 0.85%, T-junctions 0.91%. From its first field alone (one field)
/// one quad read 1.17% (at a wall point 0.3 m over the floor, mended from the
/// one-quad floor's 0.75 m cells) and T-junctions 1.00%; refining cells where
/// the field's spread could move a point by a quarter of the tolerance (not a
/// tenth), T-junctions 1.00%.
#[test]
fn the_refined_near_field_keeps_the_tilings_alike() {
    let opts = SolveOptions {
        near_field: true,
        near_fields: 3,
        ..SolveOptions::default()
    };
    let worst = worst_apart_with(
        0.01,
        Tiling::Quads(6),
        &[
            Tiling::Quads(1),
            Tiling::UnequalTriangles(4),
            Tiling::TJunctions(3),
        ],
        opts,
    );
    assert!(worst < 0.01, "{worst}");
}

/// The lamp hung 5, 10 and 20 cm under the ceiling: one quad per wall against the
/// tiled room, within 1% at every point (measured 2026-11-30: 0.61%, 0.67% and
/// 0.89% at worst; 1.1%, 2.6% and 4.3% before, with the seams welded). Two
/// causes, both meshing. The ceiling over a lamp hung 20 cm down sees the lamp's
/// black back and is dark (path tracer 0.054 at (2.75, 3, 3.05); tiled 0.112, one
/// quad 0.396): contact meshing cut a ceiling along a lamp's outline up to a gap
/// of 10% of the lamp's size, now 25%. And the walls have a kink of the direct
/// light along the lamp's plane (no direct light above it), which a cell
/// straddling it interpolated across (the wall band at y = 2.7 under the lamp
/// hung 20 cm down read 2.4–3.7% over the path tracer; one quad against tiled,
/// 2.15% at worst at gap 0.1 m with the ceiling cut): the reconstruction splits
/// the cells an emitter's plane crosses (`Solver::straddled_planes`).
#[test]
fn a_lamp_hung_lower_lights_one_quad_and_tiled_rooms_alike() {
    for gap in [0.05, 0.1, 0.2] {
        let worst = worst_apart_at(gap, Tiling::Quads(6), &[Tiling::Quads(1)]);
        assert!(worst < 0.01, "gap {gap}: {worst}");
    }
}

/// Against the path tracer, the tiled room's error off the lamp falls as eps falls
/// (measured 2026-11-30: 0.58%, 0.58%, 0.52% relative RMS at eps 0.5, 0.25, 0.1,
/// worst point 1.69%, 1.71%, 1.04%; 0.93%, 0.91%, 0.75% before the seams were
/// welded). The reference at 40 000 paths has about 0.3% noise of its own (0.18%
/// at 100 000 on the Cornell box, scaled by the square root of the paths).
#[test]
fn the_tiled_room_approaches_the_path_tracer_as_eps_falls() {
    let scene = lamp_room(Tiling::Quads(6));
    let pts: Vec<(DVec3, DVec3)> = points().iter().map(|p| (p.p, p.n)).collect();
    let reference: Vec<f64> = rhier::reference::radiosity_at(&scene, &pts, 40_000, 11)
        .iter()
        .map(|e| e.b[0])
        .collect();
    let error = |b: &[f64]| {
        let (worst, sum) = b
            .iter()
            .zip(&reference)
            .fold((0.0f64, 0.0), |(w, s), (b, r)| {
                let e = (b - r) / r;
                (w.max(e.abs()), s + e * e)
            });
        ((sum / b.len() as f64).sqrt(), worst)
    };
    let mut last = f64::MAX;
    for eps in [0.5, 0.25, 0.1] {
        let (rms, worst) = error(&radiosity(&scene, eps));
        eprintln!(
            "eps {eps}: relative RMS {:.2}%, worst point {:.2}%",
            100.0 * rms,
            100.0 * worst
        );
        assert!(rms < 0.02, "eps {eps}: {rms}");
        assert!(rms < last + 0.002, "eps {eps}: {rms} after {last}");
        last = rms;
    }
}

/// The default stopping follows the error estimate: with the lamp hung 20 cm
/// under the ceiling and turned 10° (contact meshing cuts a ceiling along
/// parallel polygons only, see `a_lamp_hung_lower_lights_one_quad_and_tiled_rooms_alike`),
/// the one-quad room's links are all under eps 0.5 after one level, and what its
/// estimate would read had it stopped there (the change between levels, or the
/// rows' and the final gather's ray checks, [`Solver::ray_check_error`], which
/// read 4.2% there since each child of an opened source takes its own rays'
/// visibility) is above the `eps/20` = 2.5% that eps promises, so it refines on
/// below eps until the estimate is under the promise; the tiled room's is already
/// under it, and it stops at eps. Level, the lamp hung 20 cm down read 3.9%
/// before its ceiling was cut along it, 0.66% since: no longer a room this test
/// can use.
#[test]
fn the_default_solve_refines_below_eps_while_its_estimate_is_above_the_promise() {
    let opts = SolveOptions::default();
    let promised = opts.promised_error();
    assert!((promised - opts.eps / 20.0).abs() < 1e-12, "{promised}");
    // Per round: the record's estimate, and what the estimate would read had
    // the solve stopped at that round (the ray checks of its leaf system).
    let run = |tiling| {
        let scene = lamp_room_tilted(tiling, 0.2, 10.0);
        let mut s = Solver::new(&scene, SolveOptions::default()).expect("solver");
        let mut if_stopped = Vec::new();
        let records = s
            .run(|r, s| if_stopped.push(r.estimated_error.max(s.ray_check_error())))
            .expect("run");
        let estimates: Vec<f64> = records.iter().map(|r| r.estimated_error).collect();
        eprintln!(
            "{tiling:?}: {:?}, estimates {estimates:?}, had it stopped {if_stopped:?}",
            s.stop_reason()
        );
        (s.stop_reason(), estimates, if_stopped)
    };
    let (stop, estimates, if_stopped) = run(Tiling::Quads(1));
    assert!(
        matches!(stop, StopReason::PromiseMet { halvings } if halvings >= 1),
        "{stop:?}"
    );
    let first = if_stopped.iter().copied().find(|e| e.is_finite()).unwrap();
    let last = *estimates.last().unwrap();
    assert!(first > promised, "first estimate {first}");
    assert!(last <= promised, "last estimate {last}");
    let (stop, estimates, _) = run(Tiling::Quads(6));
    assert_eq!(stop, StopReason::Refined, "estimates {estimates:?}");
    assert!(*estimates.last().unwrap() <= promised);
}
