//! Evaluating a `Solution` at surface points for tests that do not go through the
//! store: nearest facing patch, inverse parameterisation by Newton, leaf lookup.
#![allow(dead_code)]

use glam::DVec3;
use rhier::geometry::{Patches, nearest_facing};
use rhier::solver::Solution;

/// `(u, v)` of world point `x` on patch `i` (planar), by Newton on the bilinear map.
pub fn uv_of(patches: &Patches, i: usize, x: DVec3) -> (f64, f64) {
    let (mut u, mut v) = (0.5, 0.5);
    for _ in 0..30 {
        let p = patches.point(i, u, v);
        let h = 1e-6;
        let du = (patches.point(i, u + h, v) - p) / h;
        let dv = (patches.point(i, u, v + h) - p) / h;
        let r = x - p;
        // Least squares 2x2.
        let (a, b, c) = (du.dot(du), du.dot(dv), dv.dot(dv));
        let (ru, rv) = (du.dot(r), dv.dot(r));
        let det = a * c - b * b;
        if det.abs() < 1e-300 {
            break;
        }
        u += (c * ru - b * rv) / det;
        v += (a * rv - b * ru) / det;
    }
    (u, v)
}

/// Radiosity of `sol` at the surface point nearest `p` facing `n`.
pub fn probe(sol: &Solution, patches: &Patches, p: DVec3, n: DVec3) -> [f64; 3] {
    let Some((i, x)) = nearest_facing(&patches.polys, &patches.normals, p, n) else {
        return [0.0; 3];
    };
    let (u, v) = uv_of(patches, i, x);
    let leaves: Vec<_> = sol.leaves.iter().filter(|l| l.patch == i as u32).collect();
    for eps in [1e-9, 1e-6, 1e-3] {
        if let Some(l) = leaves.iter().find(|l| l.contains(u, v, eps)) {
            return l.eval(u, v);
        }
    }
    [0.0; 3]
}

/// A grid of probe points on every patch of a scene, `k × k` per patch, inset.
pub fn grid_points(patches: &Patches, k: usize) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for i in 0..patches.len() {
        for a in 0..k {
            for b in 0..k {
                let (u, v) = ((a as f64 + 0.5) / k as f64, (b as f64 + 0.5) / k as f64);
                let (u, v) = if patches.polys[i].n == 3 && u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                out.push((patches.point(i, u, v), patches.normals[i]));
            }
        }
    }
    out
}

/// Relative RMS error `sqrt(Σ(B − B_ref)² / Σ B_ref²)` over points and channels.
pub fn rel_rms(b: &[[f64; 3]], r: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in b.iter().zip(r) {
        for c in 0..3 {
            num += (x[c] - y[c]).powi(2);
            den += y[c] * y[c];
        }
    }
    (num / den).sqrt()
}

/// Points near contact edges: for every patch with an edge on the plane `y = 0`
/// (a block side resting on the floor), points on the floor at distances `ds` from
/// the middle of that edge, outside, and on the side itself at heights `ds`.
pub fn contact_points(patches: &Patches, ds: &[f64]) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    for i in 0..patches.len() {
        let n = patches.normals[i];
        if n.y.abs() > 0.1 {
            continue; // only vertical faces
        }
        let c = patches.polys[i].corners();
        for k in 0..c.len() {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            if a.y.abs() < 1e-6 && b.y.abs() < 1e-6 {
                let m = (a + b) * 0.5;
                let out_dir = DVec3::new(n.x, 0.0, n.z).normalize();
                for &d in ds {
                    out.push((m + out_dir * d, DVec3::Y));
                    out.push((m + DVec3::Y * d, n));
                }
            }
        }
    }
    out
}
