//! Visibility throughput: rhier's `SceneBvh::occluded` (the call every solver ray goes
//! through) against a bare obvhs CWBVH `ray_traverse_miss` loop on the same segments
//! and triangles. `cargo bench --bench visibility`
//!
//! Scene: a 10 m room with an n × n grid of boxes on the floor (6 quads each, n = 129
//! gives ~200k triangles), segments between random points of random patches (the
//! shape of the solver's link rays: surface to surface, incoherent).

use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{DVec3, Vec3A};
use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris, ray::Ray, triangle::Triangle};
use rhier::geometry::{Patches, SceneBvh};
use rhier::oracle::hash3;
use rhier::scene::{Material, MaterialId, Object, Polygon, Scene};

fn boxes_scene(n: usize) -> Scene {
    let q = |v: [[f64; 3]; 4]| Polygon {
        vertices: v.iter().map(|&p| DVec3::from_array(p)).collect(),
        material: MaterialId(0),
    };
    let (s, h) = (10.0, 4.0);
    let mut polys = vec![
        q([[0.0, 0.0, 0.0], [0.0, 0.0, s], [s, 0.0, s], [s, 0.0, 0.0]]),
        q([[0.0, h, 0.0], [s, h, 0.0], [s, h, s], [0.0, h, s]]),
        q([[0.0, 0.0, s], [0.0, h, s], [s, h, s], [s, 0.0, s]]),
        q([[0.0, 0.0, 0.0], [s, 0.0, 0.0], [s, h, 0.0], [0.0, h, 0.0]]),
        q([[0.0, 0.0, 0.0], [0.0, h, 0.0], [0.0, h, s], [0.0, 0.0, s]]),
        q([[s, 0.0, 0.0], [s, 0.0, s], [s, h, s], [s, h, 0.0]]),
    ];
    let pitch = (s - 1.0) / n as f64;
    for i in 0..n {
        for j in 0..n {
            let (x0, z0) = (0.5 + i as f64 * pitch, 0.5 + j as f64 * pitch);
            let (x1, z1, y1) = (
                x0 + 0.6 * pitch,
                z0 + 0.6 * pitch,
                0.05 + 0.03 * ((i * 7 + j * 13) % 11) as f64,
            );
            polys.push(q([[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]]));
            polys.push(q([
                [x0, 0.0, z0],
                [x1, 0.0, z0],
                [x1, y1, z0],
                [x0, y1, z0],
            ]));
            polys.push(q([
                [x1, 0.0, z1],
                [x0, 0.0, z1],
                [x0, y1, z1],
                [x1, y1, z1],
            ]));
            polys.push(q([
                [x0, 0.0, z1],
                [x0, 0.0, z0],
                [x0, y1, z0],
                [x0, y1, z1],
            ]));
            polys.push(q([
                [x1, 0.0, z0],
                [x1, 0.0, z1],
                [x1, y1, z1],
                [x1, y1, z0],
            ]));
        }
    }
    Scene {
        materials: vec![Material {
            name: "w".into(),
            rho: [0.5; 3],
            emission: [1.0; 3],
        }],
        objects: vec![Object {
            name: "room".into(),
            polygons: polys,
            motion: None,
        }],
        ..Default::default()
    }
}

fn segments(p: &Patches, count: usize) -> Vec<(DVec3, DVec3)> {
    let u = |h: u64| (h >> 11) as f64 / (1u64 << 53) as f64;
    (0..count as u64)
        .map(|k| {
            let i = (hash3(1, k, 0) % p.len() as u64) as usize;
            let j = (hash3(2, k, 0) % p.len() as u64) as usize;
            (
                p.point(i, u(hash3(3, k, 0)), u(hash3(4, k, 0))),
                p.point(j, u(hash3(5, k, 0)), u(hash3(6, k, 0))),
            )
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let n: usize = std::env::var("RHIER_BENCH_GRID")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(129);
    let scene = boxes_scene(n);
    let patches = Patches::at_time(&scene, 0.0);
    let bvh = SceneBvh::build(&scene, &patches, 0.0);
    let segs = segments(&patches, 20_000);
    // The bare loop: same triangles, same trims, obvhs alone.
    let f = |v: DVec3| Vec3A::new(v.x as f32, v.y as f32, v.z as f32);
    let mut tris = Vec::new();
    for poly in &patches.polys {
        let v = poly.corners();
        for k in 1..v.len() - 1 {
            tris.push(Triangle {
                v0: f(v[0]),
                v1: f(v[k]),
                v2: f(v[k + 1]),
            });
        }
    }
    let bare = build_cwbvh_from_tris(
        &tris,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let tris: Vec<Triangle> = bare
        .primitive_indices
        .iter()
        .map(|&i| tris[i as usize])
        .collect();
    let trim = rhier::geometry::SEGMENT_TRIM as f32;
    let mut g = c.benchmark_group(format!("occlusion_{}k_triangles", tris.len() / 1000));
    g.throughput(Throughput::Elements(segs.len() as u64));
    g.bench_function("rhier_scene_bvh", |b| {
        b.iter(|| segs.iter().filter(|(a, e)| bvh.occluded(*a, *e)).count())
    });
    g.bench_function("bare_obvhs_loop", |b| {
        b.iter(|| {
            segs.iter()
                .filter(|(a, e)| {
                    let ray = Ray::new(f(*a), f(*e - *a), trim, 1.0 - trim);
                    !bare.ray_traverse_miss(ray, |r, id| tris[id].intersect(r))
                })
                .count()
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(5));
    targets = bench
}
criterion_main!(benches);
