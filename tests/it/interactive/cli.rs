//! The `rhier interact` command line: a bad move stops the session with exit 1,
//! naming the line, and leaves a valid session file up to the last good move; a
//! move is applied and reported before the next line is read (a pipe); `--from`
//! refuses a file solved without `--keep-links`; the solver's pools follow
//! `RHIER_STORAGE`.

use std::io::{BufRead, BufReader, Write};

use rhier::store::Reader;

use crate::common::{example, rhier, spawn_piped, succeed, succeeded};

/// The flags every run here shares: the Cornell box with its blocks, coarse.
fn base(cmd: &mut std::process::Command) -> &mut std::process::Command {
    cmd.arg("interact")
        .arg(example("cornell_blocks.json"))
        .args([
            "--movable",
            "short_block",
            "--eps",
            "1",
            "--max-rounds",
            "3",
        ])
}

/// Two probe points (the floor and the left wall) written in `dir`.
fn probe_points(dir: &std::path::Path) -> std::path::PathBuf {
    let points = dir.join("p.json");
    std::fs::write(
        &points,
        r#"[{"p": [270, 0, 100], "n": [0, 1, 0]}, {"p": [0, 270, 270], "n": [1, 0, 0]}]"#,
    )
    .unwrap();
    points
}

#[test]
fn a_bad_move_names_its_line_and_the_session_file_keeps_the_good_ones() {
    let dir = tempfile::tempdir().unwrap();
    let moves = dir.path().join("moves.jsonl");
    std::fs::write(
        &moves,
        "{\"object\": \"short_block\", \"translation\": [20, 0, 0]}\n\
         \n\
         [{\"object\": \"short_block\", \"translation\": [40, 0, -10]}]\n\
         {\"object\": \"short_block\", \"rotation\": [0, 0, 0, 0.5]}\n\
         {\"object\": \"short_block\", \"translation\": [60, 0, 0]}\n",
    )
    .unwrap();
    let points = probe_points(dir.path());
    let (out, stats, probes) = (
        dir.path().join("s.rhier"),
        dir.path().join("s.jsonl"),
        dir.path().join("b.jsonl"),
    );
    let run = base(&mut rhier())
        .arg("--moves")
        .arg(&moves)
        .arg("-o")
        .arg(&out)
        .arg("--stats")
        .arg(&stats)
        .arg("--probe")
        .arg(&points)
        .arg("--probe-out")
        .arg(&probes)
        .arg("-q")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("line 4") && err.contains("unit quaternion"),
        "{err}"
    );
    // Frame 0 (as solved) and the two good moves.
    let r = Reader::open(&out).unwrap();
    assert_eq!(r.chunks().len(), 3);
    assert!(r.verify().unwrap() > 0);
    let stats = std::fs::read_to_string(&stats).unwrap();
    let lines: Vec<serde_json::Value> = stats
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["move"], i + 1);
        for key in [
            "shafts_at_old",
            "shafts_at_new",
            "shaft_tests",
            "shafts_built",
            "shafts_existing",
            "shafts_collected",
            "shafts_evicted",
            "shafts_restored",
            "shafts_total",
            "resident_shaft_bytes",
            "compressed_shaft_bytes",
            "all_shaft_bytes",
            "links_reevaluated",
            "links_refined",
            "links_reactivated",
            "traversal_s",
            "shaft_s",
            "solve_s",
            "total_s",
        ] {
            assert!(l.get(key).is_some_and(|v| v.is_number()), "{key} in {l}");
        }
        assert!(l["links_reevaluated"].as_u64().unwrap() > 0, "{l}");
    }
    // The block moved: shafts were needed at the first move, and the session
    // had built them before it (priming, `Session::prime`).
    assert!(
        lines[0]["shafts_existing"].as_u64().unwrap() > 0,
        "{}",
        lines[0]
    );
    let probes = std::fs::read_to_string(&probes).unwrap();
    let b: Vec<serde_json::Value> = probes
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(b.len(), 3);
    assert_eq!(b[2]["move"], 2);
    assert_eq!(b[2]["B"].as_array().unwrap().len(), 2);
    // The floor point in front of the block changes as the block moves.
    assert_ne!(b[0]["B"][0], b[2]["B"][0]);
}

#[test]
fn a_move_is_answered_before_the_next_line_is_read() {
    let mut child =
        spawn_piped(base(&mut rhier()).args(["--moves", "-", "--stats", "/dev/stdout", "-q"]));
    let mut stdin = child.stdin.take().unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    for (i, x) in [10, 30].iter().enumerate() {
        writeln!(
            stdin,
            "{{\"object\": \"short_block\", \"translation\": [{x}, 0, 0]}}"
        )
        .unwrap();
        stdin.flush().unwrap();
        // The pipe stays open: the answer comes before any further line.
        let mut line = String::new();
        stdout.read_line(&mut line).unwrap();
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v["move"], i + 1);
    }
    drop(stdin);
    let status = child.wait().unwrap();
    assert!(status.success());
}

#[test]
fn from_a_file_without_links_is_refused_with_the_way_out() {
    let dir = tempfile::tempdir().unwrap();
    let solved = dir.path().join("c.rhier");
    succeed(
        rhier()
            .arg("solve")
            .arg(example("cornell_blocks.json"))
            .args(["--eps", "1", "--max-rounds", "2", "-q", "-o"])
            .arg(&solved),
    );
    let moves = dir.path().join("m.jsonl");
    std::fs::write(&moves, "{\"object\": \"short_block\"}\n").unwrap();
    let run = rhier()
        .args(["interact", "--from"])
        .arg(&solved)
        .arg("--moves")
        .arg(&moves)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(err.contains("--keep-links"), "{err}");
}

#[test]
fn the_pools_follow_rhier_storage_and_give_the_same_answer() {
    let dir = tempfile::tempdir().unwrap();
    let moves = dir.path().join("m.jsonl");
    std::fs::write(
        &moves,
        "{\"object\": \"short_block\", \"translation\": [20, 0, 0]}\n\
         {\"object\": \"short_block\", \"translation\": [40, 0, 10]}\n",
    )
    .unwrap();
    let points = probe_points(dir.path());
    let scratch = dir.path().join("scratch");
    std::fs::create_dir(&scratch).unwrap();
    let run = |storage: &str, out: &std::path::Path| {
        base(&mut rhier())
            .env("RHIER_STORAGE", storage)
            .arg("--moves")
            .arg(&moves)
            .arg("--probe")
            .arg(&points)
            .arg("--probe-out")
            .arg(out)
            .arg("-q")
            .output()
            .unwrap()
    };
    let (ram, mapped) = (dir.path().join("ram.jsonl"), dir.path().join("mmap.jsonl"));
    succeeded(run("ram", &ram));
    succeeded(run(&format!("mmap:{}", scratch.display()), &mapped));
    // The backend holds the same records: the same answer, bit for bit.
    let (a, b) = (
        std::fs::read_to_string(&ram).unwrap(),
        std::fs::read_to_string(&mapped).unwrap(),
    );
    assert_eq!(a.lines().count(), 3, "{a}");
    assert_eq!(a, b);
    // A value it cannot use is refused, naming the variable.
    let bad = run("tape", &dir.path().join("bad.jsonl"));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(1), "{err}");
    assert!(err.contains("RHIER_STORAGE"), "{err}");
}
