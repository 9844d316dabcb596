//! Visibility events of moving objects (paper §5.2): the priority queue's event times
//! against brute-force time sampling of the visibility graph, and the event-by-event
//! update against from-scratch views and form factors at every step.

use std::path::Path;

use rhier::flatland::dynamic::Dynamic;
use rhier::flatland::events::{Event, EventQueue, Trajectories, find_events};
use rhier::flatland::geometry_at;
use rhier::flatland::mesh::Mesh;
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::{FlatScene, first_crossing, load, parse};
use rhier::flatland::views::{Topology, all_views};

use crate::common::{Lcg, random_moving_flat_scene, random_segments_json};

/// Brute-force visibility graph (all point pairs, `sees`).
fn brute_graph(scene: &FlatScene, t: f64) -> Vec<(u32, u32)> {
    let g = geometry_at(scene, t, Mesh::None);
    let mut out = Vec::new();
    for u in 0..g.points.len() {
        for w in u + 1..g.points.len() {
            if g.sees(g.points[u], g.points[w]) {
                out.push((u as u32, w as u32));
            }
        }
    }
    out
}

#[test]
fn queue_pops_events_in_time_order() {
    let mut q = EventQueue::default();
    for (i, t) in [0.7, 0.1, 0.5, 0.3, 0.9, 0.2].iter().enumerate() {
        q.push(Event {
            time: *t,
            ends: [i as u32, 10],
            mid: 20,
            _pad: 0,
        });
    }
    assert_eq!(q.peek_time(), Some(0.1));
    let times: Vec<f64> = q.drain_sorted().iter().map(|e| e.time).collect();
    assert_eq!(times, vec![0.1, 0.2, 0.3, 0.5, 0.7, 0.9]);
    assert!(q.is_empty());
}

#[test]
fn event_times_match_brute_force_sampling_of_the_visibility_graph() {
    let (mut scenes, mut changes) = (0, 0);
    for seed in 1..60u64 {
        let Some(scene) = random_moving_flat_scene(seed, 5, -1.5) else {
            continue;
        };
        scenes += 1;
        let steps = [0.0, 0.25, 0.5, 0.75, 1.0];
        let mut events: Vec<Event> = Vec::new();
        for w in steps.windows(2) {
            let g = geometry_at(&scene, w[0], Mesh::None);
            let traj = Trajectories::new(&scene, &g, w[0]);
            let mut q = find_events(&scene, &traj, &[1], w[0], w[1]);
            let popped = q.drain_sorted();
            assert!(popped.windows(2).all(|p| p[0].time <= p[1].time));
            assert!(popped.iter().all(|e| e.time >= w[0] && e.time <= w[1]));
            events.extend(popped);
        }
        // Every change of the visibility graph between two samples has an event of
        // the same pair inside the sample interval.
        let m = 1500;
        let mut prev = brute_graph(&scene, 0.0);
        for k in 1..=m {
            let (t0, t1) = ((k - 1) as f64 / m as f64, k as f64 / m as f64);
            let now = brute_graph(&scene, t1);
            let diff = prev
                .iter()
                .filter(|p| !now.contains(p))
                .chain(now.iter().filter(|p| !prev.contains(p)));
            for &(u, w) in diff {
                changes += 1;
                assert!(
                    events
                        .iter()
                        .any(|e| e.ends == [u, w] && e.time >= t0 - 1e-9 && e.time <= t1 + 1e-9),
                    "seed {seed}: pair ({u}, {w}) changes in [{t0}, {t1}] without an event"
                );
            }
            prev = now;
        }
    }
    assert!(scenes >= 10, "only {scenes} valid scenes");
    assert!(changes >= 50, "only {changes} visibility changes sampled");
}

/// Views and form factors after every step equal a from-scratch computation.
fn check_path(scene: &FlatScene, times: &[f64], mesh: Mesh) -> (usize, usize, usize) {
    let (mut d, _) = Dynamic::new(scene, mesh, times[0]);
    let (mut events, mut candidates, mut spliced) = (0, 0, 0);
    for &t in &times[1..] {
        let rep = d.step(t);
        assert!(!rep.full, "t {t}: full step");
        assert!(rep.events <= rep.event_candidates);
        events += rep.events;
        candidates += rep.event_candidates;
        spliced += rep.views_spliced;
        let g = geometry_at(scene, t, mesh);
        let topo = Topology::new(&g);
        let (views, _) = all_views(&g, &topo);
        for (v, view) in views.iter().enumerate() {
            assert_eq!(view, &d.views()[v], "t {t}: view of point {v}");
        }
        let (full, _) = form_factors(&g);
        let ff = d.form_factors();
        let n = g.elements.len() as u32;
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (ff.f(i, j), full.f(i, j));
                assert!((a - b).abs() < 1e-11, "t {t} F({i},{j}): {a} vs {b}");
            }
        }
        assert_eq!(rep.ff_total, full.nonzeros(), "t {t}");
        assert!(rep.ff_recomputed <= rep.ff_total + 2 * rep.pairs_vanished);
    }
    (events, candidates, spliced)
}

#[test]
fn event_by_event_update_equals_from_scratch_on_random_paths() {
    let (mut tested, mut events, mut spliced) = (0, 0, 0);
    for seed in 100..140u64 {
        let Some(scene) = random_moving_flat_scene(seed, 6, -1.5) else {
            continue;
        };
        tested += 1;
        // Forwards in uneven steps, then backwards.
        let times = [0.0, 0.1, 0.35, 0.4, 0.8, 1.0, 0.6, 0.05];
        let (e, _, s) = check_path(&scene, &times, Mesh::None);
        events += e;
        spliced += s;
    }
    assert!(tested >= 10, "only {tested} valid scenes");
    // Most event ends are updated by the local splice (and the views then equal the
    // from-scratch views, checked in check_path).
    assert!(
        spliced * 2 >= events,
        "only {spliced} local splices for {events} events"
    );
    assert!(
        events >= 100,
        "only {events} topological events on the paths"
    );
}

#[test]
fn event_by_event_update_on_the_example_path_with_splits() {
    let scene = load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/formats/examples/flatland_moving.json"
    )))
    .unwrap();
    for mesh in [Mesh::None, Mesh::Uniform(2)] {
        // One large step through many events, then small ones.
        let times = [0.0, 1.0, 0.9, 0.85, 0.5, 0.45, 0.2];
        let (events, candidates, _) = check_path(&scene, &times, mesh);
        assert!(
            events >= 10,
            "{mesh:?}: only {events} events ({candidates} candidates)"
        );
    }
}

/// Two triangles moving at once (one with a keyframe inside the path, translating then
/// rotating), among random static segments.
fn two_movers(seed: u64) -> Option<FlatScene> {
    let mut rng = Lcg(seed);
    let segs = random_segments_json(&mut rng, 5, |_| 1.0);
    let mut tri = |name: &str| {
        let (x, y) = (3.0 * rng.next(), 3.0 * rng.next());
        let (dx, dy, rot) = (
            2.0 * rng.next() - 1.0,
            2.0 * rng.next() - 1.0,
            3.0 * rng.next() - 1.5,
        );
        format!(
            r#"{{"name": "{name}", "segments": [
              {{"a": [{x}, {y}], "b": [{x1}, {y}], "reflectance": 0.3}},
              {{"a": [{x1}, {y}], "b": [{x}, {y1}], "reflectance": 0.3}},
              {{"a": [{x}, {y1}], "b": [{x}, {y}], "reflectance": 0.3}}],
             "motion": [{{"t": 0}}, {{"t": 0.5, "translation": [{dx}, {dy}]}},
                        {{"t": 1, "translation": [{dx}, {dy}], "rotation": {rot}}}]}}"#,
            x1 = x + 0.3,
            y1 = y + 0.3
        )
    };
    let (a, b) = (tri("a"), tri("b"));
    let text = format!(
        r#"{{"rhier_flatland": 1, "objects": [{{"name": "static", "segments": [{segs}]}}, {a}, {b}]}}"#
    );
    let scene = parse(Path::new("random"), &text).ok()?;
    if (0..=400).any(|k| first_crossing(&scene.posed(k as f64 / 400.0)).is_some()) {
        return None;
    }
    Some(scene)
}

#[test]
fn two_objects_moving_at_once_with_a_keyframe_inside_the_steps() {
    let (mut tested, mut events) = (0, 0);
    for seed in 200..260u64 {
        let Some(scene) = two_movers(seed) else {
            continue;
        };
        tested += 1;
        let times = [0.0, 0.3, 0.7, 1.0, 0.2];
        events += check_path(&scene, &times, Mesh::None).0;
    }
    assert!(tested >= 5, "only {tested} valid scenes");
    assert!(events >= 30, "only {events} events");
}

#[test]
fn every_local_splice_equals_a_full_resweep_of_the_view() {
    use rhier::flatland::views::{Splice, splice_event, view_of};
    let (mut spliced, mut unchanged) = (0, 0);
    for seed in 300..330u64 {
        let Some(scene) = random_moving_flat_scene(seed, 6, -1.5) else {
            continue;
        };
        let g0 = geometry_at(&scene, 0.0, Mesh::None);
        let topo = Topology::new(&g0);
        let (mut views, _) = all_views(&g0, &topo);
        let traj = Trajectories::new(&scene, &g0, 0.0);
        let mut q = find_events(&scene, &traj, &[1], 0.0, 1.0);
        let events = q.drain_sorted();
        let mut gm = g0.clone();
        for (k, e) in events.iter().enumerate() {
            let next = events.get(k + 1).map_or(1.0, |n| n.time);
            if next - e.time < 1e-9 {
                continue; // simultaneous events: not the local case
            }
            let tm = 0.5 * (e.time + next);
            for (i, p) in gm.points.iter_mut().enumerate() {
                *p = traj.point(&scene, i as u32, tm);
            }
            let mut new = Vec::new();
            for (v, other) in [(e.ends[0], e.ends[1]), (e.ends[1], e.ends[0])] {
                let full = view_of(&gm, &topo, v).0;
                match splice_event(&gm, &topo, &views, v, e.mid, other) {
                    Some(Splice::New(view)) => {
                        spliced += 1;
                        assert_eq!(view, full, "seed {seed} event {e:?} at {v}");
                    }
                    Some(Splice::Unchanged) => {
                        unchanged += 1;
                        assert_eq!(views[v as usize], full, "seed {seed} event {e:?} at {v}");
                    }
                    None => {}
                }
                new.push((v, full));
            }
            for (v, view) in new {
                views[v as usize] = view;
            }
        }
    }
    assert!(
        spliced >= 50 && unchanged >= 50,
        "{spliced} splices, {unchanged} unchanged"
    );
}
