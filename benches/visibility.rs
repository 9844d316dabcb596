//! Visibility throughput: rhier's `SceneBvh::occluded` (the call every solver ray goes
//! through) against a bare obvhs CWBVH `ray_traverse_miss` loop on the same segments
//! and triangles. `cargo bench --bench visibility`
//!
//! Scene: a 10 m room with an n × n grid of boxes on the floor (6 quads each, n = 129
//! gives ~200k triangles), segments between random points of random patches (the
//! shape of the solver's link rays: surface to surface, incoherent).
//!
//! `RHIER_EXPORT_RAYS=DIR cargo bench --bench visibility` also writes the exact triangles
//! and rays of the bare loop to DIR (for `tools/embree_rays.py`, the Embree side of the
//! comparison), times both loops once more with a plain `Instant` (median and best of 9
//! runs, single thread) and prints the numbers; then criterion runs as usual. Files, all
//! little-endian: `tris.bin` (f32 × 9 per triangle: v0, v1, v2), `rays.bin` (f32 × 8 per
//! ray: origin, direction = end − origin, tmin, tmax, the bare loop's trims),
//! `occluded.bin` (u8 per ray: the bare loop's answer, 1 = occluded) and `meta.json` (counts of occluded rays and the measured rays/s). Without the variable
//! the bench does exactly what it did before.

use std::path::Path;
use std::time::{Duration, Instant};

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
        objects: vec![Object::still("room", polys)],
        ..Default::default()
    }
}

fn segments(p: &Patches, count: usize) -> Vec<(DVec3, DVec3)> {
    let u = rhier::oracle::unit;
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
    let rhier_count = || segs.iter().filter(|(a, e)| bvh.occluded(*a, *e)).count();
    let bare_count = || {
        segs.iter()
            .filter(|(a, e)| {
                let ray = Ray::new(f(*a), f(*e - *a), trim, 1.0 - trim);
                !bare.ray_traverse_miss(ray, |r, id| tris[id].intersect(r))
            })
            .count()
    };
    if let Some(dir) = std::env::var_os("RHIER_EXPORT_RAYS") {
        let rays: Vec<[f32; 8]> = segs
            .iter()
            .map(|(a, e)| {
                let (o, d) = (f(*a), f(*e - *a));
                [o.x, o.y, o.z, d.x, d.y, d.z, trim, 1.0 - trim]
            })
            .collect();
        let (rhier_occluded, rhier_rate, rhier_best) = timed(&rhier_count, segs.len());
        let (bare_occluded, bare_rate, bare_best) = timed(&bare_count, segs.len());
        println!(
            "export: {} triangles, {} rays; occluded: rhier {rhier_occluded}, bare obvhs \
             {bare_occluded}; single thread rays/s: rhier {:.3} M, bare obvhs {:.3} M \
             (rhier/bare {:.2}); best of 9: rhier {:.3} M, bare obvhs {:.3} M",
            tris.len(),
            rays.len(),
            rhier_rate / 1e6,
            bare_rate / 1e6,
            rhier_rate / bare_rate,
            rhier_best / 1e6,
            bare_best / 1e6
        );
        let meta = serde_json::json!({
            "grid": n,
            "triangles": tris.len(),
            "rays": rays.len(),
            "occluded_bare_obvhs": bare_occluded,
            "occluded_rhier": rhier_occluded,
            "rays_per_s_bare_obvhs": bare_rate,
            "rays_per_s_rhier": rhier_rate,
            "rays_per_s_bare_obvhs_best": bare_best,
            "rays_per_s_rhier_best": rhier_best,
        });
        let tri_floats = tris
            .iter()
            .flat_map(|t| [t.v0, t.v1, t.v2].into_iter().flat_map(|v| [v.x, v.y, v.z]));
        let answers: Vec<u8> = segs
            .iter()
            .map(|(a, e)| {
                let ray = Ray::new(f(*a), f(*e - *a), trim, 1.0 - trim);
                u8::from(!bare.ray_traverse_miss(ray, |r, id| tris[id].intersect(r)))
            })
            .collect();
        if let Err(e) = export(
            Path::new(&dir),
            tri_floats,
            rays.iter().flatten().copied(),
            &answers,
            &meta,
        ) {
            eprintln!("RHIER_EXPORT_RAYS={}: {e}", Path::new(&dir).display());
            std::process::exit(1);
        }
        println!(
            "export: wrote tris.bin, rays.bin, meta.json to {}",
            Path::new(&dir).display()
        );
    }
    let mut g = c.benchmark_group(format!("occlusion_{}k_triangles", tris.len() / 1000));
    g.throughput(Throughput::Elements(segs.len() as u64));
    g.bench_function("rhier_scene_bvh", |b| b.iter(rhier_count));
    g.bench_function("bare_obvhs_loop", |b| b.iter(bare_count));
    g.finish();
    bundles(c);
}

/// The solver's rays on a scene: bundles of 8 segments from a point of one patch to
/// 8 points of another that faces it (as a row's or the final gather's rays to a
/// surface source), both patches skipped, one shadow cache per bundle
/// (`occluded_between`), cast through each occlusion backend of one build. Scene:
/// `RHIER_BENCH_SCENE` (a scene file, e.g. `tools/gen_cubes.py 20 c20.json`; its
/// patches split at contacts as the solver's are), else the box grid above at n = 20.
/// Prints each backend's answers' count of blocked rays (they must agree) and the
/// best-of-5 single-thread rays/s; then criterion times each.
fn bundles(c: &mut Criterion) {
    use rhier::geometry::{LastHit, Parts, Rays, split_at_contacts};
    let scene = match std::env::var_os("RHIER_BENCH_SCENE") {
        Some(path) => match rhier::scene::load(Path::new(&path)) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("RHIER_BENCH_SCENE: {e}");
                std::process::exit(1);
            }
        },
        None => boxes_scene(20),
    };
    let patches = Patches::at_time(&scene, 0.0);
    let patches = split_at_contacts(&scene, &patches, 0.0).0;
    let mut bvh = SceneBvh::build(&scene, &patches, 0.0);
    let u = rhier::oracle::unit;
    let n = patches.len() as u64;
    let mut rays: Vec<[(DVec3, DVec3, [u32; 2]); 8]> = Vec::new();
    let mut k = 0u64;
    while rays.len() < 20_000 {
        k += 1;
        let i = (hash3(11, k, 0) % n) as usize;
        let j = (hash3(12, k, 0) % n) as usize;
        let x = patches.point(i, u(hash3(13, k, 0)), u(hash3(14, k, 0)));
        let y = patches.point(j, 0.5, 0.5);
        if i == j || patches.normals[i].dot(y - x) <= 0.0 || patches.normals[j].dot(x - y) <= 0.0 {
            continue;
        }
        let mut b = [(x, y, [i as u32, j as u32]); 8];
        for (r, e) in b.iter_mut().enumerate() {
            let (s, t) = ((r % 3) as f64, (r / 3) as f64);
            e.1 = patches.point(
                j,
                (s + u(hash3(15, k, r as u64))) / 3.0,
                (t + u(hash3(16, k, r as u64))) / 3.0,
            );
        }
        rays.push(b);
    }
    let cast = |bvh: &SceneBvh| {
        let mut blocked = 0usize;
        for b in &rays {
            let mut last = LastHit::default();
            for &(x, y, skip) in b {
                blocked += usize::from(bvh.occluded_between(x, y, skip, Parts::All, &mut last));
            }
        }
        blocked
    };
    let mut backends = vec![Rays::Obvhs, Rays::Cwbvh];
    if bvh.set_rays(Rays::Embree).is_ok() {
        backends.push(Rays::Embree);
    }
    let total = rays.len() * 8;
    let mut g = c.benchmark_group(format!("bundles_{}_patches", patches.len()));
    g.throughput(Throughput::Elements(total as u64));
    for rays_by in backends {
        bvh.set_rays(rays_by).expect("backend set above");
        let blocked = cast(&bvh);
        let best = (0..5)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(cast(&bvh));
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        println!(
            "bundles: {rays_by:?}: {blocked} of {total} rays blocked, {:.3} M rays/s (best of 5)",
            total as f64 / best / 1e6
        );
        g.bench_function(format!("{rays_by:?}"), |b| b.iter(|| cast(&bvh)));
    }
    g.finish();
}

/// Runs `count` 9 times (after one warm-up) and returns its answer and the rates in rays
/// per second for `rays` rays per run: (answer, median rate, best rate). The best run is
/// the one least disturbed by other work on a shared machine.
fn timed(count: &dyn Fn() -> usize, rays: usize) -> (usize, f64, f64) {
    let answer = count();
    let mut secs: Vec<f64> = (0..9)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(count());
            t.elapsed().as_secs_f64()
        })
        .collect();
    secs.sort_by(f64::total_cmp);
    let rate = |s: f64| rays as f64 / s;
    (answer, rate(secs[secs.len() / 2]), rate(secs[0]))
}

/// Writes `tris.bin`, `rays.bin` (little-endian f32), `occluded.bin` (u8 per ray) and
/// `meta.json` into `dir`.
fn export(
    dir: &Path,
    mut tris: impl Iterator<Item = f32>,
    mut rays: impl Iterator<Item = f32>,
    answers: &[u8],
    meta: &serde_json::Value,
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let le = |it: &mut dyn Iterator<Item = f32>| it.flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
    std::fs::write(dir.join("tris.bin"), le(&mut tris))?;
    std::fs::write(dir.join("rays.bin"), le(&mut rays))?;
    std::fs::write(dir.join("occluded.bin"), answers)?;
    std::fs::write(dir.join("meta.json"), format!("{meta:#}\n"))
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(5));
    targets = bench
}
criterion_main!(benches);
