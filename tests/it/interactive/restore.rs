//! `rhier interact --from`: a session taken up from the hierarchy a solve
//! persisted (`rhier solve --keep-links --movable`) against the session that
//! solves at start-up: the same radiosity at probe points before any move and
//! after the same moves, in a room where a floating crate casts a shadow, tiled
//! in quads and in its tessellated twin (unequal triangles); a hierarchy that is
//! corrupt, from another scene, another set of movable objects or other settings
//! is refused with a message naming the file, the section and what differs.

use std::path::Path;

use glam::{DQuat, DVec3};
use rhier::interactive::{ObjectMove, Pose, Session, Settings, Stage};
use rhier::playback::probe::{ProbePoint, probe};
use rhier::scene::Scene;
use rhier::solver::{SolveOptions, Solver};
use rhier::store::Hierarchy;

use super::moves::{options, room};
use crate::common::shapes::Tiling;
use crate::common::{example, rhier, succeed};

/// Points on the floor and two walls, 12 × 12 each (the crate floats: none is
/// inside it).
fn points() -> Vec<ProbePoint> {
    let mut out = Vec::new();
    for i in 0..12 {
        for j in 0..12 {
            let (a, b) = (0.15 + 0.31 * i as f64, 0.15 + 0.31 * j as f64);
            let h = b * 2.5 / 4.0;
            out.push(ProbePoint {
                p: DVec3::new(a, 0.0, b),
                n: DVec3::Y,
            });
            out.push(ProbePoint {
                p: DVec3::new(0.0, h, a),
                n: DVec3::X,
            });
            out.push(ProbePoint {
                p: DVec3::new(a, h, 0.0),
                n: DVec3::Z,
            });
        }
    }
    out
}

/// The hierarchy of the solve a session on `stage` makes at start-up, as
/// `rhier solve --keep-links --movable` persists it.
fn persisted(stage: &Stage, opts: SolveOptions) -> Hierarchy {
    let opts = SolveOptions {
        keep_passive: true,
        ..opts
    };
    let mut s = Solver::new(&stage.scene, opts).unwrap();
    s.keep_restore_point();
    s.run(|_, _| {}).unwrap();
    s.hierarchy(stage.movable_names()).unwrap()
}

/// Largest difference of `a` from `b` relative to `b`'s largest value, and
/// whether they are equal bit for bit.
fn compare(a: &[[f64; 3]], b: &[[f64; 3]]) -> (f64, bool) {
    let scale = b.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    let same = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .all(|(x, y)| x.to_bits() == y.to_bits());
    (diff / scale, same)
}

fn check_restored(what: &str, scene: &Scene) {
    let movable = ["crate".to_string()];
    let stage = Stage::new(scene, Some(&movable)).unwrap();
    let h = persisted(&stage, options());
    // The section's record round trip (rkyv, as the file holds it).
    let bytes = rkyv::to_bytes::<rkyv::rancor::Error>(&h.to_record()).unwrap();
    let archived =
        rkyv::access::<rhier::store::records::ArchivedHierarchyRecord, rkyv::rancor::Error>(&bytes)
            .unwrap();
    let back = Hierarchy::from_archived(Path::new("mem.rhier"), "section", archived).unwrap();
    assert!(back == h, "{what}: the record does not round-trip");
    assert!(!h.row_start.is_empty() && !h.row_links.is_empty(), "{what}");
    let file = Path::new("mem.rhier");
    let mut solved = Session::start(&stage, options(), Settings::default()).unwrap();
    let mut restored =
        Session::restore(&stage, options(), Settings::default(), &back, file).unwrap();
    // Without the stored rows, built again from the stored radiosities.
    let bare = Hierarchy {
        row_start: Vec::new(),
        row_sources: Vec::new(),
        row_coefs: Vec::new(),
        row_links: Vec::new(),
        ..h.clone()
    };
    let rebuilt = Session::restore(&stage, options(), Settings::default(), &bare, file).unwrap();
    assert_eq!(
        solved.solver().elems.len(),
        restored.solver().elems.len(),
        "{what}"
    );
    let pts = points();
    let b_solved = probe(&solved.solution(), &pts, 0.0).unwrap();
    let b_restored = probe(&restored.solution(), &pts, 0.0).unwrap();
    let (diff, same) = compare(&b_restored, &b_solved);
    eprintln!(
        "{what}: restored against solved at start-up: largest difference {diff:.3e} of the largest B, bit for bit: {same}"
    );
    assert!(same, "{what}: the restored radiosity differs by {diff:e}");
    let b_rebuilt = probe(&rebuilt.solution(), &pts, 0.0).unwrap();
    let (diff, same) = compare(&b_rebuilt, &b_solved);
    eprintln!("{what}: rows built again: largest difference {diff:.3e}, bit for bit: {same}");
    assert!(same, "{what}: the rows built again give {diff:e}");
    let shadowed = b_solved
        .iter()
        .step_by(3)
        .map(|b| b[0])
        .fold(f64::INFINITY, f64::min);
    let lit = b_solved
        .iter()
        .step_by(3)
        .map(|b| b[0])
        .fold(0.0f64, f64::max);
    assert!(shadowed < 0.8 * lit, "{what}: no shadow on the floor");
    for (i, pose) in [
        Pose {
            translation: DVec3::new(0.5, 0.0, 0.3),
            rotation: DQuat::IDENTITY,
        },
        Pose {
            translation: DVec3::new(1.2, 0.2, 0.5),
            rotation: DQuat::from_rotation_y(0.4),
        },
    ]
    .into_iter()
    .enumerate()
    {
        let m = [ObjectMove { object: 1, pose }];
        let sa = solved.apply(&m).unwrap();
        let sb = restored.apply(&m).unwrap();
        let b_solved = probe(&solved.solution(), &pts, 0.0).unwrap();
        let b_restored = probe(&restored.solution(), &pts, 0.0).unwrap();
        let (diff, same) = compare(&b_restored, &b_solved);
        eprintln!(
            "{what}, move {i}: largest difference {diff:.3e}, bit for bit: {same}; links re-evaluated {} / {}",
            sb.links_reevaluated, sa.links_reevaluated
        );
        assert!(same, "{what}, move {i}: differs by {diff:e}");
        assert_eq!(sa.links_reevaluated, sb.links_reevaluated, "{what}");
        assert_eq!(sa.links_refined, sb.links_refined, "{what}");
    }
}

#[test]
fn a_restored_session_is_the_solved_one() {
    check_restored("quads", &room(Tiling::Quads(2), 0.3));
}

#[test]
fn a_restored_session_is_the_solved_one_tessellated() {
    check_restored("unequal triangles", &room(Tiling::UnequalTriangles(3), 0.3));
}

/// The error of restoring `h` on `stage` at `opts`, as text.
fn refusal(stage: &Stage, opts: SolveOptions, h: &Hierarchy) -> String {
    match Session::restore(stage, opts, Settings::default(), h, Path::new("bad.rhier")) {
        Ok(_) => panic!("a bad hierarchy was taken up"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_bad_hierarchy_is_refused() {
    let scene = room(Tiling::Quads(2), 0.3);
    let movable = ["crate".to_string()];
    let stage = Stage::new(&scene, Some(&movable)).unwrap();
    let h = persisted(&stage, options());
    let n = h.nodes.len();
    let expect = |h: &Hierarchy, words: &[&str]| {
        let e = refusal(&stage, options(), h);
        assert!(e.contains("bad.rhier"), "{e}");
        for w in words {
            assert!(e.contains(w), "expected {w:?} in: {e}");
        }
    };
    let mut b = h.clone();
    b.ends[7].receiver = n as u32 + 5;
    expect(&b, &["hierarchy section, link 7", "ends below"]);
    let mut b = h.clone();
    b.geoms.pop();
    expect(
        &b,
        &["hierarchy section, column geoms", &format!("{n} records")],
    );
    let mut b = h.clone();
    b.geoms[n - 1].corners[0][1] = f64::NAN;
    expect(&b, &[&format!("hierarchy section, element {}", n - 1)]);
    let inner = (0..n)
        .rev()
        .find(|&i| h.nodes[i].child_count > 0 && h.nodes[i].kind == 1)
        .unwrap();
    let mut b = h.clone();
    b.nodes[inner].first_child = n as u32 - 1;
    expect(&b, &["hierarchy section, element", "children"]);
    let mut b = h.clone();
    b.nodes[n - 1].kind = 7;
    expect(&b, &["kind"]);
    let mut b = h.clone();
    b.transports[3].flags[0] = 9;
    expect(&b, &["hierarchy section, link 3", "state"]);
    let mut b = h.clone();
    b.row_sources[5] = n as u32 + 2;
    expect(&b, &["hierarchy section, leaf row entry 5", "source"]);
    let mut b = h.clone();
    b.row_start[1] = b.row_start[2] + 1;
    expect(&b, &["hierarchy section, leaf rows", "rising"]);
    let mut b = h.clone();
    b.row_links[4][3] = u32::MAX;
    expect(&b, &["hierarchy section, leaf row link 4"]);
    let mut b = h.clone();
    b.radiosities[2][0] = f32::INFINITY;
    expect(&b, &["hierarchy section, element 2", "finite radiosity"]);
    // Another scene: the crate elsewhere.
    let other = room(Tiling::Quads(2), 0.6);
    let other_stage = Stage::new(&other, Some(&movable)).unwrap();
    let e = refusal(&other_stage, options(), &h);
    assert!(
        e.contains("hierarchy section, element") && e.contains("cluster or patch root"),
        "{e}"
    );
    // Other movable objects, other settings.
    let every = Stage::new(&scene, None).unwrap();
    let e = refusal(&every, options(), &h);
    assert!(e.contains("--movable crate"), "{e}");
    let coarser = SolveOptions {
        eps: 0.5,
        ..options()
    };
    let e = refusal(&stage, coarser, &h);
    assert!(e.contains("eps: 0.25 in the file, 0.5 here"), "{e}");
}

#[test]
fn interact_from_a_persisted_hierarchy_gives_the_solved_session() {
    let dir = tempfile::tempdir().unwrap();
    let solved = dir.path().join("s.rhier");
    let scene = example("cornell_blocks.json");
    let acc = ["--eps", "1", "--max-rounds", "3"];
    succeed(
        rhier()
            .arg("solve")
            .arg(&scene)
            .args(acc)
            .args(["-q", "--keep-links", "--movable", "short_block", "-o"])
            .arg(&solved),
    );
    let moves = dir.path().join("m.jsonl");
    std::fs::write(
        &moves,
        "{\"object\": \"short_block\", \"translation\": [0.3, 0, 0.2]}\n{\"object\": \"short_block\", \"translation\": [0.6, 0.1, 0.4]}\n",
    )
    .unwrap();
    let pts = dir.path().join("p.json");
    std::fs::write(
        &pts,
        "[{\"p\":[2.5,0,2.5],\"n\":[0,1,0]},{\"p\":[0,2.5,2.5],\"n\":[1,0,0]},{\"p\":[2.5,5.4,2.5],\"n\":[0,-1,0]},{\"p\":[4,0,1],\"n\":[0,1,0]}]",
    )
    .unwrap();
    let run = |from: Option<&Path>, out: &str| {
        let probe_out = dir.path().join(out);
        let mut c = rhier();
        c.arg("interact").arg(&scene);
        if let Some(f) = from {
            c.arg("--from").arg(f);
        }
        c.args(acc)
            .args(["-q", "--movable", "short_block", "--moves"])
            .arg(&moves)
            .arg("--probe")
            .arg(&pts)
            .arg("--probe-out")
            .arg(&probe_out);
        succeed(&mut c);
        std::fs::read_to_string(&probe_out).unwrap()
    };
    let a = run(None, "a.jsonl");
    let b = run(Some(&solved), "b.jsonl");
    assert_eq!(a.lines().count(), 3, "{a}");
    assert_eq!(a, b, "the restored session's probes differ");
    // Without SCENE: the file's scene.
    let mut c = rhier();
    c.args(["interact", "--from"])
        .arg(&solved)
        .args(acc)
        .args(["-q", "--moves"])
        .arg(&moves)
        .arg("--probe")
        .arg(&pts)
        .arg("--probe-out")
        .arg(dir.path().join("c.jsonl"));
    succeed(&mut c);
    let c = std::fs::read_to_string(dir.path().join("c.jsonl")).unwrap();
    assert_eq!(a, c, "the file's own scene gives other probes");
    let refused = |file: &Path, args: &[&str]| {
        let out = rhier()
            .arg("interact")
            .arg(&scene)
            .arg("--from")
            .arg(file)
            .args(args)
            .arg("--moves")
            .arg(&moves)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // Other accuracy flags.
    let e = refused(&solved, &["--eps", "0.5", "--max-rounds", "3"]);
    assert!(e.contains("eps") && e.contains("other settings"), "{e}");
    // A byte of the hierarchy section (the last before the table) changed.
    let mut bytes = std::fs::read(&solved).unwrap();
    let table = u64::from_le_bytes(bytes[24..32].try_into().unwrap()) as usize;
    bytes[table - 40] ^= 0x5a;
    let corrupt = dir.path().join("corrupt.rhier");
    std::fs::write(&corrupt, &bytes).unwrap();
    let e = refused(&corrupt, &acc);
    assert!(
        e.contains("corrupt.rhier") && e.contains("hierarchy"),
        "{e}"
    );
    // Cut short.
    let bytes = std::fs::read(&solved).unwrap();
    let cut = dir.path().join("cut.rhier");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    let e = refused(&cut, &acc);
    assert!(e.contains("cut.rhier"), "{e}");
    // A plain static solve's links: no hierarchy.
    let plain = dir.path().join("plain.rhier");
    succeed(
        rhier()
            .arg("solve")
            .arg(&scene)
            .args(acc)
            .args(["-q", "--keep-links", "-o"])
            .arg(&plain),
    );
    let e = refused(&plain, &acc);
    assert!(e.contains("no hierarchy") && e.contains("--movable"), "{e}");
}
