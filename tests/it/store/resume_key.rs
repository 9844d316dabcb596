//! The resume journal's key: every option that changes the windows a space-time
//! solve writes is in it, so a resume under another setting is refused and names
//! it; the options left out on purpose are exactly those the solver lists.

use std::collections::BTreeSet;

use rhier::pools::Storage;
use rhier::scene::Scene;
use rhier::solver::SolveOptions;
use rhier::solver::spacetime::{
    SOLVE_OPTIONS_NOT_IN_KEY, SPACE_TIME_OPTIONS_NOT_IN_KEY, SpaceTimeOptions, result_settings,
};
use rhier::store::journal::{Journal, fingerprint};

/// The journal key of a solve of `scene` under `opts` and `st`.
fn journal_key(scene: &Scene, opts: &SolveOptions, st: &SpaceTimeOptions) -> rhier::Result<String> {
    fingerprint(scene, &result_settings(opts, st)?)
}

/// A change of one field of the option structs, still a valid setting.
type Change = fn(&mut SolveOptions, &mut SpaceTimeOptions);

/// Every field of [`SolveOptions`] and [`SpaceTimeOptions`] that changes the
/// windows a solve writes, as `solve.NAME` / `space_time.NAME`, with a change of
/// it. A field added to either struct fails
/// [`every_setting_that_changes_the_result_refuses_the_resume`] until it is put
/// here or left out of the key on purpose (`*_NOT_IN_KEY`, [`not_in_key`]).
fn in_key() -> Vec<(&'static str, Change)> {
    vec![
        ("solve.eps", |o, _| o.eps *= 0.5),
        ("solve.min_size", |o, _| o.min_size *= 0.5),
        ("solve.rays_per_point", |o, _| o.rays_per_point += 1),
        ("solve.cluster_rays", |o, _| o.cluster_rays += 1),
        ("solve.corner_rays", |o, _| o.corner_rays += 1),
        ("solve.open_ratio", |o, _| o.open_ratio *= 0.5),
        ("solve.open_spread", |o, _| o.open_spread += 0.25),
        ("solve.max_rounds", |o, _| o.max_rounds += 1),
        ("solve.target_error", |o, _| o.target_error = Some(0.01)),
        ("solve.error_samples", |o, _| o.error_samples += 1),
        ("solve.time_budget", |o, _| o.time_budget = Some(60.0)),
        ("solve.tolerance", |o, _| o.tolerance *= 0.5),
        ("solve.seed", |o, _| o.seed += 1),
        ("solve.recon_tol", |o, _| o.recon_tol *= 0.5),
        ("solve.recon_tol_moving", |o, _| {
            o.recon_tol_moving = Some(0.01)
        }),
        ("solve.recon_min_size", |o, _| o.recon_min_size *= 0.5),
        ("solve.contact_meshing", |o, _| o.contact_meshing ^= true),
        ("solve.power_size", |o, _| o.power_size *= 0.5),
        ("solve.row_open_ratio", |o, _| o.row_open_ratio *= 0.5),
        ("solve.cluster_open_ratio", |o, _| {
            o.cluster_open_ratio *= 0.5
        }),
        ("solve.faint_source", |o, _| o.faint_source *= 0.5),
        ("solve.split_spread", |o, _| o.split_spread += 0.15),
        ("solve.leaf_shapes", |o, _| o.leaf_shapes += 0.1),
        ("solve.source_field", |o, _| {
            o.source_field = !o.source_field
        }),
        ("solve.cluster_facets", |o, _| {
            o.cluster_facets = !o.cluster_facets
        }),
        ("solve.near_gap", |o, _| o.near_gap += 0.1),
        ("solve.near_field", |o, _| o.near_field = !o.near_field),
        ("space_time.fps", |_, s| s.fps *= 2.0),
        ("space_time.window", |_, s| s.window = Some(0.5)),
        ("space_time.merge_tol", |_, s| s.merge_tol *= 0.5),
        ("space_time.kept_budget", |_, s| {
            s.kept_budget = Some(1 << 20)
        }),
        ("space_time.key_stride", |_, s| s.key_stride = Some(4)),
        ("space_time.key_motion", |_, s| s.key_motion *= 0.5),
        ("space_time.interp_tol", |_, s| s.interp_tol *= 0.5),
        ("space_time.interp_motion", |_, s| s.interp_motion *= 0.5),
        ("space_time.moving_power_tol", |_, s| {
            s.moving_power_tol *= 0.5
        }),
        ("space_time.direct_apart", |_, s| s.direct_apart ^= true),
    ]
}

/// The fields left out of the key, with a change of each: exactly those
/// [`SOLVE_OPTIONS_NOT_IN_KEY`] and [`SPACE_TIME_OPTIONS_NOT_IN_KEY`] name.
fn not_in_key() -> Vec<(&'static str, Change)> {
    vec![
        ("solve.storage", |o, _| {
            o.storage = Storage::Mmap(std::env::temp_dir())
        }),
        ("solve.keep_passive", |o, _| {
            o.keep_passive = !o.keep_passive
        }),
        ("solve.sealed_regions", |o, _| {
            o.sealed_regions = !o.sealed_regions
        }),
    ]
}

/// The fields of both structs, as `solve.NAME` / `space_time.NAME`, with values.
fn fields(o: &SolveOptions, s: &SpaceTimeOptions) -> Vec<(String, serde_json::Value)> {
    let mut all = Vec::new();
    for (prefix, v) in [
        ("solve", serde_json::to_value(o).unwrap()),
        ("space_time", serde_json::to_value(s).unwrap()),
    ] {
        let map = v
            .as_object()
            .expect("an option struct serializes as an object");
        all.extend(
            map.iter()
                .map(|(k, v)| (format!("{prefix}.{k}"), v.clone())),
        );
    }
    all
}

#[test]
fn every_setting_that_changes_the_result_refuses_the_resume() {
    // The defaults, but in RAM whatever `RHIER_STORAGE` says.
    let opts = SolveOptions {
        storage: Storage::Ram,
        ..SolveOptions::default()
    };
    let st = SpaceTimeOptions::default();
    let names = |list: &[(&'static str, Change)]| -> BTreeSet<String> {
        list.iter().map(|(n, _)| n.to_string()).collect()
    };
    let (inside, outside) = (in_key(), not_in_key());
    // Every field of the two structs is decided, once.
    let all: BTreeSet<String> = fields(&opts, &st).into_iter().map(|(n, _)| n).collect();
    let decided: BTreeSet<String> = names(&inside).union(&names(&outside)).cloned().collect();
    assert_eq!(
        all, decided,
        "every field of SolveOptions and SpaceTimeOptions must be decided: if it changes \
         the windows a solve writes, add it to in_key(); if not, name it in \
         SOLVE_OPTIONS_NOT_IN_KEY / SPACE_TIME_OPTIONS_NOT_IN_KEY with the reason, and \
         in not_in_key()"
    );
    assert!(names(&inside).is_disjoint(&names(&outside)));
    let excluded: BTreeSet<String> = (SOLVE_OPTIONS_NOT_IN_KEY.iter())
        .map(|n| format!("solve.{n}"))
        .chain(
            SPACE_TIME_OPTIONS_NOT_IN_KEY
                .iter()
                .map(|n| format!("space_time.{n}")),
        )
        .collect();
    assert_eq!(names(&outside), excluded);

    let scene = rhier::scene::cornell_box(false);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.rhier");
    let key = journal_key(&scene, &opts, &st).unwrap();
    Journal::create(&out, &key).unwrap();
    // The same solve resumes.
    Journal::resume(&out, &journal_key(&scene, &opts, &st).unwrap()).unwrap();
    let changed = |change: &Change| {
        let (mut o, mut s) = (opts.clone(), st);
        change(&mut o, &mut s);
        o.validate().unwrap();
        s.validate().unwrap();
        let before = fields(&opts, &st);
        let moved: Vec<String> = fields(&o, &s)
            .into_iter()
            .zip(before)
            .filter(|(a, b)| a != b)
            .map(|(a, _)| a.0)
            .collect();
        (journal_key(&scene, &o, &s).unwrap(), moved)
    };
    for (name, change) in &inside {
        let (other, moved) = changed(change);
        // The change is to the field it is listed under, alone.
        assert_eq!(moved, [name.to_string()]);
        let e = Journal::resume(&out, &other).unwrap_err().to_string();
        let field = name.split_once('.').map_or(*name, |(_, f)| f);
        assert!(
            e.contains("different solve") && e.contains(&format!("\"{field}\"")),
            "{name}: {e}"
        );
    }
    for (name, change) in &outside {
        let (other, moved) = changed(change);
        assert_eq!(moved, [name.to_string()]);
        assert_eq!(other, key, "{name} is not in the key");
        Journal::resume(&out, &other).unwrap();
    }
    // Another scene is refused too, its content named.
    let mut darker = scene.clone();
    darker.materials[0].rho[0] *= 0.5;
    let e = Journal::resume(&out, &journal_key(&darker, &opts, &st).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("different solve") && e.contains("scene crc32"),
        "{e}"
    );
}
