//! TEMPORARY: decomposes the leaf rows with the largest sums against cosine rays.

use super::*;
use crate::geometry::cosine_direction;

fn contains(g: &Geom, y: DVec3) -> bool {
    let n = DVec3::from_array(g.normal);
    let k = (g.n as usize).min(4);
    let c: [DVec3; 4] = std::array::from_fn(|i| DVec3::from_array(g.corners[i]));
    let size = (c[0] - c[k / 2]).length();
    let tol = 1e-6 * size * size;
    let side = |i: usize| (c[(i + 1) % k] - c[i]).cross(y - c[i]).dot(n);
    (0..k).all(|i| side(i) >= -tol) || (0..k).all(|i| side(i) <= tol)
}

impl Solver<'_> {
    /// One bounce from the leaf solution at probe points (RHIER_PROBES json).
    pub fn debug_probes(&self) {
        let Some(path) = std::env::var_os("RHIER_PROBES") else {
            return;
        };
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let pts: Vec<serde_json::Value> = serde_json::from_str(&text).unwrap_or_default();
        let geoms = self.elems.geoms.as_slice();
        let rad = self.elems.radiosities.as_slice();
        let mut by_patch: HashMap<u32, Vec<ElementId>> = HashMap::new();
        for &l in &self.sys.leaves {
            by_patch.entry(geoms[l.ix()].patch).or_default().push(l);
        }
        let diam = self.patches.diameter;
        let v3 = |v: &serde_json::Value| {
            DVec3::new(
                v[0].as_f64().unwrap_or(0.0),
                v[1].as_f64().unwrap_or(0.0),
                v[2].as_f64().unwrap_or(0.0),
            )
        };
        let orig = crate::geometry::Patches::at_time(self.scene, 0.0);
        let obvh = crate::geometry::SceneBvh::build(self.scene, &orig, 0.0);
        eprintln!(
            "PROBE solver patches {} original {}",
            self.patches.len(),
            orig.len()
        );
        let out: Vec<String> = pts.par_iter().enumerate().map(|(pi, pt)| {
            let (p, n) = (v3(&pt["p"]), v3(&pt["n"]));
            let Some((patch, x)) = crate::geometry::nearest_facing(&self.patches.polys, &self.patches.normals, p, n) else { return "null".into() };
            let at_leaf = by_patch.get(&(patch as u32)).and_then(|v| v.iter().copied().find(|l| contains(&geoms[l.ix()], x)));
            let lb = at_leaf.map_or([f32::NAN; 3], |l| rad[l.ix()]);
            let m = 20000u64;
            let mut h = [0.0; 3];
            let (mut differ, mut esc_s, mut esc_o) = (0u64, 0u64, 0u64);
            let mut where_ = Vec::new();
            for j in 0..m {
                let hh = oracle::hash3(0xbeef, pi as u64, j);
                let u1 = (hh & 0xffff_ffff) as f64 / 4294967296.0;
                let u2 = (hh >> 32) as f64 / 4294967296.0;
                let dir = cosine_direction(n, u1, u2);
                let oh = obvh.intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0).filter(|h| orig.normals[h.patch as usize].dot(dir) < 0.0);
                let sh = self.bvh.intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0).filter(|h| self.patches.normals[h.patch as usize].dot(dir) < 0.0);
                esc_s += sh.is_none() as u64;
                esc_o += oh.is_none() as u64;
                match (sh, oh) {
                    (Some(a), Some(b)) if (a.t - b.t).abs() * diam * 2.0 < 1e-4 => {}
                    (None, None) => {}
                    (a, b) => {
                        differ += 1;
                        if where_.len() < 3 {
                            where_.push((a.map(|h| (h.patch, (x + dir * diam * 2.0 * h.t).to_array().map(|v| (v * 1e4).round() / 1e4))), b.map(|h| (h.patch, (x + dir * diam * 2.0 * h.t).to_array().map(|v| (v * 1e4).round() / 1e4)))));
                        }
                    }
                }
                let Some(hit) = sh else { continue };
                if hit.patch == patch as u32 || self.patches.normals[hit.patch as usize].dot(dir) >= 0.0 { continue; }
                let y = x + dir * diam * 2.0 * hit.t;
                let Some(at) = by_patch.get(&hit.patch).and_then(|v| v.iter().copied().find(|l| contains(&geoms[l.ix()], y))) else { continue };
                for k in 0..3 { h[k] += rad[at.ix()][k] as f64 / m as f64; }
            }
            eprintln!("PROBE {pi} {p}: escape solver {esc_s} original {esc_o} differ {differ} of {m}: {where_:?}");
            let rho = self.patches.rhos[patch];
            let e = self.patches.emissions[patch];
            let b: [f64; 3] = std::array::from_fn(|k| e[k] + rho[k] * h[k]);
            format!("{{\"B\": [{}, {}, {}], \"leaf\": [{}, {}, {}]}}", b[0], b[1], b[2], lb[0], lb[1], lb[2])
        }).collect();
        let _ = std::fs::write(
            "/tmp/h45blend/onebounce.json",
            format!("[{}]", out.join(",")),
        );
    }

    /// Light lost per leaf: rays' irradiance against the row's.
    pub fn debug_loss(&self) {
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let rad = self.elems.radiosities.as_slice();
        let plain: Vec<[f64; 3]> = rad.iter().map(|v| v.map(f64::from)).collect();
        let (b, fb) = self.gained(plain.clone());
        let mut by_patch: HashMap<u32, Vec<ElementId>> = HashMap::new();
        for &l in &self.sys.leaves {
            by_patch.entry(geoms[l.ix()].patch).or_default().push(l);
        }
        let diam = self.patches.diameter;
        let m: u64 = std::env::var("RHIER_LOSSRAYS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(64);
        let centre = DVec3::new(0.0, 0.0, 0.0);
        // Per leaf: (group, area, lost power per channel, rowsum, raysum, H_row, H_rays).
        let per: Vec<(String, f64, [f64; 3], f64, f64, [f64; 3], [f64; 3])> = self
            .sys
            .leaves
            .par_iter()
            .enumerate()
            .map(|(li, &leaf)| {
                let g = &geoms[leaf.ix()];
                let q = oracle::samples(g);
                let n = DVec3::from_array(g.normal);
                let obj = self.patches.objects[g.patch as usize] as usize;
                let name = self.scene.objects.get(obj).map_or("?", |o| o.name.as_str());
                let c = q.points[..q.count].iter().sum::<DVec3>() / q.count as f64;
                let inside =
                    c.x > -1.0085 && c.x < 0.993 && c.y > -0.8672 && c.y < 0.8629 && c.z > -0.8709;
                let facing = n.dot(centre - c) > 0.0;
                let group = format!(
                    "{name}{}",
                    if inside && facing {
                        "/in"
                    } else if inside {
                        "/in-away"
                    } else {
                        "/out"
                    }
                );
                let hrow = self.row_gather(li, &b, &fb);
                let (r0, r1) = (
                    self.sys.row_start[li] as usize,
                    self.sys.row_start[li + 1] as usize,
                );
                let rowsum: f64 = self.sys.row_coefs[r0..r1].iter().sum();
                let mut hray = [0.0; 3];
                let mut raysum = 0.0;
                for i in 0..q.count {
                    let w = q.weights[i] / m as f64;
                    for j in 0..m {
                        let h = oracle::hash3(0xdeb, i as u64 * 7919 + li as u64 * 13, j);
                        let u1 = (h & 0xffff_ffff) as f64 / 4294967296.0;
                        let u2 = (h >> 32) as f64 / 4294967296.0;
                        let dir = cosine_direction(n, u1, u2);
                        let x = q.points[i];
                        let Some(hit) =
                            self.bvh
                                .intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0)
                        else {
                            continue;
                        };
                        if hit.patch == g.patch
                            || self.patches.normals[hit.patch as usize].dot(dir) >= 0.0
                        {
                            continue;
                        }
                        let y = x + dir * diam * 2.0 * hit.t;
                        let Some(at) = by_patch
                            .get(&hit.patch)
                            .and_then(|v| v.iter().copied().find(|l| contains(&geoms[l.ix()], y)))
                        else {
                            continue;
                        };
                        raysum += w;
                        for k in 0..3 {
                            hray[k] += w * b[at.ix()][k];
                        }
                    }
                }
                let rho = self.patches.rhos[g.patch as usize];
                let lost = std::array::from_fn(|k| g.area * rho[k] * (hray[k] - hrow[k]));
                let _ = nodes;
                (group, g.area, lost, rowsum, raysum, hrow, hray)
            })
            .collect();
        let mut emitted = [0.0; 3];
        for &leaf in &self.sys.leaves {
            let g = &geoms[leaf.ix()];
            for k in 0..3 {
                emitted[k] += g.area * self.patches.emissions[g.patch as usize][k];
            }
        }
        let mut groups: std::collections::BTreeMap<
            String,
            (usize, f64, [f64; 3], [f64; 3], f64, f64),
        > = Default::default();
        for (gname, a, lost, rs, ys, hrow, _) in &per {
            let x = groups.entry(gname.clone()).or_default();
            x.0 += 1;
            x.1 += a;
            for k in 0..3 {
                x.2[k] += lost[k] / emitted[k].max(1e-30);
                x.3[k] += a * hrow[k];
            }
            x.4 += a * rs;
            x.5 += a * ys;
        }
        eprintln!(
            "LOSS emitted {emitted:?}; per group: leaves, area, lost/emitted per channel (rays - row), mean row sum, mean ray sum"
        );
        for (k, v) in &groups {
            eprintln!(
                "LOSS {k:<24} {:6} {:8.4} [{:+.4} {:+.4} {:+.4}] rowsum {:.4} raysum {:.4} rel [{:+.4} {:+.4} {:+.4}]",
                v.0,
                v.1,
                v.2[0],
                v.2[1],
                v.2[2],
                v.4 / v.1,
                v.5 / v.1,
                v.2[0] * emitted[0] / v.3[0].max(1e-30),
                v.2[1] * emitted[1] / v.3[1].max(1e-30),
                v.2[2] * emitted[2] / v.3[2].max(1e-30)
            );
        }
        let mut order: Vec<usize> = (0..per.len()).collect();
        order.sort_by(|&x, &y| (per[y].2[0] + per[y].2[1]).total_cmp(&(per[x].2[0] + per[x].2[1])));
        let picks: Vec<usize> = order
            .iter()
            .copied()
            .filter(|&i| {
                per[i].0.ends_with("/in")
                    && !per[i].0.starts_with("Light")
                    && !per[i].0.starts_with("Suzanne")
                    && per[i].3 > 0.3
            })
            .take(12)
            .collect();
        for &i in order.iter().take(5).chain(picks.iter()) {
            let (gname, a, lost, rs, ys, hrow, hray) = &per[i];
            eprintln!(
                "LOSSLEAF {} {gname} area {a:.3e} lost {:?} rowsum {rs:.4} raysum {ys:.4} Hrow {:?} Hray {:?}",
                self.sys.leaves[i].0,
                lost.map(|x| x / emitted[0]),
                hrow,
                hray
            );
        }
        self.debug_rows(&picks, &b, &fb);
    }

    /// Prints the rows with the largest sums, entry by entry against rays.
    pub fn debug_rows(&self, picks: &[usize], b: &[[f64; 3]], fb: &[[f64; 3]]) {
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let sums = self.row_sums();
        let mut order: Vec<usize> = (0..sums.len()).collect();
        order.sort_by(|&a, &b| sums[b].1.total_cmp(&sums[a].1));
        let over: Vec<&(f64, f64)> = sums.iter().filter(|x| x.1 > 1.01).collect();
        eprintln!(
            "ROWDEBUG {} leaves, {} rows > 1.01 (area {:.4}), largest {:.4}",
            sums.len(),
            over.len(),
            over.iter().map(|x| x.0).sum::<f64>(),
            sums.get(order[0]).map_or(0.0, |x| x.1)
        );
        // Patch -> leaves.
        let mut by_patch: HashMap<u32, Vec<ElementId>> = HashMap::new();
        for &l in &self.sys.leaves {
            by_patch.entry(geoms[l.ix()].patch).or_default().push(l);
        }
        // Patch kinds by object to tell the head.
        let diam = self.patches.diameter;
        for &li in picks {
            let leaf = self.sys.leaves[li];
            let g = &geoms[leaf.ix()];
            let (r0, r1) = (
                self.sys.row_start[li] as usize,
                self.sys.row_start[li + 1] as usize,
            );
            let mut entries: HashMap<u32, f64> = HashMap::new();
            for (s, c) in self.sys.row_sources[r0..r1]
                .iter()
                .zip(&self.sys.row_coefs[r0..r1])
            {
                let key = if s & FACET_BIT != 0 {
                    FACET_BIT | self.facets.owner(s & !FACET_BIT)
                } else {
                    *s
                };
                *entries.entry(key).or_default() += c;
            }
            // Entries that are ancestors of other entries (double cover).
            let mut doubled = 0;
            for &e in entries.keys() {
                let mut p = if e & FACET_BIT != 0 {
                    e & !FACET_BIT
                } else {
                    nodes[e as usize].parent
                };
                while p != u32::MAX {
                    if entries.contains_key(&p) || entries.contains_key(&(FACET_BIT | p)) {
                        doubled += 1;
                    }
                    p = nodes[p as usize].parent;
                }
            }
            let q = oracle::samples(g);
            let n = DVec3::from_array(g.normal);
            let m = 2000u64;
            let mut truth: HashMap<u32, f64> = HashMap::new();
            let mut tlight: HashMap<u32, [f64; 3]> = HashMap::new();
            let mut unc: HashMap<(u32, u32), f64> = HashMap::new();
            let mut unc_ex = Vec::new();
            let (mut missed, mut own, mut back, mut none) = (0.0, 0.0, 0.0, 0.0);
            for i in 0..q.count {
                let w = q.weights[i] / m as f64;
                for j in 0..m {
                    let h = oracle::hash3(0xdeb, i as u64 * 7919 + li as u64, j);
                    let u1 = (h & 0xffff_ffff) as f64 / 4294967296.0;
                    let u2 = (h >> 32) as f64 / 4294967296.0;
                    let dir = cosine_direction(n, u1, u2);
                    let x = q.points[i];
                    let Some(hit) = self
                        .bvh
                        .intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0)
                    else {
                        none += w;
                        continue;
                    };
                    if hit.patch == g.patch {
                        own += w;
                        continue;
                    }
                    if self.patches.normals[hit.patch as usize].dot(dir) >= 0.0 {
                        back += w;
                        continue;
                    }
                    let y = x + dir * diam * 2.0 * hit.t;
                    let at = by_patch
                        .get(&hit.patch)
                        .and_then(|v| v.iter().copied().find(|l| contains(&geoms[l.ix()], y)));
                    let Some(at) = at else {
                        missed += w;
                        continue;
                    };
                    let mut e = at.0;
                    let mut found = None;
                    while e != u32::MAX {
                        if entries.contains_key(&e) {
                            found = Some(e);
                            break;
                        }
                        if entries.contains_key(&(FACET_BIT | e)) {
                            found = Some(FACET_BIT | e);
                            break;
                        }
                        e = nodes[e as usize].parent;
                    }
                    let key = found.unwrap_or(u32::MAX - 1);
                    if found.is_none() {
                        let mut chain = Vec::new();
                        let mut e = at.0;
                        while e != u32::MAX {
                            chain.push(e);
                            e = nodes[e as usize].parent;
                        }
                        *unc.entry((hit.patch, chain[chain.len().saturating_sub(1)]))
                            .or_default() += w;
                        if unc_ex.len() < 6 {
                            let tr = self.links.transports.as_slice();
                            let ends = self.links.ends.as_slice();
                            let link = self.chain_links(leaf).find(|&l| chain.contains(&ends[l as usize].source)).map(|l| {
                                let t = &tr[l as usize];
                                let e = ends[l as usize];
                                (l, e.source, e.receiver, geoms[e.receiver as usize].patch != u32::MAX, t.f, t.visibility)
                            });
                            unc_ex.push((
                                hit.patch,
                                y.to_array().map(|v| (v * 1e4).round() / 1e4),
                                chain,
                                link,
                            ));
                        }
                    }
                    *truth.entry(key).or_default() += w;
                    let tl = tlight.entry(key).or_default();
                    for k in 0..3 {
                        tl[k] += w * b[at.ix()][k];
                    }
                }
            }
            self.debug_truth(li, b, fb);
            let rowsum: f64 = entries.values().sum();
            let tsum: f64 = truth.values().sum();
            let kind = |e: u32| -> String {
                if e == u32::MAX - 1 {
                    "UNCOVERED".into()
                } else if e & FACET_BIT != 0 {
                    format!("facets of cl{}", e & !FACET_BIT)
                } else if geoms[e as usize].patch == u32::MAX {
                    format!("cluster d{}", nodes[e as usize].depth)
                } else {
                    format!(
                        "surf p{} d{} kids{}",
                        geoms[e as usize].patch,
                        nodes[e as usize].depth,
                        nodes[e as usize].child_count
                    )
                }
            };
            eprintln!(
                "ROW leaf {} patch {} area {:.3e} n {:?} c {:?}: sum {:.4} rays {:.4} (none {:.3} own {:.3} back {:.3} missed {:.3}) entries {} doubled {}",
                leaf.0,
                g.patch,
                g.area,
                g.normal.map(|v| (v * 100.0).round() / 100.0),
                q.points[0].to_array().map(|v| (v * 1e4).round() / 1e4),
                rowsum,
                tsum,
                none,
                own,
                back,
                missed,
                entries.len(),
                doubled
            );
            let rl = |e: u32| -> [f64; 3] {
                if e == u32::MAX - 1 {
                    return [0.0; 3];
                }
                let c = entries.get(&e).copied().unwrap_or(0.0);
                let v = if e & FACET_BIT != 0 {
                    // the facets of a cluster were summed: use the cluster's value
                    b[(e & !FACET_BIT) as usize]
                } else {
                    source_value(b, fb, e)
                };
                v.map(|x| x * c)
            };
            let mut diffs: Vec<(u32, f64, f64)> = entries
                .keys()
                .chain(truth.keys())
                .copied()
                .collect::<std::collections::BTreeSet<u32>>()
                .into_iter()
                .map(|e| {
                    (
                        e,
                        entries.get(&e).copied().unwrap_or(0.0),
                        truth.get(&e).copied().unwrap_or(0.0),
                    )
                })
                .collect();
            // Per kind totals.
            let mut kinds: std::collections::BTreeMap<&str, (f64, f64)> = Default::default();
            for &(e, r, t) in &diffs {
                let k = if e == u32::MAX - 1 {
                    "uncovered"
                } else if e & FACET_BIT != 0 {
                    "facet"
                } else if geoms[e as usize].patch == u32::MAX {
                    "cluster"
                } else {
                    "surface"
                };
                let x = kinds.entry(k).or_default();
                x.0 += r;
                x.1 += t;
            }
            eprintln!("   by kind (row, rays): {kinds:?}");
            let mut u: Vec<_> = unc.into_iter().collect();
            u.sort_by(|a, b| b.1.total_cmp(&a.1));
            eprintln!(
                "   uncovered by (patch, root): {:?} e.g. {:?}",
                &u[..u.len().min(6)],
                unc_ex
            );
            let mut lk_kind: std::collections::BTreeMap<&str, ([f64; 3], [f64; 3])> =
                Default::default();
            for &(e, _, _) in &diffs {
                let k = if e == u32::MAX - 1 {
                    "uncovered"
                } else if e & FACET_BIT != 0 {
                    "facet"
                } else if geoms[e as usize].patch == u32::MAX {
                    "cluster"
                } else {
                    "surface"
                };
                let x = lk_kind.entry(k).or_default();
                let r = rl(e);
                let t = tlight.get(&e).copied().unwrap_or([0.0; 3]);
                for c in 0..3 {
                    x.0[c] += r[c];
                    x.1[c] += t[c];
                }
            }
            eprintln!("   light by kind (row, rays): {lk_kind:.4?}");
            let lk = |e: u32| -> f64 {
                let r = rl(e);
                let t = tlight.get(&e).copied().unwrap_or([0.0; 3]);
                (0..3).map(|k| r[k] - t[k]).sum::<f64>()
            };
            diffs.sort_by(|a, b| lk(b.0).abs().total_cmp(&lk(a.0).abs()));
            for (e, r, t) in diffs.iter().take(8) {
                let dist = if *e == u32::MAX - 1 {
                    0.0
                } else {
                    let (c, r) = oracle::sphere(&geoms[(e & !FACET_BIT) as usize]);
                    (c - q.points[0]).length() / r.max(1e-30)
                };
                let rlv = rl(*e);
                let tlv = tlight.get(e).copied().unwrap_or([0.0; 3]);
                eprintln!(
                    "   {:>10} {:<28} row {:.4} rays {:.4} diff {:+.4} d/r {:.2} light row {:.4?} rays {:.4?}",
                    e & !FACET_BIT,
                    kind(*e),
                    r,
                    t,
                    r - t,
                    dist,
                    rlv,
                    tlv
                );
            }
        }
    }
}

impl Solver<'_> {
    /// Many-ray truth of one row entry `e` at the leaf's points: `Σ_i w_i k_i V_i`.
    pub fn debug_entry_truth(&self, g: &Geom, q: &oracle::Samples, n: DVec3, e: u32, m: u32) -> (f64, f64) {
        let geoms = self.elems.geoms.as_slice();
        let mut truth = 0.0;
        let mut unocc = 0.0;
        let mut part_truth = |p: u32, k: [f64; 4], truth: &mut f64, unocc: &mut f64| {
            for i in 0..q.count {
                if k[i] <= 0.0 {
                    continue;
                }
                let x = q.points[i];
                let v = if p & FACET_BIT == 0 && geoms[p as usize].patch != u32::MAX {
                    let gs = &geoms[p as usize];
                    let ps = oracle::poly(gs);
                    oracle::visible_fraction(
                        &self.bvh,
                        &oracle::PointRays {
                            x,
                            n,
                            gs,
                            pols: &ps,
                            ns: DVec3::from_array(gs.normal),
                            m,
                            key: oracle::hash3(0x7777, p as u64, i as u64),
                            skip: [g.patch, gs.patch],
                        },
                    )
                } else {
                    let (v, r) = self.part_visibility(x, n, g.patch, p, m, 1000 + i as u64);
                    if r == 0 { 0.0 } else { v }
                };
                *truth += q.weights[i] * k[i] * v;
                *unocc += q.weights[i] * k[i];
            }
        };
        if e & FACET_BIT != 0 {
            let f = e & !FACET_BIT;
            let c = self.facets.owner(f);
            let (cc, r) = oracle::sphere(&geoms[c as usize]);
            if let Some((ks, count)) = self.facet_factors(q, n, c, cc, r) {
                for &(ff, k) in &ks[..count] {
                    if ff == f {
                        part_truth(e, k, &mut truth, &mut unocc);
                    }
                }
            }
        } else if geoms[e as usize].patch != u32::MAX {
            let ps = oracle::poly(&geoms[e as usize]);
            let k: [f64; 4] = std::array::from_fn(|i| if i < q.count { point_to_polygon(q.points[i], n, &ps) } else { 0.0 });
            part_truth(e, k, &mut truth, &mut unocc);
        } else {
            let mut parts = Vec::new();
            self.cluster_parts(q, n, e, &mut |p, k| parts.push((p, k)));
            for (p, k) in parts {
                part_truth(p, k, &mut truth, &mut unocc);
            }
        }
        (truth, unocc)
    }

    /// Per entry kind: row coefficient and light against many-ray truth.
    pub fn debug_truth(&self, li: usize, b: &[[f64; 3]], fb: &[[f64; 3]]) {
        let geoms = self.elems.geoms.as_slice();
        let leaf = self.sys.leaves[li];
        let g = &geoms[leaf.ix()];
        let q = oracle::samples(g);
        let n = DVec3::from_array(g.normal);
        let m: u32 = std::env::var("RHIER_TRUTHRAYS").ok().and_then(|s| s.parse().ok()).unwrap_or(1024);
        let (r0, r1) = (self.sys.row_start[li] as usize, self.sys.row_start[li + 1] as usize);
        let mut kinds: std::collections::BTreeMap<String, [f64; 5]> = Default::default();
        let mut worst: Vec<(f64, String)> = Vec::new();
        for (&s, &c) in self.sys.row_sources[r0..r1].iter().zip(&self.sys.row_coefs[r0..r1]) {
            let (t, u) = self.debug_entry_truth(g, &q, n, s, m);
            let v = source_value(b, fb, s);
            let lum = |x: [f64; 3]| x[0] + x[1];
            let kind = if s & FACET_BIT != 0 {
                "facet".to_string()
            } else if geoms[s as usize].patch == u32::MAX {
                "cluster".to_string()
            } else {
                let obj = self.patches.objects[geoms[s as usize].patch as usize] as usize;
                let name = self.scene.objects.get(obj).map_or("?", |o| o.name.as_str());
                format!("surf {name}")
            };
            let x = kinds.entry(kind.clone()).or_default();
            x[0] += c;
            x[1] += t;
            x[2] += c * lum(v);
            x[3] += t * lum(v);
            x[4] += u;
            worst.push(((c - t) * lum(v), format!("{kind} e{s} row {c:.5} truth {t:.5} unocc {u:.5} v {:.3?}", v)));
        }
        let tot: [f64; 5] = kinds.values().fold([0.0; 5], |a, x| std::array::from_fn(|i| a[i] + x[i]));
        eprintln!("TRUTH leaf {} ({m} rays): row {:.4} truth {:.4} light(r+g) row {:.4} truth {:.4} unocc {:.4}", leaf.0, tot[0], tot[1], tot[2], tot[3], tot[4]);
        for (k, x) in &kinds {
            eprintln!("TRUTH   {k:<20} row {:.4} truth {:.4} light row {:.4} truth {:.4} unocc {:.4}", x[0], x[1], x[2], x[3], x[4]);
        }
        worst.sort_by(|a, b| a.0.abs().total_cmp(&b.0.abs()).reverse());
        for (d, s) in worst.iter().take(6) {
            eprintln!("TRUTH     {d:+.5} {s}");
        }
    }
}
