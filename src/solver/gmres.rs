//! Restarted GMRES (Saad & Schultz 1986) for the radiosity system `(I − ρK) B = E`.
//!
//! Why not Jacobi or Gauss–Seidel: their error shrinks by about `ρ` per sweep, so a
//! closed room with `ρ = 0.999` needs thousands of sweeps to reach 1%. The system
//! matrix `I − ρK` has one eigenvalue near `1 − ρ` (the room-wide mean) and the rest
//! near 1; GMRES removes the isolated small eigenvalue in a handful of Krylov steps,
//! so stiff rooms converge as fast as ordinary ones. The operator is applied
//! matrix-free (pull, gather, push) by the caller.

/// Result of a GMRES run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmresOutcome {
    /// Operator applications performed.
    pub applications: u32,
    /// Final relative residual `‖E − A B‖ / ‖E‖`.
    pub residual: f64,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// Solves `A x = b` with GMRES(`restart`) from the initial guess in `x`, until the
/// relative residual is below `tol` or `max_apps` operator applications were made.
/// `apply(v, out)` writes `A v` into `out`.
pub fn solve(
    mut apply: impl FnMut(&[f64], &mut [f64]),
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    restart: usize,
    max_apps: u32,
) -> GmresOutcome {
    let n = b.len();
    let bnorm = norm(b);
    if bnorm == 0.0 {
        x.iter_mut().for_each(|v| *v = 0.0);
        return GmresOutcome {
            applications: 0,
            residual: 0.0,
        };
    }
    let m = restart.max(1);
    let mut apps = 0u32;
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    loop {
        // r = b − A x
        apply(x, &mut w);
        apps += 1;
        for i in 0..n {
            r[i] = b[i] - w[i];
        }
        let beta = norm(&r);
        let rel = beta / bnorm;
        if rel <= tol || apps >= max_apps {
            return GmresOutcome {
                applications: apps,
                residual: rel,
            };
        }
        // Arnoldi with modified Gram–Schmidt and Givens rotations.
        let mut v: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
        v.push(r.iter().map(|&ri| ri / beta).collect());
        let mut h = vec![vec![0.0; m]; m + 1];
        let (mut cs, mut sn) = (vec![0.0; m], vec![0.0; m]);
        let mut g = vec![0.0; m + 1];
        g[0] = beta;
        let mut k_used = 0;
        for k in 0..m {
            apply(&v[k], &mut w);
            apps += 1;
            for j in 0..=k {
                h[j][k] = dot(&w, &v[j]);
                let hjk = h[j][k];
                for (wi, vi) in w.iter_mut().zip(&v[j]) {
                    *wi -= hjk * vi;
                }
            }
            h[k + 1][k] = norm(&w);
            // Apply previous rotations to the new column.
            for j in 0..k {
                let t = cs[j] * h[j][k] + sn[j] * h[j + 1][k];
                h[j + 1][k] = -sn[j] * h[j][k] + cs[j] * h[j + 1][k];
                h[j][k] = t;
            }
            let denom = (h[k][k] * h[k][k] + h[k + 1][k] * h[k + 1][k]).sqrt();
            if denom == 0.0 {
                k_used = k;
                break;
            }
            cs[k] = h[k][k] / denom;
            sn[k] = h[k + 1][k] / denom;
            h[k][k] = denom;
            let hk1 = h[k + 1][k];
            h[k + 1][k] = 0.0;
            g[k + 1] = -sn[k] * g[k];
            g[k] *= cs[k];
            k_used = k + 1;
            let lucky = hk1 <= 1e-14 * bnorm;
            if !lucky {
                v.push(w.iter().map(|&wi| wi / hk1).collect());
            }
            if (g[k + 1]).abs() / bnorm <= tol || apps >= max_apps || lucky {
                break;
            }
        }
        // Back-substitute y from the upper-triangular system, update x.
        let mut y = vec![0.0; k_used];
        for i in (0..k_used).rev() {
            let mut s = g[i];
            for j in i + 1..k_used {
                s -= h[i][j] * y[j];
            }
            y[i] = if h[i][i] != 0.0 { s / h[i][i] } else { 0.0 };
        }
        for (j, yj) in y.iter().enumerate() {
            for (xi, vi) in x.iter_mut().zip(&v[j]) {
                *xi += yj * vi;
            }
        }
        if k_used == 0 {
            apply(x, &mut w);
            apps += 1;
            let res: f64 = b
                .iter()
                .zip(&w)
                .map(|(bi, wi)| (bi - wi) * (bi - wi))
                .sum::<f64>()
                .sqrt();
            return GmresOutcome {
                applications: apps,
                residual: res / bnorm,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stiff "closed room": A = I − ρ P with P a row-stochastic averaging matrix;
    /// with b = E·1 the answer is E / (1 − ρ).
    #[test]
    fn stiff_uniform_room_converges_quickly() {
        let n = 200;
        let rho = 0.999;
        let apply = |x: &[f64], out: &mut [f64]| {
            for i in 0..n {
                // Each row averages three neighbours (stochastic).
                let avg = (x[(i + 1) % n] + x[(i + 7) % n] + x[(i + 31) % n]) / 3.0;
                out[i] = x[i] - rho * avg;
            }
        };
        let b = vec![1.0; n];
        let mut x = vec![1.0; n];
        let out = solve(apply, &b, &mut x, 1e-10, 30, 500);
        assert!(out.residual <= 1e-10, "{out:?}");
        for xi in &x {
            assert!((xi - 1000.0).abs() < 1e-5, "{xi}");
        }
        assert!(out.applications < 100, "{out:?}");
    }
}
