//! A session primed before its first move (`Session::prime`): the light it holds
//! is the solve's up to the rows' noise (the rows near the object are computed
//! again as a move computes them), and every move after it gives what the same
//! move gives in a session that was not primed, the same rows dirty, with the
//! shafts around the object built before the first move.

use rhier::interactive::{ObjectMove, Pose, Session, Settings, Stage};
use rhier::playback::probe::{ProbePoint, probe};
use rhier::scene::Scene;

use super::moves::{options, room, shift};
use crate::common::shapes::Tiling;

/// Points on every surface of the 4 × 2.5 × 4 room, away from the crate.
fn points() -> Vec<ProbePoint> {
    use glam::DVec3;
    let mut out = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            let (a, b) = (0.25 + 0.5 * i as f64, 0.25 + 0.5 * j as f64);
            out.push(ProbePoint {
                p: DVec3::new(a, 0.0, b),
                n: DVec3::Y,
            });
            out.push(ProbePoint {
                p: DVec3::new(a, 2.5, b),
                n: DVec3::NEG_Y,
            });
            out.push(ProbePoint {
                p: DVec3::new(0.0, b * 2.5 / 4.0, a),
                n: DVec3::X,
            });
            out.push(ProbePoint {
                p: DVec3::new(a, b * 2.5 / 4.0, 4.0),
                n: DVec3::NEG_Z,
            });
        }
    }
    out
}

/// The largest relative difference between two probe sets, per channel, over
/// the points where the light is not negligible.
fn apart(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let top = a.iter().flatten().fold(0.0f64, |m, &x| m.max(x.abs()));
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .filter(|(x, _)| x.abs() > 1e-6 * top)
        .map(|(x, y)| (x - y).abs() / x.abs())
        .fold(0.0, f64::max)
}

fn check(what: &str, scene: &Scene) {
    let movable = ["crate".to_string()];
    let stage = Stage::new(scene, Some(&movable)).unwrap();
    let settings = Settings::default();
    let pts = points();
    let mut plain = Session::start(&stage, options(), settings).unwrap();
    let mut primed = Session::start(&stage, options(), settings).unwrap();
    let solved = probe(&primed.solution(), &pts, 0.0).unwrap();
    let p = primed
        .prime()
        .unwrap()
        .expect("a session with a movable object primes");
    let after = probe(&primed.solution(), &pts, 0.0).unwrap();
    let d = apart(&solved, &after);
    eprintln!(
        "{what}: priming computed {} rows, built {} shafts; the light moved {d:.2e}",
        p.rows_recomputed, p.shafts_built
    );
    assert!(p.rows_recomputed > 0, "{what}: priming computed no row");
    assert!(p.shafts_built > 0, "{what}: priming built no shaft");
    assert!(d < 1e-3, "{what}: priming moved the light by {d:e}");
    let poses: [Pose; 3] = [
        shift(0.05, 0.0, 0.0),
        shift(0.1, 0.0, 0.0),
        shift(0.15, 0.0, 0.0),
    ];
    for (i, &pose) in poses.iter().enumerate() {
        let m = [ObjectMove { object: 1, pose }];
        let a = plain.apply(&m).unwrap();
        let b = primed.apply(&m).unwrap();
        let (pa, pb) = (
            probe(&plain.solution(), &pts, 0.0).unwrap(),
            probe(&primed.solution(), &pts, 0.0).unwrap(),
        );
        let d = apart(&pa, &pb);
        eprintln!(
            "{what}, move {}: rows {} / {}, shafts built {} / {} (plain / primed), the light {d:.2e} apart",
            i + 1,
            a.rows_recomputed,
            b.rows_recomputed,
            a.shafts_built,
            b.shafts_built
        );
        assert!(d < 1e-5, "{what}, move {}: {d:e} apart", i + 1);
        assert_eq!(
            a.rows_recomputed,
            b.rows_recomputed,
            "{what}, move {}: the same rows are dirty",
            i + 1
        );
        if i == 0 {
            assert!(
                b.shafts_built < a.shafts_built,
                "{what}: the primed first move built {} shafts, the plain one {}",
                b.shafts_built,
                a.shafts_built
            );
        }
    }
}

#[test]
fn a_primed_session_keeps_the_solved_light_and_moves_as_an_unprimed_one() {
    check("hovering crate, quads", &room(Tiling::Quads(2), 0.6));
    check(
        "hovering crate, unequal triangles",
        &room(Tiling::UnequalTriangles(2), 0.6),
    );
}

/// A room with no emitter: its answer is zero in every pose and the session did
/// not solve it, so there is nothing to prime, and a move computes nothing and
/// keeps every point dark.
#[test]
fn a_room_with_no_emitter_has_nothing_to_prime() {
    let mut scene = room(Tiling::Quads(2), 0.6);
    for m in &mut scene.materials {
        m.emission = [0.0; 3];
    }
    assert!(!scene.has_emitter());
    let movable = ["crate".to_string()];
    let stage = Stage::new(&scene, Some(&movable)).unwrap();
    let mut s = Session::start(&stage, options(), Settings::default()).unwrap();
    let b = probe(&s.solution(), &points(), 0.0).unwrap();
    assert!(b.iter().flatten().all(|&x| x == 0.0), "a dark room lit");
    assert!(s.prime().unwrap().is_none(), "a dark room was primed");
    let m = s
        .apply(&[ObjectMove {
            object: 1,
            pose: shift(0.1, 0.0, 0.0),
        }])
        .unwrap();
    let b = probe(&s.solution(), &points(), 0.0).unwrap();
    eprintln!(
        "dark room, move 1: rows {}, shafts built {}",
        m.rows_recomputed, m.shafts_built
    );
    assert_eq!(m.rows_recomputed, 0, "a move in a dark room computed rows");
    assert_eq!(m.links_reevaluated, 0);
    assert!(
        b.iter().flatten().all(|&x| x == 0.0),
        "a dark room lit after a move"
    );
}
