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
/// `opts`.
fn blender_error(opts: SolveOptions, paths: u32) -> PointError {
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
    eprintln!(
        "{}; estimate {:.3e}",
        err.text(),
        records.last().map_or(f64::NAN, |r| r.estimated_error)
    );
    err
}

/// The Blender Cornell box against the path tracer, off the lamp: short of the
/// bar. Before (2026-11-29, base colours × 0.8, 31 points, 20,000 paths): the room
/// read 0.1–4% of the path tracer at default settings (contact meshing dropped the
/// room side of every slab) while the path tracer itself read 25–90% dark (it
/// stopped on back twins). Now 11.8% relative RMS off the lamp (worst point 24%,
/// the ceiling), every point 74–101% of the path tracer and the estimate 15.4%;
/// and the solve takes minutes (1 m 40 s of CPU at `--eps 2 --max-rounds 1`), too
/// long for CI. Measured again 2026-11-29 on main at b24f13c (and the same with the
/// oracle reading the receiver's centre): 23.2% relative RMS off the lamp, worst
/// 43% (red wall, low back corner), every point 57–90% of the path tracer, the
/// estimate 2.1%; 6–11 minutes under load. The loss grows with the bounces: the
/// blue channel (reflected by the white surfaces only, so its light bounces
/// least) is within 1–5% at most points while red and green are 15–40% dark, the
/// mark of rows whose factors sum under 1 (light leaking at the slabs' overlaps
/// or around the lamp box) amplified by `1/(1 − ρ)`. Not a regression: the
/// binary of ec918e2, the commit that recorded 11.8%, gives 22.8% on this setup
/// (`rhier solve` at the defaults, these 29 points off the lamp, 20,000 paths,
/// seed 13) against 22.6% at 0f94ecf; the 11.8% was most likely taken with the
/// base colours × 0.8 of the paragraph's "before".
///
/// Where the light goes (2026-11-29, h45blend; `rhier solve` at the defaults against
/// `rhier reference` at these 29 points, 4,000 paths): not the slabs. The same room
/// rebuilt from one-sided quads (the slabs' room faces closed at the corners, no
/// twins), with the file's two-sided lamp box and head, is as far off (25.5%); without
/// the head it is within the reference's noise (3.5%), and with the head one-sided 7.1%
/// (that run also cut the floor along the chin). The two-sided head is what loses the
/// red and green (it reflects 0.999 of them, and none of the blue): its inside is a
/// cavity of back-to-back twins open only at the eyes, and its chin dips 7 mm through
/// the floor. With it the leaf system's GMRES stalls (relative residual 6–7e-4 after
/// 2,000 applications each round, 1e-6 without it or with it one-sided); a basis of 150
/// and 6,000 applications leave it at 4.3e-3, 1.2e-3, 7.4e-4, 6.6e-4 over the rounds,
/// so the restart is not what holds it. What does: the head's leaf rows. After the
/// first round of that rebuilt room, 1,687 of its 6,680 leaves sum their factors above
/// 1 (1,338 above 1.01, the largest 2.14; area 1.25 of 8.8 m², twins counted), where
/// the room's and the lamp's rows stay within 1.024 and 1.003 (`Solver::row_sums`): at
/// `ρ = 0.999` such rows make `ρK` expand, and no Krylov solve settles them. Next:
/// which entries those rows double (a twin and its original, the cavity's cluster
/// parts, the chin's crossing). The estimate now counts the residual over `1 − ρ_max`
/// (70% here), no longer 2%. Since `TWIN_GAP` (a leaf's own twin a hair in front
/// of some of its points took a factor of 1): 13.6% off the lamp, worst point 29%
/// (the red wall low at the back), every wall now reading *under* the reference,
/// and the solve's estimate 93% (this test, 520 s at load 2–4).
///
/// Why the head's rows sum above 1 (2026-11-30, h45export; Suzanne alone,
/// two-sided, in a closed one-quad-per-wall room, uniform `E = 1`, `ρ = 0.9`, one
/// round): each entry of a leaf's row was compared with 2,000 cosine rays from each
/// of the leaf's quadrature points. The worst row (1.38, an inner twin at the
/// lips) counts 0.3 of the room that no ray from its quadrature points reaches:
/// those points see nothing of the room, but two of the leaf's corners do (a lip
/// lies 0.14 mm over it), so `hidden_row_coef` integrates those entries on the
/// finer rule, at 0.43–0.51 visible, while the entry of the lip folded over it
/// keeps the three-point rule (0.78). Entries of one row integrated on different
/// rules no longer share the points at which their factors sum to at most 1:
/// that, not a twin counted twice, is what lifts the rows. Next: integrate a
/// leaf's whole row on the finer rule once one entry needs it. Rays between
/// surface points now skip both ends' twins and trim `1e-9` of the length
/// (`SURFACE_TRIM`), no longer `1e-4`, so that a fold 0.14 mm away blocks a 1 m
/// ray: that row 1.38 → 1.31; this test 12.4% off the lamp, worst point 26% (the
/// red wall low at the back), every wall still under the reference, 94 s of CPU
/// (8 min wall at load 15–20), and the estimate now 2.5% (most likely the leaf system no
/// longer stalls; not checked), and nothing else in the estimate sees the bias.
/// Since `Solver::row_excess_error` (the light rows summing above 1 make, a lower
/// bound) this test reads 10.9% off the lamp, worst point 23.9%, and the estimate
/// 4.5% (the CLI's at eps 0.5: 5.2%; 2.9% before): still under half the error
/// (ab64889, 59 s quiet).
///
/// Where the light goes now (2026-11-30, h45blend, 101c135, `rhier solve` at the
/// defaults: 10.9% off the lamp, worst 23.9%, every wall *under* the path tracer
/// in red and green, blue within a few percent; tracing code in commit 1698973,
/// and 4bd761d, reverted): not the rows that sum above 1. Those (802 above 1.01, the largest
/// 1.52) all lie outside the room: slab faces inside other slabs where they
/// overlap, the slabs' outer twins, the ceiling over the lamp (whose rows miss
/// the lamp's top 0.1 mm below entirely, which the gap's own light cannot
/// reach the room to matter). Not the final gather either: one bounce cast from
/// the probe points (20,000 cosine rays each) over the solved leaf field reads
/// 10.2% off, as dark. Not the geometry: the contact-meshed scene and the file's
/// own meet every probe point's rays at the same place (at most 1 in 20,000
/// differ). What is: the room side's rows gather less than cosine rays from the
/// same quadrature points over the same leaf field (256 rays a point): floor
/// 1.35% (red), white walls 2.4–2.6%, red wall 3.0% (red), green wall 2.5%
/// (green), blue 0.35–0.8%; spread over many entries (the lamp's bottom opened
/// into quarters, floor entries part hidden by the head, each ±0.002) and up to
/// 0.5% of the hemisphere that rays reach and no entry covers (single patches
/// of the head that a row's cluster walk left out, a strip of the ceiling
/// near the red wall's front corner in a back-wall row); per row the deficit
/// reaches 4% (back wall behind the head: 0.829 against 0.868). Red and green light is reflected at 0.999 by all but one wall
/// and the head and leaves by the open front: a 2% deficit per bounce comes out
/// about 10% dark. Next: which of those entries are biased rather than noisy
/// (the rows' visibility with `rays_per_point` rays against many), and what the
/// uncovered part is.
///
/// Bias or noise (2026-11-30, h45blend2, 7e346c7 against 200,000 paths at these 29
/// points: 10.3% off the lamp, worst 17.3%; red and green 7.5% dark on average,
/// blue 3.4%). Every entry of twelve of the worst room rows re-evaluated from the
/// leaf's quadrature points with 1,024 rays a point (the rows cast 4): the entries'
/// coefficients are not low on the whole (row sums 0.55–0.96, from 4% under to 1.7% over),
/// but the light they gather is, by 1.3% over those rows (selected as the worst,
/// so partly noise): mostly floor and white-wall sources partly hidden by the head
/// and opened into children that all take the parent's visible fraction, so a
/// child under the head that no ray reaches (row 0.0064, truth 0) takes light a
/// visible, brighter child should (a floor source: 0.074 of light short over
/// eleven rows against 0.014 of coefficient). The uncovered part was most of
/// the rest: a cluster link to a surface receiver whose eight estimate rays all
/// met something (`f = 0`, visibility 0) was dropped from every row under it,
/// though the leaves see part of the cluster: slab clusters of the ceiling were
/// 1.2–1.5% of a floor or back-wall leaf's hemisphere. Walking such links
/// from the leaf's points like any other (`Solver::cluster_link_empty`: only a
/// link that carries nothing even unoccluded would be skipped): 9.2% off the lamp,
/// worst 15.4%, red and green 6.5% dark, blue 3.3% (the Cornell box and its blocks
/// unchanged, 0.299% and 0.98% off the lamp at eps 0.1 and 0.15). Not kept
/// (4d294fe, reverted): in the room with a pillar and a floating box
/// (`solver::enclosures`) at `ρ = 0.9` the leaf system then absorbed 1.0057 of
/// the emitted power (0.998 without it) and a stored corner read 1.02% off, over
/// the 1% bar: the walked links take more than they should there, and not by
/// the fallback visibility 1 of points that cast no ray (the link's 0 in its
/// place gave the same 1.0057 to four digits); not traced further. Left: single
/// head patches still missing inside walked clusters (a part whose first rays, 2 a
/// point, all miss is dropped, one whose rays all hit is taken whole: the
/// `PARTIAL_CLUSTER_RAYS` trigger decides on the rays it then averages, which
/// biases low-visibility parts low), and the shared visibility of opened children.
/// Next: a partly hidden surface source's children each with its own rays from the
/// leaf's points.
///
/// Each child its own rays (2026-11-30, h45blend3, f771d3d, reverted): where a
/// row opens a partly hidden surface source into its children, each child took
/// its own rays' visible fraction from the leaf's points (4 rays a point,
/// weighted by the point's factor to it) in place of the source's. This test
/// read 7.58% off the lamp, worst point 16.6% (green at point 28); against
/// 200,000 paths 10.6% → 7.1%, red 7.8% → 3.1% dark, green 7.6% → 6.5%; the
/// Cornell blocks 0.89% → 0.86% and 0.71% → 0.66% at eps 0.15 and 0.1 (CPU +8%).
/// Scaling the children's fractions to keep the source's coefficient made green
/// 15% dark instead (a child the rays barely saw took the whole coefficient).
/// Reverted for three tests it broke. Traced since (h45blend4, f771d3d again):
/// - `spacetime::a_static_scene_makes_no_varying_link_and_equals_the_static_solve`
///   (1.8e-5 apart at a leaf's green): the static solve took a fresh entry's
///   visibility and an opened child's factor in `f64`, a window's frame from its
///   `f32` caches; the children's coefficient divides by that visibility. With
///   both rounded to `f32` where they are made (kept since), the static solve and
///   the space-time solve's shared part end at the same residuals to the last bit
///   (on the rows with the source's fraction shared, that test now reads 0 apart,
///   1.2e-7 before).
///   What is left is the frame's pass: it builds the rows again (which sources
///   open follows the spread the last solve left), and where an opening flips, a
///   source's children with their own fractions no longer sum to its
///   coefficient, so its row changes; GMRES then iterates on from a static solve
///   that had stopped at a residual of 9.991e-7 (tolerance 1e-6). With a
///   tolerance of 1e-8 in both: 8.0e-7 apart with the children's rays, 3.6e-7
///   without (bar 1e-6).
/// - `solver::tiled_lamp::the_default_solve_refines_below_eps_while_its_estimate_is_above_the_promise`:
///   the one-quad room with the lamp 20 cm down and turned 10°, against 100,000
///   paths at its 19 points: at eps 0.5 (two levels) 3.05% RMS off the lamp,
///   worst 5.3%, estimate 1.96% with the children's rays; 2.68%, worst 6.2%,
///   estimate 3.73% without; at eps 0.25 0.37% against 1.89%, at 0.125 0.51%
///   against 0.90%; tiled 6 × 6, 0.41% against 0.67% at every eps. The answer is
///   better from eps 0.25 on, but at eps 0.5 the change between levels reads
///   1.96% where the truth is 3.05%, under the promise (2.5%), so the solve no
///   longer halves eps. Most likely the change between the levels measured
///   mostly the children's shared visibility that refinement replaced by their
///   own; with their own rays from the first level on that change is gone, and
///   nothing sees the coarse level's mean deficit (−1.8%, the floor by a wall and
///   the ceiling by the lamp 4.5–5.3% dark). Not fixed: the estimate needs a term
///   for it.
/// - `spacetime::each_frame_is_as_accurate_as_the_static_solve_of_that_frame`: the
///   per-frame solve gains from the children's rays (t = 0: 2.03% → 1.93%,
///   t = 0.4: 1.58% → 1.56% from the fine solve), the space-time frames less
///   (1.94% → 1.88%) or not at all (1.649% at t = 0.4 either way): 1.056 times
///   at t = 0.4, over the 1.05 bar. Not traced (the frame's rows take cached
///   entries and opened rows of earlier frames).
///
/// The stiff room's leaf system (`a_stiff_room_is_balanced_and_keeps_its_light`)
/// then absorbed 0.9914 unbalanced, within `BALANCE_TRIGGER`, its mean 0.52% off.
/// The change between levels read 0.99 on this box, most likely from the leaves
/// inside the slabs.
///
/// The estimate is to see that shortfall (2026-11-30, h45est,
/// `Solver::row_ray_check`: sampled rows against cosine rays and rays at the
/// lamp over the solved field, the mean gap amplified by the bounces' gain).
/// On 128 rows the rows gathered 2.1%, 0.4%, 5.2% less in red, green and blue
/// (noise 1.4, 0.35, 2.3%), gains 9.2, 22.5, 3.6; on one row in 8 (e4edf1f)
/// the CLI's estimate still reads 5.23% (`rhier solve` at the defaults, 186 s
/// of CPU): the term stayed under the other terms. Not yet traced.
#[test]
#[ignore = "11.1% off the lamp at eps 0.5 (8a0d374), short of 5%, and a minute and a half long (issue 45)"]
fn blender_cornell_box_agrees_with_the_path_tracer() {
    let err = blender_error(
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
/// Paths per point of its reference.
const BLENDER_PATHS: u32 = 4_000;
/// Its bars: relative RMS off the lamp and the worst point.
const BLENDER_RMS: f64 = 0.05;
const BLENDER_WORST: f64 = 0.10;
