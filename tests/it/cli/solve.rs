//! The real `rhier` binary: the default job, solve's probe against `rhier probe` on
//! the file it wrote, `--keep-links`, `--report`, exit codes.

use crate::common::{rhier, succeed, succeeded};

#[test]
fn default_job_writes_the_cornell_box() {
    let dir = tempfile::tempdir().unwrap();
    succeed(rhier().current_dir(dir.path()).arg("--help"));
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
    let out = succeed(rhier().arg("probe").arg(&file).arg("--points").arg(&pts));
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
    assert_eq!(mapped, run(&["--storage", "ram"], "r.json"));
}

/// `RHIER_STORAGE` picks the default backend (CI runs the whole suite once with
/// `mmap`): a directory that does not exist fails the solve on its first scratch
/// file, named; a value that names no backend is refused before any work;
/// `--storage ram` overrides it.
#[test]
fn the_storage_variable_names_the_default_backend() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing");
    let out = dir.path().join("x.rhier");
    let solve = |env: &str, extra: &[&str]| {
        rhier()
            .env("RHIER_STORAGE", env)
            .args(["solve", "-q", "--eps", "2", "-o"])
            .arg(&out)
            .args(extra)
            .output()
            .unwrap()
    };
    let o = solve(&format!("mmap:{}", missing.display()), &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&*missing.to_string_lossy()) && err.contains(".col"),
        "{err}"
    );
    assert!(!out.exists());
    let o = solve("disk", &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("RHIER_STORAGE: expected ram, mmap or mmap:DIR, found \"disk\""),
        "{err}"
    );
    assert!(!out.exists());
    succeeded(solve(
        &format!("mmap:{}", missing.display()),
        &["--storage", "ram"],
    ));
    assert!(out.exists());
}

/// `--power-size` reaches the solver: at half the Cornell box's diameter every
/// receiver is below the power area, refined on power only, and the solve ends
/// with far fewer links than at the default (measured 429 against 3 670).
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
}

/// Every solver setting is checked before any work: a value outside its domain is
/// an error (exit 1) naming the flag and the domain, and no output is left. Before
/// the check, `--eps=-1` refined without end and `--max-rounds 0` ran no round and
/// wrote an unsolved file. Values that are not numbers stay clap's usage errors (2).
#[test]
fn solver_settings_out_of_their_domain_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.rhier");
    for (arg, code, needle) in [
        ("--eps=-1", 1, "--eps: expected a finite number > 0"),
        ("--eps=0", 1, "--eps: expected a finite number > 0"),
        ("--eps=inf", 1, "--eps: expected a finite number > 0"),
        (
            "--min-size=0",
            1,
            "--min-size: expected a finite number > 0",
        ),
        (
            "--recon-tol=nan",
            1,
            "--recon-tol: expected a finite number > 0",
        ),
        (
            "--power-size=-1",
            1,
            "--power-size: expected a finite number >= 0",
        ),
        (
            "--power-size=inf",
            1,
            "--power-size: expected a finite number >= 0",
        ),
        (
            "--max-rounds=0",
            1,
            "--max-rounds: expected a whole number >= 1",
        ),
        (
            "--split-spread=-0.1",
            1,
            "--split-spread: expected a finite number >= 0",
        ),
        (
            "--leaf-shapes=nan",
            1,
            "--leaf-shapes: expected a finite number >= 0",
        ),
        (
            "--target-error=0",
            1,
            "--target-error: expected a finite number > 0",
        ),
        (
            "--time-budget=-1",
            1,
            "--time-budget: expected a finite number >= 0",
        ),
        ("--eps=small", 2, "--eps"),
    ] {
        // The check comes before the mode is chosen: the same for a static scene,
        // a moving one (space-time) and the per-frame baseline.
        for mode in [
            &["--blocks"][..],
            &["--builtin", "actor"],
            &["--builtin", "actor", "--per-frame"],
        ] {
            let o = rhier()
                .args(["solve", "-q", "-o"])
                .arg(&out)
                .args(mode)
                .arg(arg)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(code), "{arg} {mode:?}: {err}");
            assert!(err.contains(needle), "{arg} {mode:?}: {err}");
            assert!(!out.exists(), "{arg} {mode:?} left {}", out.display());
        }
    }
}

/// `--reference` measures off the emitters first (issue 45): with a reference equal
/// to the solve's own answer on the lamp and off by known factors elsewhere, the
/// round's line and the report's columns give the error off the lamp, over all
/// points, and the worst point, each the value the factors make.
#[test]
fn reference_error_is_reported_off_the_emitters_with_the_worst_point() {
    let dir = tempfile::tempdir().unwrap();
    let pts = dir.path().join("p.json");
    // Floor, left wall, two points on the lamp (213..343 × 227..332), ceiling.
    let points = [
        ([278.0, 0.0, 278.0], [0.0, 1.0, 0.0]),
        ([0.0, 274.0, 278.0], [1.0, 0.0, 0.0]),
        ([278.0, 548.8, 278.0], [0.0, -1.0, 0.0]),
        ([230.0, 548.8, 240.0], [0.0, -1.0, 0.0]),
        ([100.0, 548.8, 100.0], [0.0, -1.0, 0.0]),
    ];
    let json = |b: Option<&[[f64; 3]]>| {
        let items: Vec<serde_json::Value> = points
            .iter()
            .enumerate()
            .map(|(i, (p, n))| match b {
                Some(b) => serde_json::json!({"p": p, "n": n, "B": b[i]}),
                None => serde_json::json!({"p": p, "n": n}),
            })
            .collect();
        serde_json::Value::Array(items).to_string()
    };
    std::fs::write(&pts, json(None)).unwrap();
    let vals = dir.path().join("v.json");
    let solve = |extra: &[&std::path::Path]| {
        let mut cmd = rhier();
        cmd.args(["solve", "--threads", "2", "--max-rounds", "2", "--probe"])
            .arg(&pts)
            .arg("--probe-out")
            .arg(&vals)
            .arg("-o")
            .arg(dir.path().join("c.rhier"));
        if let [r, csv] = extra {
            cmd.arg("--reference").arg(r).arg("--report").arg(csv);
        }
        succeed(&mut cmd)
    };
    solve(&[]);
    let b: Vec<[f64; 3]> =
        serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(&vals).unwrap())
            .unwrap()
            .as_array()
            .unwrap()
            .iter()
            .map(|v| {
                let a = v["B"].as_array().unwrap();
                [0, 1, 2].map(|c| a[c].as_f64().unwrap())
            })
            .collect();
    assert!(
        b[2][0] > 10.0 * b[4][0],
        "points 2 and 3 are on the lamp: {b:?}"
    );
    // The solve's answer over these factors: errors 1/4 on the floor and the
    // ceiling, 1/2 on the wall (the worst), none on the lamp.
    let factor = [1.25, 1.5, 1.0, 1.0, 1.25];
    let reference: Vec<[f64; 3]> = b
        .iter()
        .zip(factor)
        .map(|(v, f)| v.map(|x| x / f))
        .collect();
    let ref_file = dir.path().join("ref.json");
    std::fs::write(&ref_file, json(Some(&reference))).unwrap();
    let csv = dir.path().join("r.csv");
    let out = solve(&[&ref_file, &csv]);
    let rms = |idx: &[usize]| {
        let (mut num, mut den) = (0.0, 0.0);
        for &i in idx {
            for c in 0..3 {
                num += (b[i][c] - reference[i][c]).powi(2);
                den += reference[i][c].powi(2);
            }
        }
        (num / den).sqrt()
    };
    let (off, all) = (rms(&[0, 1, 4]), rms(&[0, 1, 2, 3, 4]));
    assert!(
        off > 2.0 * all,
        "the lamp's points dilute: {off} against {all}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let last: Vec<&str> = lines.last().unwrap().split(',').collect();
    let col = |name: &str| last[header.iter().position(|h| *h == name).unwrap()];
    let num = |name: &str| col(name).parse::<f64>().unwrap();
    eprintln!("{text}");
    assert!((num("true_error") - off).abs() < 1e-5 * off, "{text}");
    assert!((num("true_error_all") - all).abs() < 1e-5 * all, "{text}");
    assert_eq!(col("worst_point"), "1");
    assert!((num("worst_error") - 0.5).abs() < 1e-5, "{text}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("off the emitters (3 points; worst point 1: 5.000e-1)")
            && stderr.contains("over all points"),
        "{stderr}"
    );
}
