//! The leaf rows checked against rays: a term of a static solve's error estimate
//! that sees rows which gather too little (or too much) of the solved field.
//!
//! A seeded sample of leaf rows: each drawn row's gather of the solved leaf field
//! (`H_i = Σ_j K_ij B_j`, scaled as solved) is compared with what rays from points
//! spread over the leaf bring from that same field: cosine-weighted rays for the
//! reflected light (the leaf a ray meets holds its value), and rays at points on
//! the emitters, drawn by power, for the direct light. The mean relative gap of
//! the reflected power is amplified by the scene's bounces, measured from the
//! solve; sampling noise is taken off, so that the term stays at 0 on a scene
//! whose rows are right. It is a measured estimate of the error a row bias puts
//! into the answer, not a bound.
//!
//! Why: the change between levels does not see a bias no refinement removes, and
//! [`Solver::power_balance`] and [`Solver::row_excess_error`] see rows that sum
//! above 1, never rows that gather too little in a scene light leaves. The
//! Blender Cornell box (`tests/it/solver/exported.rs`) was 10.9% too dark off the
//! lamp while its estimate read 4.5%: its room rows gathered 1.35–3% less than rays
//! over the same field, and at `ρ = 0.999` a 2% loss a bounce comes out about 10%
//! dark (issue 45, part 4; the leaves of its slabs' room sides averaged in the
//! dark parts inside other slabs, until contact meshing cut where slabs cross).
//!
//! The rows are drawn until the amplified noise is under a quarter of what the
//! solve promises (within half a ray per entry of the leaf system), and one standard error is
//! taken off (`E[δ̂²] = δ² + σ²`): with the crossings cut, the Blender box's
//! gaps were 0.3–0.6% at a gain of 3.9, 2 σ of 1 500 rows' noise hid them,
//! and its estimate read 0.84% for 3.4% off the lamp at eps 0.5 (issue 45
//! part 4, against 100,000 paths).
//!
//! The second check, [`Solver::gather_ray_check`], compares the final gather
//! (the answer) at the error estimate's sample points with rays over the same
//! leaf field: what the final gather misses where it is, which the rows do not
//! show (the answer does not gather with the rows). Both are Monte Carlo
//! measurements over the solve's own field (Kajiya 1986, eq. 1: one bounce of
//! the rendering equation, cosine-sampled and by next-event estimation toward
//! the emitters), not bounds; [`Solver::run`] adds them in quadrature.

use super::*;

/// Rows drawn first ([`Solver::row_ray_check`]): one in [`CHECK_ROWS_PER`] leaves,
/// at least this many (the Cornell box at eps 0.1 draws these: 1–2% of the
/// solve), at most [`CHECK_ROWS_MAX`]. On the Blender box, 128 left the gaps'
/// noise (1.4% in red, 2.3% in blue) above the signal they amplify.
const CHECK_ROWS: usize = 128;
/// Leaves a drawn row ([`CHECK_ROWS`]): the check's cost follows the leaf
/// system's, a small share of it.
const CHECK_ROWS_PER: usize = 8;
/// Most rows drawn first ([`CHECK_ROWS`]).
const CHECK_ROWS_MAX: usize = 4096;
/// Cosine-weighted rays a drawn row casts for its reflected light (a jittered
/// 8 × 8 grid of directions, each from its own point on the leaf).
const CHECK_RAYS: usize = 64;
/// Rays a drawn row casts at points on the emitters for its direct light.
const CHECK_LIGHT_RAYS: usize = 32;
/// The share of a shadow ray's length short of the emitter's point that it
/// does not test (a blocker closer to the point is the emitter's own surface).
const LIGHT_TRIM: f64 = 1e-5;
/// Standard errors of sampling noise taken off the measured gaps: one, since a
/// gap `δ̂` measured with noise `σ` has `E[δ̂²] = δ² + σ²`, so `δ̂² − σ²` is the
/// unbiased estimate of `δ²`. Two (before 2026-12-02) took `4 σ²` off: on the
/// Blender box at eps 0.5 it left 0.84% of an amplified gap of 2.2% (gaps
/// 0.56/0.63% ± 0.27/0.28% at a gain of 3.9, 1 520 rows).
const NOISE_SIGMAS: f64 = 1.0;
/// The amplified noise the check draws more rows to get under
/// ([`Solver::row_ray_check`]), as a share of what the solve promises
/// ([`SolveOptions::promised_error`]).
const NOISE_PER_PROMISE: f64 = 0.25;
/// The rays each check may cast per entry of the leaf system (the rows' check
/// when it draws more rows than its first sample, each row casting `CHECK_RAYS +
/// CHECK_LIGHT_RAYS`; the final gather's check, or it is left out): a few
/// percent of the solve. A solve's work follows its row entries (the empty
/// Cornell box at eps 0.1: 323 000 entries, 0.56 CPU s, 1.7 µs an entry; a
/// check's ray about 0.23 µs), not its links' rays (10 000–80 000 there, 12
/// million on the Blender box). Both checks uncapped, the Cornell box's solves
/// took 0.03–0.09 s more wall (eps 0.5: 0.038 → 0.075 s), the final gather's
/// check a fixed 262 000 rays of it (2026-12-02).
const CHECK_RAYS_PER_ENTRY: f64 = 0.5;
/// Most rows the check draws in its last pass, whatever the solve cast.
const CHECK_ROWS_CAP: usize = 65_536;
/// Points of the final gather's check ([`Solver::gather_ray_check`]): the error
/// estimate's default samples.
const GATHER_POINTS: usize = 128;
/// Each of the gather check's two ray estimates at a point casts this squared
/// cosine rays (2 × 1 024 a point).
const GATHER_SIDE: usize = 32;

/// What [`Solver::row_ray_check`] measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RowCheck {
    /// Rows drawn.
    pub rows: usize,
    /// Rays cast.
    pub rays: u64,
    /// Per channel: the reflected power the rows miss against rays, over the
    /// reflected power they gather, `Σ A ρ (H_rays − H_row) / Σ A ρ H_row`
    /// (positive: the rows gather too little).
    pub gap: [f64; 3],
    /// Per channel: the standard error of `gap` (sampling noise).
    pub gap_noise: [f64; 3],
    /// Per channel: the bounces' gain, all the reflected light over the first
    /// bounce's (`Σ A ρ H / Σ A ρ H_E`, [`Solver::row_ray_check`]).
    pub gain: [f64; 3],
    /// The error term: the amplified mean gap, sampling noise taken off, as a
    /// relative RMS over the channels.
    pub error: f64,
    /// The amplified noise, `NOISE_SIGMAS G σ` combined over the channels as
    /// `error` is: what was taken off.
    pub noise: f64,
}

impl Solver<'_> {
    /// Checks a seeded sample of leaf rows (below) against
    /// `CHECK_RAYS` (64) cosine rays and `CHECK_LIGHT_RAYS` (32) rays at the emitters
    /// each (module doc): the error the rows' gaps put into the answer
    /// ([`RowCheck::error`]; `None` without a leaf system, light or reflection).
    ///
    /// The rows checked are those of the leaves that emit nothing and lie outside
    /// solids (their centroid, `Solver::outside_solids`): what the answer off
    /// the emitters is made of. They are drawn in proportion to `A ρ (H + H̄)`
    /// (their reflected power, mixed with their area so that a row that gathers
    /// nothing can be drawn), stratified with a seeded jitter. A row's rays leave
    /// from points spread uniformly over the leaf (its value is the mean over its
    /// area): cosine rays in a jittered grid of directions bring `B − E` of the
    /// leaf they meet (nothing from a back face or from nowhere), rays at points
    /// on the emitting leaves drawn by power bring `E K / pdf` where nothing
    /// blocks them. The gap of channel `k`, `δ_k = Σ A ρ (H_rays − H) / Σ A ρ H`
    /// (positive: the rows gather too little), is the ratio estimate over the
    /// draws, its noise `σ_k` their spread over `√n`.
    ///
    /// The gain `G_k = Σ A ρ H / Σ A ρ H_E`, `H_E` the rows' gather of the
    /// emission alone (the first bounce): all the reflected light over the first
    /// bounce's, `1/(1 − r)` for a share `r` a bounce returns. Rows short by `δ`
    /// each bounce leave the leaf field's reflected light short by `G δ` (the
    /// `n`-th bounce by `n δ`, and `G` is the mean bounce count). The answer
    /// gathers its own last bounce afresh from that field: short by `(G − 1) δ`
    /// where its light comes as much straight from the emitters as the rows'
    /// does, by up to `G δ` where it is all reflected (a ceiling around a flush
    /// lamp). The larger is taken: on the Cornell box with a white of 0.95 and
    /// every row 3% short, `(G − 1) δ` read 2.5% for a measured 4.3% off the
    /// lamp, `G δ` 4.8% (test below). The term is
    /// `sqrt(max(0, (G_k δ_k)² − (G_k σ_k)²))` per channel, combined over the
    /// channels by their weight `Σ A B²` (`NOISE_SIGMAS`).
    ///
    /// Rows: one in 8 leaves (128 to 4 096) first, then four times as many a
    /// pass while the amplified noise `G σ` (combined as the term is) is above
    /// a quarter of [`SolveOptions::promised_error`], within `CHECK_RAYS_PER_ENTRY`
    /// (half a ray per entry of the leaf system, but at least 512 rows, so a
    /// small scene's first 128 may be drawn again four times over) and 65 536
    /// rows. On the Blender box at eps 0.5, 6 080 rows (0.8 s).
    pub fn row_ray_check(&self) -> Option<RowCheck> {
        let nl = self.sys.leaves.len();
        if nl == 0 || !self.has_leaf_rows() {
            return None;
        }
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let plain = self.plain_radiosities();
        let (b, fb) = self.gained(plain.clone());
        // Leaves inside solids (a slab's face where slabs overlap) are left out:
        // what they gather reaches no one.
        let outside: Vec<bool> = self
            .sys
            .leaves
            .par_iter()
            .map(|&l| {
                let g = &geoms[l.ix()];
                let k = g.n.clamp(3, 4) as usize;
                let c = g.corners[..k]
                    .iter()
                    .map(|&c| DVec3::from_array(c))
                    .sum::<DVec3>()
                    / k as f64;
                self.outside_solids(c, DVec3::from_array(g.normal))
            })
            .collect();
        // The emission alone, as the leaf system pulls it: the first bounce.
        let mut e_field = vec![[0.0; 3]; plain.len()];
        for &l in &self.sys.leaves {
            e_field[l.ix()] = self.patches.emissions[geoms[l.ix()].patch as usize];
        }
        pull(nodes, geoms, &mut e_field);
        let (eb, efb) = self.gained(e_field);
        // The leaves checked: outside solids, emitting nothing (what they gather
        // is what reaches the answer off the emitters), not dark (they gather
        // exactly nothing). Their gathers as solved.
        let checked: Vec<bool> = self
            .sys
            .leaves
            .iter()
            .zip(&outside)
            .map(|(&l, &out)| {
                let p = geoms[l.ix()].patch as usize;
                let e = self.patches.emissions[p];
                out && e.iter().all(|&x| x <= 0.0) && !self.dark_patch(p)
            })
            .collect();
        let (h_row, h_first): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (0..nl)
            .into_par_iter()
            .map(|li| {
                if checked[li] {
                    (self.row_gather(li, &b, &fb), self.row_gather(li, &eb, &efb))
                } else {
                    ([0.0; 3], [0.0; 3])
                }
            })
            .unzip();
        let (mut first, mut gathered, mut weight_b2) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        let mut area = 0.0;
        for (li, &leaf) in self.sys.leaves.iter().enumerate() {
            if !checked[li] {
                continue;
            }
            let g = &geoms[leaf.ix()];
            let rho = self.patches.rhos[g.patch as usize];
            let bl = plain[leaf.ix()];
            for k in 0..3 {
                first[k] += g.area * rho[k] * h_first[li][k];
                gathered[k] += g.area * rho[k] * h_row[li][k];
                weight_b2[k] += g.area * bl[k] * bl[k];
            }
            area += g.area;
        }
        if area <= 0.0 || first.iter().all(|&x| x <= 0.0) {
            return None;
        }
        // Draw weights: reflected power, mixed with area at the mean.
        let mean_rh: f64 = gathered.iter().sum::<f64>() / area;
        let w: Vec<f64> = self
            .sys
            .leaves
            .iter()
            .enumerate()
            .map(|(li, &leaf)| {
                let g = &geoms[leaf.ix()];
                let rho = self.patches.rhos[g.patch as usize];
                let rh: f64 = (0..3).map(|k| rho[k] * h_row[li][k]).sum();
                let rho_sum: f64 = rho.iter().sum();
                if rho_sum <= 0.0 || !checked[li] {
                    0.0
                } else {
                    g.area * (rh + rho_sum / 3.0 * mean_rh)
                }
            })
            .collect();
        let total_w: f64 = w.iter().sum();
        if total_w.is_nan() || total_w <= 0.0 {
            return None;
        }
        let field = self.ray_field(plain);
        let side = (CHECK_RAYS as f64).sqrt().round().max(1.0) as usize;
        let seed = self.opts.seed ^ 0x0007_e57a;
        // One measurement with `rows` draws, stratified over the draw weights.
        let measure = |rows: usize| -> RowCheck {
            let draws = stratified_draws(&w, total_w, rows, self.opts.seed);
            // Each pass its own rays.
            let seed = seed ^ (rows as u64).rotate_left(40);
            // Per draw: `A ρ Δ / w` per channel.
            let per: Vec<[f64; 3]> = draws
                .par_iter()
                .enumerate()
                .map(|(s, &li)| {
                    let leaf = self.sys.leaves[li];
                    let g = &geoms[leaf.ix()];
                    let n = DVec3::from_array(g.normal);
                    let rho = self.patches.rhos[g.patch as usize];
                    let mut x_out = [0.0; 3];
                    if w[li] <= 0.0 {
                        return x_out;
                    }
                    let r = |j: usize, k: u64| {
                        oracle::unit(oracle::hash3(seed, s as u64, j as u64 * 8 + k))
                    };
                    let h = self.rays_at(
                        &field,
                        (g.patch, n),
                        |u, v| leaf_point(g, u, v),
                        r,
                        (side, CHECK_LIGHT_RAYS),
                    );
                    for k in 0..3 {
                        x_out[k] = g.area * rho[k] * (h[k] - h_row[li][k]) / w[li];
                    }
                    x_out
                })
                .collect();
            let m = per.len() as f64;
            let mut out = RowCheck {
                rows: per.len(),
                rays: (per.len() * (CHECK_RAYS + CHECK_LIGHT_RAYS)) as u64,
                ..RowCheck::default()
            };
            let (mut num, mut noise2, mut den) = (0.0, 0.0, 0.0);
            for k in 0..3 {
                let mean = per.iter().map(|p| p[k]).sum::<f64>() / m;
                let var =
                    per.iter().map(|p| (p[k] - mean).powi(2)).sum::<f64>() / (m - 1.0).max(1.0);
                // The estimate of `Σ A ρ Δ` over all leaves.
                let missed = total_w * mean;
                if first[k] <= 0.0 || gathered[k] <= 0.0 || weight_b2[k] <= 0.0 {
                    continue;
                }
                out.gap[k] = missed / gathered[k];
                out.gap_noise[k] = total_w * (var / m).sqrt() / gathered[k];
                out.gain[k] = gathered[k] / first[k];
                // The leaf field's reflected light is short by `G δ`; so is the
                // answer where its light is mostly reflected (doc above).
                let amp = out.gain[k];
                let (amplified, noise) = (amp * out.gap[k], NOISE_SIGMAS * amp * out.gap_noise[k]);
                let e2 = (amplified * amplified - noise * noise).max(0.0);
                num += weight_b2[k] * e2;
                noise2 += weight_b2[k] * noise * noise;
                den += weight_b2[k];
            }
            if den > 0.0 {
                out.error = (num / den).sqrt();
                out.noise = (noise2 / den).sqrt();
            }
            out
        };
        // More rows (four times as many a pass) while the amplified noise is above
        // `NOISE_PER_PROMISE` of what the solve promises, within the rows the cost
        // allows: a gap of a fraction of a percent at a gain of 4 is the whole
        // error of the Blender box, and 2 σ of 1 500 rows' noise hid it.
        let budget = ((self.sys.row_coefs.len() as f64 * CHECK_RAYS_PER_ENTRY) as usize
            / (CHECK_RAYS + CHECK_LIGHT_RAYS))
            .clamp(4 * CHECK_ROWS, CHECK_ROWS_CAP);
        let target = NOISE_PER_PROMISE * self.opts.promised_error();
        let mut rows = (nl / CHECK_ROWS_PER).clamp(CHECK_ROWS, CHECK_ROWS_MAX);
        let mut out = measure(rows);
        let mut rays = out.rays;
        while out.noise > target && rows * 4 <= budget {
            rows *= 4;
            out = measure(rows);
            rays += out.rays;
        }
        out.rays = rays;
        Some(out)
    }
}

impl Solver<'_> {
    /// What the rays of both checks need: the solved leaf field, each patch's
    /// root element (to find the leaf a ray meets) and the emitting leaves with
    /// their power (max channel), to draw points on for the direct light.
    fn ray_field(&self, plain: Vec<[f64; 3]>) -> RayField {
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let mut root = vec![u32::MAX; self.patches.len()];
        for (e, (g, node)) in geoms.iter().zip(nodes).enumerate() {
            let top = node.parent == u32::MAX || geoms[node.parent as usize].patch == u32::MAX;
            if g.patch != u32::MAX && top {
                root[g.patch as usize] = e as u32;
            }
        }
        let lights: Vec<(ElementId, f64)> = self
            .sys
            .leaves
            .iter()
            .filter_map(|&l| {
                let g = &geoms[l.ix()];
                let e = self.patches.emissions[g.patch as usize];
                let p = g.area * e.iter().copied().fold(0.0, f64::max);
                (p > 0.0).then_some((l, p))
            })
            .collect();
        let light_total = lights.iter().map(|l| l.1).sum();
        RayField {
            plain,
            root,
            lights,
            light_total,
        }
    }

    /// The irradiance `H` rays bring over `field` to points drawn by `point`
    /// (a point and its weight from two uniforms) on a surface of patch `patch`
    /// facing `n`: `side²` cosine rays in a jittered grid of directions, each from
    /// its own point, bring `B − E` of the leaf they meet (nothing from a back
    /// face or from nowhere); `light_rays` rays at points on the emitting leaves,
    /// drawn by power and stratified, bring `E K / pdf` where nothing blocks
    /// them. With `light_rays` 0 the cosine rays bring `B`, emission included.
    /// `r(j, k)` is the `k`-th uniform of ray `j`.
    fn rays_at(
        &self,
        field: &RayField,
        (patch, n): (u32, DVec3),
        point: impl Fn(f64, f64) -> (DVec3, f64),
        r: impl Fn(usize, u64) -> f64,
        (side, light_rays): (usize, usize),
    ) -> [f64; 3] {
        let geoms = self.elems.geoms.as_slice();
        let diam = self.patches.diameter;
        let (mut refl, mut wr) = ([0.0; 3], 0.0);
        for j in 0..side * side {
            let (x, jac) = point(r(j, 0), r(j, 1));
            let u1 = ((j % side) as f64 + r(j, 2)) / side as f64;
            let u2 = ((j / side) as f64 + r(j, 3)) / side as f64;
            let dir = cosine_direction(n, u1, u2);
            let v = self
                .bvh
                .intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0)
                .filter(|hit| {
                    hit.patch != patch && self.patches.normals[hit.patch as usize].dot(dir) < 0.0
                })
                .and_then(|hit| {
                    let top = *field.root.get(hit.patch as usize)?;
                    (top != u32::MAX).then(|| {
                        let y = x + dir * diam * 2.0 * hit.t;
                        let at = self.leaf_at(ElementId(top), y);
                        // With no rays at the emitters, the cosine rays bring
                        // the emission too.
                        let e = if light_rays > 0 {
                            self.patches.emissions[hit.patch as usize]
                        } else {
                            [0.0; 3]
                        };
                        std::array::from_fn(|k| field.plain[at.ix()][k] - e[k])
                    })
                })
                .unwrap_or([0.0; 3]);
            wr += jac;
            for k in 0..3 {
                refl[k] += jac * v[k];
            }
        }
        let (mut direct, mut wd) = ([0.0; 3], 0.0);
        if field.light_total > 0.0 {
            let (mut acc, mut at) = (0.0, 0);
            for j in 0..light_rays {
                let jj = j + side * side;
                let (x, jac) = point(r(jj, 0), r(jj, 1));
                wd += jac;
                let target = (j as f64 + r(jj, 2)) / light_rays as f64 * field.light_total;
                while at + 1 < field.lights.len() && acc + field.lights[at].1 < target {
                    acc += field.lights[at].1;
                    at += 1;
                }
                let (l, pw) = field.lights[at];
                let gl = &geoms[l.ix()];
                let (y, jac_y) = leaf_point(gl, r(jj, 3), r(jj, 4));
                let d = y - x;
                let r2 = d.length_squared();
                let nl = DVec3::from_array(gl.normal);
                let (cx, cy) = (n.dot(d), -nl.dot(d));
                if r2 <= 0.0 || cx <= 0.0 || cy <= 0.0 || gl.patch == patch {
                    continue;
                }
                // Cast as the cosine rays are (a ray a few millimetres long met
                // the twin its point lies on).
                let reach = r2.sqrt() / (diam * 2.0);
                if self
                    .bvh
                    .intersect_front_first(x, d / reach, 1e-6, reach * (1.0 - LIGHT_TRIM))
                    .is_some()
                {
                    continue;
                }
                // `E K / pdf`, `pdf = (P_l / P) / (jac_y A_l)` over the area.
                let k_xy = cx * cy / (std::f64::consts::PI * r2 * r2);
                let scale = k_xy * jac_y * gl.area * field.light_total / pw;
                let e = self.patches.emissions[gl.patch as usize];
                for k in 0..3 {
                    direct[k] += jac * scale * e[k];
                }
            }
        }
        std::array::from_fn(|k| {
            let mut h = if wr > 0.0 { refl[k] / wr } else { 0.0 };
            if wd > 0.0 {
                h += direct[k] / wd;
            }
            h
        })
    }

    /// Checks the final gather, the answer, against rays over the solved leaf
    /// field at `GATHER_POINTS` (128) points spread over the surfaces by area (the
    /// error estimate's samples, those off the emitters): the error a final
    /// gather that misses part of the field it gathers (a link's visibility,
    /// a cluster estimate, a source too close for its quadrature) leaves in the
    /// answer where it is, which no bounce amplifies and the rows' check does
    /// not see (the rows are not what the answer gathers with). `None` without
    /// a leaf system or samples.
    ///
    /// At each point `x` the final gather's reflected radiosity `v = ρ H_fg`
    /// is compared with two independent ray estimates `a` and `b` of `ρ H`,
    /// `GATHER_SIDE²` (1 024) cosine rays each that bring the emission of what
    /// they meet too (`Solver::rays_at`). Rays at points on the emitters read
    /// the ceiling 0.1 mm over the Blender box's lamp 86% short: the kernel's
    /// peak under the lamp's top is too narrow for them. `(a − v)(b − v)` has
    /// the expectation `(ρ H − v)²` whatever the rays' noise, since the two
    /// are independent. The term is `sqrt(max(0, Σ (a − v)(b − v)) / Σ v²)`
    /// over the points and channels: the relative RMS of the final gather's
    /// gap, as the change between levels is taken.
    ///
    /// On the Blender box one bounce of rays over the answer moved it 1.7–1.9%
    /// RMS at the test's points, up to 8% on the ceiling by the open front, where
    /// the answer was 9% dark (issue 45 part 4; the faint sources' shortcut,
    /// since bounded in sum: `Solver::gather_sum`); this check read 0.75%, 0.73%
    /// and 0.71% at eps 0.5, 0.25 and 0.1 (0.14–0.5 s): 128 points rarely fall
    /// where one point is wrong. Left out (`None`)
    /// where its rays exceed `CHECK_RAYS_PER_ENTRY` of the leaf system's
    /// entries (its 262 000 rays want 524 000 entries: the empty Cornell box
    /// has 323 000 at eps 0.1 and 843 000 at 0.02, the Blender box at eps 0.5
    /// 2.3 million).
    pub fn gather_ray_check(&self) -> Option<GatherCheck> {
        if self.sys.leaves.is_empty() || !self.has_leaf_rows() {
            return None;
        }
        let samples: Vec<ErrorSample> = self
            .error_samples(GATHER_POINTS)
            .into_iter()
            .filter(|smp| {
                self.patches.emissions[smp.patch as usize]
                    .iter()
                    .all(|&e| e <= 0.0)
            })
            .collect();
        // Left out where its rays would be more than a few percent of the solve
        // (`CHECK_RAYS_PER_ENTRY`): the Cornell box at eps 0.1 and above.
        let rays = samples.len() * 2 * GATHER_SIDE * GATHER_SIDE;
        if rays as f64 > self.sys.row_coefs.len() as f64 * CHECK_RAYS_PER_ENTRY {
            return None;
        }
        let values = self.sample_values(&samples);
        let plain = self.plain_radiosities();
        let field = self.ray_field(plain);
        let seed = self.opts.seed ^ 0x9a7e_c4ec;
        let per: Vec<Option<(f64, f64)>> = samples
            .par_iter()
            .zip(&values)
            .enumerate()
            .map(|(i, (smp, v))| {
                let v = (*v)?;
                let n = self.patches.normals[smp.patch as usize];
                let rho = self.patches.rhos[smp.patch as usize];
                let half = |h: u64| {
                    let r = |j: usize, k: u64| {
                        oracle::unit(oracle::hash3(seed ^ h, i as u64, j as u64 * 8 + k))
                    };
                    self.rays_at(
                        &field,
                        (smp.patch, n),
                        |_, _| (smp.x, 1.0),
                        r,
                        (GATHER_SIDE, 0),
                    )
                };
                let (a, b) = (half(1), half(2));
                let (mut prod, mut v2) = (0.0, 0.0);
                for k in 0..3 {
                    prod += (rho[k] * a[k] - v[k]) * (rho[k] * b[k] - v[k]);
                    v2 += v[k] * v[k];
                }
                Some((prod, v2))
            })
            .collect();
        let (mut prod, mut v2, mut points) = (0.0, 0.0, 0);
        for (p, q) in per.into_iter().flatten() {
            prod += p;
            v2 += q;
            points += 1;
        }
        if points == 0 || v2 <= 0.0 {
            return None;
        }
        Some(GatherCheck {
            points,
            rays: (points * 2 * GATHER_SIDE * GATHER_SIDE) as u64,
            error: (prod.max(0.0) / v2).sqrt(),
        })
    }
}

/// What [`Solver::rays_at`] casts over: the solved leaf field, each patch's root
/// element (`u32::MAX`: none) and the emitting leaves with their power and its
/// total. Transient, built once per check.
struct RayField {
    plain: Vec<[f64; 3]>,
    root: Vec<u32>,
    lights: Vec<(ElementId, f64)>,
    light_total: f64,
}

/// What [`Solver::gather_ray_check`] measured. 24 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatherCheck {
    /// Points compared (off the emitters, held by a leaf).
    pub points: usize,
    /// Rays cast.
    pub rays: u64,
    /// The relative RMS gap of the final gather against rays over the same field.
    pub error: f64,
}

/// `rows` draws of indices into `w` in proportion to `w` (total `total`),
/// stratified: draw `s` falls in the `s`-th of `rows` equal slices of the total,
/// at a seeded jitter within it. Entries of weight 0 are never drawn.
fn stratified_draws(w: &[f64], total: f64, rows: usize, seed: u64) -> Vec<usize> {
    let mut out = Vec::with_capacity(rows);
    let (mut acc, mut li) = (0.0, 0);
    for s in 0..rows {
        let r = oracle::unit(oracle::hash3(seed ^ 0x0c4e_c4ed, s as u64, rows as u64));
        let target = (s as f64 + r) / rows as f64 * total;
        while li + 1 < w.len() && (acc + w[li] < target || w[li] <= 0.0) {
            acc += w[li];
            li += 1;
        }
        out.push(li);
    }
    out
}

/// A point of surface element `g` at the unit-square parameters `(s, t)`, uniform
/// over its area when weighted by the returned factor (a quad's bilinear
/// Jacobian over its area; 1 on a triangle, folded into it).
fn leaf_point(g: &Geom, s: f64, t: f64) -> (DVec3, f64) {
    let c = g.corners.map(DVec3::from_array);
    let x = oracle::point_at(&c, g.n == 3, s, t);
    if g.n == 3 || g.area <= 0.0 {
        return (x, 1.0);
    }
    let ds = (1.0 - t) * (c[1] - c[0]) + t * (c[2] - c[3]);
    let dt = (1.0 - s) * (c[3] - c[0]) + s * (c[2] - c[1]);
    (x, ds.cross(dt).length() / g.area)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::playback::probe::{ProbePoint, probe};
    use crate::solution::PointError;

    /// The Cornell box (empty) with a white of 0.95, solved, and its answer at a
    /// 3 × 3 grid of points on every patch, with which points lie on the lamp.
    fn solved_box() -> (Scene, SolveOptions) {
        let mut scene = crate::scene::cornell_box(false);
        for m in &mut scene.materials {
            if m.name == "white" {
                m.rho = [0.95; 3];
            }
        }
        let opts = SolveOptions {
            max_rounds: 2,
            ..SolveOptions::default()
        };
        (scene, opts)
    }

    fn answer(s: &Solver, pts: &[(DVec3, DVec3)]) -> Vec<[f64; 3]> {
        let probes: Vec<ProbePoint> = pts.iter().map(|&(p, n)| ProbePoint { p, n }).collect();
        probe(&s.solution(), &probes, 0.0).unwrap()
    }

    fn grid(patches: &Patches) -> Vec<(DVec3, DVec3)> {
        let mut out = Vec::new();
        for i in 0..patches.len() {
            for a in 0..3 {
                for b in 0..3 {
                    let (u, v) = ((a as f64 + 0.5) / 3.0, (b as f64 + 0.5) / 3.0);
                    out.push((patches.point(i, u, v), patches.normals[i]));
                }
            }
        }
        out
    }

    /// Each quad of `scene` cut into 2 × 2 cells of unequal sizes (at 0.35 of
    /// each side, by the quad's bilinear map), each cell into two triangles
    /// along alternating diagonals, and each triangle into three of areas
    /// 0.5 : 0.3 : 0.2 (a fan from an inner point), wound as the polygon: the
    /// tessellated twin.
    fn unequal_triangles(mut scene: Scene) -> Scene {
        const AT: [f64; 3] = [0.0, 0.35, 1.0];
        for o in &mut scene.objects {
            o.polygons = o
                .polygons
                .iter()
                .flat_map(|p| {
                    let v = &p.vertices;
                    let poly = |t: [DVec3; 3]| crate::scene::Polygon {
                        vertices: t.to_vec(),
                        material: p.material,
                    };
                    if v.len() == 3 {
                        // A fan from the point of barycentres (0.5, 0.3, 0.2).
                        let c = 0.5 * v[0] + 0.3 * v[1] + 0.2 * v[2];
                        return (0..3).map(|i| poly([v[i], v[(i + 1) % 3], c])).collect();
                    }
                    assert_eq!(v.len(), 4, "the Cornell box: quads and triangles");
                    let at = |a: f64, b: f64| {
                        (1.0 - a) * (1.0 - b) * v[0]
                            + a * (1.0 - b) * v[1]
                            + a * b * v[2]
                            + (1.0 - a) * b * v[3]
                    };
                    let mut out = Vec::new();
                    for i in 0..2 {
                        for j in 0..2 {
                            let c = [
                                at(AT[i], AT[j]),
                                at(AT[i + 1], AT[j]),
                                at(AT[i + 1], AT[j + 1]),
                                at(AT[i], AT[j + 1]),
                            ];
                            let tris = if (i + j) % 2 == 0 {
                                [[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
                            } else {
                                [[c[0], c[1], c[3]], [c[1], c[2], c[3]]]
                            };
                            out.extend(tris.map(poly));
                        }
                    }
                    out
                })
                .collect();
        }
        scene
    }

    /// What [`rows_short_of_their_rays_raise_the_estimate_by_the_light_they_lose`]
    /// measures on `scene`: the check as solved, then with every leaf row × 0.97
    /// the error measured off the lamp, the check, and the row excess term.
    fn short_rows(scene: &Scene, opts: SolveOptions, scale: f64) -> (f64, f64, RowCheck, f64) {
        let mut s = Solver::new(scene, opts).unwrap();
        s.run(|_, _| {}).unwrap();
        let pts = grid(&s.patches);
        let on_lamp = crate::geometry::on_emitters(&s.patches, &pts);
        let right = answer(&s, &pts);
        let as_solved = s.row_ray_check().unwrap();
        for c in s.sys.row_coefs.iter_mut() {
            *c *= scale;
        }
        s.solve_leaves().unwrap();
        let short = answer(&s, &pts);
        let measured = PointError::measure(&short, &right, &on_lamp).off_emitters;
        let check = s.row_ray_check().unwrap();
        let excess = s.row_excess_error();
        let balance = s.power_balance();
        eprintln!(
            "{} patches: as solved {:.2e} (gap {:.4?} ± {:.4?}); rows x0.97: measured {measured:.4}, check {:.4} \
             (gap {:.4?} ± {:.4?}, gain {:.3?}), row excess {excess:.2e}, balance {balance:.4}",
            s.patches.len(),
            as_solved.error,
            as_solved.gap,
            as_solved.gap_noise,
            check.error,
            check.gap,
            check.gap_noise,
            check.gain
        );
        (as_solved.error, measured, check, excess)
    }

    /// The bars of both tests below. The rows' 3% loss (`δ`) shows in the
    /// answer: over 2% off the lamp. The check reads `G δ`, `G` the bounces'
    /// gain; the answer (a final gather over the leaf field) is off by between
    /// `(G − 1) δ` and `G δ`, so the check reads at least the measured error
    /// and at most `G / (G − 1)` (about 2 here, gains 1.7–2.2) times it. As
    /// solved, and the row excess term, it reads under a fifth of it.
    ///
    /// Measured (2026-11-30, 39cf2f2): the box of quads 4.32% off the lamp,
    /// the check 4.79% (gaps 2.1–2.4%; as solved −0.7 to −0.9%: its rows
    /// gather a little more than rays); the unequal triangles 4.50%, the check
    /// 7.58% (gaps 3.5–3.9%; as solved +0.2 to +0.7%). The bar was "within a
    /// factor 1.5" before the twin: the quads met it by their negative gap as
    /// solved. The check's gap without its gain (`δ` alone) reads 2.24% and
    /// 3.56%, with `G − 1` 2.55% and 4.03%: under the measured error, failed.
    fn assert_short_rows_seen(
        name: &str,
        (as_solved, measured, check, excess): (f64, f64, RowCheck, f64),
    ) {
        assert!(
            measured > 0.02,
            "{name}: rows x0.97 moved the answer {measured}"
        );
        assert!(
            check.error >= measured && check.error < measured * 2.0,
            "{name}: check {} for a measured {measured}",
            check.error
        );
        assert!(as_solved < measured / 5.0, "{name}: as solved {as_solved}");
        assert!(excess < measured / 5.0, "{name}: row excess {excess}");
    }

    /// Rows known to be short: the Cornell box (white 0.95) solved, then every
    /// leaf row's coefficients scaled by 0.97 and the leaf system solved again,
    /// so that every leaf gathers 3% less than its factors see. The answer
    /// (the final gather over that leaf field) moves off the one before by
    /// `(G − 1)` to `G` times 3%, `G` the bounces' gain (about 2); the estimate's
    /// other terms do not see it (no row sums above 1, and the box is open, so
    /// a deficit of power proves nothing), and the check of the rows against
    /// rays must: it reads between 1 and 2 times the measured error, and as
    /// solved (the rows right) under a fifth of it ([`assert_short_rows_seen`]).
    #[test]
    fn rows_short_of_their_rays_raise_the_estimate_by_the_light_they_lose() {
        let (scene, opts) = solved_box();
        assert_short_rows_seen("box", short_rows(&scene, opts, 0.97));
    }

    /// The tessellated twin of
    /// [`rows_short_of_their_rays_raise_the_estimate_by_the_light_they_lose`]:
    /// every quad of the box cut into 8 triangles of unequal sizes and each
    /// triangle (the right wall's two) into 3
    /// ([`unequal_triangles`]), the same bars.
    #[test]
    fn rows_short_of_their_rays_raise_the_estimate_on_unequal_triangles() {
        let (scene, opts) = solved_box();
        assert_short_rows_seen(
            "triangles",
            short_rows(&unequal_triangles(scene), opts, 0.97),
        );
    }

    /// A gap a fraction of a percent wide at a high gain, as on the Blender box
    /// (gaps of 0.3–0.6% at a gain of 3.9 left its answer 2.7–3.4% dark): the
    /// Cornell box with the Blender box's white (0.999) and every leaf row
    /// × 0.996. The answer moves by `G` times the 0.4%; the check must read
    /// between 0.7 and 2 times it (it draws rows until the amplified noise is
    /// under a quarter of what the solve promises, and takes one `σ` off).
    /// Measured (2026-12-02): 0.65% moved, the check 0.76% (gap 0.39 ± 0.18%
    /// at a gain of 2.4); with 2 σ taken off the same gaps read 0.36%, and the
    /// Blender box's check read 0.84% of the 2.2% its gaps amplify to.
    #[test]
    fn a_small_row_gap_at_a_high_gain_raises_the_estimate() {
        let (mut scene, opts) = solved_box();
        for m in &mut scene.materials {
            if m.name == "white" {
                m.rho = [0.999; 3];
            }
        }
        let (as_solved, measured, check, _) = short_rows(&scene, opts, 0.996);
        assert!(measured > 0.005, "rows x0.996 moved the answer {measured}");
        assert!(
            check.error > measured * 0.7 && check.error < measured * 2.0,
            "check {check:?} for a measured {measured}"
        );
        assert!(as_solved < measured / 3.0, "as solved {as_solved}");
    }
}
