//! Space-time solve (issue 4) against the static solver, frame by frame.

use glam::{DQuat, DVec3};
use rhier::geometry::{Patches, SceneBvh};
use rhier::playback::{ProbePoint, probe};
use rhier::scene::{MotionKey, MotionTrack, Scene, TimeDomain, cornell_box};

use crate::common::shapes;
use rhier::shafts::Shaft;
use rhier::solution::relative_rms;
use rhier::solution::{Leaf, Solution, SolveStats};
use rhier::solver::spacetime::{
    self, SpaceTime, SpaceTimeOptions, WindowOutput, frame_instants, swept_boxes,
};
use rhier::solver::{SolveOptions, Solver};

fn key(t: f64, x: f64) -> MotionKey {
    MotionKey {
        t,
        translation: DVec3::new(x, 0.0, 0.0),
        rotation: DQuat::IDENTITY,
        scale: DVec3::ONE,
    }
}

/// The Cornell box with blocks whose short block slides `dx` mm along x over
/// `[0, duration]`.
fn sliding_block(dx: f64, duration: f64) -> Scene {
    let mut scene = cornell_box(true);
    scene.time.start = 0.0;
    scene.time.end = duration;
    let block = scene
        .objects
        .iter_mut()
        .find(|o| o.name == "short_block")
        .expect("the Cornell box has a short block");
    block.motion = Some(MotionTrack {
        keys: vec![key(0.0, 0.0), key(duration, dx)],
    });
    scene
}

fn opts() -> SolveOptions {
    SolveOptions::default()
}

/// Windows of `window` seconds at `fps`, keyframes every 8 frames (the layout these
/// tests were written for; the default spaces keyframes by motion, tested apart).
fn st(fps: f64, window: f64) -> SpaceTimeOptions {
    SpaceTimeOptions {
        fps,
        window: Some(window),
        key_stride: Some(8),
        ..SpaceTimeOptions::default()
    }
}

fn solve_all(scene: &Scene, st: &SpaceTimeOptions) -> Vec<WindowOutput> {
    run_frames(scene, opts(), st).0
}

/// The windows and frame records of a space-time solve.
fn run_frames(
    scene: &Scene,
    o: SolveOptions,
    st: &SpaceTimeOptions,
) -> (Vec<WindowOutput>, Vec<spacetime::FrameRecord>) {
    let mut frames = Vec::new();
    let mut windows = Vec::new();
    spacetime::solve(
        scene,
        o,
        st,
        |f| frames.push(*f),
        |w| {
            windows.push(w);
            Ok(())
        },
    )
    .unwrap();
    (windows, frames)
}

fn as_solution(scene: &Scene, patches: &Solution, windows: &[WindowOutput]) -> Solution {
    Solution {
        scene: scene.clone(),
        patches: patches.patches.clone(),
        leaves: windows
            .iter()
            .flat_map(|w| w.leaves.iter().copied())
            .collect(),
        stats: SolveStats::default(),
    }
}

/// Probe points on the Cornell box's floor, back wall and ceiling, away from where
/// the short block slides (a point under a moving block has no surface to probe).
fn cornell_points() -> Vec<ProbePoint> {
    let mut pts = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            let (u, v) = ((i as f64 + 0.5) / 8.0, (j as f64 + 0.5) / 8.0);
            let (x, z) = (20.0 + 510.0 * u, 20.0 + 520.0 * v);
            if !((0.0..320.0).contains(&x) && (40.0..300.0).contains(&z)) {
                pts.push(ProbePoint {
                    p: DVec3::new(x, 0.0, z),
                    n: DVec3::Y,
                });
            }
            pts.push(ProbePoint {
                p: DVec3::new(x, 20.0 + 510.0 * v, 559.2),
                n: -DVec3::Z,
            });
            if !((200.0..360.0).contains(&x) && (210.0..350.0).contains(&z)) {
                pts.push(ProbePoint {
                    p: DVec3::new(x, 548.8, z),
                    n: -DVec3::Y,
                });
            }
        }
    }
    pts
}

#[test]
fn a_finer_tolerance_on_moving_surfaces_refines_them_only() {
    // `recon_tol_moving` below `recon_tol` splits more cells on the sliding block and
    // not one more anywhere else: the room's cells and values are the same bit for
    // bit (the reconstruction does not feed back into the solve).
    let scene = sliding_block(-60.0, 0.8);
    let run = |moving: Option<f64>| {
        let o = SolveOptions {
            recon_tol_moving: moving,
            ..opts()
        };
        let (out, _) = run_frames(&scene, o.clone(), &st(5.0, 0.4));
        // The solve's patches (cut at contacts), for their objects.
        let t = SpaceTime::new(&scene, o, st(5.0, 0.4), |_, _| {}).unwrap();
        let moving: Vec<bool> = t
            .patches()
            .iter()
            .map(|p| scene.objects[p.object as usize].is_moving())
            .collect();
        let split = |on: bool| -> Vec<Leaf> {
            out.iter()
                .flat_map(|w| w.leaves.to_vec())
                .filter(|l| moving[l.patch as usize] == on)
                .collect()
        };
        (split(false), split(true))
    };
    let (room, block) = run(None);
    let (room_fine, block_fine) = run(Some(SolveOptions::default().recon_tol / 4.0));
    assert!(!block.is_empty() && !room.is_empty());
    assert_eq!(room_fine, room, "the room's cells do not change");
    assert!(
        block_fine.len() > block.len() * 3 / 2,
        "the block's cells: {} -> {}",
        block.len(),
        block_fine.len()
    );
}

/// Each frame of a space-time solve of `scene` (the sliding block's layout: windows
/// of 0.4 s at 5 fps, keyframes every 8 frames) against the static solve of that
/// frame at the same eps (0.5), both against a fine static solve (eps 0.1, another
/// seed: one that shares the coarse solve's rays flatters it), at the points
/// `pts(t)` of t = 0, 0.4 and 0.8 s: `(t, per-frame error, space-time error, the
/// two apart)`, relative RMS. Every frame is solved as the per-frame baseline
/// solves it (frozen).
fn frame_errors(scene: &Scene, pts: impl Fn(f64) -> Vec<ProbePoint>) -> Vec<(f64, f64, f64, f64)> {
    let fine = fine_references(scene, opts().seed ^ 1, &pts);
    frame_errors_seeded(scene, opts().seed, pts, &fine)
}

/// The instants [`frame_errors`] compares at.
const COMPARED: [f64; 3] = [0.0, 0.4, 0.8];

/// The static solve of `scene` frozen at `t` (as the per-frame baseline solves a
/// frame), at `eps` and `seed`, without the near field
/// (`SolveOptions::near_field`): a window's frames, whose points the frames
/// between interpolate, do not mend their final gathers from their own field, and
/// these tests hold space-time's windows (kept terms, frames between) to the
/// static solve of the same method. With it, the static solves moved off the
/// windows by the near field's own change (the moving block's faces 0.83% →
/// 1.91% apart from the per-frame solve at t = 0), not by anything windows do.
fn frozen_solve(scene: &Scene, eps: f64, seed: u64, t: f64) -> Solution {
    let o = SolveOptions {
        eps,
        seed,
        near_field: false,
        ..opts()
    };
    let mut s = Solver::at_time(scene, o, t, [0.0, 0.8]).unwrap();
    s.freeze_motion();
    s.run(|_, _| {}).unwrap();
    s.solution()
}

/// The reference of [`frame_errors_seeded`]: a fine static solve (eps 0.1) of
/// `scene` at `seed`, probed at `pts(t)` for each instant of [`COMPARED`]. Its
/// seed must differ from the coarse solves' (one that shares their rays flatters
/// them); one reference serves every coarse seed.
fn fine_references(
    scene: &Scene,
    seed: u64,
    pts: &impl Fn(f64) -> Vec<ProbePoint>,
) -> Vec<Vec<[f64; 3]>> {
    COMPARED
        .into_iter()
        .map(|t| probe(&frozen_solve(scene, 0.1, seed, t), &pts(t), t).unwrap())
        .collect()
}

/// [`frame_errors`] with the space-time and per-frame solves at `seed`, against
/// `fine` (from [`fine_references`] at another seed).
fn frame_errors_seeded(
    scene: &Scene,
    seed: u64,
    pts: impl Fn(f64) -> Vec<ProbePoint>,
    fine: &[Vec<[f64; 3]>],
) -> Vec<(f64, f64, f64, f64)> {
    let seeded = SolveOptions { seed, ..opts() };
    let windows = run_frames(scene, seeded.clone(), &st(5.0, 0.4)).0;
    assert_eq!(
        frame_instants(
            TimeDomain {
                start: 0.0,
                end: 0.8
            },
            5.0
        )
        .unwrap()
        .len(),
        5
    );
    assert_eq!(
        windows.len(),
        3,
        "2 frames per window: 0.0 0.2 | 0.4 0.6 | 0.8"
    );
    COMPARED
        .into_iter()
        .zip(fine)
        .map(|(t, fine)| {
            let pts = pts(t);
            let per_frame = probe(&frozen_solve(scene, 0.5, seed, t), &pts, t).unwrap();
            let space_time = probe(&st_solution(scene, seeded.clone(), &windows), &pts, t).unwrap();
            let (e_pf, e_st) = (
                relative_rms(&per_frame, fine),
                relative_rms(&space_time, fine),
            );
            let apart = relative_rms(&space_time, &per_frame);
            eprintln!(
                "t = {t}: per-frame {:.3}%, space-time {:.3}% from the fine solve; {:.3}% apart",
                e_pf * 100.0,
                e_st * 100.0,
                apart * 100.0
            );
            (t, e_pf, e_st, apart)
        })
        .collect()
}

/// The windows of a space-time solve of `scene` (at options `o`, the windows of
/// `st(5.0, 0.4)`) as one solution on the space-time solve's own patches, which
/// are those of a static solve at any time of the domain (contact meshing hides
/// pieces under moving objects where they stand at the start).
fn st_solution(scene: &Scene, o: SolveOptions, windows: &[WindowOutput]) -> Solution {
    let t = SpaceTime::new(scene, o, st(5.0, 0.4), |_, _| {}).unwrap();
    Solution {
        scene: scene.clone(),
        patches: t.patches().to_vec(),
        leaves: windows
            .iter()
            .flat_map(|w| w.leaves.iter().copied())
            .collect(),
        stats: SolveStats::default(),
    }
}

#[test]
fn each_frame_is_as_accurate_as_the_static_solve_of_that_frame() {
    // The tolerance is the per-frame solve's own discretisation error: against a fine
    // static solve of the same frame, space-time must be as close as the static
    // solve at the same eps (within 5%), on the room (`cornell_points`; the moving
    // block's own faces are
    // `the_moving_surfaces_are_as_accurate_as_in_the_static_solve_of_each_frame`).
    let scene = sliding_block(-60.0, 0.8);
    for (t, e_pf, e_st, apart) in frame_errors(&scene, |_| cornell_points()) {
        // Measured 0.94-0.97 times (1.68%/1.79%, 1.37%/1.40%, 1.39%/1.46%), 0.72-0.80%
        // apart; at b9da3ca 0.96, 1.04 and 0.98 times (1.94%/2.03%, 1.65%/1.58%,
        // 1.69%/1.72%), 0.69-0.83% apart. 1.08-1.16 times and 0.81-0.98% apart while a window's frames
        // stored their cells without the mean shift of the static solve's
        // (`Solver::mean_shifts`); not the gathers: a window's with no swept boxes
        // (no static masks, no cluster opened for the motion) read 1.62% for 1.63%.
        assert!(e_st <= 1.05 * e_pf, "t = {t}");
        assert!(apart < 0.01, "t = {t}");
    }
}

/// `k × k` points on each face of `scene`'s moving objects (bilinear in the face's
/// first, second and last vertex, inset from its edges), where the object is at `t`,
/// facing out of it.
fn moving_face_points(scene: &Scene, k: usize, t: f64) -> Vec<ProbePoint> {
    let mut out = Vec::new();
    for o in scene.objects.iter().filter(|o| o.is_moving()) {
        let to_world = o.to_world(t);
        for p in &o.polygons {
            let v = &p.vertices;
            let n = to_world.transform_vector3(p.normal()).normalize();
            for i in 0..k {
                for j in 0..k {
                    let (a, b) = ((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
                    // A triangle folds its upper half onto the lower.
                    let (a, b) = if v.len() == 3 && a + b > 1.0 {
                        (1.0 - a, 1.0 - b)
                    } else {
                        (a, b)
                    };
                    let last = v[v.len() - 1];
                    let local = if v.len() == 3 {
                        v[0] + a * (v[1] - v[0]) + b * (last - v[0])
                    } else {
                        v[0] + a * (v[1] - v[0])
                            + b * (last - v[0])
                            + a * b * (v[2] - v[1] - last + v[0])
                    };
                    out.push(ProbePoint {
                        p: to_world.transform_point3(local),
                        n,
                    });
                }
            }
        }
    }
    out
}

/// `scene` with every object's quads fanned into unequal triangles
/// ([`shapes::fan_quads`]): the tessellated twin of a scene of quads.
fn fanned(scene: &Scene) -> Scene {
    let mut out = scene.clone();
    for o in &mut out.objects {
        o.polygons = shapes::fan_quads(&o.polygons);
    }
    out
}

/// [`frame_errors_seeded`] at the faces of `scene`'s moving objects (4 × 4 points
/// each) at every seed of `seeds`, held to the static solve: at each frame the
/// mean error over the seeds as small within 5%, and at each seed apart by less
/// than the static solve's own error (the room's 1% of
/// `each_frame_is_as_accurate_as_the_static_solve_of_that_frame` is not a bound
/// here: the block's faces read 2.4% off the fine solve at t = 0, space-time
/// 2.0%, 1.4% apart).
///
/// Why a mean over seeds: on the triangles' faces the per-frame solve's own error
/// moves with the seed by more than the 5% bar (t = 0.8: 3.99%, 5.06%, 5.09% and
/// 5.54% at seeds 0x5eed, 1, 2, 3; main bc60554), and so does the ratio of the two
/// errors at one seed (0.98–1.10 there; 0.99–1.05 at t = 0.4, 1.01–1.05 at t = 0):
/// at one seed the bar measured the rays' luck, not the method. Over those four
/// seeds space-time was 1.027, 1.014 and 1.012 times the static solve. Every
/// seed is measured against one fine solve (at the default seed `^ 1`): the
/// reference's own noise is then common to the seeds, and the test solves it
/// three times, not nine.
fn moving_faces_as_accurate(name: &str, scene: &Scene, seeds: &[u64]) {
    eprintln!("{name}:");
    let pts = |t| moving_face_points(scene, 4, t);
    let fine = fine_references(scene, opts().seed ^ 1, &pts);
    let runs: Vec<_> = seeds
        .iter()
        .map(|&seed| frame_errors_seeded(scene, seed, pts, &fine))
        .collect();
    for (i, &(t, ..)) in runs[0].iter().enumerate() {
        let n = seeds.len() as f64;
        let e_pf = runs.iter().map(|r| r[i].1).sum::<f64>() / n;
        let e_st = runs.iter().map(|r| r[i].2).sum::<f64>() / n;
        eprintln!(
            "t = {t}: over {} seeds per-frame {:.3}%, space-time {:.3}% ({:.3} times)",
            seeds.len(),
            e_pf * 100.0,
            e_st * 100.0,
            e_st / e_pf
        );
        assert!(e_st <= 1.05 * e_pf, "{name}, t = {t}");
        for r in &runs {
            assert!(r[i].3 < r[i].1, "{name}, t = {t}");
        }
    }
}

#[test]
fn the_moving_surfaces_are_as_accurate_as_in_the_static_solve_of_each_frame() {
    // `each_frame_is_as_accurate_as_the_static_solve_of_that_frame` on the sliding
    // block's own faces (top and sides), which that test's room points leave out:
    // the light of a moving surface takes other paths in a window (its points
    // gather afresh from the shared hierarchy, with their direct light apart,
    // `Solver::direct_light`). Measured (b9da3ca): 0.84-0.96 times the static
    // solve's error (2.01%/2.41%, 1.37%/1.43%, 1.41%/1.54%), 0.41-1.43% apart.
    //
    // ACTOR's actors read 6.7% off the reference in space-time at `--eps 1` and
    // 3.8% in per-frame at `--eps 0.3`, but per-frame at `--eps 1` reads 7.1%: the
    // gap was the eps, 74-93% of it on the five probes of the actors' bottom
    // faces, 1 cm over the floor ("Space-time against frame by frame" in
    // BENCHMARKS.md); this test holds the two methods to each other at one eps.
    moving_faces_as_accurate("quads", &sliding_block(-60.0, 0.8), &[opts().seed]);
}

#[test]
fn the_moving_surfaces_are_as_accurate_as_in_the_static_solve_of_each_frame_in_triangles() {
    // The tessellated twin: the same scene with every quad in four triangles
    // (`fanned`), over three seeds (`moving_faces_as_accurate`: at one seed the
    // ratio moves 0.98-1.10 with the seed). Measured at the default seed (main
    // bc60554): 3.78%, 3.41% and 3.91% against the static solve's 3.61%, 3.26% and
    // 3.99% at t = 0, 0.4 and 0.8 s (1.045, 1.046 and 0.98 times), 0.58-0.76%
    // apart. At b9da3ca, 7.48% and 7.40% against 1.71% and
    // 1.62% at 0.4 and 0.8 s: contact meshing hid the floor's pieces under the
    // block where it stood at each solve's own time, so the space-time solve
    // (hidden at 0) and the static solve of the frame had other floors there,
    // and `rhier solve --per-frame` refused the scene ("expected the 88 patches
    // of frame 0, found 86"). Both now hide them where the block stands at the
    // start (`geometry::contact`, "Moving objects"), which leaves the floor under
    // where it started missing after it has left: the static solve's own error
    // at 0.4 s rose from 1.7% to 3.3% with it.
    let seeds = [opts().seed, 1, 2];
    moving_faces_as_accurate("triangles", &fanned(&sliding_block(-60.0, 0.8)), &seeds);
}

/// A `k × k` grid of upward points on the Cornell floor, leaving out the strip the
/// sliding block itself passes over (its shadow moves around it).
fn floor_around_block(k: usize) -> Vec<ProbePoint> {
    let mut out = Vec::new();
    for i in 0..k {
        for j in 0..k {
            let (x, z) = (
                10.0 + 530.0 * i as f64 / (k - 1) as f64,
                10.0 + 540.0 * j as f64 / (k - 1) as f64,
            );
            if !((10.0..300.0).contains(&x) && (55.0..285.0).contains(&z)) {
                out.push(ProbePoint {
                    p: DVec3::new(x, 0.0, z),
                    n: DVec3::Y,
                });
            }
        }
    }
    out
}

#[test]
fn the_moving_shadow_moves() {
    // Where the per-frame solves change most between the first and the last frame
    // (the floor the block's shadow leaves or reaches), the stored leaves follow.
    let scene = sliding_block(-60.0, 0.8);
    let windows = solve_all(&scene, &st(5.0, 0.4));
    let floor = floor_around_block(24);
    let fixed = |t: f64| {
        let mut s = Solver::at_time(&scene, opts(), t, [0.0, 0.8]).unwrap();
        s.run(|_, _| {}).unwrap();
        s.solution()
    };
    let (s0, s1) = (fixed(0.0), fixed(0.8));
    let r0 = probe(&s0, &floor, 0.0).unwrap();
    let r1 = probe(&s1, &floor, 0.8).unwrap();
    let sol = as_solution(&scene, &s0, &windows);
    let b0 = probe(&sol, &floor, 0.0).unwrap();
    let b1 = probe(&sol, &floor, 0.8).unwrap();
    let change = |a: [f64; 3], b: [f64; 3]| (a[0] - b[0]).abs() / a[0].max(b[0]);
    let k = (0..floor.len())
        .max_by(|&a, &b| change(r0[a], r1[a]).total_cmp(&change(r0[b], r1[b])))
        .unwrap();
    eprintln!(
        "at {:?}: per-frame {:?} → {:?}, space-time {:?} → {:?}",
        floor[k].p, r0[k], r1[k], b0[k], b1[k]
    );
    assert!(change(r0[k], r1[k]) > 0.2, "the shadow moves");
    // Measured 2026-11-29: 0.1% at 0 s, 7.4% at 0.8 s (under 5% before leaf rows
    // took a cluster's parts at their exact factors; the per-frame solve moved).
    let scale = r0[k][0].max(r1[k][0]);
    assert!((b0[k][0] - r0[k][0]).abs() < 0.05 * scale);
    assert!((b1[k][0] - r1[k][0]).abs() < 0.08 * scale);
}

#[test]
fn a_static_scene_makes_no_varying_link_and_equals_the_static_solve() {
    let scene = cornell_box(true);
    let mut varying = 0;
    let mut windows = Vec::new();
    spacetime::solve(
        &scene,
        opts(),
        &st(10.0, 0.2),
        |f| varying += f.varying_links,
        |w| {
            windows.push(w);
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(varying, 0);
    let mut s = Solver::new(&scene, opts()).unwrap();
    s.run(|_, _| {}).unwrap();
    let fixed = s.solution();
    // One window (the domain is one instant), every cell stored once.
    assert_eq!(windows.len(), 1);
    let leaves = &windows[0].leaves;
    assert_eq!(leaves.len(), fixed.leaves.len());
    let key = |l: &Leaf| (l.patch, l.uv.map(|c| c.map(f32::to_bits)));
    let mut a: Vec<&Leaf> = leaves.iter().collect();
    let mut b: Vec<&Leaf> = fixed.leaves.iter().collect();
    a.sort_by_key(|l| key(l));
    b.sort_by_key(|l| key(l));
    // Same cells and the same values: both paths end every solve at the fixed point
    // of the cluster sources' radiosity-dependent coefficients (`solve_rows`). Before
    // they did, the two stopped at different points of that iteration and differed
    // by up to 6.4e-4 relative (measured).
    let mut worst = 0.0f32;
    for (x, y) in a.iter().zip(&b) {
        assert_eq!((x.patch, x.uv), (y.patch, y.uv));
        for i in 0..x.corners as usize {
            for c in 0..3 {
                let d = (x.b[i][c] - y.b[i][c]).abs() / y.b[i][c].abs().max(1e-3);
                worst = worst.max(d);
                assert!(d <= 1e-6, "{x:?} vs {y:?}");
            }
        }
    }
    eprintln!("largest relative difference {worst:e}");
}

/// Two closed rooms side by side, each lit by a ceiling lamp; a cube slides inside
/// the first. Nothing in the second room can change.
fn two_rooms() -> Scene {
    use rhier::scene::{Material, MaterialId, Object, Polygon, TimeDomain};
    let white = Material::diffuse("white", [0.7, 0.7, 0.7]);
    let lamp = Material {
        name: "lamp".into(),
        rho: [0.5, 0.5, 0.5],
        emission: [10.0, 10.0, 10.0],
    };
    // Inward-facing box [lo, hi]: 6 quads and a lamp facing down.
    let room = |name: &str, lo: DVec3, hi: DVec3| {
        let c = |x: usize, y: usize, z: usize| {
            DVec3::new(
                if x == 0 { lo.x } else { hi.x },
                if y == 0 { lo.y } else { hi.y },
                if z == 0 { lo.z } else { hi.z },
            )
        };
        // The corner lists below run clockwise seen from inside: reversed here.
        let q = |v: [DVec3; 4], m: u32| Polygon {
            vertices: v.iter().rev().copied().collect(),
            material: MaterialId(m),
        };
        let mid = (lo + hi) * 0.5;
        let lamp_quad = [
            DVec3::new(mid.x - 0.2, hi.y - 1e-3, mid.z - 0.2),
            DVec3::new(mid.x - 0.2, hi.y - 1e-3, mid.z + 0.2),
            DVec3::new(mid.x + 0.2, hi.y - 1e-3, mid.z + 0.2),
            DVec3::new(mid.x + 0.2, hi.y - 1e-3, mid.z - 0.2),
        ];
        Object::still(
            name,
            vec![
                q([c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], 0),
                q([c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)], 0),
                q([c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], 0),
                q([c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)], 0),
                q([c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)], 0),
                q([c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], 0),
                q(lamp_quad, 1),
            ],
        )
    };
    let a = room("room_a", DVec3::ZERO, DVec3::new(2.0, 2.0, 2.0));
    let b = room(
        "room_b",
        DVec3::new(3.0, 0.0, 0.0),
        DVec3::new(5.0, 2.0, 2.0),
    );
    // An outward-facing cube of side 0.4 resting 1 cm above room A's floor.
    let (lo, hi) = (DVec3::new(0.3, 0.01, 0.8), DVec3::new(0.7, 0.41, 1.2));
    let c = |x: usize, y: usize, z: usize| {
        DVec3::new(
            if x == 0 { lo.x } else { hi.x },
            if y == 0 { lo.y } else { hi.y },
            if z == 0 { lo.z } else { hi.z },
        )
    };
    let q = |v: [DVec3; 4]| Polygon {
        vertices: v.iter().rev().copied().collect(),
        material: MaterialId(0),
    };
    let cube = Object {
        name: "cube".into(),
        polygons: vec![
            q([c(0, 0, 0), c(0, 0, 1), c(1, 0, 1), c(1, 0, 0)]),
            q([c(0, 1, 0), c(1, 1, 0), c(1, 1, 1), c(0, 1, 1)]),
            q([c(0, 0, 0), c(0, 1, 0), c(0, 1, 1), c(0, 0, 1)]),
            q([c(1, 0, 0), c(1, 0, 1), c(1, 1, 1), c(1, 1, 0)]),
            q([c(0, 0, 0), c(1, 0, 0), c(1, 1, 0), c(0, 1, 0)]),
            q([c(0, 0, 1), c(0, 1, 1), c(1, 1, 1), c(1, 0, 1)]),
        ],
        motion: Some(MotionTrack {
            keys: vec![key(0.0, 0.0), key(1.0, 0.9)],
        }),
    };
    Scene {
        time: TimeDomain {
            start: 0.0,
            end: 1.0,
        },
        materials: vec![white, lamp],
        objects: vec![a, b, cube],
        ..Scene::default()
    }
}

#[test]
fn where_nothing_changes_consecutive_frames_are_one_leaf() {
    let scene = two_rooms();
    let windows = solve_all(&scene, &st(10.0, 0.5));
    // 11 frames, windows of 5: the one-frame tail joins the second window.
    assert_eq!(windows.len(), 2);
    // The solver's patches by object: room A is object 0, room B object 1 (each
    // ceiling cut around its lamp by contact meshing).
    let objects = Solver::new(&scene, opts()).unwrap().patches.objects.clone();
    let room = |l: &Leaf| objects[l.patch as usize];
    let mut in_b = 0;
    for w in &windows {
        for l in w.leaves.iter() {
            if room(l) == 1 {
                in_b += 1;
                assert_eq!(
                    (l.time[0] as f64, l.time[1] as f64),
                    (w.t0 as f32 as f64, w.t1 as f32 as f64),
                    "a leaf of the static room holds over its whole window: {l:?}"
                );
            }
        }
    }
    assert!(in_b > 0);
    // And room A does change: some of its leaves are shorter than their window.
    let short = windows
        .iter()
        .flat_map(|w| w.leaves.iter().map(move |l| (w, l)))
        .filter(|(w, l)| room(l) == 0 && (l.time[1] - l.time[0]) < (w.t1 - w.t0) as f32 - 1e-6)
        .count();
    assert!(short > 0);
}

#[test]
fn the_shared_part_gathers_light_when_every_first_link_varies() {
    // In `cornell_moving.json` the block slides through the middle of the box, so the
    // swept box meets the root cluster and every first-level cluster link varies.
    // The shared part must still open them (they have no estimate), or its first
    // round gathers nothing, `B_ref` is 0 and every constant link splits down to the
    // minimum area (a regression once took this scene to millions of links).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/formats/examples/cornell_moving.json"
    );
    let scene = rhier::scene::load(std::path::Path::new(path)).unwrap();
    let mut fixed = Solver::at_time(&scene, opts(), 0.0, [0.0, 0.0]).unwrap();
    let rounds = fixed.run(|_, _| {}).unwrap();
    let static_elems = rounds.last().unwrap().elements;
    let static_scale = fixed.radiosity_scale();
    let run = SpaceTime::new(&scene, opts(), st(4.0, 0.5), |_, _| {}).unwrap();
    let shared = &run.stats;
    assert!(
        shared.shared_elements <= 2 * static_elems,
        "shared part {} elements, static solve at t = 0 {static_elems}",
        shared.shared_elements
    );
    let ratio = shared.b_ref / static_scale;
    assert!(
        (0.5..2.0).contains(&ratio),
        "shared B_ref {} against the static solve's {static_scale}",
        shared.b_ref
    );
}

#[test]
fn a_window_depends_on_no_other() {
    // What makes shards and resume exact: a run that solves window 2 alone, or
    // windows 3 and 4 alone, writes what the full run wrote for them, bit for bit
    // (each window starts from the shared part and an empty cache of terms; when
    // windows handed their terms on, a shard's first window differed by up to
    // 0.7% at a frame, BENCHMARKS.md "Farm").
    let scene = sliding_block(-60.0, 0.8);
    let o = st(5.0, 0.2);
    let mut full = SpaceTime::new(&scene, opts(), o, |_, _| {}).unwrap();
    assert_eq!(full.window_count(), 5);
    let windows: Vec<_> = (0..5)
        .map(|w| full.solve_window(w, |_| {}).unwrap())
        .collect();
    let mut alone = SpaceTime::new(&scene, opts(), o, |_, _| {}).unwrap();
    assert_eq!(alone.solve_window(2, |_| {}).unwrap(), windows[2]);
    let mut later = SpaceTime::new(&scene, opts(), o, |_, _| {}).unwrap();
    assert_eq!(later.solve_window(3, |_| {}).unwrap(), windows[3]);
    assert_eq!(later.solve_window(4, |_| {}).unwrap(), windows[4]);
    assert!(windows.iter().all(|w| w.leaves.len() > 100));
}

#[test]
fn a_budget_on_kept_terms_bounds_them_and_keeps_the_result() {
    // Bounding what a window keeps (down to nothing) changes where the work goes,
    // not what is computed: a kept term was gathered at an earlier frame of the
    // window, a dropped one is gathered again, with the same rays. The only
    // difference is a source the frame has opened into finer children than when
    // the term was kept.
    let scene = sliding_block(-60.0, 0.8);
    let window = |budget: Option<u64>| {
        let o = SpaceTimeOptions {
            kept_budget: budget,
            ..st(5.0, 0.4)
        };
        let mut run = SpaceTime::new(&scene, opts(), o, |_, _| {}).unwrap();
        let mut frames = Vec::new();
        let w = run.solve_window(1, |f| frames.push(*f)).unwrap();
        let sol = Solution {
            scene: scene.clone(),
            patches: run.patches().to_vec(),
            leaves: w.leaves.to_vec(),
            stats: SolveStats::default(),
        };
        let most = frames.iter().map(|f| f.bytes_kept).max().unwrap();
        (sol, most)
    };
    let (free, kept) = window(None);
    assert!(kept > 10_000, "the window keeps terms: {kept} bytes");
    let pts = cornell_points();
    for budget in [0, kept / 3] {
        let (bounded, most) = window(Some(budget));
        // The collector holds the bound up to one frame's admissions.
        assert!(most < kept, "budget {budget}: kept {most} of {kept}");
        if budget == 0 {
            assert_eq!(most, 0);
        }
        for t in [0.4, 0.6] {
            let a = probe(&free, &pts, t).unwrap();
            let b = probe(&bounded, &pts, t).unwrap();
            let apart = relative_rms(&b, &a);
            eprintln!("budget {budget}, t = {t}: {:.4}% apart", apart * 100.0);
            assert!(apart < 0.002, "budget {budget}, t = {t}: {apart}");
        }
    }
}

#[test]
fn a_window_on_mapped_storage_is_the_one_in_ram() {
    // The pools, the kept final-gather terms and the window's leaves live in
    // scratch files and their pages are handed back after every batch of gathers
    // (out of core): the leaves are bit for bit those of the RAM run, and no
    // scratch file outlives what it holds.
    let scene = sliding_block(-60.0, 0.8);
    let dir = tempfile::tempdir().unwrap();
    let mapped = SolveOptions {
        storage: rhier::pools::Storage::Mmap(dir.path().to_path_buf()),
        ..opts()
    };
    let window = |o: SolveOptions| {
        let mut run = SpaceTime::new(&scene, o, st(5.0, 0.4), |_, _| {}).unwrap();
        let mut kept = 0;
        let w = run
            .solve_window(1, |f| kept = kept.max(f.bytes_kept))
            .unwrap();
        (w, kept)
    };
    let ram = SolveOptions {
        storage: rhier::pools::Storage::Ram,
        ..opts()
    };
    let (ram, kept) = window(ram);
    assert!(kept > 10_000, "the window keeps terms: {kept} bytes");
    let (on_disk, kept_mapped) = window(mapped);
    assert!(on_disk.leaves.is_mapped() && !ram.leaves.is_mapped());
    assert_eq!(on_disk, ram);
    // The same terms: RAM counts its arenas' capacity, a mapped file their length.
    assert!(
        kept_mapped <= kept && 5 * kept_mapped >= 4 * kept,
        "mapped {kept_mapped}, RAM {kept}"
    );
    // Scratch files are unlinked as they are made (Unix): the directory shows none
    // while the leaves live, and none after (elsewhere the leaves' file goes with
    // them).
    let live = if cfg!(unix) { 0 } else { 1 };
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), live);
    drop(on_disk);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Brute force over `[t0, t1]`: visibility between 16 pairs of points of every two
/// static patches of `scene`, sampled at 48 times with the moving objects placed at
/// each; whenever it changes, the shaft between the patches must meet a swept box.
/// Returns `(pairs, pairs whose visibility changes, pairs flagged varying)`.
fn swept_boxes_against_time_sampling(scene: &Scene, t0: f64, t1: f64) -> (u32, u32, u32) {
    let patches = Patches::at_time(scene, t0);
    let swept = swept_boxes(scene, t0, t1);
    let moving: Vec<bool> = (0..patches.len())
        .map(|i| scene.objects[patches.objects[i] as usize].is_moving())
        .collect();
    let mut bvh = SceneBvh::build(scene, &patches, t0);
    let stat: Vec<usize> = (0..patches.len()).filter(|&i| !moving[i]).collect();
    let times: Vec<f64> = (0..48).map(|k| t0 + (t1 - t0) * k as f64 / 47.0).collect();
    let (mut changed, mut flagged, mut pairs) = (0, 0, 0);
    for (ai, &a) in stat.iter().enumerate() {
        for &b in &stat[ai + 1..] {
            let (pa, pb) = (&patches.polys[a], &patches.polys[b]);
            let shaft = Shaft::new(
                pa.corners(),
                patches.normals[a],
                pb.corners(),
                patches.normals[b],
            );
            let varying = swept.iter().any(|&(lo, hi)| !shaft.misses_box(lo, hi));
            let mut seen: Option<Vec<bool>> = None;
            let mut changes = false;
            for &t in &times {
                bvh.place(scene, t);
                let mut vis = Vec::new();
                for i in 0..4 {
                    for j in 0..4 {
                        let x = patches.point(a, (i as f64 + 0.5) / 4.0, (j as f64 + 0.37) / 4.0);
                        let y = patches.point(b, (j as f64 + 0.61) / 4.0, (i as f64 + 0.5) / 4.0);
                        vis.push(bvh.occluded_except(x, y, [a as u32, b as u32]));
                    }
                }
                if let Some(prev) = &seen {
                    changes |= *prev != vis;
                }
                seen = Some(vis);
            }
            pairs += 1;
            changed += changes as u32;
            flagged += varying as u32;
            assert!(
                !changes || varying,
                "patches {a} and {b} over [{t0}, {t1}]: visibility changes over time but the shaft misses every swept box"
            );
        }
    }
    (pairs, changed, flagged)
}

#[test]
fn swept_shafts_catch_every_transient_blocker_that_time_sampling_sees() {
    let scene = sliding_block(-200.0, 1.0);
    assert_eq!(swept_boxes(&scene, 0.0, 1.0).len(), 1);
    let (pairs, changed, flagged) = swept_boxes_against_time_sampling(&scene, 0.0, 1.0);
    eprintln!("{pairs} pairs: {changed} change over time, {flagged} flagged varying");
    assert!(changed > 0, "the sliding block must block something");
    // The swept box is conservative but not everything.
    assert!(flagged < pairs);
}

#[test]
fn swept_shafts_catch_every_transient_blocker_of_actor_and_light() {
    // The paper's scenes (their room's patches, not cut): the actors walking and the
    // board sliding, over a one-second window and over an 8-frame window
    // (`benches/transient.rs` measures the same on finer cells against the paper's
    // time sampling).
    for name in ["actor", "light"] {
        let scene = rhier::scene::builtin(name).unwrap();
        for (t0, t1) in [(1.0, 2.0), (0.4, 0.72)] {
            let (pairs, changed, flagged) = swept_boxes_against_time_sampling(&scene, t0, t1);
            eprintln!("{name} [{t0}, {t1}]: {pairs} pairs, {changed} change, {flagged} flagged");
            assert!(
                changed > 10,
                "{name}: the moving objects must change some visibility"
            );
            assert!(
                flagged < pairs,
                "{name}: the swept boxes must leave some pairs constant"
            );
        }
    }
}

#[test]
fn static_masks_plus_moving_rays_equal_full_visibility() {
    // What lets a window keep the static half of every ray: for any point, source and
    // time, the visible fraction from a static mask and rays against the moving
    // objects only is exactly the fraction from full rays; so is the one-pass
    // `masked_rays`, and `visible_fraction_moving` from a kept static visibility.
    use rhier::oracle::{
        PointRays, masked_rays, static_clear_mask, visible_fraction, visible_fraction_masked,
        visible_fraction_moving,
    };
    use rhier::pools::elements::Geom;
    let scene = sliding_block(-200.0, 1.0);
    let patches = Patches::at_time(&scene, 0.0);
    let mut bvh = SceneBvh::build(&scene, &patches, 0.0);
    let stat: Vec<usize> = (0..patches.len())
        .filter(|&i| !scene.objects[patches.objects[i] as usize].is_moving())
        .collect();
    let geom = |i: usize| {
        let p = &patches.polys[i];
        let mut corners = [[0.0; 3]; 4];
        for (c, v) in corners.iter_mut().zip(p.corners()) {
            *c = v.to_array();
        }
        Geom {
            corners,
            normal: patches.normals[i].to_array(),
            area: patches.areas[i],
            uv: [[0.0; 2]; 4],
            patch: i as u32,
            n: p.corners().len() as u32,
        }
    };
    let (mut compared, mut partial, mut blocked) = (0, 0, 0);
    for (k, t) in [0.0, 0.3, 0.7, 1.0].into_iter().enumerate() {
        bvh.place(&scene, t);
        for &a in &stat {
            for &b in &stat {
                if a == b {
                    continue;
                }
                let gb = geom(b);
                let pb = rhier::oracle::poly(&gb);
                let x = patches.point(a, 0.37, 0.41);
                let (na, nb) = (patches.normals[a], patches.normals[b]);
                let r = PointRays {
                    x,
                    n: na,
                    gs: &gb,
                    pols: &pb,
                    ns: nb,
                    m: 32,
                    key: (k * 1000 + a * 31 + b) as u64,
                    skip: [a as u32, b as u32],
                };
                let full = visible_fraction(&bvh, &r);
                let mask = static_clear_mask(&bvh, &r);
                let split = visible_fraction_masked(Some(&bvh), &r, mask);
                assert_eq!(full.to_bits(), split.to_bits(), "t {t}, patches {a} → {b}");
                // The same in one pass, and from a kept static visibility.
                let rays = masked_rays(&bvh, &r, None, true);
                assert_eq!(rays.mask, mask, "t {t}, patches {a} → {b}");
                assert_eq!(rays.vis_now.to_bits(), full.to_bits());
                let alone = visible_fraction_masked(None, &r, mask);
                assert_eq!(rays.vis_static.to_bits(), alone.to_bits());
                let known = masked_rays(&bvh, &r, Some(mask), true);
                assert_eq!(known, rays);
                let kept = visible_fraction_moving(&bvh, &r, mask, alone);
                assert_eq!(kept.to_bits(), full.to_bits());
                blocked += (rays.blocked != 0) as u32;
                compared += 1;
                partial += (full > 0.0 && full < 1.0) as u32;
            }
        }
    }
    assert!(
        compared > 500 && partial > 20 && blocked > 20,
        "{compared} pairs, {partial} partly visible, {blocked} with rays the block stops"
    );
}

/// One window of 9 frames (fps 10 over 0.8 s) solved with keyframes every `stride`
/// frames, every frame between tested by `interp_tol` (`interp_motion` 0; the tests
/// of `interp_motion` set it): its leaves and every frame's record. A frame between
/// skips its leaf solve only where the moving power holds within 1%
/// ([`SOLVED_MIDPOINTS`]).
fn keyed_run(scene: &Scene, stride: u32) -> (Vec<WindowOutput>, Vec<spacetime::FrameRecord>) {
    let o = SpaceTimeOptions {
        key_stride: Some(stride),
        interp_motion: 0.0,
        moving_power_tol: SOLVED_MIDPOINTS,
        ..st(10.0, 0.8)
    };
    run_frames(scene, opts(), &o)
}

/// A `moving_power_tol` under the 1.8–2.2% of its power by which the block of
/// `sliding_block(-60.0, 0.8)` changes the light it hands on between keyframes four
/// frames (0.4 s) apart (measured), so the frames between them solve their leaf
/// system: what the tests of those frames' leaf rows need. The default (3%) lets
/// them skip it (`midpoints_skip_their_solve_where_the_moving_power_holds`).
const SOLVED_MIDPOINTS: f64 = 0.01;

/// The windows of each of `runs`, solves of a sliding-block scene, as one solution
/// each, on the patches of [`sliding_base`].
fn sliding_solutions<const N: usize>(scene: &Scene, runs: [&[WindowOutput]; N]) -> [Solution; N] {
    let base = sliding_base(scene);
    runs.map(|windows| as_solution(scene, &base, windows))
}

/// A static solve of a sliding-block scene at its start (for its patches).
fn sliding_base(scene: &Scene) -> Solution {
    let mut s = Solver::at_time(scene, opts(), 0.0, [0.0, 0.8]).unwrap();
    s.run(|_, _| {}).unwrap();
    s.solution()
}

/// The Cornell probe points and the floor around the block, where its shadow moves.
fn sliding_points() -> Vec<ProbePoint> {
    let mut pts = cornell_points();
    pts.extend(floor_around_block(16));
    pts
}

/// A fine static solve (`eps` 0.1) of a sliding-block scene at `t`, probed at `pts`.
fn fine_probe(scene: &Scene, pts: &[ProbePoint], t: f64) -> Vec<[f64; 3]> {
    let o = SolveOptions { eps: 0.1, ..opts() };
    let mut s = Solver::at_time(scene, o, t, [0.0, 0.8]).unwrap();
    s.run(|_, _| {}).unwrap();
    probe(&s.solution(), pts, t).unwrap()
}

/// The sliding-block solutions `sols` and [`fine_probe`]'s fine static solve at
/// `t`, probed at `pts`: `(fine, [each solution's values])`.
fn probes_at<const N: usize>(
    scene: &Scene,
    pts: &[ProbePoint],
    sols: [&Solution; N],
    t: f64,
) -> (Vec<[f64; 3]>, [Vec<[f64; 3]>; N]) {
    let fine = fine_probe(scene, pts, t);
    (fine, sols.map(|s| probe(s, pts, t).unwrap()))
}

#[test]
fn frames_between_keyframes_are_as_accurate_as_gathered_frames() {
    // One window of 9 frames (fps 10 over 0.8 s), keyframes 0, 4 and 8: the frames
    // between take interpolated values where the keyframes allow it and gather the
    // rest (the floor the block's shadow crosses). Against a fine static solve of
    // each frame, they must be as close as the same frames gathered everywhere.
    let scene = sliding_block(-60.0, 0.8);
    let (every, every_frames) = keyed_run(&scene, 1);
    let (keyed, keyed_frames) = keyed_run(&scene, 4);
    assert_eq!((every.len(), keyed.len()), (1, 1));
    assert!(every_frames.iter().all(|f| f.interpolated == 0));
    let between = |f: &&spacetime::FrameRecord| f.frame % 4 != 0;
    for f in keyed_frames.iter().filter(|f| !between(f)) {
        assert_eq!(f.interpolated, 0, "keyframe {}", f.frame);
    }
    // The block's faces change the light they hand on by more than 1% of the
    // block's power between keyframes (measured), so the midpoint of each interval
    // (frames 2 and 6, solved first by the bisection) solves its leaf system (its
    // varying links are re-evaluated); the quarter frames then lie between solved
    // frames two apart.
    let solved: Vec<u32> = keyed_frames
        .iter()
        .filter(|f| f.varying_links > 0)
        .map(|f| f.frame)
        .collect();
    eprintln!("solved frames: {solved:?}");
    assert!(solved.contains(&2) && solved.contains(&6), "{solved:?}");
    let interpolated: u64 = keyed_frames
        .iter()
        .filter(between)
        .map(|f| f.interpolated)
        .sum();
    let gathered: u64 = keyed_frames
        .iter()
        .filter(between)
        .map(|f| f.gathered)
        .sum();
    eprintln!("between keyframes: {interpolated} points interpolated, {gathered} gathered");
    assert!(
        interpolated > gathered,
        "most points hold between keyframes"
    );
    // The floor the block's shadow crosses is gathered (13% of the points with the
    // bisection, 16% when each frame between looked at the keyframes alone;
    // interpolating every point the keyframes share would gather 0.2%).
    assert!(
        gathered * 20 > interpolated,
        "the moving shadow is gathered"
    );
    let [every, keyed] = sliding_solutions(&scene, [&every, &keyed]);
    let pts = sliding_points();
    for t in [0.1, 0.3, 0.5, 0.6] {
        let (fine, [a, b]) = probes_at(&scene, &pts, [&every, &keyed], t);
        let (e_every, e_keyed) = (relative_rms(&a, &fine), relative_rms(&b, &fine));
        let apart = relative_rms(&b, &a);
        let scale = a.iter().map(|v| v[0]).fold(0.0, f64::max);
        let worst = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x[0] - y[0]).abs() / scale)
            .fold(0.0, f64::max);
        eprintln!(
            "t = {t}: gathered {:.3}%, keyed {:.3}% from the fine solve; {:.3}% apart, worst point {:.2}% of the brightest",
            e_every * 100.0,
            e_keyed * 100.0,
            apart * 100.0,
            worst * 100.0
        );
        // Each interpolated point is within `interp_tol` (1% of B_ref) of agreeing
        // or linear solved frames. Measured: 0.17–0.35% apart, worst point 0.8–1.9%
        // (0.18–0.27% and 0.9–1.8% when each frame between looked at the keyframes
        // alone); interpolating every point both keyframes hold instead: 0.47–0.99%
        // apart, worst point 1.4–5.3%. With leaf rows taking a cluster's parts at
        // their exact factors (2026-11-29): 0.42% apart, worst point 3.24% at 0.1 s.
        assert!(apart < 0.005, "t = {t}: {apart}");
        assert!(worst < 0.035, "t = {t}: worst point {worst}");
        assert!(e_keyed <= 1.1 * e_every + 1e-3, "t = {t}");
    }
}

#[test]
fn midpoints_skip_their_solve_where_the_moving_power_holds() {
    // The block of `sliding_block(-60.0, 0.8)` changes the light it hands on by
    // 1.8–2.2% of its power between keyframes 0.4 s apart: under the default
    // `moving_power_tol` (3%) the midpoints (frames 2 and 6) skip their leaf solve
    // and take the radiosity of what every frame shares on the line between the
    // keyframes. Their gathers must be as close to a fine static solve of each
    // frame as with the midpoints solved. The block moved four times as fast
    // changes it by more than 3%, and its midpoints solve at the default too.

    // The frames that solved their leaf system, in frame order.
    let solved_at = |frames: &[spacetime::FrameRecord]| -> Vec<u32> {
        let mut solved: Vec<u32> = frames
            .iter()
            .filter(|f| f.varying_links > 0)
            .map(|f| f.frame)
            .collect();
        solved.sort_unstable();
        solved
    };
    let default_run = |scene: &Scene| {
        let o = SpaceTimeOptions {
            key_stride: Some(4),
            interp_motion: 0.0,
            ..st(10.0, 0.8)
        };
        run_frames(scene, opts(), &o)
    };
    let fast = sliding_block(-240.0, 0.8);
    let fast_solved = solved_at(&default_run(&fast).1);
    assert!(
        fast_solved.contains(&2) && fast_solved.contains(&6),
        "{fast_solved:?}"
    );
    let scene = sliding_block(-60.0, 0.8);
    let (solved, solved_frames) = keyed_run(&scene, 4);
    let (skipped, skipped_frames) = default_run(&scene);
    let midpoints_solved = solved_at(&solved_frames);
    assert!(
        midpoints_solved.contains(&2) && midpoints_solved.contains(&6),
        "{midpoints_solved:?}"
    );
    assert_eq!(solved_at(&skipped_frames), [0, 4, 8]);
    let [solved, skipped] = sliding_solutions(&scene, [&solved, &skipped]);
    let pts = sliding_points();
    for t in [0.1, 0.2, 0.3, 0.6] {
        let (fine, [a, b]) = probes_at(&scene, &pts, [&solved, &skipped], t);
        let (e_solved, e_skipped) = (relative_rms(&a, &fine), relative_rms(&b, &fine));
        let apart = relative_rms(&b, &a);
        eprintln!(
            "t = {t}: from the fine solve, midpoints solved {:.3}%, skipped {:.3}%; {:.3}% apart",
            e_solved * 100.0,
            e_skipped * 100.0,
            apart * 100.0
        );
        // Measured: skipped 1.82–1.92% where solved gives 1.81–1.91%, 0.03–0.26%
        // apart, the most at the skipped midpoint itself (t = 0.2: 0.247% before
        // each child of an opened source took its own rays' visibility, 0.263%
        // since; the two runs' errors from the fine solve stay within 0.011% of
        // each other). The fast block's midpoints skipped against solved (a
        // tolerance of 10) are 0.32–1.51% apart, 2.38–2.89% from the fine solve
        // against 2.35–2.37% (5.27% and 5.30% at 0.6 s).
        assert!(e_skipped <= 1.05 * e_solved + 5e-4, "t = {t}");
        assert!(apart < 0.003, "t = {t}: {apart}");
    }
}

#[test]
fn frames_between_keyframes_skip_the_solve_where_moving_light_holds() {
    // The short block creeps 6 mm over 0.8 s: its faces hand on the same light at
    // every keyframe, so the frames between them skip the leaf solve and gather
    // from the keyframe's hierarchy with interpolated radiosity. They must match
    // the same frames solved and gathered everywhere.
    let scene = sliding_block(-6.0, 0.8);
    let (every, _) = keyed_run(&scene, 1);
    let (keyed, keyed_frames) = keyed_run(&scene, 4);
    let skipped: Vec<u32> = keyed_frames
        .iter()
        .filter(|f| f.varying_links == 0)
        .map(|f| f.frame)
        .collect();
    assert_eq!(skipped.len(), 6, "frames without a solve: {skipped:?}");
    assert!(skipped.iter().all(|f| f % 4 != 0), "keyframes are solved");
    let gathered: u64 = keyed_frames
        .iter()
        .filter(|f| f.frame % 4 != 0)
        .map(|f| f.gathered)
        .sum();
    assert!(gathered > 0, "some points are gathered without a solve");
    let [every, keyed] = sliding_solutions(&scene, [&every, &keyed]);
    let pts = cornell_points();
    for t in [0.1, 0.3, 0.5, 0.7] {
        let a = probe(&every, &pts, t).unwrap();
        let b = probe(&keyed, &pts, t).unwrap();
        let apart = relative_rms(&b, &a);
        eprintln!(
            "t = {t}: {:.3}% apart, {gathered} points gathered between keyframes",
            apart * 100.0
        );
        assert!(apart < 0.005, "t = {t}: {apart}");
    }
}

#[test]
fn frames_closer_in_motion_than_interp_motion_take_the_line() {
    // The block slides 60 mm in 0.8 s: 0.78% of the box's diameter a frame at
    // 10 fps. Keyframes 0, 4 and 8; the midpoints 2 and 6 lie between brackets 3.1%
    // apart in motion, the quarter frames between brackets 1.56% apart.
    let scene = sliding_block(-60.0, 0.8);
    let diameter = Solver::at_time(&scene, opts(), 0.0, [0.0, 0.8])
        .unwrap()
        .patches
        .diameter;
    let motion = spacetime::frame_motion(
        &scene,
        &frame_instants(
            TimeDomain {
                start: 0.0,
                end: 0.8,
            },
            10.0,
        )
        .unwrap(),
        diameter,
    );
    let two = motion[0] + motion[1];
    assert!((two - 0.0156).abs() < 1e-3, "{two}");
    let keyed = |fps: f64, stride: u32, interp_motion: f64| {
        let o = SpaceTimeOptions {
            key_stride: Some(stride),
            interp_motion,
            moving_power_tol: SOLVED_MIDPOINTS,
            ..st(fps, 0.8)
        };
        run_frames(&scene, opts(), &o)
    };
    // Just above two frames' travel: the quarter frames are free.
    let (every, _) = keyed_run(&scene, 1);
    let (tested, tested_frames) = keyed_run(&scene, 4);
    let (free, free_frames) = keyed(10.0, 4, two * 1.01);
    for (a, b) in tested_frames.iter().zip(&free_frames) {
        assert_eq!(a.frame, b.frame);
        if b.frame % 2 == 1 {
            // Measured: 4–6 points gathered (cells the brackets lack) against
            // 397–703, and no leaf solve (frames 5 and 7 solve when tested).
            assert_eq!(b.varying_links, 0, "free frame {} skips its solve", b.frame);
            assert!(
                b.gathered * 20 < a.gathered,
                "frame {}: {} gathered free, {} tested",
                b.frame,
                b.gathered,
                a.gathered
            );
        } else {
            // Keyframes and midpoints are solved and tested as without.
            assert!(b.varying_links > 0, "frame {} is solved", b.frame);
        }
    }
    let [every, tested, free] = sliding_solutions(&scene, [&every, &tested, &free]);
    let pts = sliding_points();
    for t in [0.1, 0.3, 0.5, 0.7] {
        let (fine, [a, b, c]) = probes_at(&scene, &pts, [&every, &tested, &free], t);
        let (e_every, e_tested, e_free) = (
            relative_rms(&a, &fine),
            relative_rms(&b, &fine),
            relative_rms(&c, &fine),
        );
        let apart = relative_rms(&c, &a);
        eprintln!(
            "t = {t}: from the fine solve, every frame gathered {:.3}%, tested {:.3}%, free {:.3}%; free {:.3}% from every frame gathered",
            e_every * 100.0,
            e_tested * 100.0,
            e_free * 100.0,
            apart * 100.0
        );
        // Measured: free 2.28–2.51% where every frame gathered gives 2.28–2.50%,
        // 0.32–0.85% apart (the block's shadow edge fades over one interval).
        assert!(e_free <= 1.1 * e_every + 1e-3, "t = {t}");
        assert!(apart < 0.015, "t = {t}: {apart}");
    }
    // The same motion over twice the frames (keyframes at the same times): with
    // the default, the frames it adds lie between brackets 0.78% apart and take
    // the line, and it gathers as many points as at 10 fps (measured 15 839
    // against 15 797 at the default 0.03, whose quarter frames at 10 fps are free
    // as well; 18 555 against 18 529 at 0.015); tested, it gathers 19% more.
    let sum =
        |frames: &[spacetime::FrameRecord]| -> u64 { frames.iter().map(|f| f.gathered).sum() };
    let gathered = |fps: f64, stride: u32, im: f64| sum(&keyed(fps, stride, im).1);
    let im = SpaceTimeOptions::default().interp_motion;
    let (g10, g20) = (gathered(10.0, 4, im), gathered(20.0, 8, im));
    let (t10, t20) = (sum(&tested_frames), gathered(20.0, 8, 0.0));
    eprintln!("points gathered at 10 and 20 fps: {g10} and {g20} (tested: {t10} and {t20})");
    assert!(g20 * 100 < g10 * 105, "{g20} against {g10}");
    assert!(t20 * 100 > t10 * 110, "{t20} against {t10}");
}

/// `tests/data/hung_box_room.json` with its box (hung 1 cm over the floor) sliding
/// 0.5 m along x over `[0, 0.8]` s.
fn sliding_hung_box() -> Scene {
    let mut scene =
        rhier::scene::load(std::path::Path::new("tests/data/hung_box_room.json")).unwrap();
    scene.time.start = 0.0;
    scene.time.end = 0.8;
    let b = scene.objects.iter_mut().find(|o| o.name == "box").unwrap();
    b.motion = Some(MotionTrack {
        keys: vec![key(0.0, 0.0), key(0.8, 0.5)],
    });
    scene
}

#[test]
fn a_sliding_box_hung_over_the_floor_keeps_its_gap_dark_in_every_frame() {
    // `--near-gap` in a space-time solve: the box's bottom is a moving point whose
    // foot lies on the static floor, the floor under it a static point (its terms
    // kept over the window) whose foot lies on the moving bottom. Each frame's gap
    // must match the static solve of that frame with the option within 0.5% of the
    // lit floor (measured: 0.27% at most; the two solves' hierarchies differ, and
    // the static one is within 0.2% of the path tracer, in `solver::known`); without
    // the option the space-time gap is off by 2–9% of it at its worst point
    // (asserted: over 1% at one point of each frame; at 0.8 s some points are
    // right without it).
    let scene = sliding_hung_box();
    let with = SolveOptions {
        near_gap: 0.1,
        ..opts()
    };
    let gapped = run_frames(&scene, with.clone(), &st(5.0, 0.4)).0;
    let plain = solve_all(&scene, &st(5.0, 0.4));
    for t in [0.0, 0.4, 0.8] {
        let dx = 0.5 * t / 0.8;
        let at = |x: f64, y: f64, z: f64, n: DVec3| ProbePoint {
            p: DVec3::new(x + dx, y, z),
            n,
        };
        let pts = [
            at(1.3, 0.01, 2.0, -DVec3::Y),
            at(1.1, 0.01, 1.8, -DVec3::Y),
            at(1.3, 0.0, 2.0, DVec3::Y),
            at(1.1, 0.0, 1.8, DVec3::Y),
            // The lit floor, for the scale.
            ProbePoint {
                p: DVec3::new(3.5, 0.0, 2.0),
                n: DVec3::Y,
            },
        ];
        let mut s = Solver::at_time(&scene, with.clone(), t, [0.0, 0.8]).unwrap();
        s.freeze_motion();
        s.run(|_, _| {}).unwrap();
        let base = s.solution();
        let fixed = probe(&base, &pts, t).unwrap();
        let space_time = probe(&as_solution(&scene, &base, &gapped), &pts, t).unwrap();
        let without = probe(&as_solution(&scene, &base, &plain), &pts, t).unwrap();
        let lit = fixed[4][1];
        let mut excess = 0.0f64;
        for i in 0..4 {
            eprintln!(
                "t = {t}, point {i}: static {:.5}, space-time {:.5}, space-time without the option {:.5}",
                fixed[i][1], space_time[i][1], without[i][1]
            );
            assert!(
                (space_time[i][1] - fixed[i][1]).abs() < 5e-3 * lit,
                "t = {t}, point {i}"
            );
            excess = excess.max(without[i][1] - fixed[i][1]);
        }
        assert!(excess > 1e-2 * lit, "t = {t}: without the option {excess}");
    }
}

/// The Cornell box (no blocks) with a square panel, 160 mm wide and 10 mm thick,
/// hung with its top 69 mm under the lamp and sliding 500 mm along x across it
/// over `[0, 0.8]` s (centred under the lamp at 0.4 s): the light on its top
/// rises and falls steeply as it passes (LIGHT's board, in small).
fn panel_under_lamp() -> Scene {
    let mut scene = cornell_box(false);
    scene.time.end = 0.8;
    let white = scene.objects[0].polygons[0].material;
    let (x, z, y) = ([-80.0, 80.0], [199.5, 359.5], [470.0, 480.0]);
    let quad = |v: [[f64; 3]; 4]| rhier::scene::Polygon {
        vertices: v.iter().map(|&p| DVec3::from_array(p)).collect(),
        material: white,
    };
    // Counter-clockwise seen from outside.
    let polygons = vec![
        quad([
            [x[0], y[1], z[0]],
            [x[0], y[1], z[1]],
            [x[1], y[1], z[1]],
            [x[1], y[1], z[0]],
        ]),
        quad([
            [x[0], y[0], z[0]],
            [x[1], y[0], z[0]],
            [x[1], y[0], z[1]],
            [x[0], y[0], z[1]],
        ]),
        quad([
            [x[0], y[0], z[0]],
            [x[0], y[0], z[1]],
            [x[0], y[1], z[1]],
            [x[0], y[1], z[0]],
        ]),
        quad([
            [x[1], y[0], z[0]],
            [x[1], y[1], z[0]],
            [x[1], y[1], z[1]],
            [x[1], y[0], z[1]],
        ]),
        quad([
            [x[0], y[0], z[0]],
            [x[0], y[1], z[0]],
            [x[1], y[1], z[0]],
            [x[1], y[0], z[0]],
        ]),
        quad([
            [x[0], y[0], z[1]],
            [x[1], y[0], z[1]],
            [x[1], y[1], z[1]],
            [x[0], y[1], z[1]],
        ]),
    ];
    scene.objects.push(rhier::scene::Object {
        name: "panel".into(),
        polygons,
        motion: Some(MotionTrack {
            keys: vec![key(0.0, 28.0), key(0.8, 528.0)],
        }),
    });
    scene
}

#[test]
fn a_panel_passing_a_lamp_takes_its_direct_light_anew_between_keyframes() {
    // Keyframes 0, 4 and 8 (the panel beside the lamp, under it, beside it on the
    // other side), every frame between free: on the line. The light on the panel's
    // top follows a bump the line cannot: with its direct light taken apart and
    // computed anew at each frame between, only the rest (what it gets back from
    // the ceiling it lights) is on the line.
    let scene = panel_under_lamp();
    let run = |stride: u32, direct_apart: bool| {
        let o = SpaceTimeOptions {
            key_stride: Some(stride),
            interp_motion: 1.0,
            direct_apart,
            ..st(10.0, 0.8)
        };
        run_frames(&scene, opts(), &o)
    };
    let (every, _) = run(1, true);
    let (apart, apart_frames) = run(4, true);
    let (whole, whole_frames) = run(4, false);
    for frames in [&apart_frames, &whole_frames] {
        for f in frames.iter().filter(|f| f.frame % 4 != 0) {
            assert_eq!(f.varying_links, 0, "frame {} is free", f.frame);
        }
    }
    let base = {
        let mut s = Solver::at_time(&scene, opts(), 0.0, [0.0, 0.8]).unwrap();
        s.run(|_, _| {}).unwrap();
        s.solution()
    };
    let [every, apart, whole] = [&every, &apart, &whole].map(|w| as_solution(&scene, &base, w));
    // Points on the panel's top where it is at time `t`.
    let top = |t: f64| -> Vec<ProbePoint> {
        let dx = 28.0 + 500.0 * t / 0.8;
        let mut pts = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                pts.push(ProbePoint {
                    p: DVec3::new(dx - 64.0 + 32.0 * i as f64, 480.0, 215.5 + 32.0 * j as f64),
                    n: DVec3::Y,
                });
            }
        }
        pts
    };
    for t in [0.1, 0.2, 0.3, 0.5, 0.7] {
        let pts = top(t);
        let a = probe(&every, &pts, t).unwrap();
        let e_apart = relative_rms(&probe(&apart, &pts, t).unwrap(), &a);
        let e_whole = relative_rms(&probe(&whole, &pts, t).unwrap(), &a);
        eprintln!(
            "t = {t}: from every frame gathered, direct apart {:.3}%, whole light on the line {:.3}%",
            e_apart * 100.0,
            e_whole * 100.0
        );
        // Measured: 1.9–2.0% at 0.3 and 0.5 s against 43% on the line; 8.2% and
        // 25–26% at 0.2 and 0.1 / 0.7 s (the panel's top dim beside the lamp, the
        // light it gets back from the ceiling under the lamp on the line) against
        // 83% and 182–185%.
        assert!(
            e_apart < 0.2 * e_whole,
            "t = {t}: {e_apart} against {e_whole}"
        );
        if (0.25..0.55).contains(&t) {
            assert!(e_apart < 0.03, "t = {t}: {e_apart}");
        }
    }
}
