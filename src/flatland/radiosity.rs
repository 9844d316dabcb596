//! Exact flatland form factors (string rule, eq. 2–3 of the paper, §3.1 and §4.2) and
//! the dense radiosity solve `B = E + rho F B` (§3).
//!
//! How it works: the views of all points ([`super::views`]: one rotational sweep
//! around each point, `O(P^2 log P)`) give, for every pair of elements `(i, j)`, the
//! measure `mu_ij` of the lines whose free segment joins their lit sides, as a sum of
//! `+- v . dN` over the complex's edges (eq. 3); then `F_ij = mu_ij / (2 L_i)` (Hottel's crossed
//! strings, strings stretched around obstacles). Pairs that see nothing of each other
//! have no entry (zero). Reciprocity `L_i F_ij = L_j F_ji` holds by construction, and
//! closure (`sum_j F_ij = 1` in a closed room) holds to round-off because the lines
//! meeting a segment have measure `2 L`. The linear system `(I - diag(rho) F) B = E` is
//! solved per channel by Gaussian elimination with partial pivoting in `f64`: exact to
//! round-off and robust for `rho` close to 1.
//!
//! What it does not do: no hierarchy, no iterative solver: the matrix is dense,
//! `O(N^2)` memory and `O(N^3)` time in the number of elements `N` (fine up to a few
//! thousand elements).

use super::geometry::{FlatGeometry, PairMap};
use super::views::{ViewStats, form_factors_mu};

/// Sparse exact form factors between the elements of one geometry.
#[derive(Clone, Debug, Default)]
pub struct FormFactors {
    /// Element lengths.
    pub lens: Vec<f64>,
    /// `mu[(i, j)]`, `i < j`: measure of the free lines joining the lit sides.
    pub mu: PairMap,
}

impl FormFactors {
    /// Form factors from measures (see the module header).
    pub fn from_mu(geom: &FlatGeometry, mu: PairMap) -> Self {
        FormFactors {
            lens: geom.elements.iter().map(|e| e.len).collect(),
            mu,
        }
    }

    /// `F_ij`: the fraction of the energy leaving `i` that reaches `j` (eq. 1).
    pub fn f(&self, i: u32, j: u32) -> f64 {
        let key = (i.min(j), i.max(j));
        self.mu
            .get(&key)
            .map_or(0.0, |m| m / (2.0 * self.lens[i as usize]))
    }

    /// The dense row-major matrix `F` (`N x N`).
    pub fn dense(&self) -> Vec<f64> {
        let n = self.lens.len();
        let mut f = vec![0.0; n * n];
        for (&(i, j), &m) in &self.mu {
            let (i, j) = (i as usize, j as usize);
            f[i * n + j] += m / (2.0 * self.lens[i]);
            if i != j {
                f[j * n + i] += m / (2.0 * self.lens[j]);
            }
        }
        f
    }

    /// Number of non-zero entries `F_ij` (ordered pairs).
    pub fn nonzeros(&self) -> usize {
        self.mu
            .iter()
            .filter(|(_, m)| **m > 0.0)
            .map(|(k, _)| if k.0 == k.1 { 1 } else { 2 })
            .sum()
    }
}

/// Exact form factors of all element pairs, from the views of all points
/// ([`super::views`], `O(P^2 log P)`).
pub fn form_factors(geom: &FlatGeometry) -> (FormFactors, ViewStats) {
    let (mu, stats) = form_factors_mu(geom);
    (FormFactors::from_mu(geom, mu), stats)
}

/// Solves `(I - diag(rho) F) B = E` per channel; `rho` and `e` per element.
pub fn solve_radiosity(ff: &FormFactors, rho: &[[f64; 3]], e: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let n = ff.lens.len();
    let f = ff.dense();
    let mut b = vec![[0.0; 3]; n];
    let mut done: Vec<([f64; 3], usize)> = Vec::new();
    for c in 0..3 {
        // Channels with identical rho and E share the answer.
        if let Some(&(_, prev)) = done
            .iter()
            .find(|(_, p)| (0..n).all(|i| rho[i][c] == rho[i][*p] && e[i][c] == e[i][*p]))
        {
            for bi in b.iter_mut() {
                bi[c] = bi[prev];
            }
            continue;
        }
        let mut a = vec![0.0; n * n];
        let mut rhs: Vec<f64> = e.iter().map(|x| x[c]).collect();
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = -rho[i][c] * f[i * n + j];
            }
            a[i * n + i] += 1.0;
        }
        let x = gauss(&mut a, &mut rhs, n);
        for i in 0..n {
            b[i][c] = x[i];
        }
        done.push(([0.0; 3], c));
    }
    b
}

/// Gaussian elimination with partial pivoting (the matrix `I - rho F` is strictly
/// diagonally dominant by columns when `rho < 1`, so pivots never vanish).
fn gauss(a: &mut [f64], b: &mut [f64], n: usize) -> Vec<f64> {
    for k in 0..n {
        let mut piv = k;
        for i in k + 1..n {
            if a[i * n + k].abs() > a[piv * n + k].abs() {
                piv = i;
            }
        }
        if piv != k {
            for j in 0..n {
                a.swap(k * n + j, piv * n + j);
            }
            b.swap(k, piv);
        }
        let d = a[k * n + k];
        if d == 0.0 {
            continue;
        }
        for i in k + 1..n {
            let m = a[i * n + k] / d;
            if m != 0.0 {
                for j in k..n {
                    a[i * n + j] -= m * a[k * n + j];
                }
                b[i] -= m * b[k];
            }
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        let mut s = b[k];
        for j in k + 1..n {
            s -= a[k * n + j] * x[j];
        }
        let d = a[k * n + k];
        x[k] = if d == 0.0 { 0.0 } else { s / d };
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_solves_a_known_system() {
        let mut a = vec![0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let mut b = vec![3.0, 2.0, 4.0];
        let x = gauss(&mut a, &mut b, 3);
        for (xi, ei) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((xi - ei).abs() < 1e-14);
        }
    }
}
