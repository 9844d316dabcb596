//! The shaft store in a session: on a straight path linear prediction has every
//! shaft ready before a move needs it (none built on the fly after two moves of
//! warm-up), without prediction they are built on the fly; under a budget the
//! resident bytes stay within one block of it, and shafts evicted to the compressed
//! store come back when the object returns.

use glam::DVec3;
use rhier::interactive::predict::Method;
use rhier::interactive::store::{BLOCK_BYTES, Keep, Policy};
use rhier::interactive::{ObjectMove, Pose, Session, Settings, Stage, Traversal};
use rhier::solver::SolveOptions;

use super::moves::room;
use crate::common::shapes::Tiling;

fn options() -> SolveOptions {
    SolveOptions {
        eps: 0.5,
        max_rounds: 4,
        ..SolveOptions::default()
    }
}

fn at(x: f64, z: f64) -> [ObjectMove; 1] {
    [ObjectMove {
        object: 1,
        pose: Pose {
            translation: DVec3::new(x, 0.0, z),
            rotation: glam::DQuat::IDENTITY,
        },
    }]
}

fn session(stage: &Stage, predict: Method, policy: Policy) -> Session<'_> {
    let settings = Settings {
        traversal: Traversal::Affected,
        policy,
        predict,
        ahead: 1,
        scale: 1.1,
        ..Settings::default()
    };
    Session::start(stage, options(), settings).unwrap()
}

#[test]
fn on_a_straight_path_prediction_has_every_shaft_ready() {
    for tiling in [Tiling::Quads(2), Tiling::UnequalTriangles(2)] {
        let stage = Stage::new(&room(tiling, 0.6), Some(&["crate".to_string()])).unwrap();
        let mut with = session(&stage, Method::Linear, Policy::default());
        let mut without = session(&stage, Method::None, Policy::default());
        for k in 1..=8 {
            let m = at(0.1 * k as f64, 0.05 * k as f64);
            let a = with.apply(&m).unwrap();
            let b = without.apply(&m).unwrap();
            assert!(a.shaft_tests > 0 && b.shaft_tests > 0, "{a:?}");
            if k > 2 {
                assert_eq!(a.shafts_built, 0, "{tiling:?}, move {k}: {a:?}");
                assert!(a.shafts_existing > 0, "{a:?}");
                assert!(a.shafts_predicted > 0 || k > 3, "{a:?}");
            }
            // Stored only near the moving box: a fraction of every link's shaft.
            assert!(a.resident_shaft_bytes < a.all_shaft_bytes / 2, "{a:?}");
            assert_eq!(b.shafts_predicted, 0);
            if k == 1 {
                assert!(b.shafts_built > 0);
            }
        }
    }
}

#[test]
fn a_budget_holds_and_evicted_shafts_come_back() {
    let stage = Stage::new(&room(Tiling::Quads(2), 0.6), Some(&["crate".to_string()])).unwrap();
    let budget = 40_000;
    let mut s = session(
        &stage,
        Method::None,
        Policy {
            budget: Some(budget),
            max_age: 1,
            keep: Keep::Zstd,
            ..Policy::default()
        },
    );
    let (mut evicted, mut restored) = (0, 0);
    for k in 0..12 {
        // There and back: the shafts of the far end are evicted, then wanted again.
        let x = if k % 6 < 3 { 0.0 } else { 1.5 };
        let st = s.apply(&at(x + 0.01 * k as f64, 0.0)).unwrap();
        assert!(
            st.resident_shaft_bytes <= budget + BLOCK_BYTES,
            "move {k}: {} resident",
            st.resident_shaft_bytes
        );
        evicted += st.shafts_evicted;
        restored += st.shafts_restored;
    }
    assert!(
        evicted > 0 && restored > 0,
        "{evicted} evicted, {restored} restored"
    );
}
