//! Flatland form factors: string rule (exact, eq. 2–3) against known answers and
//! against numerical quadrature of the point kernel (Figure 4), reciprocity, closure.

use rhier::flatland::geometry::FlatGeometry;
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::PosedSegment;

use crate::common::random_segments;

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
    let g = geom(vec![
        seg([0.0, 0.0], [1.0, 0.0]),
        seg([1.0, 1.0], [0.0, 1.0]),
    ]);
    let (ff, _) = form_factors(&g);
    let want = 2f64.sqrt() - 1.0; // (2 sqrt 2 - 2) / 2
    assert!((ff.f(0, 1) - want).abs() < 1e-14, "{}", ff.f(0, 1));
    assert!((ff.f(1, 0) - want).abs() < 1e-14);
}

#[test]
fn back_facing_pair_has_no_factor() {
    // Both lit sides face down: the ceiling's lit side looks away from the floor's.
    let g = geom(vec![
        seg([0.0, 0.0], [1.0, 0.0]),
        seg([0.0, 1.0], [1.0, 1.0]),
    ]);
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
    assert!(
        (ff.f(0, 1) - want).abs() < 1e-14,
        "{} vs {want}",
        ff.f(0, 1)
    );
}

/// A closed room (lit inside) with a box (lit outside) whose corners are collinear
/// with the room's: degenerate events on purpose.
fn room_with_box(splits: usize) -> FlatGeometry {
    let room = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let boxp = [[0.4, 0.4], [0.4, 0.6], [0.6, 0.6], [0.6, 0.4]];
    let mut segs = Vec::new();
    for poly in [room, boxp] {
        for k in 0..4 {
            segs.push(seg(poly[k], poly[(k + 1) % 4]));
        }
    }
    let ts: Vec<f64> = (1..splits).map(|k| k as f64 / splits as f64).collect();
    let n = segs.len();
    FlatGeometry::new(segs, &vec![ts; n])
}

#[test]
fn closure_and_reciprocity_in_a_closed_room() {
    for splits in [1, 3, 7] {
        let g = room_with_box(splits);
        let (ff, _) = form_factors(&g);
        let n = g.elements.len() as u32;
        for i in 0..n {
            let sum: f64 = (0..n).map(|j| ff.f(i, j)).sum();
            assert!((sum - 1.0).abs() < 1e-12, "splits {splits}, row {i}: {sum}");
            for j in 0..n {
                let (li, lj) = (g.elements[i as usize].len, g.elements[j as usize].len);
                assert!((li * ff.f(i, j) - lj * ff.f(j, i)).abs() < 1e-14);
            }
        }
        // A flat element sees nothing of itself nor of its collinear neighbours.
        assert_eq!(ff.f(0, 0), 0.0);
        if splits > 1 {
            assert_eq!(ff.f(0, 1), 0.0);
        }
    }
}

fn blocked(segs: &[PosedSegment], x: [f64; 2], y: [f64; 2], skip: [usize; 2]) -> bool {
    use rhier::flatland::scene::orient;
    segs.iter().enumerate().any(|(k, s)| {
        !skip.contains(&k)
            && orient(x, y, s.a) * orient(x, y, s.b) < 0.0
            && orient(s.a, s.b, x) * orient(s.a, s.b, y) < 0.0
    })
}

/// Midpoint quadrature of the 2D point kernel `cos_i cos_j / (2 r)` with visibility
/// (Figure 4 of the paper), `m x m` samples.
fn quadrature(segs: &[PosedSegment], i: usize, j: usize, m: usize) -> f64 {
    let (si, sj) = (&segs[i], &segs[j]);
    let mut acc = 0.0;
    for a in 0..m {
        let x = si.at((a as f64 + 0.5) / m as f64);
        for b in 0..m {
            let y = sj.at((b as f64 + 0.5) / m as f64);
            let d = [y[0] - x[0], y[1] - x[1]];
            let r = d[0].hypot(d[1]);
            let ci = (d[0] * si.n[0] + d[1] * si.n[1]) / r;
            let cj = -(d[0] * sj.n[0] + d[1] * sj.n[1]) / r;
            if ci <= 0.0 || cj <= 0.0 || blocked(segs, x, y, [i, j]) {
                continue;
            }
            acc += ci * cj / (2.0 * r);
        }
    }
    // (1 / L_i) * sum * (L_i / m) * (L_j / m)
    acc * sj.len / (m * m) as f64
}

#[test]
fn string_rule_matches_quadrature_on_random_scenes() {
    let mut checked_hidden = 0;
    for seed in 1..4u64 {
        let segs = random_segments(seed, 7, 0.1);
        let g = geom(segs.clone());
        let (ff, _) = form_factors(&g);
        for i in 0..segs.len() {
            for j in 0..segs.len() {
                if i == j {
                    continue;
                }
                let q = quadrature(&segs, i, j, 400);
                let exact = ff.f(i as u32, j as u32);
                // Midpoint rule with visibility steps: error O(1/m).
                assert!(
                    (q - exact).abs() < 4e-3 + 1e-2 * exact,
                    "seed {seed} pair ({i}, {j}): string rule {exact}, quadrature {q}"
                );
                let unoccluded = geom(vec![segs[i], segs[j]]);
                let (ff0, _) = form_factors(&unoccluded);
                if ff0.f(0, 1) > exact + 1e-3 && exact > 1e-3 {
                    checked_hidden += 1; // a partly hidden pair
                }
            }
        }
    }
    assert!(
        checked_hidden >= 3,
        "only {checked_hidden} partly hidden pairs"
    );
}

#[test]
fn closure_holds_with_massively_collinear_points() {
    // A room with a 3 x 3 lattice of boxes: many points on common lines (rows,
    // columns, diagonals), so most events are degenerate blocks.
    let mut segs = Vec::new();
    let room = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
    for k in 0..4 {
        segs.push(seg(room[k], room[(k + 1) % 4]));
    }
    for i in 0..3 {
        for j in 0..3 {
            let (x, y) = (1.0 + i as f64, 1.0 + j as f64);
            let b = [
                [x - 0.25, y - 0.25],
                [x - 0.25, y + 0.25],
                [x + 0.25, y + 0.25],
                [x + 0.25, y - 0.25],
            ];
            for k in 0..4 {
                segs.push(seg(b[k], b[(k + 1) % 4]));
            }
        }
    }
    let n = segs.len();
    for splits in [1usize, 2] {
        let ts: Vec<f64> = (1..splits).map(|k| k as f64 / splits as f64).collect();
        let g = FlatGeometry::new(segs.clone(), &vec![ts; n]);
        let (ff, stats) = form_factors(&g);
        let m = g.elements.len() as u32;
        for i in 0..m {
            let sum: f64 = (0..m).map(|j| ff.f(i, j)).sum();
            assert!((sum - 1.0).abs() < 1e-12, "splits {splits} row {i}: {sum}");
        }
        assert!(stats.events > 0);
    }
}
