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

/// The Blender Cornell box against the path tracer at the 29 points off the
/// lamp (issue 45 part 4): within the 5% bar off the lamp, not yet at its worst
/// point (10%), and minutes of CPU under load.
///
/// With the slabs cut where they pass through each other (contact meshing's
/// crossing segments; 2026-12-02, this test's 4 000 paths): **4.49% off the
/// lamp**, worst point 17 (the red wall near the floor and the back wall)
/// 11.0%, estimate 0.84%. Uncut, the floor's and ceiling's room sides ran into
/// the back wall's slab and the back wall's room side into the floor, ceiling
/// and red wall (18% of it), and their leaves averaged the lit room side with
/// the dark inside: the rows of the walls gathered 5–10% short from the floor
/// and back wall where rays over the same field did not (a scratch trace of
/// every room leaf's row against 256 cosine rays, by receiving and source
/// object, branch h45obj).
/// On 8f50acd (the same 4 000 paths): 11.07% off the lamp, worst
/// point 17 (the red wall) 21.7%, estimate 8.1%. On 2026-12-01 (e61cb15, `rhier
/// solve` at the defaults against 100,000 paths): 10.5% off the lamp, worst point 17.2% (17, the back wall), red,
/// green and blue at 0.905, 0.906 and 0.972 of the reference on the mean; the
/// estimate reads 5.2%, half the error.
///
/// Before the crossings were cut, the darkness was laid on the head (ρ 0.999
/// in red and green, so a row 2% short a bounce comes out about 10% dark):
/// opened sources' children sharing the source's visible fraction (f771d3d,
/// 8ea1afc) and cluster parts decided by their first rays (4d294fe) were tried
/// and reverted, for 7–9% at best and unbalanced rooms. The by-object trace
/// found the rows from the head within 1–4% of the rays, and those from the
/// floor and back wall 5–10% short, their factors 3–4% short and the values
/// more: the uncut slabs.
///
/// The estimate (2026-12-02, h45est), against 100,000 paths (this test's 4,000
/// carry 3.5% relative RMS of noise off the lamp, 100,000 paths 0.57%): at eps
/// 0.5 3.36% off the lamp, estimate 2.40% (0.92% before the rows' check drew
/// rows to its noise and took one σ off, and the final gather was checked
/// against rays); at eps 0.25 2.69%, estimate 1.30% (0.75% before). The answer
/// is 2–3% dark nearly everywhere and up to 9% on the ceiling by the opening.
#[test]
#[ignore = "4.49% off the lamp against the test's 4,000 paths at eps 0.5, but its worst point 11.0% (bar 10%), and minutes of CPU (issue 45)"]
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

/// SCRATCH (h45est, not for merge): the estimate's terms on the Blender box.
#[test]
#[ignore = "scratch"]
fn scratch_blender_estimate_terms() {
    let scene = blender_box();
    let pts = points();
    let eps: f64 = std::env::var("SCRATCH_EPS").ok().and_then(|v| v.parse().ok()).unwrap_or(0.5);
    let paths: u32 = std::env::var("SCRATCH_PATHS").ok().and_then(|v| v.parse().ok()).unwrap_or(BLENDER_PATHS);
    let cache = format!("/tmp/h45est_ref_{paths}.txt");
    let reference: Vec<rhier::reference::Estimate> = match std::fs::read_to_string(&cache) {
        Ok(t) => t
            .lines()
            .map(|l| {
                let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                rhier::reference::Estimate { b: [v[0], v[1], v[2]], std_error: [v[3], v[4], v[5]] }
            })
            .collect(),
        Err(_) => {
            let r = rhier::reference::radiosity_at(&scene, &pts, paths, 13);
            let t: String = r
                .iter()
                .map(|e| format!("{} {} {} {} {} {}\n", e.b[0], e.b[1], e.b[2], e.std_error[0], e.std_error[1], e.std_error[2]))
                .collect();
            std::fs::write(&cache, t).unwrap();
            r
        }
    };
    let rb: Vec<[f64; 3]> = reference.iter().map(|e| e.b).collect();
    let patches = rhier::geometry::Patches::at_time(&scene, 0.0);
    let on_lamp = rhier::geometry::on_emitters(&patches, &pts);
    let (mut n2, mut d2) = (0.0, 0.0);
    for (i, e) in reference.iter().enumerate() {
        if !on_lamp[i] {
            for k in 0..3 {
                n2 += e.std_error[k].powi(2);
                d2 += e.b[k].powi(2);
            }
        }
    }
    eprintln!("reference noise (rel RMS std error off lamp) {:.4}", (n2 / d2).sqrt());
    let opts = SolveOptions { eps, ..SolveOptions::default() };
    let t0 = std::time::Instant::now();
    let mut s = rhier::solver::Solver::new(&scene, opts).expect("solver");
    let records = s.run(|_, _| {}).expect("run");
    eprintln!("solve {:.1} s", t0.elapsed().as_secs_f64());
    for r in &records {
        eprintln!("round {} leaves {} est {:.4} residual {:.2e}", r.round, r.leaves, r.estimated_error, r.residual);
    }
    let t1 = std::time::Instant::now();
    let check = s.row_ray_check();
    eprintln!("check {:.3} s: {check:?}", t1.elapsed().as_secs_f64());
    let t1 = std::time::Instant::now();
    let gather = s.gather_ray_check();
    eprintln!("gather check {:.3} s: {gather:?}", t1.elapsed().as_secs_f64());
    eprintln!("excess {:.4} balance {:.4}", s.row_excess_error(), s.power_balance());
    let sol = s.solution();
    eprintln!("solution estimate {:.4}", sol.stats.estimated_error);
    let probes: Vec<ProbePoint> = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
    let b = probe(&sol, &probes, 0.0).expect("probe");
    let err = PointError::measure(&b, &rb, &on_lamp);
    for (i, ((p, _), (x, r))) in pts.iter().zip(b.iter().zip(&rb)).enumerate() {
        eprintln!("{i:2} {p}: {x:.4?} reference {r:.4?} ratio {:.3?}", std::array::from_fn::<f64, 3, _>(|k| x[k] / r[k]));
    }
    eprintln!("eps {eps}: {}", err.text());
    let t2 = std::time::Instant::now();
    let rays: usize = std::env::var("SCRATCH_RAYS").ok().and_then(|v| v.parse().ok()).unwrap_or(4096);
    let one = scratch_one_bounce(&scene, &sol, &pts, rays);
    eprintln!("one bounce {:.1} s", t2.elapsed().as_secs_f64());
    for (i, (o, (x, r))) in one.iter().zip(b.iter().zip(&rb)).enumerate() {
        eprintln!("{i:2} one bounce / answer {:.3?} / reference {:.3?}", std::array::from_fn::<f64, 3, _>(|k| o[k] / x[k]), std::array::from_fn::<f64, 3, _>(|k| o[k] / r[k]));
    }
    eprintln!("one bounce vs answer {} ; vs reference {}", PointError::measure(&one, &b, &on_lamp).text(), PointError::measure(&one, &rb, &on_lamp).text());
}

/// SCRATCH: one bounce over the answer at `pts`: `E + ρ (direct + mean over
/// cosine rays of (B − E) of the answer where they land)`, `rays` of each.
fn scratch_one_bounce(
    scene: &Scene,
    sol: &rhier::solution::Solution,
    pts: &[(DVec3, DVec3)],
    rays: usize,
) -> Vec<[f64; 3]> {
    use rhier::geometry::{Patches, SceneBvh, cosine_direction, nearest_facing};
    let patches = Patches::at_time(scene, 0.0);
    let bvh = SceneBvh::build(scene, &patches, 0.0);
    let diam = patches.diameter;
    let em: Vec<usize> = (0..patches.len())
        .filter(|&i| patches.emissions[i].iter().any(|&e| e > 0.0))
        .collect();
    let em_area: f64 = em.iter().map(|&i| patches.areas[i]).sum();
    let u = |a: u64, b: u64, c: u64| {
        let mut h = a.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ b.wrapping_mul(0xc2b2_ae3d_27d4_eb4f) ^ c.wrapping_mul(0x1656_67b1_9e37_79f9);
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        (h >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut out = Vec::new();
    for (pi, &(p, n)) in pts.iter().enumerate() {
        let (patch, x) = nearest_facing(&patches.polys, &patches.normals, p, n).expect("facing");
        let nx = patches.normals[patch];
        let mut probes = Vec::new();
        let mut e_hit = Vec::new();
        for j in 0..rays {
            let side = (rays as f64).sqrt() as usize;
            let (a, b) = (j % side, j / side);
            let dir = cosine_direction(nx, (a as f64 + u(pi as u64, j as u64, 1)) / side as f64, (b as f64 + u(pi as u64, j as u64, 2)) / side as f64);
            if let Some(hit) = bvh.intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0) {
                let hp = hit.patch as usize;
                if patches.normals[hp].dot(dir) < 0.0 {
                    probes.push(ProbePoint { p: x + dir * diam * 2.0 * hit.t, n: patches.normals[hp] });
                    e_hit.push(patches.emissions[hp]);
                }
            }
        }
        let b = probe(sol, &probes, 0.0).expect("probe");
        let mut h = [0.0; 3];
        for (v, e) in b.iter().zip(&e_hit) {
            for k in 0..3 {
                h[k] += (v[k] - e[k]) / rays as f64;
            }
        }
        // Direct: uniform points over the emitters by area, triangle-split quads.
        let mut d = [0.0; 3];
        for j in 0..rays {
            let mut pick = u(pi as u64, j as u64, 3) * em_area;
            let mut ep = em[em.len() - 1];
            for &i in &em {
                if pick < patches.areas[i] {
                    ep = i;
                    break;
                }
                pick -= patches.areas[i];
            }
            let c = patches.polys[ep].corners();
            let (s, t) = (u(pi as u64, j as u64, 4).sqrt(), u(pi as u64, j as u64, 5));
            let (a0, a1) = if c.len() == 4 {
                let a0 = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
                let a1 = 0.5 * (c[2] - c[0]).cross(c[3] - c[0]).length();
                (a0, a1)
            } else {
                (1.0, 0.0)
            };
            let y = if u(pi as u64, j as u64, 6) * (a0 + a1) < a0 {
                c[0] * (1.0 - s) + c[1] * (s * (1.0 - t)) + c[2] * (s * t)
            } else {
                c[0] * (1.0 - s) + c[2] * (s * (1.0 - t)) + c[3] * (s * t)
            };
            let dd = y - x;
            let r2 = dd.length_squared();
            let (cx, cy) = (nx.dot(dd), -patches.normals[ep].dot(dd));
            if ep != patch && r2 > 0.0 && cx > 0.0 && cy > 0.0 && !bvh.occluded(x, y) {
                let g = cx * cy / (r2 * r2) / std::f64::consts::PI * em_area / rays as f64;
                for k in 0..3 {
                    d[k] += patches.emissions[ep][k] * g;
                }
            }
        }
        let rho = patches.rhos[patch];
        let e = patches.emissions[patch];
        out.push(std::array::from_fn(|k| e[k] + rho[k] * (h[k] + d[k])));
    }
    out
}

/// SCRATCH (h45est, not for merge): the rays' checks on the Cornell boxes.
#[test]
#[ignore = "scratch"]
fn scratch_cornell_checks() {
    for blocks in [false, true] {
        for eps in [0.5, 0.25, 0.1] {
            let scene = rhier::scene::cornell_box(blocks);
            let opts = SolveOptions { eps, ..SolveOptions::default() };
            let t0 = std::time::Instant::now();
            let mut s = rhier::solver::Solver::new(&scene, opts).expect("solver");
            let records = s.run(|_, _| {}).expect("run");
            let solve = t0.elapsed().as_secs_f64();
            let t1 = std::time::Instant::now();
            let rows = s.row_ray_check();
            let t_rows = t1.elapsed().as_secs_f64();
            let t2 = std::time::Instant::now();
            let gather = s.gather_ray_check();
            let t_gather = t2.elapsed().as_secs_f64();
            let before = records.iter().rev().nth(0).map_or(f64::NAN, |r| r.estimated_error);
            eprintln!(
                "blocks {blocks} eps {eps}: solve {solve:.2} s, estimate {before:.4}, solution {:.4}; rows {:.4} (noise {:.4}, {} rows, {t_rows:.3} s, gap {:.4?} ± {:.4?} gain {:.2?}); gather {:.4} ({t_gather:.3} s)",
                s.solution().stats.estimated_error,
                rows.map_or(f64::NAN, |c| c.error),
                rows.map_or(f64::NAN, |c| c.noise),
                rows.map_or(0, |c| c.rows),
                rows.map_or([0.0; 3], |c| c.gap),
                rows.map_or([0.0; 3], |c| c.gap_noise),
                rows.map_or([0.0; 3], |c| c.gain),
                gather.map_or(f64::NAN, |g| g.error)
            );
        }
    }
}
