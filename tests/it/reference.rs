//! Known answers for the Monte Carlo reference (`rhier reference`), which the
//! accuracy benchmarks and tests measure the solver against.

use glam::DVec3;

use crate::common;

/// Closed enclosure, uniform E and ρ: B = E / (1 − ρ) at every point; the estimate
/// must agree within 4 standard errors and 1.5% at every ρ. At ρ = 0.99 a path
/// takes a hundred bounces on average, and this failed three ways: Russian roulette
/// capped at 0.95 let the paths' weights grow as (ρ/0.95)^k (unbounded variance:
/// 81.5 ± 2.5 here), a cap of 256 bounces would have cut 8% of the paths, and
/// bounces from within a millimetre of a corner went through the wall they faced
/// (`SceneBvh::intersect`; 97.9 ± 0.5). Now 99.0 ± 0.6.
#[test]
fn reference_reaches_e_over_one_minus_rho() {
    let pts = [
        (DVec3::new(0.5, 0.0, 0.5), DVec3::Y),
        (DVec3::new(0.5, 1.0, 0.3), DVec3::NEG_Y),
        (DVec3::new(0.0, 0.4, 0.6), DVec3::X),
        (DVec3::new(0.7, 0.2, 1.0), DVec3::NEG_Z),
    ];
    for &rho in &[0.5, 0.9, 0.99] {
        let scene = common::uniform_enclosure(rho, 1.0, 1.0, 2);
        let est = rhier::reference::radiosity_at(&scene, &pts, 20_000, 3);
        let exact = 1.0 / (1.0 - rho);
        // The mean of the points (one estimate with a quarter of the variance).
        let mean = est.iter().map(|e| e.b[1]).sum::<f64>() / est.len() as f64;
        let se = est
            .iter()
            .map(|e| e.std_error[1].powi(2))
            .sum::<f64>()
            .sqrt()
            / est.len() as f64;
        eprintln!("rho {rho}: mean {mean} exact {exact} standard error {se}");
        assert!(
            (mean - exact).abs() < 4.0 * se && (mean - exact).abs() < 0.015 * exact,
            "rho {rho}: mean {mean}, exact {exact}, standard error {se}"
        );
    }
}

/// The same closed enclosure made two-sided (every polygon with a reversed twin, as
/// glTF `doubleSided` loads): the twins facing into the walls see only the walls'
/// insides, so the answer in the room is unchanged. A bounce that met a wall used to
/// stop on whichever twin the traversal found first, often the back one
/// (`SceneBvh::intersect_front_first`; the Blender Cornell box read 25–90% dark).
#[test]
fn reference_is_unchanged_by_back_to_back_twins() {
    let pts = [
        (DVec3::new(0.5, 0.0, 0.5), DVec3::Y),
        (DVec3::new(0.5, 1.0, 0.3), DVec3::NEG_Y),
        (DVec3::new(0.0, 0.4, 0.6), DVec3::X),
    ];
    let rho = 0.9;
    let mut scene = common::uniform_enclosure(rho, 1.0, 1.0, 2);
    assert!(rhier::scene::two_sided(&mut scene) > 0);
    let est = rhier::reference::radiosity_at(&scene, &pts, 4_000, 5);
    let exact = 1.0 / (1.0 - rho);
    for (e, (p, _)) in est.iter().zip(&pts) {
        eprintln!("{p}: {} ± {} (exact {exact})", e.b[1], e.std_error[1]);
        assert!(
            (e.b[1] - exact).abs() < (4.0 * e.std_error[1]).max(0.02 * exact),
            "{p}: {} ± {}, exact {exact}",
            e.b[1],
            e.std_error[1]
        );
    }
}
