//! Round trips through the `.rhier` file: what the writer puts in, the reader gives
//! back; probing the file equals probing the solution in memory; RAM-built and
//! file-built bytes are identical; chunked space-time files are read chunk by chunk.

use glam::DVec3;
use rhier::playback::{ProbePoint, SolutionView, probe};
use rhier::solution::{Leaf, Solution};
use rhier::store::samples::{
    PLATE_TRAVEL, animated_box, box_solution, plate_radiosity, wall_radiosity,
};
use rhier::store::{Reader, SolutionHeader, WriteOptions, Writer, encode_solution, write_solution};

use crate::common;

fn lcg(s: &mut u64) -> f64 {
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    rhier::oracle::unit(*s)
}

/// Random points on the inside of the walls, slightly off the surface, with the
/// inward normal.
fn wall_points(count: usize, seed: u64) -> Vec<(ProbePoint, DVec3)> {
    let mut s = seed;
    let mut out = Vec::new();
    for k in 0..count {
        let (a, b) = (0.02 + 0.96 * lcg(&mut s), 0.02 + 0.96 * lcg(&mut s));
        let axis = k % 3;
        let side = (k / 3) % 2;
        let mut on = DVec3::ZERO;
        let mut n = DVec3::ZERO;
        on[axis] = side as f64;
        on[(axis + 1) % 3] = a;
        on[(axis + 2) % 3] = b;
        n[axis] = if side == 0 { 1.0 } else { -1.0 };
        out.push((
            ProbePoint {
                p: on + n * 0.01,
                n,
            },
            on,
        ));
    }
    out
}

fn sorted(mut v: Vec<Leaf>) -> Vec<Leaf> {
    v.sort_by(|a, b| {
        (
            a.patch,
            a.time[0].to_bits(),
            a.uv[0][0].to_bits(),
            a.uv[0][1].to_bits(),
            a.uv[1][0].to_bits(),
        )
            .cmp(&(
                b.patch,
                b.time[0].to_bits(),
                b.uv[0][0].to_bits(),
                b.uv[0][1].to_bits(),
                b.uv[1][0].to_bits(),
            ))
    });
    v
}

#[test]
fn static_box_round_trip_and_known_answer() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("box.rhier");
    let mut sol = box_solution(4);
    sol.scene.camera = Some(rhier::scene::Camera {
        eye: DVec3::new(0.5, 0.5, 3.0),
        target: DVec3::splat(0.5),
        up: DVec3::Y,
        fov_y: 0.8,
    });
    // The writer keeps whatever order the solver hands leaves in.
    sol.leaves.reverse();
    write_solution(&path, &sol, WriteOptions::default()).unwrap();
    assert!(!dir.path().join("box.rhier.tmp").exists());
    let r = Reader::open(&path).unwrap();
    let back = r.to_solution().unwrap();
    assert_eq!(back.patches, sol.patches);
    assert_eq!(back.leaves, sol.leaves);
    assert_eq!(back.stats, sol.stats);
    assert_eq!(back.scene.materials, sol.scene.materials);
    assert_eq!(back.scene.time, sol.scene.time);
    assert_eq!(
        back.scene.objects[0].polygons,
        sol.scene.objects[0].polygons
    );

    let pts = wall_points(300, 11);
    let points: Vec<ProbePoint> = pts.iter().map(|p| p.0).collect();
    let from_mem = probe(&sol, &points, 0.0).unwrap();
    let from_file = probe(&r, &points, 0.0).unwrap();
    assert_eq!(
        from_mem, from_file,
        "file probe must equal the solve's probe bit for bit"
    );
    for ((_, on), b) in pts.iter().zip(&from_file) {
        let want = wall_radiosity(*on);
        for k in 0..3 {
            // f32 storage of corner values (up to 4 in magnitude): 1e-5 relative.
            assert!(
                (b[k] - want[k]).abs() < 4e-6 * want[k].abs().max(1.0),
                "{on:?}: {b:?} vs {want:?}"
            );
        }
    }
}

#[test]
fn memory_built_bytes_equal_file_bytes_and_both_readers_agree() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("box.rhier");
    let sol = box_solution(3);
    for options in [
        WriteOptions::default(),
        WriteOptions {
            compress: false,
            keep_links: true,
        },
    ] {
        write_solution(&path, &sol, options).unwrap();
        let on_disk = std::fs::read(&path).unwrap();
        let in_ram = encode_solution(&path, &sol, options).unwrap();
        assert_eq!(on_disk, in_ram);
        let mapped = Reader::open(&path).unwrap();
        let ram = Reader::from_bytes(&path, in_ram).unwrap();
        assert_eq!(mapped.sections(), ram.sections());
        let points: Vec<ProbePoint> = wall_points(50, 3).into_iter().map(|p| p.0).collect();
        assert_eq!(
            probe(&mapped, &points, 0.0).unwrap(),
            probe(&ram, &points, 0.0).unwrap()
        );
    }
}

#[test]
fn streamed_space_time_file_reads_chunk_by_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anim.rhier");
    let sample = animated_box(3, 8);
    let sol = &sample.solution;
    let mut w = Writer::create(&path, &SolutionHeader::of(sol), WriteOptions::default()).unwrap();
    for (t0, t1, leaves) in &sample.chunks {
        w.write_chunk(*t0, *t1, leaves).unwrap();
    }
    w.finish(&sol.stats).unwrap();
    let r = Reader::open(&path).unwrap();

    // Only moving objects keep a track.
    let moving: Vec<bool> = r.objects().iter().map(|o| o.motion.is_some()).collect();
    assert_eq!(moving, vec![false, true, false]);
    // Static leaves are stored once: 5 quads * 9 + 2 triangles * 9 + still triangle 9,
    // plus the plate's 9 leaves per chunk.
    let stored: u64 = r.chunks().iter().map(|c| c.leaves as u64).sum();
    assert_eq!(stored, 5 * 9 + 2 * 9 + 9 + 8 * 9);
    assert_eq!(r.to_solution().unwrap().leaves, sol.leaves);

    for &t in &[0.0, 0.1, 0.125, 0.3, 0.5, 0.74, 0.999, 1.0] {
        // Random access: chunk 0 (static leaves) and the chunk holding t.
        let chunks = r.chunks_for(t);
        let k = ((t * 8.0).floor() as usize).min(7);
        let want: Vec<usize> = if k == 0 { vec![0] } else { vec![0, k] };
        assert_eq!(chunks, want, "t = {t}");
        let a = sorted(r.leaves_at(t).unwrap());
        let b = sorted(sol.leaves_at(t).unwrap());
        assert_eq!(a, b, "t = {t}");
        // Exactly one plate leaf set (9 leaves) is live at any t.
        assert_eq!(a.iter().filter(|l| l.patch == 7).count(), 9, "t = {t}");

        // Probe the moving plate from in front of its centre, and a wall.
        let centre = DVec3::new(0.2 + PLATE_TRAVEL * t, 0.5, 0.5);
        let points = [
            ProbePoint {
                p: centre + DVec3::Z * 0.05,
                n: DVec3::Z,
            },
            ProbePoint {
                p: DVec3::new(0.999, 0.3, 0.6),
                n: DVec3::NEG_X,
            },
        ];
        let mem = probe(sol, &points, t).unwrap();
        let file = probe(&r, &points, t).unwrap();
        assert_eq!(mem, file);
        let t0 = k as f64 / 8.0;
        let want = plate_radiosity(t0);
        for c in 0..3 {
            assert!(
                (file[0][c] - want[c]).abs() < 1e-6,
                "t = {t}: {:?} vs {want:?}",
                file[0]
            );
        }
        let wall = wall_radiosity(DVec3::new(1.0, 0.3, 0.6));
        for c in 0..3 {
            assert!((file[1][c] - wall[c]).abs() < 1e-5);
        }
    }
    let err = r.leaves_at(1.5).map(|_| ()).unwrap_err().to_string();
    assert!(
        err.contains("anim.rhier") && err.contains("[0, 1]") && err.contains("1.5"),
        "{err}"
    );
}

#[test]
fn writer_refuses_bad_chunks_and_leaves_no_file_when_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.rhier");
    let sample = animated_box(1, 4);
    let sol: &Solution = &sample.solution;
    let mut w = Writer::create(&path, &SolutionHeader::of(sol), WriteOptions::default()).unwrap();
    assert!(dir.path().join("bad.rhier.tmp").exists());
    let (t0, t1, leaves) = &sample.chunks[1];
    w.write_chunk(*t0, *t1, leaves).unwrap();
    // Out of time order.
    let (a, b, l0) = &sample.chunks[0];
    let err = w.write_chunk(*a, *b, l0).unwrap_err().to_string();
    assert!(
        err.contains("chunk 1") && err.contains("[0, 0.25]"),
        "{err}"
    );
    // A leaf starting outside its chunk.
    let (c0, c1, l2) = &sample.chunks[2];
    let mut bad = l2.clone();
    bad[0].time = [0.9, 1.0];
    let err = w.write_chunk(*c0, *c1, &bad).unwrap_err().to_string();
    assert!(err.contains("leaf 0"), "{err}");
    // A leaf of a patch that does not exist.
    let mut bad = l2.clone();
    bad[0].patch = 99;
    assert!(w.write_chunk(*c0, *c1, &bad).is_err());
    // A radiosity that overflowed (what the reader would refuse at playback).
    let mut bad = l2.clone();
    bad[0].b[2][0] = f32::INFINITY;
    let err = w.write_chunk(*c0, *c1, &bad).unwrap_err().to_string();
    assert!(
        err.contains("leaf 0") && err.contains("a value not finite"),
        "{err}"
    );
    drop(w);
    assert!(!path.exists());
    assert!(!dir.path().join("bad.rhier.tmp").exists());
}

#[test]
fn unfinished_file_is_refused() {
    // What an interrupted solve leaves behind (the .tmp file before finish) has no
    // header: the reader refuses it by its magic.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.rhier");
    let sol = box_solution(2);
    let mut w = Writer::create(&path, &SolutionHeader::of(&sol), WriteOptions::default()).unwrap();
    w.write_chunk(0.0, 0.0, &sol.leaves).unwrap();
    let tmp = dir.path().join("cut.rhier.tmp");
    let partial = std::fs::read(&tmp).unwrap();
    drop(w);
    std::fs::write(&path, &partial).unwrap();
    let err = Reader::open(&path).map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("cut.rhier"), "{err}");
    assert!(err.contains("magic") || err.contains("header"), "{err}");
}

#[test]
fn links_are_kept_only_when_asked() {
    use rhier::store::LinkRecord;
    let dir = tempfile::tempdir().unwrap();
    let sol = box_solution(1);
    let links = vec![
        LinkRecord {
            receiver: 3,
            source: 9,
            time: [0.0, 0.0],
            coefficient: [0.1, 0.2, 0.3],
            error: 0.01,
            active: 1,
            reserved: 0,
        },
        LinkRecord {
            receiver: 4,
            source: 1,
            time: [0.0, 0.0],
            coefficient: [0.0, 0.5, 0.25],
            error: 0.5,
            active: 0,
            reserved: 0,
        },
    ];
    for keep in [false, true] {
        let path = dir.path().join(format!("links_{keep}.rhier"));
        let opts = WriteOptions {
            compress: true,
            keep_links: keep,
        };
        let mut w = Writer::create(&path, &SolutionHeader::of(&sol), opts).unwrap();
        w.write_chunk(0.0, 0.0, &sol.leaves).unwrap();
        w.write_links(&links);
        w.finish(&sol.stats).unwrap();
        let r = Reader::open(&path).unwrap();
        let want = if keep { links.clone() } else { Vec::new() };
        assert_eq!(r.links().unwrap(), want);
        let has_section = r
            .sections()
            .iter()
            .any(|e| e.kind == rhier::store::SectionKind::Links);
        assert_eq!(has_section, keep);
    }
}

#[test]
fn writer_report_in_progress_matches_the_finished_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("report.rhier");
    let sample = animated_box(2, 4);
    let sol = &sample.solution;
    let mut w = Writer::create(&path, &SolutionHeader::of(sol), WriteOptions::default()).unwrap();
    for (k, (t0, t1, leaves)) in sample.chunks.iter().enumerate() {
        w.write_chunk(*t0, *t1, leaves).unwrap();
        let m = w.memory_report();
        assert_eq!(m.chunks.len(), k + 1);
        assert_eq!(m.chunks[k].leaves, leaves.len() as u64);
    }
    let during = w.memory_report();
    w.finish(&sol.stats).unwrap();
    let r = Reader::open(&path).unwrap();
    let after = rhier::store::MemoryReport::from_reader(&r);
    assert_eq!(during.chunks, after.chunks);
    assert_eq!(during.sections[..], after.sections[..during.sections.len()]);
    assert_eq!(after.file_bytes, std::fs::metadata(&path).unwrap().len());
    let stored: u64 = after.sections.iter().map(|s| s.stored_bytes).sum();
    assert_eq!(stored + after.table_bytes, after.file_bytes);
    // Chunk 0 holds the walls (4 leaves each) and the still triangle and the plate.
    assert_eq!(after.chunks[0].leaves, 7 * 4 + 4 + 4);
    assert_eq!(after.chunks[3].live_upper_bound, 7 * 4 + 4 + 4 + 4);
    let text = after.to_string();
    assert!(text.contains("play one frame") && text.contains("chunk_index"));
}

/// `-o /dev/null` once replaced the device with a regular file (the writer renamed its
/// temporary file over it), and every later reader of `/dev/null` read a `.rhier`
/// file. A FIFO stands in for the device here: it must still be a FIFO afterwards and
/// have received exactly the bytes of an in-memory write.
#[cfg(unix)]
#[test]
fn a_device_or_fifo_is_written_in_place_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    let reader = common::fifo::fifo_with_reader(&fifo);
    let sol = box_solution(2);
    let want = encode_solution(&fifo, &sol, WriteOptions::default()).unwrap();
    write_solution(&fifo, &sol, WriteOptions::default()).unwrap();
    // Checked before joining: a replaced FIFO would leave the reader blocked forever.
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let got = reader.join().unwrap();
    assert!(!rhier::store::writer::temp_path(&fifo).exists());
    assert_eq!(got, want);
}
