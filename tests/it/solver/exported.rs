//! A real exported scene (issue 45, part 4): Blender's Cornell box with Suzanne,
//! `tests/data/blender/cornell-box.glb`, as exported: its walls, floor and ceiling
//! are two-sided slabs that pass through each other at the corners, the lamp is a
//! two-sided 5.8 mm box 0.1 mm under the ceiling, and the white is 1.0 (clamped to
//! 0.999). Measured against the path tracer at points off the lamp; and a
//! hand-built twin, a closed room of two-sided slabs overlapping at the corners
//! lit uniformly (exactly `E/(1 − ρ)` inside), which isolates what went wrong:
//! contact meshing took the room side of a slab for a face resting on its own
//! back-to-back twin, and dropped it whenever a ray behind it met a back face of
//! the slab's far side first (the traversal's order chose among coincident twins).

use std::path::Path;

use glam::DVec3;
use rhier::playback::probe::{ProbePoint, probe};
use rhier::scene::Scene;
use rhier::solution::PointError;
use rhier::solver::{SolveOptions, solve};

use crate::common;
use crate::common::shapes;

/// The Blender file as loaded (two-sided materials get their twins).
fn blender_box() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender/cornell-box.glb");
    rhier::scene::load(&path).expect("the Blender Cornell box loads")
}

/// 29 points on the room side of the floor (top at y = −0.8668), the red, green
/// and back walls (x = −1.008, x = 0.9925, z = −0.8705) and the ceiling (bottom at
/// y = 0.8625) off the lamp (|x|, |z| ≤ 0.502 under it), then 2 on the lamp's
/// bottom (y = 0.8566).
fn points() -> Vec<(DVec3, DVec3)> {
    let mut p = Vec::new();
    for (x, z) in [
        (-0.8, 0.85),
        (0.8, 0.85),
        (-0.85, -0.7),
        (0.85, -0.7),
        (0.0, 0.9),
        (-0.9, 0.2),
        (0.9, 0.2),
        (0.0, -0.75),
    ] {
        p.push((DVec3::new(x, -0.8668, z), DVec3::Y));
    }
    for (y, z) in [
        (0.0, 0.0),
        (0.5, -0.5),
        (-0.5, 0.5),
        (0.7, 0.8),
        (-0.7, -0.7),
    ] {
        p.push((DVec3::new(0.9925, y, z), DVec3::NEG_X));
        p.push((DVec3::new(-1.008, y, z), DVec3::X));
    }
    for (x, y) in [
        (0.0, 0.0),
        (-0.6, 0.5),
        (0.6, -0.5),
        (0.0, 0.7),
        (0.0, -0.7),
    ] {
        p.push((DVec3::new(x, y, -0.8705), DVec3::Z));
    }
    for (x, z) in [
        (-0.8, 0.0),
        (0.8, 0.0),
        (0.0, -0.75),
        (0.0, 0.8),
        (-0.8, 0.85),
        (0.8, -0.8),
    ] {
        p.push((DVec3::new(x, 0.8625, z), DVec3::NEG_Y));
    }
    for (x, z) in [(0.0, 0.0), (0.3, -0.3)] {
        p.push((DVec3::new(x, 0.8566, z), DVec3::NEG_Y));
    }
    p
}

/// The solver's error against the path tracer at [`points`], off the lamp, with
/// `opts`, and the solve's own estimate.
fn blender_error(opts: SolveOptions, paths: u32) -> (PointError, f64) {
    let scene = blender_box();
    let pts = points();
    let reference: Vec<[f64; 3]> = rhier::reference::radiosity_at(&scene, &pts, paths, 13)
        .iter()
        .map(|e| e.b)
        .collect();
    let (sol, records) = solve(&scene, opts).expect("solve");
    let probes: Vec<ProbePoint> = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
    let b = probe(&sol, &probes, 0.0).expect("probe");
    let patches = rhier::geometry::Patches::at_time(&scene, 0.0);
    let on_lamp = rhier::geometry::on_emitters(&patches, &pts);
    assert_eq!(
        on_lamp.iter().filter(|&&x| x).count(),
        2,
        "the last two points are on the lamp"
    );
    let err = PointError::measure(&b, &reference, &on_lamp);
    for (i, ((p, _), (x, r))) in pts.iter().zip(b.iter().zip(&reference)).enumerate() {
        eprintln!("{i:2} {p}: {x:.4?} reference {r:.4?}");
    }
    let estimate = records.last().map_or(f64::NAN, |r| r.estimated_error);
    eprintln!("{}; estimate {estimate:.3e}", err.text());
    (err, estimate)
}

/// The Blender Cornell box against the path tracer at the 29 points off the
/// lamp (issue 45 part 4): within 5% off the lamp at the defaults, every point
/// within 7%, and an estimate that reads at least a third of the error.
///
/// Measured 2026-12-03 with the near field (`SolveOptions::near_field`, off by
/// default; each field cell seen by a ray): 2.56% off the lamp, worst point 23 4.17%; with
/// every cell of a near source counted, hidden or not, 5.36%, point 2 (the floor
/// by the red wall) 20.1% bright from the red and back walls' faces running on
/// inside the slabs they cross.
///
/// Measured 2026-12-03 at the defaults (100 000 paths): **2.78% off the lamp**, worst point 23
/// (the ceiling by the red wall) 5.52%, since the final gather's faint sources
/// take their links' visibility only while their bounds sum under
/// `faint_source` at a point (`Solver::gather_sum`). Before, each source under
/// the bound took it: point 26 (the ceiling by the open front, dim, lit by many
/// small far sources) read 9.27% dark, 19% in blue, and the bar was 10%.
///
/// Measured 2026-12-02: 2.90% off the lamp, worst point 26 9.27%, estimate
/// 1.85%, since each child
/// of an opened source takes the visible fraction of the entry's own rays that
/// land on it (h45child); before, 3.36%, worst 9.67%, estimate 2.37% (main
/// 44e6ab2, 59 s on the quiet 2-core machine). Against the 4 000 paths this test
/// took before (3.5% of noise of their own) the 44e6ab2 answer read 4.49%, worst
/// point 17 (the red wall) 11.0%, and the test was ignored for that worst point.
///
/// With the slabs cut where they pass through each other (contact meshing's
/// crossing segments, 1374460). Uncut, the floor's and ceiling's room sides ran
/// into the back wall's slab and the back wall's room side into the floor,
/// ceiling and red wall (18% of it), and their leaves averaged the lit room side
/// with the dark inside: the rows of the walls gathered 5–10% short from the
/// floor and back wall where rays over the same field did not (a scratch trace
/// of every room leaf's row against 256 cosine rays, by receiving and source
/// object, branch h45obj). On 8f50acd (4 000 paths): 11.07% off the lamp, worst
/// point 17 21.7%, estimate 8.1%.
///
/// Before the crossings were cut, the darkness was laid on the head (ρ 0.999
/// in red and green): opened sources' children sharing the source's visible
/// fraction (f771d3d, 8ea1afc) and cluster parts decided by their first rays
/// (4d294fe) were tried and reverted; each child's fraction from the entry's
/// own rays (above) is what mended it.
#[test]
fn blender_cornell_box_agrees_with_the_path_tracer() {
    let (err, estimate) = blender_error(
        SolveOptions {
            eps: BLENDER_EPS,
            ..SolveOptions::default()
        },
        BLENDER_PATHS,
    );
    assert!(
        err.off_emitters < BLENDER_RMS && err.worst_error < BLENDER_WORST,
        "{}",
        err.text()
    );
    assert!(
        estimate >= err.off_emitters / 3.0,
        "estimate {estimate} for {}",
        err.text()
    );
}

/// Whether contact meshing of `scene` keeps a patch through each of `points`
/// facing its way: the largest distance from a point to the nearest patch facing
/// it, printed.
fn farthest_from_a_kept_patch(scene: &Scene, points: &[(DVec3, DVec3)]) -> f64 {
    let patches = rhier::geometry::Patches::at_time(scene, 0.0);
    let (kept, stats) = rhier::geometry::split_at_contacts(scene, &patches, 0.0);
    let far = points
        .iter()
        .map(|&(p, n)| {
            rhier::geometry::nearest_facing(&kept.polys, &kept.normals, p, n)
                .map_or(f64::INFINITY, |(_, x)| x.distance(p))
        })
        .fold(0.0, f64::max);
    eprintln!("{stats:?}; farthest point {far:.3e} from a kept patch");
    far
}

/// Contact meshing keeps the room side of the Blender box's two-sided slabs at
/// every probe point (the points lie on the surfaces to the file's precision,
/// 4 decimals). Before, it dropped 976 pieces, the room sides among them: the
/// nearest kept patch facing a floor point was 13 cm away.
#[test]
fn blender_cornell_box_keeps_the_room_side_of_its_slabs() {
    let far = farthest_from_a_kept_patch(&blender_box(), &points());
    assert!(far < 1e-4, "a probe point is {far} from a kept patch");
}

/// A closed room 2 × 2 × 2 whose six walls are two-sided slabs `t` thick that pass
/// through each other at the corners as Blender's do, every polygon emitting `e`
/// with reflectance `rho`: inside the room `B = e/(1 − ρ)` exactly.
fn slab_room(rho: f64, e: f64, t: f64) -> Scene {
    let (w, o) = (2.0, t / 2.0);
    // Each slab: a solid box (faces outward), overlapping its neighbours by `o`.
    let slabs = [
        (DVec3::new(-o, -t, -o), DVec3::new(w + o, 0.0, w + o)), // floor
        (DVec3::new(-o, w, -o), DVec3::new(w + o, w + t, w + o)), // ceiling
        (
            DVec3::new(-t, -t - o, -t),
            DVec3::new(0.0, w + t + o, w + t),
        ), // x = 0
        (
            DVec3::new(w, -t - o, -t),
            DVec3::new(w + t, w + t + o, w + t),
        ), // x = 2
        (
            DVec3::new(-o, -t - o, -t),
            DVec3::new(w + o, w + t + o, 0.0),
        ), // z = 0
        (
            DVec3::new(-o, -t - o, w),
            DVec3::new(w + o, w + t + o, w + t),
        ), // z = 2
    ];
    let mut polygons = Vec::new();
    for (lo, hi) in slabs {
        for mut p in common::closed_box(lo, hi, 1, |_| 0) {
            p.vertices.reverse();
            polygons.push(p);
        }
    }
    let mut scene = shapes::uniform_scene(polygons, rho, e);
    rhier::scene::two_sided(&mut scene);
    scene
}

/// Contact meshing keeps the room side of every slab of the two-sided slab room,
/// at points on each wall (before, it dropped 119 pieces, and a point was 2 m from
/// a kept patch facing it); and its solve gives the known answer (too long for CI:
/// minutes of CPU at default settings, the slabs' insides being closed rooms too).
#[test]
fn two_sided_slab_room_keeps_the_room_side_of_its_slabs() {
    let far = farthest_from_a_kept_patch(&slab_room(0.5, 1.0, 0.1), &slab_points());
    assert!(far < 1e-9, "a probe point is {far} from a kept patch");
}

/// Points on the room side of each wall of [`slab_room`].
fn slab_points() -> Vec<(DVec3, DVec3)> {
    vec![
        (DVec3::new(0.7, 0.0, 1.3), DVec3::Y),
        (DVec3::new(1.3, 2.0, 0.6), DVec3::NEG_Y),
        (DVec3::new(0.0, 0.8, 1.1), DVec3::X),
        (DVec3::new(2.0, 1.4, 0.4), DVec3::NEG_X),
        (DVec3::new(1.2, 0.3, 0.0), DVec3::Z),
        (DVec3::new(0.5, 1.7, 2.0), DVec3::NEG_Z),
    ]
}

/// The slab room's known answer at [`slab_points`], at two reflectances; the
/// worst point within 1%.
#[test]
#[ignore = "minutes of CPU at default settings"]
fn two_sided_slab_room_gives_e_over_one_minus_rho() {
    let probes: Vec<ProbePoint> = slab_points()
        .into_iter()
        .map(|(p, n)| ProbePoint { p, n })
        .collect();
    for rho in [0.5, 0.9] {
        let (sol, _) = solve(&slab_room(rho, 1.0, 0.1), SolveOptions::default()).expect("solve");
        let exact = 1.0 / (1.0 - rho);
        let b = probe(&sol, &probes, 0.0).expect("probe");
        let worst = b
            .iter()
            .map(|x| (x[1] - exact).abs() / exact)
            .fold(0.0, f64::max);
        eprintln!(
            "rho {rho}: {:?} (exact {exact}); worst {worst:.4}",
            b.iter().map(|x| x[1]).collect::<Vec<_>>()
        );
        assert!(worst < 0.01, "rho {rho}: worst point {worst} from {exact}");
    }
}

/// A closed room `[0, 2]³` (walls tiled `n × n`, facing in) holding a two-sided
/// closed box `0.8 × t × 0.8` (faces tiled `n × n`) whose top and bottom lie `t`
/// apart: every polygon emits 1 with reflectance `rho`, so `B = 1/(1 − ρ)` on
/// both sides of every surface.
fn room_with_thin_two_sided_box(rho: f64, t: f64, n: usize) -> Scene {
    let mut polygons = shapes::tiled_box(
        DVec3::ZERO,
        DVec3::splat(2.0),
        shapes::Tiling::Quads(n),
        true,
        rhier::scene::MaterialId(0),
    );
    let mut thin = shapes::uniform_scene(
        shapes::tiled_box(
            DVec3::new(0.6, 0.8, 0.6),
            DVec3::new(1.4, 0.8 + t, 1.4),
            shapes::Tiling::Quads(n),
            false,
            rhier::scene::MaterialId(0),
        ),
        rho,
        1.0,
    );
    rhier::scene::two_sided(&mut thin);
    polygons.extend(thin.objects.remove(0).polygons);
    shapes::uniform_scene(polygons, rho, 1.0)
}

/// A fold of a two-sided mesh nearer to a point than the `1e-4` trim of a
/// segment's length (`SEGMENT_TRIM`) let the point's rays through: a closed
/// room around a two-sided box 0.04 mm thick (thinner than that trim of the
/// room's 1–3 m segments), uniformly emitting, is to give `E/(1 − ρ)` at every
/// stored corner within 1% at `ρ = 0.9`, and no leaf row is to sum above 1.01,
/// with the box and room in one quad a face and tiled 3 × 3. The rays between
/// surface points now skip their patches' twins and keep a `1e-9` trim
/// (`SURFACE_TRIM`), so that the ceiling no longer sees the inside of the box's
/// bottom through its top. Still short (2026-11-30, one quad a face): the
/// largest row sums to 1.027, and corners along the box's edges and on its
/// bottom read about 1.0–1.26 for the exact 10 (they gather next to nothing;
/// contact meshing's handling of the box's inner faces, 0.04 mm apart, is the
/// first suspect, not traced).
#[test]
#[ignore = "short: a row sums to 1.027 and box corners read about E (issue 45, part 4)"]
fn a_thin_two_sided_box_in_a_uniform_room_gives_e_over_one_minus_rho() {
    let rho = 0.9;
    let exact = 1.0 / (1.0 - rho);
    for n in [1, 3] {
        let scene = room_with_thin_two_sided_box(rho, 4e-5, n);
        let mut s = rhier::solver::Solver::new(&scene, SolveOptions::default()).expect("solver");
        s.run(|_, _| {}).expect("run");
        let rows = s.row_sums();
        let top = rows.iter().map(|r| r.1).fold(0.0, f64::max);
        let sol = s.solution();
        let mut worst: f64 = 0.0;
        for leaf in &sol.leaves {
            for c in 0..leaf.corners as usize {
                worst = worst.max((leaf.b[c][0] as f64 - exact).abs() / exact);
            }
        }
        eprintln!(
            "tiled {n}: {} leaves, largest row sum {top:.4}, worst corner {worst:.2e}",
            rows.len()
        );
        assert!(top <= 1.01, "tiled {n}: a row sums to {top}");
        assert!(worst < 0.01, "tiled {n}: a corner is {worst} off {exact}");
    }
}

/// Settings of `blender_cornell_box_agrees_with_the_path_tracer`.
const BLENDER_EPS: f64 = 0.5;
/// Paths per point of its reference: 100 000 carry 0.57% relative RMS of noise
/// off the lamp; the 4 000 it took before carried 3.5% (2.9% RMS between the
/// two references), enough to fail the worst-point bar on noise alone.
const BLENDER_PATHS: u32 = 100_000;
/// Its bars: relative RMS off the lamp and the worst point.
const BLENDER_RMS: f64 = 0.05;
const BLENDER_WORST: f64 = 0.07;
