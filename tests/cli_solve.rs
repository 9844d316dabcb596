//! The real `rhier` binary: the default job, solve's probe against `rhier probe` on
//! the file it wrote, `--keep-links`, `--report`, exit codes.

use std::process::Command;

fn rhier() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rhier"))
}

/// Runs `cmd` and fails the test with its standard error unless it succeeds.
fn succeed(cmd: &mut Command) -> std::process::Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn default_job_writes_the_cornell_box() {
    let dir = tempfile::tempdir().unwrap();
    let out = rhier()
        .current_dir(dir.path())
        .arg("--help")
        .output()
        .unwrap();
    assert!(out.status.success());
    succeed(rhier().current_dir(dir.path()));
    let file = dir.path().join("cornell.rhier");
    let reader = rhier::store::Reader::open(&file).unwrap();
    assert_eq!(reader.patches().len(), 10);
    assert!(reader.stats().links_active > 0);
}

#[test]
fn solve_probe_equals_file_probe_and_report_has_rounds() {
    let dir = tempfile::tempdir().unwrap();
    let pts = dir.path().join("p.json");
    std::fs::write(&pts, r#"[{"p":[278,0,278],"n":[0,1,0]},{"p":[0,274,278],"n":[1,0,0]},{"p":[278,548.8,278],"n":[0,-1,0]}]"#).unwrap();
    let (vals, file, csv) = (
        dir.path().join("v.json"),
        dir.path().join("b.rhier"),
        dir.path().join("r.csv"),
    );
    succeed(
        rhier()
            .args(["solve", "--blocks", "-q", "--keep-links", "--probe"])
            .arg(&pts)
            .arg("--probe-out")
            .arg(&vals)
            .arg("--report")
            .arg(&csv)
            .arg("-o")
            .arg(&file),
    );
    let from_solve: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&vals).unwrap()).unwrap();
    let out = rhier()
        .arg("probe")
        .arg(&file)
        .arg("--points")
        .arg(&pts)
        .output()
        .unwrap();
    assert!(out.status.success());
    let from_file: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (a, b) = (
        from_solve.as_array().unwrap(),
        from_file.as_array().unwrap(),
    );
    assert_eq!(a.len(), 3);
    for (x, y) in a.iter().zip(b) {
        for k in 0..3 {
            let (x, y) = (x["B"][k].as_f64().unwrap(), y["B"][k].as_f64().unwrap());
            assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{x} vs {y}");
        }
    }
    // The lamp point reads at least its exitance; the floor under the lamp is lit.
    assert!(a[2]["B"][0].as_f64().unwrap() >= 17.0);
    assert!(a[0]["B"][0].as_f64().unwrap() > 0.1);
    // Links kept: every link of the run, active and passive.
    let reader = rhier::store::Reader::open(&file).unwrap();
    let links = reader.links().unwrap();
    let stats = reader.stats();
    assert_eq!(links.len() as u64, stats.links_active + stats.links_passive);
    assert_eq!(
        links.iter().filter(|l| l.active == 1).count() as u64,
        stats.links_active
    );
    let csv = std::fs::read_to_string(&csv).unwrap();
    assert!(csv.starts_with("round,seconds,elements"));
    assert!(csv.lines().count() >= 2);
}

#[test]
fn bad_input_exits_1_and_bad_usage_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"rhier_scene": 1, "materials": {}, "objects": [{"name": "o", "polygons": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "material": "nope"}]}]}"#).unwrap();
    let out = rhier()
        .arg("solve")
        .arg(&bad)
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.json") && err.contains("nope"), "{err}");
    assert!(!dir.path().join("bad.rhier").exists());
    let out = rhier().args(["solve", "--eps"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = rhier()
        .args(["solve", "/nonexistent/scene.json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn mmap_storage_creates_its_scratch_directory_and_gives_the_ram_answer() {
    let dir = tempfile::tempdir().unwrap();
    let scratch = dir.path().join("not").join("yet");
    let pts = dir.path().join("p.json");
    std::fs::write(
        &pts,
        r#"[{"p":[278,0,278],"n":[0,1,0]},{"p":[0,274,278],"n":[1,0,0]}]"#,
    )
    .unwrap();
    let run = |extra: &[&str], name: &str| {
        let vals = dir.path().join(name);
        succeed(
            rhier()
                .current_dir(dir.path())
                .args([
                    "solve",
                    "--builtin",
                    "cornell",
                    "-q",
                    "--threads",
                    "1",
                    "--probe",
                ])
                .arg(&pts)
                .arg("--probe-out")
                .arg(&vals)
                .args(extra),
        );
        std::fs::read_to_string(vals).unwrap()
    };
    let mapped = run(
        &["--storage", "mmap", "--scratch", scratch.to_str().unwrap()],
        "m.json",
    );
    assert!(scratch.is_dir());
    assert_eq!(mapped, run(&[], "r.json"));
}

/// `--power-size` reaches the solver: at half the Cornell box's diameter every
/// receiver is below the power area, refined on power only, and the solve ends
/// with far fewer links than at the default (measured 429 against 3 670); a
/// negative or non-finite value is a usage error.
#[test]
fn power_size_sets_which_receivers_refine_on_power() {
    let dir = tempfile::tempdir().unwrap();
    let links = |extra: &[&str]| {
        let csv = dir.path().join("r.csv");
        succeed(
            rhier()
                .args(["solve", "--blocks", "-q", "-o"])
                .arg(dir.path().join("b.rhier"))
                .arg("--report")
                .arg(&csv)
                .args(extra),
        );
        let text = std::fs::read_to_string(&csv).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let col = header.iter().position(|&h| h == "links_active").unwrap();
        let last = text.lines().last().unwrap();
        last.split(',').nth(col).unwrap().parse::<u64>().unwrap()
    };
    let default = links(&[]);
    let coarse = links(&["--power-size", "0.5"]);
    assert!(
        coarse * 4 < default,
        "links at --power-size 0.5: {coarse}, at the default: {default}"
    );
    for bad in ["-1", "nan", "inf"] {
        let out = rhier()
            .args(["solve", "--blocks", "-q", "-o", "/dev/null"])
            .arg(format!("--power-size={bad}"))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "--power-size={bad}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--power-size") && err.contains(">= 0"),
            "{err}"
        );
    }
}
