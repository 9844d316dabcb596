//! What several test modules share: the `rhier` binary (run, or spawned and killed
//! when dropped), the example files, scenes
//! built in code (boxes, enclosures, random flatland scenes) and a seeded generator.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

use glam::DVec3;
use rhier::scene::{Material, MaterialId, Object, Polygon, Scene};

/// A command that runs the `rhier` binary cargo built for these tests.
pub fn rhier() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rhier"))
}

/// `out`, after failing the test with the process's standard error unless it exited 0.
#[track_caller]
pub fn succeeded(out: Output) -> Output {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs `cmd` (a [`rhier`] command) and fails the test with its standard error unless
/// it exits 0.
#[track_caller]
pub fn succeed(cmd: &mut Command) -> Output {
    succeeded(cmd.output().expect("rhier starts"))
}

/// A running `rhier` process, killed and reaped when dropped, so that a failing test
/// leaves none behind; it derefs to its [`Child`].
pub struct Running(Child);

impl std::ops::Deref for Running {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Running {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        // Already ended (waited for by the test) is fine: nothing to kill.
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `cmd` (a [`rhier`] command) with its stdin, stdout and stderr piped.
pub fn spawn_piped(cmd: &mut Command) -> Running {
    Running(
        cmd.stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("rhier starts"),
    )
}

/// The path of `formats/examples/<name>`, the example files the formats' docs show.
pub fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("formats/examples")
        .join(name)
}

/// An axis-aligned box `[lo, hi]` as 6 quads facing inwards, each split into
/// `n × n` quads; all faces use material 0 unless `material_of_face` says otherwise.
pub fn closed_box(
    lo: DVec3,
    hi: DVec3,
    n: usize,
    material_of_face: impl Fn(usize) -> u32,
) -> Vec<Polygon> {
    let mut polys = Vec::new();
    // Each face: origin, edge u, edge v with u × v pointing inwards.
    let d = hi - lo;
    let faces = [
        (lo, DVec3::new(d.x, 0.0, 0.0), DVec3::new(0.0, d.y, 0.0)), // z = lo, +z
        (
            DVec3::new(lo.x, lo.y, hi.z),
            DVec3::new(0.0, d.y, 0.0),
            DVec3::new(d.x, 0.0, 0.0),
        ), // z = hi, -z
        (lo, DVec3::new(0.0, d.y, 0.0), DVec3::new(0.0, 0.0, d.z)), // x = lo, +x
        (
            DVec3::new(hi.x, lo.y, lo.z),
            DVec3::new(0.0, 0.0, d.z),
            DVec3::new(0.0, d.y, 0.0),
        ), // x = hi, -x
        (lo, DVec3::new(0.0, 0.0, d.z), DVec3::new(d.x, 0.0, 0.0)), // y = lo, +y
        (
            DVec3::new(lo.x, hi.y, lo.z),
            DVec3::new(d.x, 0.0, 0.0),
            DVec3::new(0.0, 0.0, d.z),
        ), // y = hi, -y
    ];
    for (fi, (o, u, v)) in faces.iter().enumerate() {
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
                let (c, e) = (j as f64 / n as f64, (j + 1) as f64 / n as f64);
                polys.push(Polygon {
                    vertices: vec![
                        *o + a * *u + c * *v,
                        *o + b * *u + c * *v,
                        *o + b * *u + e * *v,
                        *o + a * *u + e * *v,
                    ],
                    material: MaterialId(material_of_face(fi)),
                });
            }
        }
    }
    polys
}

/// A closed unit cube with uniform exitance `e` and reflectance `rho` everywhere.
pub fn uniform_enclosure(rho: f64, e: f64, scale: f64, n: usize) -> Scene {
    let polys = closed_box(DVec3::ZERO, DVec3::splat(scale), n, |_| 0);
    Scene {
        materials: vec![Material {
            name: "m".into(),
            rho: [rho; 3],
            emission: [e; 3],
        }],
        objects: vec![Object::still("box", polys)],
        ..Default::default()
    }
}
#[cfg(unix)]
pub mod fifo;
pub mod probe;
pub mod shapes;

/// Deterministic pseudo-random numbers in [0, 1) (a 64-bit LCG, the high 53 bits).
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number.
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        rhier::oracle::unit(self.0)
    }
}

/// `n` random segments in the unit square, of lengths `min_len` to `min_len + 0.3`,
/// none crossing another, from seed `seed`.
pub fn random_segments(
    seed: u64,
    n: usize,
    min_len: f64,
) -> Vec<rhier::flatland::scene::PosedSegment> {
    use rhier::flatland::scene::{PosedSegment, first_crossing};
    let mut rng = Lcg(seed);
    let mut segs: Vec<PosedSegment> = Vec::new();
    while segs.len() < n {
        let a = [rng.next(), rng.next()];
        let ang = rng.next() * std::f64::consts::TAU;
        let len = min_len + 0.3 * rng.next();
        let s = PosedSegment::new(a, [a[0] + len * ang.cos(), a[1] + len * ang.sin()], 0);
        let mut all = segs.clone();
        all.push(s);
        if first_crossing(&all).is_none() {
            segs.push(s);
        }
    }
    segs
}

/// [`random_segments`] of lengths 0.15–0.45, each split at `splits - 1` evenly
/// spaced parameters (1: whole): the flatland tests' scenes in general position.
pub fn random_flat_geometry(
    seed: u64,
    n: usize,
    splits: usize,
) -> rhier::flatland::geometry::FlatGeometry {
    let ts: Vec<f64> = (1..splits).map(|k| k as f64 / splits as f64).collect();
    rhier::flatland::geometry::FlatGeometry::new(random_segments(seed, n, 0.15), &vec![ts; n])
}

/// `k` random static segments of length 0.6 in `[0, 3]²` as the JSON of a flatland
/// object's segment list, segment `i` emitting `emission(i)`, drawn from `rng`.
pub fn random_segments_json(rng: &mut Lcg, k: usize, emission: impl Fn(usize) -> f64) -> String {
    let mut segs = String::new();
    for i in 0..k {
        let a = [3.0 * rng.next(), 3.0 * rng.next()];
        let ang = rng.next() * std::f64::consts::TAU;
        let b = [a[0] + 0.6 * ang.cos(), a[1] + 0.6 * ang.sin()];
        if i > 0 {
            segs.push(',');
        }
        segs.push_str(&format!(
            r#"{{"a": [{}, {}], "b": [{}, {}], "reflectance": 0.5, "emission": {}}}"#,
            a[0],
            a[1],
            b[0],
            b[1],
            emission(i)
        ));
    }
    segs
}

/// `k` random static segments of length 0.6 in `[0, 3]²` (the first one emits) and
/// a triangle moving over `t ∈ [0, 1]` (a translation in `[-1, 1]²`, a rotation in
/// `[rot_min, rot_min + 3]` radians), from seed `seed`; None if two segments cross
/// anywhere along the path (401 times sampled): the flatland motion tests' scenes.
pub fn random_moving_flat_scene(
    seed: u64,
    k: usize,
    rot_min: f64,
) -> Option<rhier::flatland::scene::FlatScene> {
    use rhier::flatland::scene::{first_crossing, parse};
    let mut rng = Lcg(seed);
    let segs = random_segments_json(&mut rng, k, |i| if i == 0 { 1.0 } else { 0.0 });
    let (x, y) = (3.0 * rng.next(), 3.0 * rng.next());
    let (dx, dy, rot) = (
        2.0 * rng.next() - 1.0,
        2.0 * rng.next() - 1.0,
        rot_min + 3.0 * rng.next(),
    );
    let text = format!(
        r#"{{"rhier_flatland": 1, "objects": [{{"name": "static", "segments": [{segs}]}},
        {{"name": "tri", "segments": [
          {{"a": [{x}, {y}], "b": [{x1}, {y}], "reflectance": 0.3}},
          {{"a": [{x1}, {y}], "b": [{x}, {y1}], "reflectance": 0.3}},
          {{"a": [{x}, {y1}], "b": [{x}, {y}], "reflectance": 0.3}}],
         "motion": [{{"t": 0}}, {{"t": 1, "translation": [{dx}, {dy}], "rotation": {rot}}}]}}]}}"#,
        x1 = x + 0.3,
        y1 = y + 0.3
    );
    let scene = parse(std::path::Path::new("random"), &text).ok()?;
    if (0..=400).any(|k| first_crossing(&scene.posed(k as f64 / 400.0)).is_some()) {
        return None;
    }
    Some(scene)
}
