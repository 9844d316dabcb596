//! A space-time solve run as shards and merged (issue 50), through the real `rhier`
//! binary: `plan --shards N`, `solve --shard K/N` (and `--shard-index-env`), `merge`.
//! The merged file against the solve on one machine (the same leaves, the same
//! probes at every frame), the same file whatever N for the same
//! boundaries, `--resume` inside a shard, and every refusal of `merge` (a missing
//! shard, one given twice, another shard count, other settings, a corrupt part, a
//! file that is no part), each naming the part and leaving no output behind.

use std::path::{Path, PathBuf};
use std::process::Output;

use rhier::geometry::Patches;
use rhier::playback::{ProbePoint, probe};
use rhier::store::Reader;

use crate::common::{example, probe::grid_points, rhier, succeed, succeeded};

/// LIGHT at 4 fps in windows of half a second (13 frames, 7 windows), coarse.
const LIGHT: &[&str] = &[
    "--fps",
    "4",
    "--window",
    "0.5",
    "--eps",
    "1",
    "--recon-tol",
    "0.2",
    "-q",
];

/// The moving Cornell box at 4 fps in windows of half a second (9 frames, 5
/// windows), as `cli::spacetime` solves it.
const CORNELL: &[&str] = &["--fps", "4", "--window", "0.5", "-q"];

/// Solves `scene` with `settings` into `out`, as shard `shard` (`K/N`) if given.
fn solve(scene: &Path, settings: &[&str], shard: Option<&str>, out: &Path) -> Output {
    let mut cmd = rhier();
    cmd.arg("solve")
        .arg(scene)
        .args(settings)
        .arg("-o")
        .arg(out);
    if let Some(s) = shard {
        cmd.args(["--shard", s]);
    }
    cmd.output().unwrap()
}

/// Solves every shard of `n` into `dir/part-K.rhier`; returns their paths.
fn solve_shards(scene: &Path, settings: &[&str], n: usize, dir: &Path) -> Vec<PathBuf> {
    (0..n)
        .map(|k| {
            let p = dir.join(format!("part-{k}.rhier"));
            succeeded(solve(scene, settings, Some(&format!("{k}/{n}")), &p));
            p
        })
        .collect()
}

/// Solves `scene` (`CORNELL`) as a shard of 6 whose index is `index`, read from the
/// environment variable `RHIER_TEST_INDEX` as a job array's task reads its own.
fn solve_from_env(scene: &Path, index: &str, out: &Path) -> Output {
    rhier()
        .arg("solve")
        .arg(scene)
        .args(CORNELL)
        .args([
            "--shards",
            "6",
            "--shard-index-env",
            "RHIER_TEST_INDEX",
            "-o",
        ])
        .arg(out)
        .env("RHIER_TEST_INDEX", index)
        .output()
        .unwrap()
}

fn merge(parts: &[PathBuf], out: &Path) -> Output {
    rhier()
        .arg("merge")
        .args(parts)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

/// `merge` fails with a message holding every one of `fragments`, and leaves no
/// output file (nor its temporary).
fn refused(parts: &[PathBuf], out: &Path, fragments: &[&str]) {
    let o = merge(parts, out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    for f in fragments {
        assert!(err.contains(f), "expected {f:?} in: {err}");
    }
    assert!(!out.exists(), "a failed merge left {}", out.display());
    assert!(!rhier::store::writer::temp_path(out).exists());
}

/// Both files hold as many chunks with the same time ranges and leaves.
fn same_chunks(a: &Reader, b: &Reader) -> bool {
    a.chunks().len() == b.chunks().len()
        && (0..a.chunks().len()).all(|k| {
            let (ca, cb) = (a.chunks()[k], b.chunks()[k]);
            (ca.t0, ca.t1, ca.reach) == (cb.t0, cb.t1, cb.reach)
                && a.chunk_leaves(k).unwrap() == b.chunk_leaves(k).unwrap()
        })
}

/// Probe points on every non-emitting patch of `scene` at `t`, a 3 × 3 grid on each,
/// with the area each stands for: the static patches cut at their contacts as the
/// solver cuts them (a point under a resting box finds an arbitrary surface), the
/// moving ones placed at `t`.
fn points_at(scene: &rhier::scene::Scene, t: f64) -> Vec<(ProbePoint, f64)> {
    let opts = rhier::solver::SolveOptions::default();
    let cut = rhier::solver::spacetime::plan_patches(scene, &opts);
    let placed = Patches::at_time(scene, t);
    let moving = |p: &Patches, i: usize| scene.objects[p.objects[i] as usize].is_moving();
    let mut out = Vec::new();
    for (patches, want_moving) in [(&cut, false), (&placed, true)] {
        let off = |i: usize| patches.emissions[i].iter().all(|&e| e == 0.0);
        for (j, (p, n)) in grid_points(patches, 3).into_iter().enumerate() {
            let i = j / 9;
            if off(i) && moving(patches, i) == want_moving {
                out.push((ProbePoint { p, n }, patches.areas[i] / 9.0));
            }
        }
    }
    out
}

/// Relative RMS difference of `a` against `b` over the surfaces (area-weighted) at
/// each frame time (at `fps`).
fn frame_differences(scene: &rhier::scene::Scene, a: &Reader, b: &Reader, fps: f64) -> Vec<f64> {
    let times = rhier::solver::spacetime::frame_instants(scene.time, fps).unwrap();
    times
        .iter()
        .map(|&t| {
            let (pts, areas): (Vec<ProbePoint>, Vec<f64>) = points_at(scene, t).into_iter().unzip();
            let (va, vb) = (probe(a, &pts, t).unwrap(), probe(b, &pts, t).unwrap());
            let (mut num, mut den) = (0.0, 0.0);
            for ((x, y), w) in va.iter().zip(&vb).zip(&areas) {
                for k in 0..3 {
                    num += w * (x[k] - y[k]).powi(2);
                    den += w * y[k].powi(2);
                }
            }
            assert!(den > 0.0, "no light at t = {t}");
            (num / den).sqrt()
        })
        .collect()
}

#[test]
fn grid_points_cover_each_patch_nine_times() {
    // `points_at` tells a point's patch by its index: 9 points a patch.
    let scene = rhier::scene::load(&example("light.json")).unwrap();
    let patches = Patches::at_time(&scene, 0.0);
    assert_eq!(grid_points(&patches, 3).len(), 9 * patches.geometry.len());
}

/// The shards of LIGHT and ACTOR merge into the file the solve on one machine
/// writes: every window's leaves bit for bit (a window depends on no other, so a
/// shard's first window is the single solve's), and so every probe at every frame.
/// Issue 50 asks for 0.5% relative RMS at every frame; when windows handed their
/// final-gather terms on, a shard's cold first window made LIGHT's worst frame here
/// 1.2% off (BENCHMARKS.md, "Farm").
#[test]
fn merged_shards_match_the_solve_on_one_machine_at_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["light.json", "actor.json"] {
        let scene_path = example(name);
        let scene = rhier::scene::load(&scene_path).unwrap();
        let sub = dir.path().join(name);
        std::fs::create_dir_all(&sub).unwrap();
        let single = sub.join("single.rhier");
        succeeded(solve(&scene_path, LIGHT, None, &single));
        let parts = solve_shards(&scene_path, LIGHT, 3, &sub);
        let merged = sub.join("merged.rhier");
        succeeded(merge(&parts, &merged));
        let (a, b) = (
            Reader::open(&merged).unwrap(),
            Reader::open(&single).unwrap(),
        );
        a.verify().unwrap();
        assert_eq!(a.chunks().len(), 7);
        // Every shard holds windows, so every shard but the first starts cold.
        for p in &parts {
            assert!(Reader::open(p).unwrap().chunks().len() >= 2, "{p:?}");
        }
        assert!(same_chunks(&a, &b), "{name}: the merged chunks differ");
        // The merged file says what it is: every window, shard 0 of 1, the
        // single solve's fingerprint.
        let (pa, pb) = (a.provenance().unwrap(), b.provenance().unwrap());
        assert_eq!(pa, pb);
        assert_eq!((pa.first, pa.end, pa.shard, pa.shards), (0, 7, 0, 1));
        let diffs = frame_differences(&scene, &a, &b, 4.0);
        assert_eq!(diffs.len(), 13);
        assert!(diffs.iter().all(|&d| d == 0.0), "{name}: {diffs:?}");
    }
}

/// The merged file is the same whatever N for the same shard boundaries: 6 shards
/// of 5 windows are 5 of one window and an empty one, as 5 shards are. `plan`
/// shows those boundaries; a shard read from `--shard-index-env` is the one given
/// by `--shard K/N`.
#[test]
fn the_merged_file_is_the_same_whatever_n_for_the_same_boundaries() {
    let dir = tempfile::tempdir().unwrap();
    let scene = example("cornell_moving.json");
    let plan = |n: &str| {
        let o = succeed(
            rhier()
                .arg("plan")
                .arg(&scene)
                .args(&CORNELL[..4])
                .args(["--shards", n, "--json"]),
        );
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let bounds = |p: &serde_json::Value| -> Vec<(u64, u64)> {
        p["shards"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                (
                    s["windows"][0].as_u64().unwrap(),
                    s["windows"][1].as_u64().unwrap(),
                )
            })
            .collect()
    };
    let (p5, p6) = (plan("5"), plan("6"));
    assert_eq!(p5["windows"].as_array().unwrap().len(), 5);
    assert_eq!(bounds(&p5), [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)]);
    assert_eq!(&bounds(&p6)[..5], &bounds(&p5)[..]);
    assert_eq!(bounds(&p6)[5], (5, 5));
    let (d5, d6) = (dir.path().join("n5"), dir.path().join("n6"));
    std::fs::create_dir_all(&d5).unwrap();
    std::fs::create_dir_all(&d6).unwrap();
    let parts5 = solve_shards(&scene, CORNELL, 5, &d5);
    // N = 6 through the environment, as a job array runs it.
    let parts6: Vec<PathBuf> = (0..6)
        .map(|k| {
            let p = d6.join(format!("part-{k}.rhier"));
            succeeded(solve_from_env(&scene, &k.to_string(), &p));
            p
        })
        .collect();
    assert!(
        Reader::open(&parts6[5]).unwrap().chunks().is_empty(),
        "the sixth shard holds no window"
    );
    let (m5, m6) = (dir.path().join("m5.rhier"), dir.path().join("m6.rhier"));
    succeeded(merge(&parts5, &m5));
    succeeded(merge(&parts6, &m6));
    let (a, b) = (Reader::open(&m5).unwrap(), Reader::open(&m6).unwrap());
    assert_eq!(a.chunks().len(), 5);
    assert!(same_chunks(&a, &b));
    // An index the shard count does not have is refused, naming the variable.
    let o = solve_from_env(&scene, "6", &dir.path().join("x.rhier"));
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("RHIER_TEST_INDEX = 6"));
}

/// Every refusal of `merge` names the part (or the missing shard) and leaves no
/// file; re-running the missing index alone completes the set.
#[test]
fn merge_refuses_gaps_overlaps_other_settings_and_corrupt_parts() {
    let dir = tempfile::tempdir().unwrap();
    let scene = example("cornell_moving.json");
    let parts = solve_shards(&scene, CORNELL, 3, dir.path());
    let out = dir.path().join("full.rhier");
    // A missing shard: a gap, the shard named with its windows.
    let missing = [parts[0].clone(), parts[2].clone()];
    refused(&missing, &out, &["shard 1", "missing", "windows"]);
    // The same part twice: an overlap.
    let twice = dir.path().join("again.rhier");
    std::fs::copy(&parts[1], &twice).unwrap();
    let mut all = parts.clone();
    all.push(twice.clone());
    refused(&all, &out, &["again.rhier", "shard 1 of 3 again"]);
    // A shard of another split.
    let other_n = dir.path().join("other-n.rhier");
    succeeded(solve(&scene, CORNELL, Some("1/2"), &other_n));
    refused(
        &[parts[0].clone(), other_n.clone(), parts[2].clone()],
        &out,
        &["other-n.rhier", "a shard of 2"],
    );
    // Other settings: the setting named.
    let other = dir.path().join("other-eps.rhier");
    succeeded(solve(
        &scene,
        &[CORNELL, &["--eps", "0.75"]].concat(),
        Some("1/3"),
        &other,
    ));
    refused(
        &[parts[0].clone(), other.clone(), parts[2].clone()],
        &out,
        &["other-eps.rhier", "different solve", "eps"],
    );
    // A file that is no part: a static solve.
    let stat = dir.path().join("static.rhier");
    succeed(rhier().args(["solve", "-q", "--eps", "1", "-o"]).arg(&stat));
    refused(
        std::slice::from_ref(&stat),
        &out,
        &["static.rhier", "provenance"],
    );
    // A corrupt part: one bit of a chunk flipped.
    let bad = dir.path().join("bad.rhier");
    let mut bytes = std::fs::read(&parts[1]).unwrap();
    let r = Reader::open(&parts[1]).unwrap();
    let e = r.sections()[r.chunks()[0].section as usize];
    bytes[(e.offset + e.stored_len / 2) as usize] ^= 0x10;
    std::fs::write(&bad, &bytes).unwrap();
    refused(
        &[parts[0].clone(), bad.clone(), parts[2].clone()],
        &out,
        &["bad.rhier", "CRC-32"],
    );
    // A merge that fails leaves an existing output as it was.
    std::fs::write(&out, b"earlier").unwrap();
    assert_eq!(merge(&missing, &out).status.code(), Some(1));
    assert_eq!(std::fs::read(&out).unwrap(), b"earlier");
    std::fs::remove_file(&out).unwrap();
    // The output may not be a part.
    let before = std::fs::read(&parts[0]).unwrap();
    let o = merge(&parts, &parts[0]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is one of the parts"));
    assert_eq!(std::fs::read(&parts[0]).unwrap(), before);
    // Re-running the missing index alone completes the set.
    std::fs::remove_file(&parts[1]).unwrap();
    succeeded(solve(&scene, CORNELL, Some("1/3"), &parts[1]));
    succeeded(merge(&parts, &out));
    let m = Reader::open(&out).unwrap();
    m.verify().unwrap();
    assert_eq!(m.chunks().len(), 5);
}

/// `--resume` inside a shard continues from the shard's last journaled window (its
/// journal counts from the shard's first window) with the leaves of an
/// uninterrupted shard, and refuses the journal of another shard.
#[test]
fn resume_works_inside_a_shard_and_the_journal_knows_its_shard() {
    let dir = tempfile::tempdir().unwrap();
    let scene = example("cornell_moving.json");
    let (full, cut) = (dir.path().join("full.rhier"), dir.path().join("cut.rhier"));
    // Shard 1 of 2 holds the last windows, at least two of them.
    succeeded(solve(&scene, CORNELL, Some("1/2"), &full));
    let p = Reader::open(&full).unwrap().provenance().unwrap().clone();
    assert!(p.end - p.first >= 2, "{p:?}");
    let stop = rhier()
        .arg("solve")
        .arg(&scene)
        .args(CORNELL)
        .args(["--shard", "1/2", "--stop-after-windows", "1", "-o"])
        .arg(&cut)
        .output()
        .unwrap();
    assert_eq!(stop.status.code(), Some(1));
    assert!(!cut.exists());
    let journal = rhier::store::journal::journal_dir(&cut);
    assert!(journal.join(format!("window-{:05}.bin", p.first)).exists());
    assert!(
        !journal
            .join(format!("window-{:05}.bin", p.first + 1))
            .exists()
    );
    // Another shard's resume is another solve.
    let other = rhier()
        .arg("solve")
        .arg(&scene)
        .args(CORNELL)
        .args(["--shard", "0/2", "--resume", "-o"])
        .arg(&cut)
        .output()
        .unwrap();
    assert_eq!(other.status.code(), Some(1));
    let err = String::from_utf8_lossy(&other.stderr);
    assert!(
        err.contains("different solve") && err.contains("shard"),
        "{err}"
    );
    succeed(
        rhier()
            .arg("solve")
            .arg(&scene)
            .args(CORNELL)
            .args(["--shard", "1/2", "--resume", "-o"])
            .arg(&cut),
    );
    assert!(!journal.exists());
    let (a, b) = (Reader::open(&full).unwrap(), Reader::open(&cut).unwrap());
    assert!(same_chunks(&a, &b));
    assert_eq!(a.provenance(), b.provenance());
}
