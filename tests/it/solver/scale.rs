//! Scale: a room cluttered with small boxes (the scene of `tools/gen_cubes.py`, built
//! here at small sizes). The number of active links per patch must stay bounded as
//! the clutter grows, and the power criterion for small receivers
//! (`SolveOptions::power_size`) with the cheap final gather of small leaves must give
//! the same point radiosity as the radiosity criterion with rays everywhere; leaves
//! split on their spread, or seen by their shape, must bring the shadowed slots of a
//! corner of the 100k-polygon room towards the path tracer.

use std::path::Path;

use rhier::playback::probe::{ProbePoint, probe};
use rhier::scene::{Scene, load_json_str};
use rhier::solver::{SolveOptions, Solver};

/// A 10 × 4 × 10 room with a ceiling lamp and an `n × n` grid of boxes on the floor
/// (as `tools/gen_cubes.py n`).
fn clutter(n: usize) -> Scene {
    clutter_block(n, 0..n)
}

/// The room of [`clutter`] with only the boxes of rows and columns `block` (as
/// `tools/gen_cubes.py n --block LO HI`).
fn clutter_block(n: usize, block: std::ops::Range<usize>) -> Scene {
    let (size, h) = (10.0f64, 4.0f64);
    let quad = |v: [[f64; 3]; 4], m: &str| {
        format!(
            r#"{{"vertices": [[{},{},{}],[{},{},{}],[{},{},{}],[{},{},{}]], "material": "{m}"}}"#,
            v[0][0],
            v[0][1],
            v[0][2],
            v[1][0],
            v[1][1],
            v[1][2],
            v[2][0],
            v[2][1],
            v[2][2],
            v[3][0],
            v[3][1],
            v[3][2]
        )
    };
    let s = size;
    let room = [
        quad(
            [[0., 0., 0.], [0., 0., s], [s, 0., s], [s, 0., 0.]],
            "white",
        ),
        quad([[0., h, 0.], [s, h, 0.], [s, h, s], [0., h, s]], "white"),
        quad([[0., 0., s], [0., h, s], [s, h, s], [s, 0., s]], "white"),
        quad(
            [[0., 0., 0.], [s, 0., 0.], [s, h, 0.], [0., h, 0.]],
            "white",
        ),
        quad([[0., 0., 0.], [0., h, 0.], [0., h, s], [0., 0., s]], "red"),
        quad([[s, 0., 0.], [s, 0., s], [s, h, s], [s, h, 0.]], "green"),
    ];
    let (l0, l1, y) = (4.0, 6.0, h - 0.01);
    let lamp = quad([[l0, y, l0], [l1, y, l0], [l1, y, l1], [l0, y, l1]], "lamp");
    let mut cubes = Vec::new();
    let pitch = (size - 1.0) / n as f64;
    for i in block.clone() {
        for j in block.clone() {
            let hgt = 0.05 + 0.3 * (((i * 7 + j * 13) % 11) as f64 / 10.0);
            let (x0, z0) = (0.5 + i as f64 * pitch, 0.5 + j as f64 * pitch);
            let (x1, z1, y1) = (x0 + 0.6 * pitch, z0 + 0.6 * pitch, hgt);
            // Each face counter-clockwise seen from outside the box.
            cubes.extend([
                quad(
                    [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]],
                    "white",
                ),
                quad(
                    [[x0, y1, z0], [x1, y1, z0], [x1, 0., z0], [x0, 0., z0]],
                    "white",
                ),
                quad(
                    [[x1, y1, z1], [x0, y1, z1], [x0, 0., z1], [x1, 0., z1]],
                    "white",
                ),
                quad(
                    [[x0, y1, z1], [x0, y1, z0], [x0, 0., z0], [x0, 0., z1]],
                    "white",
                ),
                quad(
                    [[x1, y1, z0], [x1, y1, z1], [x1, 0., z1], [x1, 0., z0]],
                    "white",
                ),
                quad(
                    [[x1, 0., z0], [x1, 0., z1], [x0, 0., z1], [x0, 0., z0]],
                    "white",
                ),
            ]);
        }
    }
    let text = format!(
        r#"{{"rhier_scene": 1,
  "materials": {{
    "white": {{"reflectance": [0.7, 0.7, 0.7]}},
    "red": {{"reflectance": [0.6, 0.1, 0.1]}},
    "green": {{"reflectance": [0.1, 0.6, 0.1]}},
    "lamp": {{"reflectance": [0.5, 0.5, 0.5], "emission": [20.0, 20.0, 20.0]}}}},
  "objects": [
    {{"name": "room", "polygons": [{}]}},
    {{"name": "lamp", "polygons": [{lamp}]}},
    {{"name": "cubes", "polygons": [{}]}}]}}"#,
        room.join(","),
        cubes.join(",")
    );
    match load_json_str(&text, Path::new("clutter.json")) {
        Ok(s) => s,
        Err(e) => panic!("generated scene does not load: {e}"),
    }
}

/// Options light enough for a test: coarse elements, no contact meshing.
fn coarse() -> SolveOptions {
    SolveOptions {
        min_size: 1.0 / 64.0,
        recon_min_size: 1.0 / 64.0,
        max_rounds: 3,
        contact_meshing: false,
        ..SolveOptions::default()
    }
}

/// Active links per patch after the rounds.
fn links_per_patch(n: usize) -> f64 {
    let scene = clutter(n);
    let mut solver = Solver::new(&scene, coarse()).expect("solver");
    let records = solver.run(|_, _| {}).expect("rounds");
    let last = records.last().expect("at least one round");
    last.links_active as f64 / solver.patches.len() as f64
}

#[test]
fn links_per_patch_stay_bounded_as_clutter_grows() {
    let small = links_per_patch(3);
    let large = links_per_patch(8);
    eprintln!("links per patch: {small:.1} (3×3 boxes), {large:.1} (8×8 boxes)");
    // 60 → 390 polygons: the links per patch may grow a little (more neighbours),
    // not with the number of patches (6.5×).
    assert!(small > 1.0 && large > 1.0, "{small} {large}");
    assert!(
        large < 2.0 * small,
        "links per patch grew from {small:.1} (3×3 boxes) to {large:.1} (8×8 boxes)"
    );
}

#[test]
fn the_estimated_error_is_a_finite_change_in_clutter() {
    // The estimate once summed link bounds, and links the power criterion leaves
    // whole at small receivers (no estimate, infinite spread) made it read 1e38. It
    // is now the final gather's change at sample points between levels: none in the
    // rounds of the first level (`2 eps`), then finite and small.
    let scene = clutter(8);
    let mut solver = Solver::new(&scene, coarse()).expect("solver");
    let records = solver.run(|_, _| {}).expect("rounds");
    assert!(records[0].estimated_error.is_nan());
    let first = records
        .iter()
        .position(|r| !r.estimated_error.is_nan())
        .expect("a round at eps");
    assert!(first <= 2, "the first level has at most two rounds");
    for r in &records[first..] {
        eprintln!("round {} estimated error {:e}", r.round, r.estimated_error);
        assert!(
            r.estimated_error.is_finite() && r.estimated_error > 0.0 && r.estimated_error < 0.5,
            "round {}: estimated error {}",
            r.round,
            r.estimated_error
        );
    }
}

/// Probe points (58 for 4 × 4 boxes): floor between boxes, box tops, box sides, walls, ceiling.
fn probes(n: usize) -> Vec<ProbePoint> {
    let pitch = 9.0 / n as f64;
    let w = 0.6 * pitch;
    let mut pts = Vec::new();
    let p = |x: f64, y: f64, z: f64| glam::DVec3::new(x, y, z);
    for i in 0..n {
        for j in 0..n {
            let hgt = 0.05 + 0.3 * (((i * 7 + j * 13) % 11) as f64 / 10.0);
            let (x0, z0) = (0.5 + i as f64 * pitch, 0.5 + j as f64 * pitch);
            pts.push(ProbePoint {
                p: p(x0 + w + 0.5 * (pitch - w), 1e-4, z0 + 0.5 * w),
                n: glam::DVec3::Y,
            });
            pts.push(ProbePoint {
                p: p(x0 + 0.5 * w, hgt + 1e-4, z0 + 0.5 * w),
                n: glam::DVec3::Y,
            });
            pts.push(ProbePoint {
                p: p(x0 + 0.5 * w, 0.5 * hgt, z0 - 1e-4),
                n: -glam::DVec3::Z,
            });
        }
    }
    for k in 0..5 {
        let t = 1.0 + 2.0 * k as f64;
        pts.push(ProbePoint {
            p: p(1e-4, 2.0, t),
            n: glam::DVec3::X,
        });
        pts.push(ProbePoint {
            p: p(t, 4.0 - 1e-4, 1.0),
            n: -glam::DVec3::Y,
        });
    }
    pts
}

#[test]
fn power_criterion_and_cheap_gather_keep_point_radiosity() {
    let n = 4;
    let scene = clutter(n);
    let pts = probes(n);
    let run = |opts: SolveOptions| {
        let mut solver = Solver::new(&scene, opts).expect("solver");
        let records = solver.run(|_, _| {}).expect("rounds");
        let links = records.last().expect("a round").links_active;
        let sol = solver.solution();
        (probe(&sol, &pts, 0.0).expect("probe"), links)
    };
    // Box faces (0.07–0.5 m²) below the power area (0.84 m² here).
    let (fast, fast_links) = run(SolveOptions {
        power_size: 1.0 / 16.0,
        ..coarse()
    });
    let (full, full_links) = run(SolveOptions {
        power_size: 0.0,
        faint_source: 0.0,
        ..coarse()
    });
    // With the boxes' faces facing out (they faced in before the generator was fixed)
    // the power criterion no longer saves links at this size (9435 vs 9322 links,
    // measured); at 6 × 6 boxes, measured before the contact-meshing and close
    // cluster fixes, it saved 12% of the links and moved the points by 6.7% RMS, over
    // this test's bound. What is asserted here is the point radiosity at 4 × 4 boxes:
    // 2.0% RMS apart while a small leaf's points took every non-emitting surface
    // source's visibility from its row, 1.1% since they cast their own rays where
    // that visibility is partial (`Solver::leaf_visibility`).
    eprintln!("links {fast_links} (power criterion) vs {full_links}");
    let scale = (full.iter().map(|b| b[1] * b[1]).sum::<f64>() / full.len() as f64).sqrt();
    assert!(scale > 0.01, "scene is dark: {scale}");
    let rms = (fast
        .iter()
        .zip(&full)
        .map(|(a, b)| (a[1] - b[1]).powi(2))
        .sum::<f64>()
        / full.len() as f64)
        .sqrt();
    eprintln!(
        "links {fast_links} (power) vs {full_links}; RMS difference {rms:.4}, scale {scale:.4}"
    );
    assert!(
        rms < 0.015 * scale,
        "RMS difference {rms:.4} vs scale {scale:.4} ({} points)",
        pts.len()
    );
}

/// A corner of the 100k-polygon room (`gen_cubes.py 129 --block 0 8`): far from the
/// lamp, its 2.8 cm slots between boxes are in shadow and lit through their
/// openings. Their faces are single leaves below the power area whose radiosity
/// varies several-fold over their height; the faces around saw them at their mean,
/// and the slots came out far too bright against the path tracer.
struct SlotCorner {
    scene: Scene,
    probes: Vec<ProbePoint>,
    /// Path-traced radiosity (channel 0) at the probes.
    reference: Vec<f64>,
}

impl SlotCorner {
    /// 60 points: on the floor of each slot towards the +x neighbour, and half way up
    /// each box's −z face.
    fn new() -> Self {
        let (n, block) = (129, 0..8);
        let scene = clutter_block(n, block.clone());
        let pitch = 9.0 / n as f64;
        let w = 0.6 * pitch;
        let mut pts = Vec::new();
        for i in block.start + 1..block.end - 2 {
            for j in block.start + 1..block.end - 1 {
                let hgt = 0.05 + 0.3 * (((i * 7 + j * 13) % 11) as f64 / 10.0);
                let (x0, z0) = (0.5 + i as f64 * pitch, 0.5 + j as f64 * pitch);
                pts.push((
                    glam::DVec3::new(x0 + w + 0.5 * (pitch - w), 1e-4, z0 + 0.5 * w),
                    glam::DVec3::Y,
                ));
                pts.push((
                    glam::DVec3::new(x0 + 0.5 * w, 0.5 * hgt, z0 - 1e-4),
                    -glam::DVec3::Z,
                ));
            }
        }
        let reference = rhier::reference::radiosity_at(&scene, &pts, 20_000, 7)
            .iter()
            .map(|e| e.b[0])
            .collect();
        let probes = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
        SlotCorner {
            scene,
            probes,
            reference,
        }
    }

    /// Bias (sum over sum − 1) and relative RMS error at the probes of a solve with
    /// `opts`, and its leaves.
    fn error(&self, opts: SolveOptions) -> (f64, f64, u64) {
        let mut solver = Solver::new(&self.scene, opts).expect("solver");
        let records = solver.run(|_, _| {}).expect("rounds");
        let leaves = records.last().expect("a round").leaves;
        let b = probe(&solver.solution(), &self.probes, 0.0).expect("probe");
        let r = &self.reference;
        let bias = b.iter().map(|v| v[0]).sum::<f64>() / r.iter().sum::<f64>() - 1.0;
        let rms = (b
            .iter()
            .zip(r)
            .map(|(v, r)| ((v[0] - r) / r).powi(2))
            .sum::<f64>()
            / b.len() as f64)
            .sqrt();
        (bias, rms, leaves)
    }

    /// [`SlotCorner::error`] with the default options and with `opts`, printed; the
    /// default's slots must be too bright (bias above 20%), or there is nothing
    /// to mend.
    fn against_default(&self, opts: SolveOptions) -> [(f64, f64, u64); 2] {
        let (bias0, rms0, leaves0) = self.error(SolveOptions::default());
        let (bias, rms, leaves) = self.error(opts);
        eprintln!(
            "{} slot points: bias {:+.1}% -> {:+.1}%, relative RMS {:.1}% -> {:.1}%, leaves {leaves0} -> {leaves}",
            self.probes.len(),
            100.0 * bias0,
            100.0 * bias,
            100.0 * rms0,
            100.0 * rms
        );
        assert!(
            bias0 > 0.2,
            "the slots were not too bright by default: {bias0}"
        );
        [(bias0, rms0, leaves0), (bias, rms, leaves)]
    }
}

/// Leaves split on their spread (`SolveOptions::split_spread` 0.15) must take the
/// slots' floor and sides of [`SlotCorner`] much closer to the path tracer, and
/// split some leaves.
#[test]
fn leaves_split_on_their_spread_mend_shadowed_slots() {
    let [(bias0, rms0, leaves0), (bias, rms, leaves)] =
        SlotCorner::new().against_default(SolveOptions {
            split_spread: 0.15,
            ..SolveOptions::default()
        });
    // Measured: 60 points, bias +66.6% -> +36.4%, relative RMS 84.8% -> 47.0%,
    // 1 429 -> 2 071 leaves (2026-11-29). The default's +66.6% was +27.8% before
    // leaf rows took a cluster's parts at their exact factors: a slot's floor
    // now gathers each neighbouring box side at its exact factor (about 0.3) and
    // at its mean radiosity, several times what the side has at its foot; the
    // close-cluster estimate it replaced gave less and lost light elsewhere
    // (`the_clutter_keeps_its_light`).
    assert!(leaves > leaves0, "no leaf split: {leaves0} -> {leaves}");
    assert!(bias < 0.6 * bias0, "bias {bias0} -> {bias}");
    assert!(rms < 0.7 * rms0, "relative RMS {rms0} -> {rms}");
}

/// Leaves seen by their shape (`SolveOptions::leaf_shapes` 0.1) must take the slots
/// of [`SlotCorner`] towards the path tracer without new leaves: the final gather
/// sees the slots' faces dark at the bottom and lit at the top.
#[test]
fn leaves_seen_by_their_shape_mend_shadowed_slots() {
    let [(bias0, rms0, leaves0), (bias, rms, leaves)] =
        SlotCorner::new().against_default(SolveOptions {
            leaf_shapes: 0.1,
            ..SolveOptions::default()
        });
    // Measured: 60 points, bias +66.6% -> +54.8%, relative RMS 84.8% -> 66.6%,
    // 1 429 leaves both (2026-11-29; see the test above for the default's bias).
    assert_eq!(leaves, leaves0, "the shapes changed the leaves");
    assert!(bias < 0.9 * bias0, "bias {bias0} -> {bias}");
    assert!(rms < 0.85 * rms0, "relative RMS {rms0} -> {rms}");
}

/// The near field (`SolveOptions::near_field`, `--near-field`) must take the slots
/// of [`SlotCorner`] towards the path tracer (60 points, 20 000 paths each): a
/// slot's floor sees the box sides beside it large, and gathered them at their
/// mean, several times what the sides have at their foot; mended from the
/// reconstruction's field over them, cell by cell. Measured against the same
/// solve without it, nothing else changed.
#[test]
fn near_field_mends_shadowed_slots() {
    let corner = SlotCorner::new();
    let (bias0, rms0, leaves0) = corner.error(SolveOptions::default());
    let (bias, rms, leaves) = corner.error(SolveOptions {
        near_field: true,
        ..SolveOptions::default()
    });
    eprintln!(
        "{} slot points: bias {:+.1}% -> {:+.1}%, relative RMS {:.1}% -> {:.1}%, leaves {leaves0} -> {leaves}",
        corner.probes.len(),
        100.0 * bias0,
        100.0 * bias,
        100.0 * rms0,
        100.0 * rms
    );
    // Measured: 60 points, bias +59.5% -> +40.0%, relative RMS 77.1% -> 53.1%,
    // 871 leaves both (2026-12-03, h45near). The near field changes the
    // reconstruction only, not the leaves.
    assert_eq!(leaves, leaves0, "the near field changed the leaves");
    assert!(
        bias0 > 0.2,
        "the slots were not too bright without it: {bias0}"
    );
    assert!(bias.abs() < 0.8 * bias0, "bias {bias0} -> {bias}");
    assert!(rms < 0.85 * rms0, "relative RMS {rms0} -> {rms}");
}

/// Power absorbed by the surfaces over power emitted, `Σ A (1 − ρ)(B − E) / ρ` over
/// the leaves over `Σ A E` (channel 0).
fn absorbed_over_emitted(solver: &Solver) -> f64 {
    let geoms = solver.elems.geoms.as_slice();
    let nodes = solver.elems.nodes.as_slice();
    let b = solver.elems.radiosities.as_slice();
    let (mut absorbed, mut emitted) = (0.0, 0.0);
    for e in 0..solver.elems.len() {
        let g = &geoms[e];
        if g.patch == u32::MAX || nodes[e].child_count > 0 {
            continue;
        }
        let p = g.patch as usize;
        let (rho, em) = (solver.patches.rhos[p][0], solver.patches.emissions[p][0]);
        absorbed += g.area * (1.0 - rho) * (b[e][0] as f64 - em) / rho;
        emitted += g.area * em;
    }
    absorbed / emitted
}

/// The room of boxes is closed and its boxes rest on the floor with their hidden
/// faces dropped (contact meshing), so the light the lamp emits is all absorbed by
/// the surfaces but for what the ceiling sends to the back of the lamp hung under
/// it, which no surface receives (about half a point here). Cluster links too
/// close for the cluster estimate, left whole at small receivers by the power
/// criterion, once carried nothing: 0.913 at 32 × 32 boxes (measured), 0.985 with
/// a receiver-averaged Monte Carlo factor. A box's side gathered nothing from the
/// floor in front of it where the link from the box's cluster estimated zero (rows
/// 0.6–0.8); each leaf now opens such links itself: 1.000 (2026-11-29). The bound
/// is 2.5%.
#[test]
fn the_clutter_keeps_its_light() {
    let n = 32;
    let scene = clutter(n);
    let mut solver = Solver::new(
        &scene,
        SolveOptions {
            contact_meshing: true,
            ..coarse()
        },
    )
    .expect("solver");
    solver.run(|_, _| {}).expect("rounds");
    let ratio = absorbed_over_emitted(&solver);
    eprintln!("{n} x {n} boxes: absorbed / emitted = {ratio:.4}");
    assert!((ratio - 1.0).abs() < 0.025, "{n} x {n} boxes: {ratio}");
}
