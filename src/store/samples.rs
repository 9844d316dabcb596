//! Solutions with known answers, built without the solver: used by the store and
//! playback tests, the committed sample files (`tests/data/`) and the benchmarks.
//!
//! [`box_solution`] is the closed unit box `[0,1]^3` seen from inside: six walls (the
//! floor as two triangles, the others quads) whose normals face the centre, each
//! subdivided uniformly into `n × n` leaves (`n²` sub-triangles for a triangle), with
//! corner radiosity taken from [`wall_radiosity`], a function linear in the world
//! position. On a planar wall a linear function is exactly bilinear in the patch
//! parameters, so every leaf interpolant reproduces it: probing any wall point `p`
//! must give `wall_radiosity(p)` (to f32 precision). [`animated_box`] adds a plate that
//! moves along `+x` over `[0, 1]` s, with one radiosity per time chunk
//! ([`plate_radiosity`]), while the walls' leaves hold over the whole animation and are
//! stored once.

use glam::{DQuat, DVec3};

use crate::scene::{
    Material, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, TimeDomain,
};
use crate::solution::{Leaf, PatchGeometry, Solution, SolveStats};

/// Radiosity of the box walls at world point `p`.
pub fn wall_radiosity(p: DVec3) -> [f64; 3] {
    [1.0 + p.x, 1.0 + 2.0 * p.y, 0.5 + 3.0 * p.z]
}

/// Radiosity of the moving plate in the chunk starting at `t0`.
pub fn plate_radiosity(t0: f64) -> [f64; 3] {
    [2.0 + t0, 0.25, 0.125]
}

/// How far the plate moves along `+x` over the animation.
pub const PLATE_TRAVEL: f64 = 0.5;

fn walls() -> Vec<Vec<DVec3>> {
    let c = DVec3::splat(0.5);
    let faces = [
        (DVec3::ZERO, DVec3::Y, DVec3::Z),
        (DVec3::X, DVec3::Y, DVec3::Z),
        (DVec3::Y, DVec3::X, DVec3::Z),
        (DVec3::ZERO, DVec3::X, DVec3::Y),
        (DVec3::Z, DVec3::X, DVec3::Y),
    ];
    let mut out: Vec<Vec<DVec3>> = faces
        .iter()
        .map(|&(o, a, b)| {
            // Order the corners so that the normal a × b faces the centre.
            let (a, b) = if (c - o).dot(a.cross(b)) > 0.0 {
                (a, b)
            } else {
                (b, a)
            };
            vec![o, o + a, o + a + b, o + b]
        })
        .collect();
    // Floor y = 0 as two triangles, normal +y.
    let f = [DVec3::ZERO, DVec3::Z, DVec3::new(1.0, 0.0, 1.0), DVec3::X];
    out.push(vec![f[0], f[1], f[2]]);
    out.push(vec![f[0], f[2], f[3]]);
    out
}

fn plate() -> Vec<DVec3> {
    // A small quad at z = 0.5 facing +z.
    vec![
        DVec3::new(0.1, 0.4, 0.5),
        DVec3::new(0.3, 0.4, 0.5),
        DVec3::new(0.3, 0.6, 0.5),
        DVec3::new(0.1, 0.6, 0.5),
    ]
}

fn materials() -> Vec<Material> {
    vec![
        Material::diffuse("white", [0.7, 0.7, 0.7]),
        Material {
            name: "light".into(),
            rho: [0.0; 3],
            emission: [1.0, 1.0, 1.0],
        },
    ]
}

/// Leaves of a uniform `n × n` subdivision of `patch`, corner radiosity from `b`
/// evaluated at the corner's point, holding over `time`.
pub fn uniform_leaves(
    index: u32,
    patch: &PatchGeometry,
    n: u32,
    time: [f32; 2],
    b: impl Fn(DVec3) -> [f64; 3],
) -> Vec<Leaf> {
    let mut out = Vec::new();
    let s = 1.0 / n as f64;
    let leaf = |uv: &[(f64, f64)]| {
        let mut l = Leaf {
            patch: index,
            corners: patch.corners,
            time,
            uv: [[0.0; 2]; 4],
            b: [[0.0; 3]; 4],
        };
        for (c, &(u, v)) in uv.iter().enumerate() {
            l.uv[c] = [u as f32, v as f32];
            l.b[c] = b(patch.point(u, v)).map(|x| x as f32);
        }
        l
    };
    for j in 0..n {
        for i in 0..n {
            let (u0, v0, u1, v1) = (
                i as f64 * s,
                j as f64 * s,
                (i + 1) as f64 * s,
                (j + 1) as f64 * s,
            );
            if patch.corners == 4 {
                out.push(leaf(&[(u0, v0), (u1, v0), (u1, v1), (u0, v1)]));
            } else if i + j < n {
                out.push(leaf(&[(u0, v0), (u1, v0), (u0, v1)]));
                if i + j + 1 < n {
                    out.push(leaf(&[(u1, v0), (u1, v1), (u0, v1)]));
                }
            }
        }
    }
    out
}

fn patches_of(scene: &Scene) -> Vec<PatchGeometry> {
    let mut out = Vec::new();
    for (o, obj) in scene.objects.iter().enumerate() {
        for poly in &obj.polygons {
            let mut v = [DVec3::ZERO; 4];
            v[..poly.vertices.len()].copy_from_slice(&poly.vertices);
            out.push(PatchGeometry {
                object: o as u32,
                material: poly.material.0,
                corners: poly.vertices.len() as u32,
                vertices: v,
            });
        }
    }
    out
}

fn stats() -> SolveStats {
    SolveStats {
        seconds: 0.25,
        iterations: 3,
        elements: 1234,
        links_active: 56,
        links_passive: 7,
        estimated_error: 0.01,
        residual: 1e-4,
    }
}

/// A static one-object scene of `polygons` (time domain `[0, 0]`) with `n × n`
/// leaves per patch at [`wall_radiosity`].
fn static_solution(name: &str, polygons: Vec<Polygon>, n: u32) -> Solution {
    let scene = Scene {
        time: TimeDomain::default(),
        materials: materials(),
        objects: vec![Object::still(name, polygons)],
        camera: None,
        warnings: Vec::new(),
    };
    let patches = patches_of(&scene);
    let mut leaves = Vec::new();
    for (i, p) in patches.iter().enumerate() {
        leaves.extend(uniform_leaves(i as u32, p, n, [0.0, 0.0], wall_radiosity));
    }
    Solution {
        scene,
        patches,
        leaves,
        stats: stats(),
    }
}

/// The static box: walls only, leaves `n × n` per wall, time domain `[0, 0]`.
pub fn box_solution(n: u32) -> Solution {
    let polygons = walls()
        .into_iter()
        .enumerate()
        .map(|(k, vertices)| Polygon {
            vertices,
            material: MaterialId(u32::from(k == 3)),
        })
        .collect();
    static_solution("box", polygons, n)
}

/// A space-time sample: the whole solution in memory and the same leaves cut into
/// time chunks, as a streaming solver hands them to the writer.
#[derive(Clone, Debug)]
pub struct AnimatedSample {
    /// Everything, leaves sorted by `(time[0], patch)`.
    pub solution: Solution,
    /// `(t0, t1, leaves starting in [t0, t1))`, in time order.
    pub chunks: Vec<(f64, f64, Vec<Leaf>)>,
}

/// The box over `[0, 1]` s with a plate moving by [`PLATE_TRAVEL`] along `+x`; `chunks`
/// equal time chunks; walls' leaves (`n × n`) hold over `[0, 1]` and sit in chunk 0;
/// the plate has `n × n` leaves per chunk with [`plate_radiosity`].
pub fn animated_box(n: u32, chunks: u32) -> AnimatedSample {
    let mut sol = box_solution(n);
    sol.scene.time = TimeDomain {
        start: 0.0,
        end: 1.0,
    };
    sol.scene.objects.push(Object {
        name: "plate".into(),
        polygons: vec![Polygon {
            vertices: plate(),
            material: MaterialId(0),
        }],
        motion: Some(MotionTrack {
            keys: vec![
                MotionKey::identity(0.0),
                MotionKey {
                    t: 1.0,
                    translation: DVec3::X * PLATE_TRAVEL,
                    rotation: DQuat::IDENTITY,
                    scale: DVec3::ONE,
                },
            ],
        }),
    });
    // A static object with a (non-moving) track: the writer must drop the track.
    sol.scene.objects.push(Object {
        name: "still".into(),
        polygons: vec![Polygon {
            vertices: vec![
                DVec3::new(0.6, 0.1, 0.2),
                DVec3::new(0.8, 0.1, 0.2),
                DVec3::new(0.7, 0.3, 0.2),
            ],
            material: MaterialId(0),
        }],
        motion: Some(MotionTrack {
            keys: vec![MotionKey::identity(0.0), MotionKey::identity(1.0)],
        }),
    });
    sol.patches = patches_of(&sol.scene);
    let plate_index = sol.patches.len() as u32 - 2;
    let still_index = plate_index + 1;
    for l in &mut sol.leaves {
        l.time = [0.0, 1.0];
    }
    let still = sol.patches[still_index as usize];
    sol.leaves.extend(uniform_leaves(
        still_index,
        &still,
        n,
        [0.0, 1.0],
        wall_radiosity,
    ));
    let mut out = Vec::new();
    for k in 0..chunks {
        let (t0, t1) = (k as f64 / chunks as f64, (k + 1) as f64 / chunks as f64);
        let mut leaves = if k == 0 {
            sol.leaves.clone()
        } else {
            Vec::new()
        };
        let plate = sol.patches[plate_index as usize];
        leaves.extend(uniform_leaves(
            plate_index,
            &plate,
            n,
            [t0 as f32, t1 as f32],
            |_| plate_radiosity(t0),
        ));
        leaves.sort_by(|a, b| a.time[0].total_cmp(&b.time[0]).then(a.patch.cmp(&b.patch)));
        out.push((t0, t1, leaves));
    }
    sol.leaves = out.iter().flat_map(|c| c.2.iter().copied()).collect();
    AnimatedSample {
        solution: sol,
        chunks: out,
    }
}

/// A box of `6 m²` quad patches (each wall cut into `m × m` tiles), `n × n` leaves per
/// patch, radiosity [`wall_radiosity`]: the many-patch scene of the probe benchmark.
pub fn tiled_box(m: u32, n: u32) -> Solution {
    let c = DVec3::splat(0.5);
    let faces = [
        (DVec3::ZERO, DVec3::Y, DVec3::Z),
        (DVec3::X, DVec3::Y, DVec3::Z),
        (DVec3::ZERO, DVec3::X, DVec3::Z),
        (DVec3::Y, DVec3::X, DVec3::Z),
        (DVec3::ZERO, DVec3::X, DVec3::Y),
        (DVec3::Z, DVec3::X, DVec3::Y),
    ];
    let s = 1.0 / m as f64;
    let mut polygons = Vec::new();
    for &(o, a, b) in &faces {
        let (a, b) = if (c - o).dot(a.cross(b)) > 0.0 {
            (a, b)
        } else {
            (b, a)
        };
        for j in 0..m {
            for i in 0..m {
                let p = o + a * (i as f64 * s) + b * (j as f64 * s);
                polygons.push(Polygon {
                    vertices: vec![p, p + a * s, p + (a + b) * s, p + b * s],
                    material: MaterialId(0),
                });
            }
        }
    }
    static_solution("tiled box", polygons, n)
}

/// [`tiled_box`] (`m × m` tiles a wall, one leaf each) turning a quarter turn about
/// its centre and `y` over `[0, 2]` s, every leaf holding the whole time: one rigid
/// motion of the whole scene (the viewer benchmark's moving scene).
pub fn turning_tiled_box(m: u32) -> Solution {
    let mut sol = tiled_box(m, 1);
    sol.scene.time = TimeDomain {
        start: 0.0,
        end: 2.0,
    };
    let c = DVec3::splat(0.5);
    let key = |t: f64| {
        let rotation = DQuat::from_rotation_y(t * std::f64::consts::FRAC_PI_4);
        MotionKey {
            t,
            translation: c - rotation * c,
            rotation,
            scale: DVec3::ONE,
        }
    };
    sol.scene.objects[0].motion = Some(MotionTrack {
        keys: (0..=4).map(|k| key(k as f64 * 0.5)).collect(),
    });
    for l in &mut sol.leaves {
        l.time = [0.0, 2.0];
    }
    sol
}
