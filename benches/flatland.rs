//! Flatland benchmarks: visibility-complex construction against the scene size, and
//! the moving-object update against a full recomputation. Results in BENCHMARKS.md
//! ("## Flatland"). Run: `cargo bench --bench flatland`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use rhier::flatland::complex::sweep;
use rhier::flatland::dynamic::Dynamic;
use rhier::flatland::geometry::FlatGeometry;
use rhier::flatland::geometry_at;
use rhier::flatland::mesh::Mesh;
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::{PosedSegment, first_crossing, parse};
use rhier::flatland::views::{Topology, all_views, visibility_graph};

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        rhier::oracle::unit(self.0)
    }
}

/// `n` random non-crossing segments in the unit square (length ~ 0.6 / sqrt(n)).
fn random_scene(seed: u64, n: usize) -> FlatGeometry {
    let mut rng = Lcg(seed);
    let mut segs: Vec<PosedSegment> = Vec::new();
    let l = 0.6 / (n as f64).sqrt();
    while segs.len() < n {
        let a = [rng.next(), rng.next()];
        let ang = rng.next() * std::f64::consts::TAU;
        let len = l * (0.5 + rng.next());
        let s = PosedSegment::new(a, [a[0] + len * ang.cos(), a[1] + len * ang.sin()], 0);
        let mut all = segs.clone();
        all.push(s);
        if first_crossing(&all).is_none() {
            segs.push(s);
        }
    }
    FlatGeometry::new(segs, &vec![Vec::new(); n])
}

fn complex_construction(c: &mut Criterion) {
    let mut g = c.benchmark_group("flatland_complex");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for n in [10usize, 20, 40, 80, 160, 320] {
        let geom = random_scene(7, n);
        let topo = Topology::new(&geom);
        let (views, vs) = all_views(&geom, &topo);
        let m = visibility_graph(&topo, &views).len();
        let (_, fs) = form_factors(&geom);
        eprintln!(
            "n = {n}: points {}, visibility-graph edges m = {m}, view boundaries {}, \
             sweep events {}, intervals {}",
            geom.points.len(),
            vs.boundaries,
            vs.events,
            fs.intervals
        );
        g.bench_with_input(BenchmarkId::new("views", n), &geom, |b, geom| {
            b.iter(|| black_box(all_views(geom, &Topology::new(geom))))
        });
        g.bench_with_input(BenchmarkId::new("form_factors", n), &geom, |b, geom| {
            b.iter(|| black_box(form_factors(geom)))
        });
        if n <= 160 {
            let out = sweep(&geom, None, true);
            let cx = out.complex.as_ref().unwrap();
            eprintln!(
                "n = {n}: dual sweep: complex vertices {}, faces {}, edges {}, cells {}",
                cx.vertices.len(),
                cx.faces.len(),
                cx.edges.len(),
                cx.cells.len()
            );
            g.bench_with_input(
                BenchmarkId::new("dual_sweep_complex", n),
                &geom,
                |b, geom| b.iter(|| black_box(sweep(geom, None, true))),
            );
            g.bench_with_input(BenchmarkId::new("dual_sweep_mu", n), &geom, |b, geom| {
                b.iter(|| black_box(sweep(geom, None, false)))
            });
        }
    }
    g.finish();
}

/// A 4 x 3 room with a light, `k` static boxes and one box moving across.
fn moving_scene(k: usize) -> String {
    let mut objs = vec![
        r#"{"name": "room", "segments": [
        {"a": [0, 0], "b": [4, 0], "reflectance": 0.7},
        {"a": [4, 0], "b": [4, 3], "reflectance": 0.7},
        {"a": [4, 3], "b": [2.5, 3], "reflectance": 0.7},
        {"a": [2.5, 3], "b": [1.5, 3], "reflectance": 0.5, "emission": 10},
        {"a": [1.5, 3], "b": [0, 3], "reflectance": 0.7},
        {"a": [0, 3], "b": [0, 0], "reflectance": 0.7}]}"#
            .to_string(),
    ];
    let boxj = |name: &str, x: f64, y: f64, s: f64, motion: &str| {
        format!(
            r#"{{"name": "{name}", "segments": [
            {{"a": [{x}, {y}], "b": [{x}, {y1}], "reflectance": 0.5}},
            {{"a": [{x}, {y1}], "b": [{x1}, {y1}], "reflectance": 0.5}},
            {{"a": [{x1}, {y1}], "b": [{x1}, {y}], "reflectance": 0.5}},
            {{"a": [{x1}, {y}], "b": [{x}, {y}], "reflectance": 0.5}}]{motion}}}"#,
            y1 = y + s,
            x1 = x + s
        )
    };
    let mut rng = Lcg(3);
    for i in 0..k {
        // Static boxes on a jittered grid in the lower part of the room (6 or 12 per
        // row).
        let per_row = if k > 24 { 12 } else { 6 };
        let (col, row) = (i % per_row, i / per_row);
        let (dx, s) = if k > 24 { (0.3, 0.12) } else { (0.6, 0.2) };
        let x = 0.3 + col as f64 * dx + 0.1 * rng.next();
        let y = 0.2 + row as f64 * 0.45 + 0.1 * rng.next();
        objs.push(boxj(&format!("b{i}"), x, y, s, ""));
    }
    objs.push(boxj(
        "mover",
        0.2,
        2.4,
        0.25,
        r#", "motion": [{"t": 0, "translation": [0, 0]}, {"t": 1, "translation": [3.3, 0]}]"#,
    ));
    format!(
        r#"{{"rhier_flatland": 1, "objects": [{}]}}"#,
        objs.join(",")
    )
}

fn moving_update(c: &mut Criterion) {
    let mut g = c.benchmark_group("flatland_update");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for k in [0usize, 6, 12, 24, 48] {
        let text = moving_scene(k);
        let scene = parse(std::path::Path::new("bench"), &text).unwrap();
        for (t0, t1) in [(0.50, 0.52), (0.30, 0.70)] {
            let (mut d, _) = Dynamic::new(&scene, Mesh::None, t0);
            let rep = d.step(t1);
            eprintln!(
                "boxes {k}, step {t0} -> {t1}: segments {}, points {}, events {} of {} candidates \
                 ({} triples), views re-swept {}, points evaluated {}, edges {}, faces {}, \
                 update recomputes {} of {} form factors ({:.1} %); \
                 find {:.2} ms, apply {:.2} ms, measure {:.2} ms, total {:.2} ms",
                d.geometry().segments.len(),
                d.geometry().points.len(),
                rep.events,
                rep.event_candidates,
                rep.triples_tested,
                rep.views_reswept,
                rep.points_evaluated,
                rep.edges_visited,
                rep.faces_visited,
                rep.ff_recomputed,
                rep.ff_total,
                100.0 * rep.ff_recomputed as f64 / rep.ff_total as f64,
                1e3 * rep.seconds_find,
                1e3 * rep.seconds_apply,
                1e3 * rep.seconds_measure,
                1e3 * rep.seconds,
            );
            let id = format!("{k}_{t0}_{t1}");
            let (mut d, _) = Dynamic::new(&scene, Mesh::None, t0);
            let mut at = t0;
            g.bench_function(BenchmarkId::new("update_step", &id), |b| {
                b.iter(|| {
                    at = if at == t0 { t1 } else { t0 };
                    black_box(d.step(at))
                })
            });
        }
        g.bench_function(BenchmarkId::new("full_recompute", k), |b| {
            b.iter(|| black_box(form_factors(&geometry_at(&scene, 0.52, Mesh::None))))
        });
    }
    g.finish();
}

criterion_group!(benches, complex_construction, moving_update);
criterion_main!(benches);
