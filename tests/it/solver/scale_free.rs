//! Scale freedom (issue 45): the same scene in millimetres, metres or kilometres must
//! give the same radiosity, so every tolerance of the solver must be relative to the
//! scene's size. Each scene (the Cornell box with its blocks, in millimetres; a room
//! with boxes touching each other and the floor, in metres) is solved as given and
//! scaled (every vertex and every probe point), with the same options, and probed at
//! a 3 × 3 grid on every patch plus points 0.4%–8% of the room's width from where the
//! boxes meet the floor (on the floor and on the boxes' sides), where contact
//! meshing, ray offsets and coplanarity tests act: 950 and 2,943 points.
//!
//! Difference measure: `|a − b| / max(|a|, 1% of the scene's RMS radiosity)`, worst
//! channel. A plain relative measure is meaningless where `B` is near zero (a
//! ceiling behind a hanging lamp, a colour channel the walls barely reflect); the
//! floor keeps it relative everywhere else.
//!
//! Scaling by a power of two scales every floating-point number exactly, so any
//! difference there comes from an absolute length or epsilon: the answers must be
//! bit for bit the same from 2^-30 to 2^40 (before the BVHs were built at unit
//! scale, `SceneBvh`, the Cornell box differed by 117% at 2^-30). Scaling by 1000 or
//! 0.001 also rounds every coordinate differently, and every decision that compared
//! rounded numbers exactly flipped somewhere: the cluster split's axis and median
//! order (ties within 2^-30 of the extent), `choose_split`'s size comparison (ties
//! within 1e-9), the shafts' culling (f32 triangles against a 1e-9 tolerance; now
//! f64), contact meshing (a cut through a tile's corner kept it alone or twice, a
//! quad with a repeated corner in metres and a triangle in millimetres; the cuts
//! came in the f32 BVH's order), occlusion (a hit within the f32 round-off of the
//! segment's trim, by a box's corner; now decided in f64) and the probe's leaf (a
//! point on the edge of two leaves, the middle of a patch, took one leaf or the
//! other). Before, the Cornell box at ×1000 differed by up to 2.8% (420 of 950
//! points over 1e-3) and the boxes at 790 and 812 of their points; now no point
//! differs by more than 1e-4: the Cornell box by at most 1.3e-8, the boxes by
//! 1.3e-5 at ×0.001 and 1.9e-5 at ×1000. The boxes had read up to 1e-3 apart at
//! ×1000 at the small box's foot until the BVH's boxes were padded beyond f32
//! round-off (`geometry::visibility`, `padded_boxes`): a gather point 10⁻⁴ m
//! beside the box cast a ray that crosses the box's side 6·10⁻⁸ m from its edge,
//! and the f32 traversal found that side at one scale only.

use glam::DVec3;
use rhier::geometry::Patches;
use rhier::playback::{ProbePoint, probe};
use rhier::scene::{Scene, cornell_box};
use rhier::solver::{SolveOptions, solve};

use crate::common;
use crate::common::shapes;

/// `scene` with every vertex multiplied by `s`.
fn scaled(scene: &Scene, s: f64) -> Scene {
    let mut out = scene.clone();
    for obj in &mut out.objects {
        for poly in &mut obj.polygons {
            for v in &mut poly.vertices {
                *v *= s;
            }
        }
    }
    out
}

/// Solves `scene` at scale 1 and at each of `scales` with `opts`, probes each at the
/// same points (scaled alike) and returns, per scale, the worst difference from
/// scale 1 (module docs), the point where it is, and how many points differ by more
/// than [`BAR`].
fn scale_differences(
    name: &str,
    scene: &Scene,
    ds: &[f64],
    scales: &[f64],
    opts: &SolveOptions,
) -> Vec<(f64, f64, DVec3, usize)> {
    let patches = Patches::at_time(scene, 0.0);
    let mut pts = common::probe::grid_points(&patches, 3);
    pts.extend(common::probe::contact_points(
        &patches,
        0.0,
        ds,
        &[0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 0.98],
    ));
    let at = |s: f64| {
        let points: Vec<ProbePoint> = pts
            .iter()
            .map(|&(p, n)| ProbePoint { p: p * s, n })
            .collect();
        let (sol, _) = solve(&scaled(scene, s), opts.clone()).unwrap();
        probe(&sol, &points, 0.0).unwrap()
    };
    let base = at(1.0);
    let rms = (base.iter().flatten().map(|b| b * b).sum::<f64>() / (3 * base.len()) as f64).sqrt();
    let mut out = Vec::new();
    for &s in scales {
        let other = at(s);
        let (mut worst, mut at_point, mut count) = (0.0f64, 0, 0);
        for (i, (a, b)) in base.iter().zip(&other).enumerate() {
            let d = (0..3)
                .map(|c| (a[c] - b[c]).abs() / a[c].abs().max(0.01 * rms))
                .fold(0.0, f64::max);
            count += usize::from(d > BAR);
            if d > worst {
                (worst, at_point) = (d, i);
            }
        }
        eprintln!(
            "{name} ×{s}: worst {worst:.2e} at {} ({count} of {} over {BAR:.0e})",
            pts[at_point].0,
            pts.len()
        );
        out.push((s, worst, pts[at_point].0, count));
    }
    out
}

/// Largest difference allowed between scales (module docs).
const BAR: f64 = 1e-4;

/// Power-of-two scales: mm ↔ m (2^±10) and far beyond.
const EXACT_SCALES: [f64; 4] = [
    1024.0,
    1.0 / 1024.0,
    1.0 / (1u64 << 30) as f64,
    (1u64 << 40) as f64,
];

const CORNELL_GAPS: [f64; 5] = [2.0, 5.0, 10.0, 20.0, 40.0];
const BOXES_GAPS: [f64; 5] = [0.005, 0.01, 0.02, 0.05, 0.1];

#[test]
fn cornell_blocks_bit_for_bit_at_power_of_two_scales() {
    let scene = cornell_box(true);
    let opts = SolveOptions::default();
    for (s, w, p, count) in
        scale_differences("cornell", &scene, &CORNELL_GAPS, &EXACT_SCALES, &opts)
    {
        assert!(
            w == 0.0,
            "×{s}: {count} points differ, worst {w:.2e} at {p}"
        );
    }
}

#[test]
fn touching_boxes_bit_for_bit_at_power_of_two_scales() {
    let scene = shapes::touching_boxes();
    let opts = SolveOptions::default();
    for (s, w, p, count) in scale_differences("boxes", &scene, &BOXES_GAPS, &EXACT_SCALES, &opts) {
        assert!(
            w == 0.0,
            "×{s}: {count} points differ, worst {w:.2e} at {p}"
        );
    }
}

#[test]
fn same_answer_in_millimetres_and_kilometres() {
    let opts = SolveOptions::default();
    let cases = [
        ("cornell", cornell_box(true), CORNELL_GAPS),
        ("boxes", shapes::touching_boxes(), BOXES_GAPS),
    ];
    for (name, scene, gaps) in cases {
        for (s, w, p, count) in scale_differences(name, &scene, &gaps, &[1000.0, 0.001], &opts) {
            assert!(
                w <= BAR,
                "{name} ×{s}: {count} points differ, worst {w:.2e} at {p}"
            );
        }
    }
}

/// Scratch (h48flip): the leaves of the touching boxes whose corner radiosity
/// differs most between ×1 and ×1000 (same leaves in the same order).
#[test]
#[ignore = "scratch diagnosis"]
fn scratch_touching_boxes_leaves_at_two_scales() {
    let scene = shapes::touching_boxes();
    let (a, _) = solve(&scene, SolveOptions::default()).unwrap();
    let (b, _) = solve(&scaled(&scene, 1000.0), SolveOptions::default()).unwrap();
    assert_eq!(a.leaves.len(), b.leaves.len());
    let rms = (a
        .leaves
        .iter()
        .flat_map(|l| l.b.iter().flatten())
        .map(|&x| (x as f64).powi(2))
        .sum::<f64>()
        / (a.leaves.len() * 12) as f64)
        .sqrt();
    let mut d: Vec<(f64, usize, usize, usize)> = Vec::new();
    for (i, (x, y)) in a.leaves.iter().zip(&b.leaves).enumerate() {
        assert_eq!(x.patch, y.patch);
        for c in 0..x.corners as usize {
            for ch in 0..3 {
                let (p, q) = (x.b[c][ch] as f64, y.b[c][ch] as f64);
                let rel = (p - q).abs() / p.abs().max(0.01 * rms);
                if rel > 1e-5 {
                    d.push((rel, i, c, ch));
                }
            }
        }
    }
    d.sort_by(|u, v| v.0.total_cmp(&u.0));
    eprintln!(
        "{} leaf corner channels over 1e-5 (of {} leaves)",
        d.len(),
        a.leaves.len()
    );
    let mut by_patch = std::collections::BTreeMap::new();
    for &(_, i, _, _) in &d {
        *by_patch.entry(a.leaves[i].patch).or_insert(0) += 1;
    }
    eprintln!("by patch: {by_patch:?}");
    for &(rel, i, c, ch) in d.iter().take(15) {
        let l = &a.leaves[i];
        let p = &a.patches[l.patch as usize];
        eprintln!(
            "leaf {i} patch {} corner {c} ch {ch}: {:.4} vs {:.4} ({rel:.2e}); uv {:?}; patch {:?}",
            l.patch, l.b[c][ch], b.leaves[i].b[c][ch], l.uv[c], p
        );
    }
}

/// Scratch (h48flip2): element radiosities (the solve's leaves) at x1 and x1000.
#[test]
#[ignore = "scratch diagnosis"]
fn scratch_touching_boxes_elements_at_two_scales() {
    let scene = shapes::touching_boxes();
    let run = |sc: &Scene| {
        let mut s = rhier::solver::Solver::new(sc, SolveOptions::default()).unwrap();
        let rec = s.run(|_, _| {}).unwrap();
        for r in &rec {
            eprintln!("round {r:?}");
        }
        s.leaf_radiosities()
    };
    let a = run(&scene);
    let b = run(&scaled(&scene, 1000.0));
    assert_eq!(a.len(), b.len());
    let rms = (a.iter().flat_map(|l| l.2).map(|x| (x as f64).powi(2)).sum::<f64>()
        / (a.len() * 3) as f64)
        .sqrt();
    let mut d: Vec<(f64, usize)> = Vec::new();
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert_eq!(x.0, y.0);
        let rel = (0..3)
            .map(|c| (x.2[c] as f64 - y.2[c] as f64).abs() / (x.2[c] as f64).abs().max(0.01 * rms))
            .fold(0.0, f64::max);
        d.push((rel, i));
    }
    d.sort_by(|u, v| v.0.total_cmp(&u.0));
    let over = |t: f64| d.iter().filter(|x| x.0 > t).count();
    eprintln!(
        "{} elements: over 1e-7 {}, 1e-6 {}, 1e-5 {}, 1e-4 {}",
        a.len(),
        over(1e-7),
        over(1e-6),
        over(1e-5),
        over(1e-4)
    );
    for &(rel, i) in d.iter().take(40) {
        eprintln!("elem#{i} patch {} uv0 {:?}: {:?} vs {:?} ({rel:.2e})", a[i].0, a[i].1, a[i].2, b[i].2);
    }
}

/// Scratch (h48flip2): per round, element radiosities and link transports at x1
/// and x1000.
#[test]
#[ignore = "scratch diagnosis"]
fn scratch_touching_boxes_links_at_two_scales() {
    use rhier::pools::links::Transport;
    let scene = shapes::touching_boxes();
    type Round = (Vec<[f32; 3]>, Vec<(u32, u32)>, Vec<Transport>, Vec<(u32, [[f32; 2]; 4], u32)>);
    let run = |sc: &Scene| {
        let mut s = rhier::solver::Solver::new(sc, SolveOptions::default()).unwrap();
        let mut rounds: Vec<Round> = Vec::new();
        s.run(|_, s| {
            rounds.push((
                s.elems.radiosities.as_slice().to_vec(),
                s.links.ends.as_slice().iter().map(|e| (e.receiver, e.source)).collect(),
                s.links.transports.as_slice().to_vec(),
                s.elems.geoms.as_slice().iter().map(|g| (g.patch, g.uv, g.n)).collect(),
            ));
        })
        .unwrap();
        rounds
    };
    let ra = run(&scene);
    let rb = run(&scaled(&scene, 1000.0));
    for (r, (a, b)) in ra.iter().zip(&rb).enumerate() {
        eprintln!("round {r}: elems {} {}, links {} {}", a.0.len(), b.0.len(), a.1.len(), b.1.len());
        assert_eq!(a.1, b.1);
        // Links: transports that differ.
        let mut ld: Vec<(f64, usize)> = Vec::new();
        for (i, (x, y)) in a.2.iter().zip(&b.2).enumerate() {
            let rel = |p: f32, q: f32| ((p - q).abs() / p.abs().max(1e-12)) as f64;
            let d = rel(x.f, y.f).max(rel(x.visibility, y.visibility));
            if (x.f != 0.0 || y.f != 0.0) && (d > 1e-5 || x.flags != y.flags) {
                ld.push((d, i));
            }
        }
        ld.sort_by(|u, v| v.0.total_cmp(&u.0));
        eprintln!("  {} links differ (f or vis > 1e-5 or flags)", ld.len());
        for &(d, i) in ld.iter().take(30) {
            let (rc, sc) = a.1[i];
            eprintln!(
                "  link {i} {rc}<-{sc} ({:?} <- {:?}): {:?} vs {:?} ({d:.2e})",
                a.3[rc as usize], a.3[sc as usize], a.2[i], b.2[i]
            );
        }
        let mut ed: Vec<(f64, usize)> = Vec::new();
        for (i, (x, y)) in a.0.iter().zip(&b.0).enumerate() {
            let d = (0..3)
                .map(|c| ((x[c] - y[c]).abs() / x[c].abs().max(1e-3)) as f64)
                .fold(0.0, f64::max);
            ed.push((d, i));
        }
        ed.sort_by(|u, v| v.0.total_cmp(&u.0));
        for &(d, i) in ed.iter().take(8) {
            eprintln!("  elem {i} {:?}: {:?} vs {:?} ({d:.2e})", a.3[i], a.0[i], b.0[i]);
        }
    }
}

/// Scratch (h48flip2): per round, the leaf rows at x1 and x1000.
#[test]
#[ignore = "scratch diagnosis"]
fn scratch_touching_boxes_rows_at_two_scales() {
    let scene = shapes::touching_boxes();
    let patches = Patches::at_time(&scene, 0.0);
    #[allow(clippy::type_complexity)]
    let run = |sc: &Scene| {
        let mut s = rhier::solver::Solver::new(sc, SolveOptions::default()).unwrap();
        let mut rounds = Vec::new();
        s.run(|_, s| {
            let g: Vec<(u32, [[f32; 2]; 4], u32, [[f64; 3]; 4])> = s
                .elems
                .geoms
                .as_slice()
                .iter()
                .map(|g| (g.patch, g.uv, g.n, g.corners))
                .collect();
            let ends: Vec<(u32, u32)> = s.links.ends.as_slice().iter().map(|e| (e.receiver, e.source)).collect();
            rounds.push((s.scratch_rows(), g, ends, s.elems.radiosities.as_slice().to_vec()));
        })
        .unwrap();
        rounds
    };
    let ra = run(&scene);
    let rb = run(&scaled(&scene, 1000.0));
    for (r, (a, b)) in ra.iter().zip(&rb).enumerate() {
        eprintln!("round {r}: {} leaves", a.0.len());
        let mut diffs: Vec<(f64, String)> = Vec::new();
        for (x, y) in a.0.iter().zip(&b.0) {
            assert_eq!(x.0, y.0);
            if (x.1 - y.1).abs() > 1e-7 * x.1.abs() || (x.2 - y.2).abs() > 1e-7 * x.2.abs() {
                diffs.push(((x.1 - y.1).abs().max((x.2 - y.2).abs()), format!("leaf {} scale {} vs {}, gain {} vs {}", x.0, x.1, y.1, x.2, y.2)));
            }
            let sum: f64 = x.3.iter().map(|e| e.1.abs()).sum();
            let ma: std::collections::BTreeMap<u32, f64> = x.3.iter().copied().collect();
            let mb: std::collections::BTreeMap<u32, f64> = y.3.iter().copied().collect();
            for k in ma.keys().chain(mb.keys()) {
                let (p, q) = (ma.get(k).copied().unwrap_or(0.0), mb.get(k).copied().unwrap_or(0.0));
                let d = (p - q).abs() / sum.max(1e-30);
                if d > 1e-6 && p >= q {
                    let lg = &a.1[x.0 as usize];
                    let sg = &a.1[(*k & 0x7fff_ffff) as usize];
                    diffs.push((d, format!(
                        "leaf {} (patch {} uv {:?} corners {:?}) entry src {k} (patch {} uv {:?} corners {:?}): {p:.6e} vs {q:.6e} (of row sum {sum:.4}); B_src {:?}",
                        x.0, lg.0, &lg.1[..lg.2 as usize], &lg.3[..lg.2.min(4) as usize], sg.0, &sg.1[..sg.2.min(4) as usize], &sg.3[..sg.2.min(4) as usize], a.3[(*k & 0x7fff_ffff) as usize]
                    )));
                }
            }
            let ka: std::collections::BTreeMap<u32, (f32, f32)> = x.4.iter().map(|e| (e.0, (e.1, e.2))).collect();
            for &(l, c, v) in &y.4 {
                if let Some(&(c0, v0)) = ka.get(&l)
                    && ((c - c0).abs() > 1e-6 * c0.abs().max(1e-9) || v != v0)
                {
                    let (rc, sc) = a.2[l as usize];
                    diffs.push(((c - c0).abs() as f64 / sum.max(1e-30), format!(
                        "  kept leaf {} link {l} {rc}<-{sc} (src patch {} uv {:?}): coef {c0:.6e} vs {c:.6e}, vis {v0} vs {v}",
                        x.0, a.1[sc as usize].0, &a.1[sc as usize].1[..a.1[sc as usize].2.min(4) as usize]
                    )));
                }
            }
        }
        diffs.sort_by(|u, v| v.0.total_cmp(&u.0));
        eprintln!("  {} differences", diffs.len());
        for (d, s) in diffs.iter().take(40) {
            eprintln!("  {d:.2e}: {s}");
        }
    }
    for p in [11usize, 45, 122, 188, 94] {
        eprintln!("patch {p}: {:?} n {:?}", &patches.polys[p].v[..patches.polys[p].n], patches.normals[p]);
    }
}

/// Scratch (h48flip2): details of chosen row entries and link estimates at x1
/// and x1000.
#[test]
#[ignore = "scratch diagnosis"]
fn scratch_touching_boxes_details_at_two_scales() {
    let scene = shapes::touching_boxes();
    let run = |sc: &Scene| {
        let mut s = rhier::solver::Solver::new(sc, SolveOptions::default()).unwrap();
        let mut out = String::new();
        let mut round = 0;
        s.run(|_, s| {
            if round == 1 {
                out += &s.scratch_row_part(148, 0x8000_0000 | 218);
                // Link estimates' cluster emission.
                for (l, r, c) in [(2969usize, 427usize, 368usize), (3483, 424, 198), (2308, 422, 368)] {
                    let ends = s.links.ends.as_slice()[l];
                    let g = &s.elems.geoms.as_slice()[c];
                    let em = &s.elems.directions.as_slice()[c];
                    let b = s.elems.radiosities.as_slice()[c].iter().copied().fold(0.0f32, f32::max) as f64;
                    let (cr, _) = rhier::oracle::sphere(&s.elems.geoms.as_slice()[r]);
                    let (cs, _) = rhier::oracle::sphere(g);
                    let u = (cs - cr).normalize();
                    let p = g.area * b;
                    let nl = glam::DVec3::new(em.normal[0] as f64, em.normal[1] as f64, em.normal[2] as f64).length();
                    out += &format!(
                        "link {l} ends {}<-{} f {:e}: cluster {c} box {:?} area {} b {b} em {:?} p {p:e} |N| {nl:e} rest {:e} u {u} emission {:e}\n",
                        ends.receiver, ends.source, s.links.transports.as_slice()[l].f, &g.corners[..3], g.area, em, 1.0 - nl.min(p) / p,
                        rhier::oracle::cluster_emission(g, em, b, -u, true)
                    );
                }
            }
            round += 1;
        })
        .unwrap();
        out
    };
    eprintln!("=== x1\n{}", run(&scene));
    eprintln!("=== x1000\n{}", run(&scaled(&scene, 1000.0)));
}
