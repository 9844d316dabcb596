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

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
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
    for n in [10usize, 20, 40, 80, 160] {
        let geom = random_scene(7, n);
        let out = sweep(&geom, None, true);
        let cx = out.complex.as_ref().unwrap();
        eprintln!(
            "n = {n}: points {}, complex vertices m = {}, faces {}, edges {}, cells {}",
            geom.points.len(),
            cx.vertices.len(),
            cx.faces.len(),
            cx.edges.len(),
            cx.cells.len()
        );
        g.bench_with_input(BenchmarkId::new("complex", n), &geom, |b, geom| {
            b.iter(|| black_box(sweep(geom, None, true)))
        });
        g.bench_with_input(BenchmarkId::new("form_factors", n), &geom, |b, geom| {
            b.iter(|| black_box(form_factors(geom)))
        });
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
        // Static boxes on a jittered grid in the lower part of the room.
        let (col, row) = (i % 6, i / 6);
        let x = 0.3 + col as f64 * 0.6 + 0.1 * rng.next();
        let y = 0.2 + row as f64 * 0.45 + 0.1 * rng.next();
        objs.push(boxj(&format!("b{i}"), x, y, 0.2, ""));
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
    for k in [0usize, 6, 12, 24] {
        let text = moving_scene(k);
        let scene = parse(std::path::Path::new("bench"), &text).unwrap();
        let (t0, t1) = (0.50, 0.52);
        let (mut d, _) = Dynamic::new(&scene, Mesh::None, t0);
        let rep = d.step(t1);
        eprintln!(
            "boxes {k}: segments {}, faces visited {}, update recomputes {} of {} form factors ({:.1} %), {} casts",
            d.geometry().segments.len(),
            rep.faces_visited,
            rep.ff_recomputed,
            rep.ff_total,
            100.0 * rep.ff_recomputed as f64 / rep.ff_total as f64,
            rep.casts
        );
        let (mut d, _) = Dynamic::new(&scene, Mesh::None, t0);
        let mut at = t0;
        g.bench_function(BenchmarkId::new("update_step", k), |b| {
            b.iter(|| {
                at = if at == t0 { t1 } else { t0 };
                black_box(d.step(at))
            })
        });
        g.bench_function(BenchmarkId::new("full_recompute", k), |b| {
            b.iter(|| black_box(form_factors(&geometry_at(&scene, t1, Mesh::None))))
        });
    }
    g.finish();
}

criterion_group!(benches, complex_construction, moving_update);
criterion_main!(benches);
