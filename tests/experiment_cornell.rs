//! Accuracy against run time on the Cornell box versus the path-traced reference
//! (ignored by default: minutes of path tracing). `cargo test --release --test
//! experiment_cornell -- --ignored --nocapture`
mod common;

use rhier::geometry::Patches;
use rhier::solver::{SolveOptions, solve};

#[test]
#[ignore]
fn cornell_error_vs_time() {
    for blocks in [false, true] {
        let scene = rhier::scene::cornell_box(blocks);
        let patches = Patches::at_time(&scene, 0.0);
        let mut pts = common::probe::grid_points(&patches, 3);
        let contact = common::probe::contact_points(&patches, &[2.0, 5.0, 10.0, 20.0, 40.0]);
        let n_grid = pts.len();
        pts.extend(contact);
        let paths: u32 = std::env::var("PATHS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(2000);
        let t = std::time::Instant::now();
        let cache = format!("/tmp/rhier-ref-{blocks}-{paths}-{}.json", pts.len());
        let (refb, noise): (Vec<[f64; 3]>, f64) = match std::fs::read_to_string(&cache) {
            Ok(t) => serde_json::from_str(&t).unwrap(),
            Err(_) => {
                let reference = rhier::reference::radiosity_at(&scene, &pts, paths, 7);
                let refb: Vec<[f64; 3]> = reference.iter().map(|e| e.b).collect();
                let noise: f64 = reference
                    .iter()
                    .map(|e| e.std_error.iter().map(|s| s * s).sum::<f64>())
                    .sum::<f64>()
                    .sqrt()
                    / refb
                        .iter()
                        .map(|b| b.iter().map(|x| x * x).sum::<f64>())
                        .sum::<f64>()
                        .sqrt();
                std::fs::write(&cache, serde_json::to_string(&(&refb, noise)).unwrap()).unwrap();
                (refb, noise)
            }
        };
        eprintln!(
            "blocks {blocks}: {} points, reference {paths} paths in {:.1} s, noise {noise:.2e}",
            pts.len(),
            t.elapsed().as_secs_f64()
        );
        for eps in [0.5, 0.2, 0.1, 0.05, 0.02, 0.01] {
            let t = std::time::Instant::now();
            let recon_tol: f64 = std::env::var("RECON")
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(0.02);
            let (sol, recs) = solve(
                &scene,
                SolveOptions {
                    eps,
                    recon_tol,
                    contact_meshing: std::env::var("NOCONTACT").is_err(),
                    ..Default::default()
                },
            )
            .unwrap();
            let secs = t.elapsed().as_secs_f64();
            let points: Vec<rhier::playback::ProbePoint> = pts
                .iter()
                .map(|&(p, n)| rhier::playback::ProbePoint { p, n })
                .collect();
            let b = rhier::playback::probe(&sol, &points, 0.0).unwrap();
            let err = rhier::solver::report::relative_rms(&b, &refb);
            let err_contact = if pts.len() > n_grid {
                rhier::solver::report::relative_rms(&b[n_grid..], &refb[n_grid..])
            } else {
                0.0
            };
            let last = recs.last().unwrap();
            if std::env::var("DUMP").is_ok() && eps == 0.05 {
                for i in n_grid..pts.len() {
                    eprintln!(
                        "    p {:?} n {:?} ours {:.4?} ref {:.4?}",
                        pts[i].0, pts[i].1, b[i], refb[i]
                    );
                }
            }
            eprintln!(
                "  eps {eps:<5} {secs:>7.3} s  leaves {:>6} cells {:>6} links {:>7} rounds {} rays {}  error {err:.4} contact {err_contact:.4}",
                last.leaves,
                sol.leaves.len(),
                last.links_active,
                recs.len(),
                recs.iter().map(|r| r.rays).sum::<u64>()
            );
        }
    }
}
