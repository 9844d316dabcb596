//! The real `rhier` binary on a moving scene: a space-time solve streams one chunk per
//! window, an interrupted solve leaves no `.rhier` file and `--resume` finishes it with
//! the same leaves, and bad settings are refused with exit code 1 or 2.

use std::path::Path;
use std::process::Output;

use crate::common::{self, rhier, succeeded};

const SCENE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/formats/examples/cornell_moving.json"
);

fn solve(out: &Path, extra: &[&str]) -> Output {
    rhier()
        .args(["solve", SCENE, "-q", "--fps", "4", "--window", "0.5", "-o"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// [`solve`], which must succeed.
fn solve_ok(out: &Path, extra: &[&str]) {
    succeeded(solve(out, extra));
}

/// `a` and `b` hold as many chunks, with the same leaves.
fn assert_same_chunks(a: &rhier::store::Reader, b: &rhier::store::Reader) {
    assert_eq!(a.chunks().len(), b.chunks().len());
    for k in 0..a.chunks().len() {
        assert_eq!(
            a.chunk_leaves(k).unwrap(),
            b.chunk_leaves(k).unwrap(),
            "chunk {k}"
        );
    }
}

#[test]
fn interrupted_solve_leaves_no_file_and_resume_gives_the_same_leaves() {
    let dir = tempfile::tempdir().unwrap();
    let (full, cut) = (dir.path().join("full.rhier"), dir.path().join("cut.rhier"));
    solve_ok(&full, &[]);
    // 2 s at 4 fps: 9 frames, windows of 2 frames: 5 windows, one chunk each.
    let a = rhier::store::Reader::open(&full).unwrap();
    assert_eq!(a.chunks().len(), 5);
    assert_eq!(a.stats().iterations, 9);
    assert!(!rhier::store::journal::journal_dir(&full).exists());

    let out = solve(&cut, &["--stop-after-windows", "2"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        !cut.exists(),
        "an interrupted solve must not leave a .rhier file"
    );
    let journal = rhier::store::journal::journal_dir(&cut);
    assert!(journal.join("window-00001.bin").exists());
    assert!(!journal.join("window-00002.bin").exists());

    // Resuming with other settings is refused, the journal kept.
    let out = solve(&cut, &["--resume", "--eps", "0.25"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("solve.key") && err.contains("different solve"),
        "{err}"
    );
    assert!(journal.exists());

    solve_ok(&cut, &["--resume"]);
    assert!(!journal.exists());
    let b = rhier::store::Reader::open(&cut).unwrap();
    assert_eq!(b.chunks().len(), 5);
    assert_same_chunks(&a, &b);
    // Every time of the animation has leaves covering the frame, and probing works.
    for t in [0.0, 0.37, 1.0, 1.99, 2.0] {
        assert!(!b.leaves_at(t).unwrap().is_empty(), "t = {t}");
    }
}

#[test]
fn the_last_window_is_solved_again_on_resume_from_the_one_before() {
    // A solve is journaled up to the window before the last (the file is
    // finished right after the last; a solve interrupted in it solves it again).
    // Stopped there, the journal holds the four windows, and resuming solves the
    // last window as the uninterrupted solve did.
    let dir = tempfile::tempdir().unwrap();
    let (full, cut) = (dir.path().join("full.rhier"), dir.path().join("cut.rhier"));
    solve_ok(&full, &[]);
    let out = solve(&cut, &["--stop-after-windows", "4"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(!cut.exists());
    let journal = rhier::store::journal::journal_dir(&cut);
    assert!(journal.join("window-00003.bin").exists());
    assert!(!journal.join("window-00004.bin").exists());
    solve_ok(&cut, &["--resume"]);
    assert!(!journal.exists());
    let (a, b) = (
        rhier::store::Reader::open(&full).unwrap(),
        rhier::store::Reader::open(&cut).unwrap(),
    );
    assert_eq!(a.chunks().len(), 5);
    assert_same_chunks(&a, &b);
}

/// Regression (issue 46): the journal's fingerprint was spelt out by hand and left
/// out `--near-gap`, so resuming with another `--near-gap` silently mixed windows
/// solved under two settings. It is refused now, the setting named, the journal
/// kept; what changes no result (the thread count, the storage) may change, and the
/// resumed file has the leaves of the uninterrupted solve.
#[test]
fn resume_refuses_another_near_gap_and_takes_other_threads_and_storage() {
    let dir = tempfile::tempdir().unwrap();
    let (full, cut) = (dir.path().join("full.rhier"), dir.path().join("cut.rhier"));
    solve_ok(&full, &["--threads", "2"]);
    let out = solve(&cut, &["--threads", "1", "--stop-after-windows", "2"]);
    assert_eq!(out.status.code(), Some(1));
    let journal = rhier::store::journal::journal_dir(&cut);
    let out = solve(&cut, &["--resume", "--near-gap", "0.1"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("different solve") && err.contains("near_gap"),
        "{err}"
    );
    assert!(journal.join("window-00001.bin").exists());
    solve_ok(&cut, &["--resume", "--threads", "2", "--storage", "ram"]);
    assert!(!journal.exists());
    assert_same_chunks(
        &rhier::store::Reader::open(&full).unwrap(),
        &rhier::store::Reader::open(&cut).unwrap(),
    );
}

#[test]
fn out_of_core_by_default_with_the_leaves_of_ram_and_no_scratch_left() {
    // A space-time solve pages its pools, kept terms and leaves through files in
    // the journal directory unless asked for RAM; the file is the same either way
    // (but for the timing in its stats), and no scratch file outlives the solve,
    // interrupted or not.
    let dir = tempfile::tempdir().unwrap();
    let (paged, ram) = (dir.path().join("paged.rhier"), dir.path().join("ram.rhier"));
    for (out, extra) in [
        (&paged, &["--stats"][..]),
        (&ram, &["--storage", "ram"][..]),
    ] {
        solve_ok(out, extra);
    }
    let (a, b) = (
        rhier::store::Reader::open(&paged).unwrap(),
        rhier::store::Reader::open(&ram).unwrap(),
    );
    assert_same_chunks(&a, &b);
    let names = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(dir.path()), ["paged.rhier", "ram.rhier"]);
    // Interrupted after two windows: the journal holds its windows and its key
    // only (a window depends on no other).
    let cut = dir.path().join("cut.rhier");
    let o = solve(&cut, &["--stop-after-windows", "2"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        names(&rhier::store::journal::journal_dir(&cut)),
        ["solve.key", "window-00000.bin", "window-00001.bin"]
    );
}

#[test]
fn bad_time_settings_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.rhier");
    for (args, code, needle) in [
        (vec!["--fps", "0"], 1, "--fps"),
        (vec!["--window=-1"], 1, "--window"),
        (vec!["--keep-links"], 1, "--keep-links"),
        (vec!["--fps", "many"], 2, "--fps"),
        (vec!["--key-stride", "0"], 1, "--key-stride"),
        (vec!["--key-stride=-1"], 2, "--key-stride"),
        (vec!["--key-motion", "0"], 1, "--key-motion"),
        (vec!["--key-motion", "inf"], 1, "--key-motion"),
        (vec!["--interp-tol", "0"], 1, "--interp-tol"),
        (vec!["--interp-tol", "NaN"], 1, "--interp-tol"),
        // Settings of the static solve's last round, which a window never reaches.
        (
            vec!["--leaf-shapes", "0.1"],
            1,
            "--leaf-shapes applies to static solves",
        ),
        (
            vec!["--split-spread", "0.15"],
            1,
            "--split-spread applies to static",
        ),
    ] {
        let o = rhier()
            .args(["solve", SCENE, "-q", "-o"])
            .arg(&out)
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(code), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!out.exists());
    }
}

/// A space-time solve into a FIFO (as into `/dev/null`): the file arrives whole
/// through the FIFO, no journal is created beside it, and `--resume` is refused.
#[cfg(unix)]
#[test]
fn a_fifo_output_gets_the_file_and_no_journal() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let (fifo, file) = (dir.path().join("pipe"), dir.path().join("file.rhier"));
    let reader = common::fifo::fifo_with_reader(&fifo);
    succeeded(solve(&fifo, &[]));
    assert!(!rhier::store::journal::journal_dir(&fifo).exists());
    // Checked before joining: a replaced FIFO would leave the reader blocked forever.
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let got = reader.join().unwrap();
    // The same solve into a file: the same leaves (the stats differ in seconds).
    solve_ok(&file, &[]);
    let piped = dir.path().join("piped.rhier");
    std::fs::write(&piped, got).unwrap();
    let leaves = |p: &Path| {
        rhier::store::Reader::open(p)
            .unwrap()
            .to_solution()
            .unwrap()
            .leaves
    };
    assert_eq!(leaves(&piped), leaves(&file));
    let resumed = solve(&fifo, &["--resume"]);
    assert_eq!(resumed.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&resumed.stderr).contains("not a regular file"));
}
