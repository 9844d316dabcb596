//! An independent Monte Carlo reference: radiosity at surface points by diffuse path
//! tracing, sharing nothing with the hierarchical solver but the scene, the patches
//! and the ray queries.
//!
//! At a point `x` on a patch, `B(x) = E + ρ ⊙ H(x)`. The irradiance is estimated
//! along paths: at every vertex, next-event estimation samples a point on an emitter
//! (chosen with probability ∝ area × max exitance, uniform on its area) and adds
//! `(E_y / π) cos θx cos θy / r²` divided by the pdf when unoccluded; the path then
//! continues in a cosine-distributed direction, its throughput multiplied by the
//! reflectance of the surface it reaches (emission found by such a bounce is not
//! counted: next-event estimation already did), with Russian roulette after three
//! bounces (a bounce meets the face turned to it first, so that a two-sided
//! surface's back-to-back twins reflect it: [`SceneBvh::intersect_front_first`]): a
//! path goes on with probability its throughput's largest channel (then
//! divided by it), so no path weighs more than 1 and a path lasts about
//! `1/(1 − ρ)` bounces (a hundred at ρ = 0.99; `MAX_BOUNCES` is far beyond).
//! The estimate is unbiased; its standard error is reported per point
//! (`tests/it/reference.rs`: a closed box at ρ = 0.99 within 1% of `E/(1 − ρ)`).

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{Patches, SceneBvh, cosine_direction, nearest_facing};
use crate::oracle::{hash3, unit as uniform};
use crate::scene::Scene;

/// A reference value with its standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Radiosity (RGB).
    pub b: [f64; 3],
    /// Standard error of each channel.
    pub std_error: [f64; 3],
}

struct Emitters {
    patches: Vec<usize>,
    cdf: Vec<f64>,
    total: f64,
}

/// Uniform point on patch `i` from two uniforms (quads split into two triangles by area).
fn sample_patch(patches: &Patches, i: usize, u1: f64, u2: f64) -> DVec3 {
    let c = patches.polys[i].corners();
    let tri = |a: DVec3, b: DVec3, cc: DVec3, u1: f64, u2: f64| {
        let s = u1.sqrt();
        a * (1.0 - s) + b * (s * (1.0 - u2)) + cc * (s * u2)
    };
    if c.len() == 3 {
        return tri(c[0], c[1], c[2], u1, u2);
    }
    let a0 = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
    let a1 = 0.5 * (c[2] - c[0]).cross(c[3] - c[0]).length();
    let p0 = if a0 + a1 > 0.0 { a0 / (a0 + a1) } else { 0.5 };
    if u1 < p0 {
        tri(c[0], c[1], c[2], u1 / p0, u2)
    } else {
        tri(
            c[0],
            c[2],
            c[3],
            (u1 - p0) / (1.0 - p0).max(f64::MIN_POSITIVE),
            u2,
        )
    }
}

/// Radiosity at each `(p, n)` by path tracing with `paths` paths per point; points
/// are located like `probe` does (nearest patch facing `n`). Points with no facing
/// patch get zero.
pub fn radiosity_at(
    scene: &Scene,
    points: &[(DVec3, DVec3)],
    paths: u32,
    seed: u64,
) -> Vec<Estimate> {
    let t = scene.time.start;
    let patches = Patches::at_time(scene, t);
    let bvh = SceneBvh::build(scene, &patches, t);
    let mut em = Emitters {
        patches: Vec::new(),
        cdf: Vec::new(),
        total: 0.0,
    };
    for i in 0..patches.len() {
        let e = patches.emissions[i].iter().copied().fold(0.0, f64::max);
        if e > 0.0 && patches.areas[i] > 0.0 {
            em.total += e * patches.areas[i];
            em.patches.push(i);
            em.cdf.push(em.total);
        }
    }
    let diam = patches.diameter.max(f64::MIN_POSITIVE);
    points
        .par_iter()
        .enumerate()
        .map(|(pi, &(p, n))| {
            let Some((patch, x)) = nearest_facing(&patches.polys, &patches.normals, p, n) else {
                return Estimate {
                    b: [0.0; 3],
                    std_error: [0.0; 3],
                };
            };
            let (mut sum, mut sum2) = ([0.0; 3], [0.0; 3]);
            for k in 0..paths {
                let h = path_irradiance(
                    &patches,
                    &bvh,
                    &em,
                    patch,
                    x,
                    diam,
                    hash3(seed, pi as u64, k as u64),
                );
                for c in 0..3 {
                    sum[c] += h[c];
                    sum2[c] += h[c] * h[c];
                }
            }
            let nf = paths.max(1) as f64;
            let rho = patches.rhos[patch];
            let e = patches.emissions[patch];
            let mut out = Estimate {
                b: [0.0; 3],
                std_error: [0.0; 3],
            };
            for c in 0..3 {
                let mean = sum[c] / nf;
                let var = (sum2[c] / nf - mean * mean).max(0.0) / nf;
                out.b[c] = e[c] + rho[c] * mean;
                out.std_error[c] = rho[c] * var.sqrt();
            }
            out
        })
        .collect()
}

/// Most bounces of a path. A path on surfaces of reflectance ρ reaches it with
/// probability `ρ^(2^20)`: 10⁻⁴⁵⁵ at 0.999, 5·10⁻⁵ at 0.99999 (scenes allow any
/// ρ < 1). 256 cut 8% of the paths at ρ = 0.99.
const MAX_BOUNCES: u64 = 1 << 20;

/// One path's irradiance estimate at `x` on `patch`.
#[allow(clippy::too_many_arguments)]
fn path_irradiance(
    patches: &Patches,
    bvh: &SceneBvh,
    em: &Emitters,
    patch: usize,
    x: DVec3,
    diam: f64,
    key: u64,
) -> [f64; 3] {
    let mut h = [0.0; 3];
    let mut thr = [1.0f64; 3];
    let (mut x, mut patch) = (x, patch);
    for bounce in 0..MAX_BOUNCES {
        let n = patches.normals[patch];
        // Next-event estimation.
        if em.total > 0.0 {
            let r = hash3(key, bounce, 1);
            let pick = uniform(r) * em.total;
            let j = em
                .cdf
                .partition_point(|&c| c <= pick)
                .min(em.patches.len() - 1);
            let ep = em.patches[j];
            let y = sample_patch(
                patches,
                ep,
                uniform(hash3(key, bounce, 2)),
                uniform(hash3(key, bounce, 3)),
            );
            let d = y - x;
            let r2 = d.length_squared();
            let ny = patches.normals[ep];
            let (cx, cy) = (n.dot(d), -ny.dot(d));
            if ep != patch && r2 > 0.0 && cx > 0.0 && cy > 0.0 && !bvh.occluded(x, y) {
                let emax = patches.emissions[ep].iter().copied().fold(0.0, f64::max);
                // pdf of y = emax / total (per area): weight total / emax.
                let g = cx * cy / (r2 * r2) / std::f64::consts::PI * em.total / emax;
                for c in 0..3 {
                    h[c] += thr[c] * patches.emissions[ep][c] * g;
                }
            }
        }
        // Continue in a cosine-distributed direction.
        let (u1, u2) = (
            uniform(hash3(key, bounce, 4)),
            uniform(hash3(key, bounce, 5)),
        );
        let dir = cosine_direction(n, u1, u2);
        let Some(hit) = bvh.intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0) else {
            break;
        };
        let y = x + dir * diam * 2.0 * hit.t;
        let hp = hit.patch as usize;
        if patches.normals[hp].dot(dir) >= 0.0 {
            break; // back face: the inside of a solid or an open side
        }
        let rho = patches.rhos[hp];
        for c in 0..3 {
            thr[c] *= rho[c];
        }
        if bounce >= 3 {
            // Not capped below 1: at 0.95 a path on surfaces of ρ = 0.99 gained
            // (0.99/0.95)^k in weight, and the variance was unbounded (a closed box
            // at ρ = 0.99 read 81.5 for 100).
            let q = thr.iter().copied().fold(0.0, f64::max).min(1.0);
            if q <= 0.0 || uniform(hash3(key, bounce, 6)) >= q {
                break;
            }
            for c in thr.iter_mut() {
                *c /= q;
            }
        }
        x = y;
        patch = hp;
    }
    h
}
