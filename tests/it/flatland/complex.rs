//! The visibility complex (paper §2.2–2.3) against brute-force visibility on random
//! scenes in general position: labels of sampled lines, face connectivity on a grid
//! of the dual plane, chains (eq. 3), vertices = visibility-graph edges.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use rhier::flatland::complex::{Complex, sweep};
use rhier::flatland::geometry::{FlatGeometry, Hit};
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::{PosedSegment, orient};

use crate::common::{Lcg, random_flat_geometry};

/// Labels (unordered segment pairs) of the free segments of a line, by brute force.
fn brute_labels(g: &FlatGeometry, theta: f64, p: f64) -> Vec<(u32, u32)> {
    let mut hits: Vec<Hit> = Vec::new();
    g.cast(theta, p, &mut hits);
    let mut out: Vec<(u32, u32)> = hits
        .windows(2)
        .map(|h| (h[0].elem.min(h[1].elem), h[0].elem.max(h[1].elem)))
        .collect();
    out.sort_unstable();
    out
}

/// (label, face) of the complex's cells containing the line.
fn complex_labels(g: &FlatGeometry, c: &Complex, theta: f64, p: f64) -> Vec<((u32, u32), u32)> {
    let mut out: Vec<((u32, u32), u32)> = c
        .locate(g, theta, p)
        .iter()
        .map(|id| {
            let cell = &c.cells[id.0 as usize];
            (
                (cell.from.min(cell.to), cell.from.max(cell.to)),
                cell.face.0,
            )
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn sampled_lines_have_the_labels_of_their_cells() {
    for seed in 1..6u64 {
        let g = random_flat_geometry(seed, 6, 1);
        let c = sweep(&g, None, true).complex.unwrap();
        let mut rng = Lcg(seed + 100);
        for _ in 0..2000 {
            let theta = rng.next() * 2.0 * PI;
            let p = -1.5 + 3.0 * rng.next();
            let brute = brute_labels(&g, theta, p);
            let got: Vec<(u32, u32)> = complex_labels(&g, &c, theta, p)
                .into_iter()
                .map(|x| x.0)
                .collect();
            assert_eq!(brute, got, "seed {seed}, line ({theta}, {p})");
        }
    }
}

#[test]
#[expect(
    clippy::needless_range_loop,
    reason = "grid indices are used in several arrays"
)]
fn faces_are_the_connected_components_of_each_label() {
    for seed in 1..4u64 {
        let g = random_flat_geometry(seed, 5, 1);
        let c = sweep(&g, None, true).complex.unwrap();
        let (nt, np) = (220usize, 220usize);
        let pr = 1.5;
        let at = |i: usize, j: usize| {
            let th = c.theta0 + (i as f64 + 0.5) / nt as f64 * PI;
            let p = -pr + (j as f64 + 0.5) / np as f64 * 2.0 * pr;
            (th, p)
        };
        // Grid of (label -> face) per sample.
        let mut grid: Vec<Vec<((u32, u32), u32)>> = Vec::with_capacity(nt * np);
        for i in 0..nt {
            for j in 0..np {
                let (th, p) = at(i, j);
                let labels = complex_labels(&g, &c, th, p);
                let brute = brute_labels(&g, th, p);
                assert_eq!(labels.iter().map(|x| x.0).collect::<Vec<_>>(), brute);
                grid.push(labels);
            }
        }
        // Union-find over (sample, label) nodes: neighbours with the same label.
        let idx = |i: usize, j: usize| i * np + j;
        let mut comp: HashMap<(usize, (u32, u32)), usize> = HashMap::new();
        let mut parent: Vec<usize> = Vec::new();
        for k in 0..nt * np {
            for (l, _) in &grid[k] {
                comp.insert((k, *l), parent.len());
                parent.push(parent.len());
            }
        }
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
        let link = |a: usize, b: usize, parent: &mut Vec<usize>| {
            for (l, fa) in &grid[a] {
                if let Some((_, fb)) = grid[b].iter().find(|(m, _)| m == l) {
                    // No over-splitting: neighbouring samples of one label share a face.
                    assert_eq!(fa, fb, "seed {seed}: label {l:?} split between faces");
                    let (x, y) = (comp[&(a, *l)], comp[&(b, *l)]);
                    let (rx, ry) = (find(parent, x), find(parent, y));
                    parent[rx] = ry;
                }
            }
        };
        for i in 0..nt {
            for j in 0..np {
                if i + 1 < nt {
                    link(idx(i, j), idx(i + 1, j), &mut parent);
                }
                if j + 1 < np {
                    link(idx(i, j), idx(i, j + 1), &mut parent);
                }
            }
        }
        // The seam: (theta0 + pi, p) is (theta0, -p).
        for j in 0..np {
            link(idx(nt - 1, j), idx(0, np - 1 - j), &mut parent);
        }
        // No under-splitting: each face hit by the grid is one grid component.
        let mut comps_of_face: HashMap<u32, HashSet<usize>> = HashMap::new();
        for k in 0..nt * np {
            for (l, f) in &grid[k] {
                let r = find(&mut parent, comp[&(k, *l)]);
                comps_of_face.entry(*f).or_default().insert(r);
            }
        }
        let mut merged = 0;
        for (f, comps) in &comps_of_face {
            if comps.len() < 2 {
                continue;
            }
            // Faces taper to a point at their extremal vertices, where grid samples
            // are isolated: only components of 20+ samples count.
            let mut sizes: HashMap<usize, usize> = HashMap::new();
            for k in 0..nt * np {
                for (l, ff) in &grid[k] {
                    if ff == f {
                        *sizes.entry(find(&mut parent, comp[&(k, *l)])).or_default() += 1;
                    }
                }
            }
            if sizes.values().filter(|&&n| n >= 20).count() > 1 {
                merged += 1;
            }
        }
        assert_eq!(merged, 0, "seed {seed}: faces merging separate components");
        // Every face of visible size is seen by the grid.
        for (fi, f) in c.faces.iter().enumerate() {
            if f.measure > 0.05 {
                assert!(comps_of_face.contains_key(&(fi as u32)), "face {fi} missed");
            }
        }
    }
}

#[test]
fn chains_give_the_face_measure_by_eq_3_and_faces_sum_to_form_factors() {
    for seed in 1..6u64 {
        let g = random_flat_geometry(seed, 7, 1);
        let c = sweep(&g, None, true).complex.unwrap();
        let mut checked = 0;
        for (fi, f) in c.faces.iter().enumerate() {
            let seam =
                (f.theta[0] - c.theta0).abs() < 1e-12 || (f.theta[1] - c.theta0 - PI).abs() < 1e-12;
            if seam {
                continue;
            }
            let m = c.chain_measure(&g, rhier::flatland::complex::FaceId(fi as u32));
            assert!(
                (m - f.measure).abs() < 1e-12,
                "seed {seed} face {fi}: chains {m}, cells {}",
                f.measure
            );
            checked += 1;
        }
        assert!(checked > 10);
        // Front faces of a label sum to mu of the form factors.
        let (ff, _) = form_factors(&g);
        let mut sums: HashMap<(u32, u32), f64> = HashMap::new();
        for f in c.faces.iter().filter(|f| f.front) {
            *sums.entry((f.objects[0], f.objects[1])).or_default() += f.measure;
        }
        for (k, v) in &ff.mu {
            assert!((sums.get(k).copied().unwrap_or(0.0) - v).abs() < 1e-13);
        }
        assert_eq!(sums.len(), ff.mu.len());
    }
}

#[test]
fn vertices_are_the_visibility_graph_edges() {
    for seed in 1..6u64 {
        let g = random_flat_geometry(seed, 8, 1);
        let c = sweep(&g, None, true).complex.unwrap();
        c.validate(&g).unwrap();
        let got: HashSet<(u32, u32)> = c
            .vertices
            .iter()
            .map(|v| (v.u.min(v.w), v.u.max(v.w)))
            .collect();
        assert_eq!(got.len(), c.vertices.len());
        // Brute force: the open segment u w properly crosses no segment and is not a
        // segment itself (general position: no three points collinear).
        let mut want = HashSet::new();
        let pts = &g.points;
        for u in 0..pts.len() {
            for w in u + 1..pts.len() {
                let (pu, pw) = (pts[u], pts[w]);
                let own = g
                    .segments
                    .iter()
                    .any(|s| (s.a == pu && s.b == pw) || (s.a == pw && s.b == pu));
                let crossed = g.segments.iter().any(|s| {
                    orient(pu, pw, s.a) * orient(pu, pw, s.b) < 0.0
                        && orient(s.a, s.b, pu) * orient(s.a, s.b, pw) < 0.0
                });
                if !own && !crossed {
                    want.insert((u as u32, w as u32));
                }
            }
        }
        assert_eq!(got, want, "seed {seed}");
        // Every edge end at a vertex names a vertex through the edge's point.
        for e in &c.edges {
            for v in e.ends.iter().flatten() {
                let v = &c.vertices[v.0 as usize];
                assert!(v.u == e.point || v.w == e.point);
            }
        }
    }
}

#[test]
fn complex_of_degenerate_rooms_validates() {
    // Collinear corners, a lattice of boxes, split segments: the structure stays
    // consistent (face connectivity is only guaranteed in general position).
    let mut segs = Vec::new();
    let room = [[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]];
    for k in 0..4 {
        segs.push(PosedSegment::new(room[k], room[(k + 1) % 4], 0));
    }
    for (x, y) in [(1.0, 1.0), (2.0, 2.0), (1.0, 2.0)] {
        let b = [
            [x - 0.2, y - 0.2],
            [x - 0.2, y + 0.2],
            [x + 0.2, y + 0.2],
            [x + 0.2, y - 0.2],
        ];
        for k in 0..4 {
            segs.push(PosedSegment::new(b[k], b[(k + 1) % 4], 1));
        }
    }
    let n = segs.len();
    for splits in [vec![], vec![0.5], vec![0.25, 0.5, 0.75]] {
        let g = FlatGeometry::new(segs.clone(), &vec![splits.clone(); n]);
        let c = sweep(&g, None, true).complex.unwrap();
        c.validate(&g).unwrap();
        let (ff, _) = form_factors(&g);
        let mut sums: HashMap<(u32, u32), f64> = HashMap::new();
        for f in c.faces.iter().filter(|f| f.front) {
            *sums.entry((f.objects[0], f.objects[1])).or_default() += f.measure;
        }
        for (k, v) in &ff.mu {
            assert!((sums[k] - v).abs() < 1e-12);
        }
    }
}

#[test]
fn window_sweep_over_everything_finds_the_complex_faces() {
    use rhier::flatland::window::window_sweep;
    for seed in 1..8u64 {
        let g = random_flat_geometry(seed, 6, 1);
        let c = sweep(&g, None, true).complex.unwrap();
        let front = c.faces.iter().filter(|f| f.front).count();
        let w = window_sweep(&g, &[[-5.0, -5.0], [6.0, -5.0], [6.0, 6.0], [-5.0, 6.0]]);
        assert_eq!(w.faces, front, "seed {seed}");
        let (ff, _) = form_factors(&g);
        for (k, v) in &ff.mu {
            assert!((w.mu[k] - v).abs() < 1e-12);
        }
    }
}
