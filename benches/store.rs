//! Benchmarks of the `.rhier` store and playback (BENCHMARKS.md, "Store and playback"):
//!
//! - `file_size`: bytes per frame of a space-time file (static leaves stored once)
//!   against a file storing each frame's leaves separately (printed once, not timed);
//! - `open_and_play`: open a file and render one frame at mid-animation, for files of
//!   24, 240 and 2400 chunks (should not grow with the file's length);
//! - `probe`: probe throughput on a ~100k-patch box, from a file.
//!
//! Run: `cargo bench --bench store`.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use rhier::playback::nearest::nearest_brute_force;
use rhier::playback::raster::{FrameMesh, Shading, auto_camera, render};
use rhier::playback::{Frame, ProbePoint, probe};
use rhier::solution::Leaf;
use rhier::store::samples::{AnimatedSample, animated_box, tiled_box};
use rhier::store::{Reader, SolutionHeader, WriteOptions, Writer, write_solution};

fn write_space_time(path: &Path, s: &AnimatedSample) {
    let mut w = Writer::create(
        path,
        &SolutionHeader::of(&s.solution),
        WriteOptions::default(),
    )
    .unwrap();
    for (t0, t1, leaves) in &s.chunks {
        w.write_chunk(*t0, *t1, leaves).unwrap();
    }
    w.finish(&s.solution.stats).unwrap();
}

/// Every frame stores all its leaves (walls repeated), as independent per-frame
/// solves would.
fn write_per_frame(path: &Path, s: &AnimatedSample) {
    let mut w = Writer::create(
        path,
        &SolutionHeader::of(&s.solution),
        WriteOptions::default(),
    )
    .unwrap();
    // Patch 7 is the moving plate; every other leaf of chunk 0 holds over [0, 1].
    let walls: Vec<Leaf> = s.chunks[0]
        .2
        .iter()
        .filter(|l| l.patch != 7)
        .copied()
        .collect();
    for (t0, t1, leaves) in &s.chunks {
        let mut frame: Vec<Leaf> = walls
            .iter()
            .map(|l| Leaf {
                time: [*t0 as f32, *t1 as f32],
                ..*l
            })
            .collect();
        frame.extend(leaves.iter().filter(|l| l.patch == 7));
        w.write_chunk(*t0, *t1, &frame).unwrap();
    }
    w.finish(&s.solution.stats).unwrap();
}

fn file_size(_c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let frames = 240;
    let s = animated_box(16, frames);
    let (a, b) = (dir.path().join("st.rhier"), dir.path().join("pf.rhier"));
    write_space_time(&a, &s);
    write_per_frame(&b, &s);
    let (sa, sb) = (
        std::fs::metadata(&a).unwrap().len(),
        std::fs::metadata(&b).unwrap().len(),
    );
    let (la, lb) = (Reader::open(&a).unwrap(), Reader::open(&b).unwrap());
    let count = |r: &Reader| r.chunks().iter().map(|c| c.leaves as u64).sum::<u64>();
    println!(
        "file_size: {frames} frames, {} static + {} moving leaves per frame",
        s.chunks[0].2.len() - 256,
        256
    );
    println!(
        "file_size: space-time {sa} B ({:.0} B/frame, {} leaves stored); per-frame {sb} B ({:.0} B/frame, {} leaves stored); ratio {:.1}x",
        sa as f64 / frames as f64,
        count(&la),
        sb as f64 / frames as f64,
        count(&lb),
        sb as f64 / sa as f64
    );
}

fn open_and_play(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("open_and_play");
    g.sample_size(20);
    g.measurement_time(std::time::Duration::from_secs(3));
    for frames in [24u32, 240, 2400, 24000] {
        let path = dir.path().join(format!("a{frames}.rhier"));
        write_space_time(&path, &animated_box(8, frames));
        let bytes = std::fs::metadata(&path).unwrap().len();
        println!("open_and_play: {frames} chunks, {bytes} bytes");
        g.bench_function(format!("open_{frames}_chunks"), |b| {
            b.iter(|| black_box(Reader::open(&path).unwrap()))
        });
        g.bench_function(format!("open_play_{frames}_chunks"), |b| {
            b.iter(|| {
                let r = Reader::open(&path).unwrap();
                let frame = Frame::build(&r, 0.5).unwrap();
                let mesh = FrameMesh::build(&frame, Shading::Smooth);
                black_box(render(&mesh, &auto_camera(&frame), 160, 120))
            })
        });
    }
    g.finish();
}

fn probe_throughput(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tiled.rhier");
    let sol = tiled_box(128, 1);
    write_solution(&path, &sol, WriteOptions::default()).unwrap();
    let r = Reader::open(&path).unwrap();
    println!(
        "probe: {} patches, {} leaves",
        r.patches().len(),
        sol.leaves.len()
    );
    let mut s = 1u64;
    let mut rnd = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        rhier::oracle::unit(s)
    };
    let points: Vec<ProbePoint> = (0..10_000)
        .map(|k| {
            let axis = k % 3;
            let mut p = DVec3::new(rnd(), rnd(), rnd());
            let mut n = DVec3::ZERO;
            let side = (k / 3) % 2;
            p[axis] = if side == 0 { 0.01 } else { 0.99 };
            n[axis] = if side == 0 { 1.0 } else { -1.0 };
            ProbePoint { p, n }
        })
        .collect();
    let mut g = c.benchmark_group("probe");
    g.sample_size(10);
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("10k_points_100k_patches_from_file", |b| {
        b.iter(|| black_box(probe(&r, &points, 0.0).unwrap()))
    });
    let frame = Frame::build(&r, 0.0).unwrap();
    g.bench_function("10k_points_100k_patches_frame_built", |b| {
        b.iter(|| {
            black_box(rhier::playback::probe::probe_frame(Path::new("x"), &frame, &points).unwrap())
        })
    });
    // Baseline: the plain scan over every patch, on 1% of the points.
    let ids: Vec<u32> = (0..frame.patches.len() as u32).collect();
    g.throughput(Throughput::Elements(100));
    g.bench_function("100_points_100k_patches_brute_force_nearest", |b| {
        b.iter(|| {
            for p in &points[..100] {
                let facing = |k: u32| frame.patches[k as usize].normal.dot(p.n) > 0.0;
                black_box(nearest_brute_force(&frame.patches, &ids, p.p, facing));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, file_size, open_and_play, probe_throughput);
criterion_main!(benches);
