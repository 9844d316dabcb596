//! An interactive move's rows keep the entries of a static part whose shaft to
//! the leaf meets the moved boxes where the moving object blocks the same of
//! its rays as at the move that computed them (`solver::row_patch`, surface
//! parts, since h49move). Every part kept so in a walk into a cluster is
//! computed again beside, as the walk would compute it, and must come out bit
//! for bit the same: keeping is exact, not an approximation.

use rhier::interactive::{ObjectMove, Session, Settings, Stage};

use super::moves::{options, room, shift};
use crate::common::shapes::Tiling;

/// The hovering crate moved by 2 cm steps (its shadow edges cross few rays a
/// step) and then far (most kept records no longer hold): every part the rows
/// keep by its trace equals its recomputation, in the room of quads and in its
/// tessellated twin.
#[test]
fn parts_kept_by_their_blocked_rays_equal_a_recomputation() {
    for tiling in [Tiling::Quads(2), Tiling::UnequalTriangles(2)] {
        let scene = room(tiling, 0.6);
        let movable = ["crate".to_string()];
        let stage = Stage::new(&scene, Some(&movable)).unwrap();
        let mut s = Session::start(&stage, options(), Settings::default()).unwrap();
        s.solver().check_kept_parts(true);
        let poses = [
            shift(0.02, 0.0, 0.0),
            shift(0.04, 0.0, 0.01),
            shift(0.06, 0.0, 0.02),
            shift(0.08, 0.0, 0.03),
            shift(0.9, 0.0, 0.5),
            shift(0.92, 0.0, 0.5),
        ];
        for pose in poses {
            s.apply(&[ObjectMove { object: 1, pose }]).unwrap();
        }
        let kept = s.solver().kept_parts();
        eprintln!("{tiling:?}: {kept:?}");
        // Parts are kept, some of them in a walk and so checked, and none came
        // out otherwise.
        assert!(kept.checked > 0, "{tiling:?}: {kept:?}");
        assert!(kept.surface >= kept.checked, "{tiling:?}: {kept:?}");
        assert_eq!(kept.differ, 0, "{tiling:?}: {kept:?}");
    }
}
