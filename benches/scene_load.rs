//! Scene loading throughput: load + validate of generated scenes of 20 000 quads
//! (a 100 x 100 grid per object, 2 objects) in native JSON and OBJ, and of the
//! committed animated glTF sample.
//!
//! `cargo bench --bench scene_load`; results in BENCHMARKS.md, section "## scene".

use std::fmt::Write;
use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use rhier::scene;

const N: usize = 100;

/// Two N x N grids of unit quads facing +y (floor) and -y (ceiling, emitting).
fn grid_json() -> String {
    let mut s = String::from(
        r#"{"rhier_scene": 1, "materials": {"w": {"reflectance": [0.5,0.5,0.5]}, "e": {"reflectance": [0.5,0.5,0.5], "emission": [1,1,1]}}, "objects": ["#,
    );
    for (o, (y, mat)) in [(0.0, "w"), (10.0, "e")].iter().enumerate() {
        if o > 0 {
            s.push(',');
        }
        write!(s, r#"{{"name": "grid{o}", "polygons": ["#).unwrap();
        for i in 0..N {
            for j in 0..N {
                if i + j > 0 {
                    s.push(',');
                }
                let (x0, z0, x1, z1) = (i as f64, j as f64, i as f64 + 1.0, j as f64 + 1.0);
                let v = if *mat == "w" {
                    [[x0, z0], [x0, z1], [x1, z1], [x1, z0]]
                } else {
                    [[x0, z0], [x1, z0], [x1, z1], [x0, z1]]
                };
                write!(
                    s,
                    r#"{{"vertices": [[{},{y},{}],[{},{y},{}],[{},{y},{}],[{},{y},{}]], "material": "{mat}"}}"#,
                    v[0][0], v[0][1], v[1][0], v[1][1], v[2][0], v[2][1], v[3][0], v[3][1]
                )
                .unwrap();
            }
        }
        s.push_str("]}");
    }
    s.push_str("]}");
    s
}

fn grid_obj(dir: &Path) -> std::path::PathBuf {
    let mut s = String::from("mtllib g.mtl\n");
    for y in [0.0, 10.0] {
        for i in 0..=N {
            for j in 0..=N {
                writeln!(s, "v {i} {y} {j}").unwrap();
            }
        }
    }
    let id = |g: usize, i: usize, j: usize| g * (N + 1) * (N + 1) + i * (N + 1) + j + 1;
    for g in 0..2 {
        writeln!(s, "o grid{g}\nusemtl {}", if g == 0 { "w" } else { "e" }).unwrap();
        for i in 0..N {
            for j in 0..N {
                let (a, b, c, d) = (
                    id(g, i, j),
                    id(g, i, j + 1),
                    id(g, i + 1, j + 1),
                    id(g, i + 1, j),
                );
                if g == 0 {
                    writeln!(s, "f {a} {b} {c} {d}").unwrap();
                } else {
                    writeln!(s, "f {a} {d} {c} {b}").unwrap();
                }
            }
        }
    }
    std::fs::write(
        dir.join("g.mtl"),
        "newmtl w\nKd 0.5 0.5 0.5\nnewmtl e\nKd 0.5 0.5 0.5\nKe 1 1 1\n",
    )
    .unwrap();
    let path = dir.join("g.obj");
    std::fs::write(&path, s).unwrap();
    path
}

fn bench(c: &mut Criterion) {
    let json = grid_json();
    let s = scene::load_json_str(&json, Path::new("grid.json")).unwrap();
    assert_eq!(s.polygon_count(), 2 * N * N);
    assert!(s.warnings.is_empty());
    c.bench_function("json_20k_quads", |b| {
        b.iter(|| scene::load_json_str(black_box(&json), Path::new("grid.json")).unwrap())
    });

    let dir = tempfile::tempdir().unwrap();
    let obj = grid_obj(dir.path());
    let s = scene::load(&obj).unwrap();
    assert_eq!(s.polygon_count(), 2 * N * N);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    c.bench_function("obj_20k_quads", |b| {
        b.iter(|| scene::load(black_box(&obj)).unwrap())
    });

    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("formats/examples/moving_cube.glb");
    c.bench_function("glb_moving_cube", |b| {
        b.iter(|| scene::load(black_box(&glb)).unwrap())
    });

    c.bench_function("cornell_box_embedded", |b| {
        b.iter(|| scene::cornell_box(black_box(true)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
