//! Known-answer scenes for the hierarchical solver.

mod common;

use rhier::solver::{SolveOptions, solve};

/// Closed enclosure, uniform E and ρ: B = E / (1 − ρ) everywhere, at every stored
/// corner. Tolerance 1% (the bar), for ρ up to 0.999.
#[test]
fn closed_enclosure_reaches_e_over_one_minus_rho() {
    for &rho in &[0.5, 0.9, 0.99, 0.999] {
        let scene = common::uniform_enclosure(rho, 1.0, 1.0, 1);
        let (sol, recs) = solve(&scene, SolveOptions::default()).unwrap();
        let exact = 1.0 / (1.0 - rho);
        let mut worst: f64 = 0.0;
        for leaf in &sol.leaves {
            for c in 0..leaf.corners as usize {
                for k in 0..3 {
                    worst = worst.max((leaf.b[c][k] as f64 - exact).abs() / exact);
                }
            }
        }
        eprintln!(
            "rho {rho}: leaves {} rounds {} worst {worst:e} residual {:e}",
            sol.leaves.len(),
            recs.len(),
            recs.last().unwrap().residual
        );
        assert!(worst < 0.01, "rho {rho}: worst relative error {worst}");
    }
}
