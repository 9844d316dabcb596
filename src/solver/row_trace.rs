//! Scratch tracing (issue 45 part 4): where the Blender box's leaf rows lose
//! light against cosine rays over the same solved field, by row entry kind.
//! Not part of the suite (ignored); kept in the branch history only.

use super::*;
use std::collections::HashSet;

const KINDS: [&str; 8] = [
    "surf link",
    "opened child",
    "cluster part surf",
    "cluster est",
    "facet",
    "emitter",
    "overlap(>1 entry)",
    "NO ENTRY",
];

#[derive(Default, Clone)]
struct Acc {
    /// Row's Σ c B per kind (gray = mean of channels).
    row: [f64; 8],
    /// Row's Σ c per kind.
    coef: [f64; 8],
    /// Rays' Σ w B_hit / Σw per kind.
    ray: [f64; 8],
    /// Rays' hit fraction per kind.
    hits: [f64; 8],
    /// Rays' (B_hit − B_entry) per kind (the radiosity part of the gap).
    dev: [f64; 8],
    rows: usize,
    /// Missing hits by where they landed: (description → gray light).
    missing: HashMap<String, f64>,
    /// Per row relative gaps.
    gaps: Vec<f64>,
    /// Per link source of kinds 0/1: [coef, hits, coef·B, hits·B, unoccluded, rows,
    /// opened children, transport vis].
    links: HashMap<u32, [f64; 8]>,
}

fn gray(v: [f64; 3]) -> f64 {
    (v[0] + v[1] + v[2]) / 3.0
}

impl Solver<'_> {
    fn facet_roots(&self, f: u32, out: &mut HashSet<u32>) {
        for &(m, _) in self.facets.members(f) {
            if m & FACET_BIT != 0 {
                self.facet_roots(m & !FACET_BIT, out);
            } else {
                out.insert(m);
            }
        }
    }

    fn where_is(&self, patch: u32, y: DVec3) -> String {
        let n = self.patches.normals[patch as usize];
        let e = self.patches.emissions[patch as usize];
        if e.iter().any(|&x| x > 0.0) {
            return "lamp".into();
        }
        let axis = if n.x.abs() > 0.99 {
            format!("{}x", if n.x > 0.0 { "+" } else { "-" })
        } else if n.y.abs() > 0.99 {
            format!("{}y", if n.y > 0.0 { "+" } else { "-" })
        } else if n.z.abs() > 0.99 {
            format!("{}z", if n.z > 0.0 { "+" } else { "-" })
        } else {
            return "head/other".into();
        };
        let inside = y.x > -1.0 && y.x < 0.99 && y.y > -0.866 && y.y < 0.862 && y.z > -0.87;
        format!(
            "{axis} @({:.2},{:.2},{:.2}) {}",
            y.x,
            y.y,
            y.z,
            if inside { "room" } else { "edge/outside" }
        )
    }

    /// Traces `rows` seeded leaf rows among `leaves`, `side²` cosine rays at each
    /// quadrature point.
    fn trace_rows(&self, leaves: &[usize], side: usize) -> Acc {
        let geoms = self.elems.geoms.as_slice();
        let nodes = self.elems.nodes.as_slice();
        let ends = self.links.ends.as_slice();
        let plain: Vec<[f64; 3]> = self
            .elems
            .radiosities
            .as_slice()
            .iter()
            .map(|v| v.map(f64::from))
            .collect();
        let (b, fb) = self.gained(plain);
        let mut root = vec![u32::MAX; self.patches.len()];
        for (e, (g, node)) in geoms.iter().zip(nodes).enumerate() {
            let top = node.parent == u32::MAX || geoms[node.parent as usize].patch == u32::MAX;
            if g.patch != u32::MAX && top {
                root[g.patch as usize] = e as u32;
            }
        }
        let diam = self.patches.diameter;
        let ancestors = |mut e: u32| {
            let mut v = vec![e];
            while nodes[e as usize].parent != u32::MAX {
                e = nodes[e as usize].parent;
                v.push(e);
            }
            v
        };
        let accs: Vec<Acc> = leaves
            .par_iter()
            .map(|&li| {
                let mut acc = Acc::default();
                let leaf = self.sys.leaves[li];
                let g = &geoms[leaf.ix()];
                let n = DVec3::from_array(g.normal);
                let (r0, r1) = (
                    self.sys.row_start[li] as usize,
                    self.sys.row_start[li + 1] as usize,
                );
                let scale = self.sys.row_scale.get(li).copied().unwrap_or(1.0);
                let mut s_link = HashSet::new();
                for l in self.chain_links(leaf) {
                    let s = ends[l as usize].source;
                    if geoms[s as usize].patch != u32::MAX {
                        s_link.insert(s);
                    }
                }
                // Entries: (source, coef, kind, value, facet roots).
                let mut ent: Vec<(u32, f64, usize, f64, Option<HashSet<u32>>)> = Vec::new();
                for j in r0..r1 {
                    let s = self.sys.row_sources[j];
                    let c = self.sys.row_coefs[j] * scale;
                    let v = gray(source_value(&b, &fb, s));
                    if s & FACET_BIT != 0 {
                        let mut set = HashSet::new();
                        self.facet_roots(s & !FACET_BIT, &mut set);
                        ent.push((s, c, 4, v, Some(set)));
                        continue;
                    }
                    let gs = &geoms[s as usize];
                    let kind = if gs.patch == u32::MAX {
                        3
                    } else if self.patches.emissions[gs.patch as usize]
                        .iter()
                        .any(|&x| x > 0.0)
                    {
                        5
                    } else if s_link.contains(&s) {
                        0
                    } else if ancestors(s).iter().any(|a| s_link.contains(a)) {
                        1
                    } else {
                        2
                    };
                    ent.push((s, c, kind, v, None));
                }
                for e in &ent {
                    acc.row[e.2] += e.1 * e.3;
                    acc.coef[e.2] += e.1;
                }
                // The link source each surface-link or opened-child entry came from.
                let link_of = |s: u32| ancestors(s).into_iter().find(|a| s_link.contains(a));
                let q0 = oracle::samples(g);
                let qw: f64 = q0.weights[..q0.count].iter().sum();
                for l in self.chain_links(leaf) {
                    let s = ends[l as usize].source;
                    if geoms[s as usize].patch == u32::MAX {
                        continue;
                    }
                    let ps = oracle::poly(&geoms[s as usize]);
                    let un: f64 = (0..q0.count)
                        .map(|i| q0.weights[i] / qw * point_to_polygon(q0.points[i], n, &ps))
                        .sum();
                    let r = acc.links.entry(s).or_default();
                    r[4] += un;
                    r[5] += 1.0;
                    r[7] += self.links.transports.as_slice()[l as usize].visibility as f64;
                }
                for e in &ent {
                    if e.2 <= 1 || e.2 == 5 {
                        if let Some(ls) = e.4.is_none().then(|| link_of(e.0)).flatten() {
                            let r = acc.links.entry(ls).or_default();
                            r[0] += e.1;
                            r[2] += e.1 * e.3;
                            if e.0 != ls {
                                r[6] += 1.0;
                            }
                        }
                    }
                }
                let q = oracle::samples(g);
                let wsum: f64 = q.weights[..q.count].iter().sum();
                let nr = (side * side) as f64;
                let mut ray_tot = 0.0;
                for p in 0..q.count {
                    let x = q.points[p];
                    let w = q.weights[p] / wsum / nr;
                    for j in 0..side * side {
                        let h = |k: u64| {
                            oracle::unit(oracle::hash3(
                                0x7ace ^ li as u64,
                                (p * 100000 + j) as u64,
                                k,
                            ))
                        };
                        let u1 = ((j % side) as f64 + h(0)) / side as f64;
                        let u2 = ((j / side) as f64 + h(1)) / side as f64;
                        let dir = cosine_direction(n, u1, u2);
                        let Some(hit) = self
                            .bvh
                            .intersect_front_first(x, dir * diam * 2.0, 1e-6, 1.0)
                            .filter(|hit| {
                                hit.patch != g.patch
                                    && self.patches.normals[hit.patch as usize].dot(dir) < 0.0
                            })
                        else {
                            continue;
                        };
                        let top = root[hit.patch as usize];
                        if top == u32::MAX {
                            continue;
                        }
                        let y = x + dir * diam * 2.0 * hit.t;
                        let at = self.leaf_at(ElementId(top), y);
                        let bv = gray(b[at.ix()]);
                        ray_tot += w * bv;
                        let anc = ancestors(at.0);
                        let mut cover: Vec<(usize, usize)> = Vec::new(); // (entry, depth)
                        for (k, e) in ent.iter().enumerate() {
                            if let Some(set) = &e.4 {
                                if set.contains(&top) {
                                    let d = anc.iter().position(|&a| a == top).unwrap_or(99);
                                    cover.push((k, d + 1));
                                }
                            } else if let Some(d) = anc.iter().position(|&a| a == e.0) {
                                cover.push((k, d));
                            }
                        }
                        if cover.is_empty() {
                            acc.ray[7] += w * bv;
                            acc.hits[7] += w;
                            *acc.missing.entry(self.where_is(hit.patch, y)).or_default() += w * bv;
                            continue;
                        }
                        if cover.len() > 1 {
                            acc.ray[6] += w * bv;
                            acc.hits[6] += w;
                        }
                        let &(k, _) = cover.iter().min_by_key(|c| c.1).unwrap();
                        let kind = ent[k].2;
                        acc.ray[kind] += w * bv;
                        acc.hits[kind] += w;
                        acc.dev[kind] += w * (bv - ent[k].3);
                        if (kind <= 1 || kind == 5) && ent[k].4.is_none() {
                            if let Some(ls) = link_of(ent[k].0) {
                                let r = acc.links.entry(ls).or_default();
                                r[1] += w;
                                r[3] += w * bv;
                            }
                        }
                    }
                }
                let row_tot: f64 = acc.row[..6].iter().sum();
                acc.gaps.push((ray_tot - row_tot) / ray_tot.max(1e-30));
                acc.rows = 1;
                acc
            })
            .collect();
        let mut out = Acc::default();
        for a in accs {
            for k in 0..8 {
                out.row[k] += a.row[k];
                out.coef[k] += a.coef[k];
                out.ray[k] += a.ray[k];
                out.hits[k] += a.hits[k];
                out.dev[k] += a.dev[k];
            }
            out.rows += a.rows;
            out.gaps.extend(a.gaps);
            for (m, v) in a.missing {
                *out.missing.entry(m).or_default() += v;
            }
            for (l, v) in a.links {
                let r = out.links.entry(l).or_default();
                for k in 0..8 {
                    r[k] += v[k];
                }
            }
        }
        out
    }
}

impl Solver<'_> {
    /// Per surface link source: Σ over `leaves` of the row coefficient
    /// `hidden_row_coef` gives with the current `rays_per_point`.
    fn link_coefs(&self, leaves: &[usize]) -> HashMap<u32, f64> {
        let geoms = self.elems.geoms.as_slice();
        let ends = self.links.ends.as_slice();
        let per: Vec<Vec<(u32, f64)>> = leaves
            .par_iter()
            .map(|&li| {
                let leaf = self.sys.leaves[li];
                let g = &geoms[leaf.ix()];
                let n = DVec3::from_array(g.normal);
                let q = oracle::samples(g);
                let qw: f64 = q.weights[..q.count].iter().sum();
                self.chain_links(leaf)
                    .filter_map(|l| {
                        let s = ends[l as usize].source;
                        (geoms[s as usize].patch != u32::MAX).then(|| {
                            let ((f, _), _, _) =
                                self.hidden_row_coef(leaf, l, s, &q, n, rows::RowMasks::None);
                            (s, f / qw)
                        })
                    })
                    .collect()
            })
            .collect();
        let mut out = HashMap::new();
        for v in per {
            for (s, f) in v {
                *out.entry(s).or_default() += f;
            }
        }
        out
    }
}

fn print_links(s: &Solver, a: &Acc) {
    let ray_tot: f64 = a.ray[..6].iter().sum::<f64>() + a.ray[7];
    let geoms = s.elems.geoms.as_slice();
    let mut l: Vec<_> = a.links.iter().collect();
    l.sort_by(|x, y| (y.1[3] - y.1[2]).abs().total_cmp(&(x.1[3] - x.1[2]).abs()));
    eprintln!(
        "  link source (id patch normal centroid area)  rows  kids  unocc  coef  hits  rowvis  rayvis  trvis  gap%"
    );
    for (src, r) in l.iter().take(14) {
        let g = &geoms[**src as usize];
        let k = g.n.clamp(3, 4) as usize;
        let c = g.corners[..k]
            .iter()
            .map(|&c| DVec3::from_array(c))
            .sum::<DVec3>()
            / k as f64;
        eprintln!(
            "  {:6} p{:4} n({:+.0},{:+.0},{:+.0}) c({:+.2},{:+.2},{:+.2}) A{:.4} {:3} {:5} {:.5} {:.5} {:.5} {:.3} {:.3} {:.3} {:+.3}",
            src,
            g.patch,
            g.normal[0],
            g.normal[1],
            g.normal[2],
            c.x,
            c.y,
            c.z,
            g.area,
            r[5],
            r[6],
            r[4],
            r[0],
            r[1],
            r[0] / r[4].max(1e-30),
            r[1] / r[4].max(1e-30),
            r[7] / r[5].max(1.0),
            100.0 * (r[3] - r[2]) / ray_tot
        );
    }
}

fn print(name: &str, a: &Acc) {
    let ray_tot: f64 = a.ray[..6].iter().sum::<f64>() + a.ray[7];
    let row_tot: f64 = a.row[..6].iter().sum();
    let n = a.rows as f64;
    eprintln!(
        "== {name}: {} rows; rows gather {:.4}, rays {:.4} (gap {:+.2}% of rays); row gaps min {:.2}% max {:.2}%",
        a.rows,
        row_tot / n,
        ray_tot / n,
        100.0 * (ray_tot - row_tot) / ray_tot,
        100.0 * a.gaps.iter().copied().fold(f64::INFINITY, f64::min),
        100.0 * a.gaps.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    eprintln!(
        "{:>18} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "kind", "coef", "hitfrac", "rowH", "rayH", "gap%", "Bdev%"
    );
    for k in 0..8 {
        eprintln!(
            "{:>18} {:9.5} {:9.5} {:9.5} {:9.5} {:+9.3} {:+9.3}",
            KINDS[k],
            a.coef[k] / n,
            a.hits[k] / n,
            a.row[k] / n,
            a.ray[k] / n,
            if k == 6 {
                0.0
            } else {
                100.0 * (a.ray[k] - a.row[k]) / ray_tot
            },
            100.0 * a.dev[k] / ray_tot
        );
    }
    let mut m: Vec<_> = a.missing.iter().collect();
    m.sort_by(|x, y| y.1.total_cmp(x.1));
    for (w, v) in m.iter().take(12) {
        eprintln!("   missing {:+.3}% at {w}", 100.0 * *v / ray_tot);
    }
}

#[test]
#[ignore = "scratch tracing of the Blender box's rows (issue 45 part 4)"]
fn trace_blender_rows_by_entry_kind() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender/cornell-box.glb");
    let scene = crate::scene::load(&path).unwrap();
    let opts = SolveOptions {
        eps: 0.5,
        ..SolveOptions::default()
    };
    let mut s = Solver::new(&scene, opts).unwrap();
    s.run(|_, _| {}).unwrap();
    let side: usize = std::env::var("TRACE_SIDE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(32);
    let per: usize = std::env::var("TRACE_ROWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24);
    // Walls: (name, normal, offset).
    let walls = [
        ("red wall x=-1.008", DVec3::X, -1.008),
        ("green wall x=0.9925", DVec3::NEG_X, -0.9925),
        ("back wall z=-0.8705", DVec3::Z, -0.8705),
        ("floor y=-0.8668", DVec3::Y, -0.8668),
        ("ceiling y=0.8625", DVec3::NEG_Y, -0.8625),
    ];
    for (name, nrm, off) in walls {
        let geoms = s.elems.geoms.as_slice();
        let cand: Vec<usize> = (0..s.sys.leaves.len())
            .filter(|&li| {
                let g = &geoms[s.sys.leaves[li].ix()];
                let gn = DVec3::from_array(g.normal);
                let c = DVec3::from_array(g.corners[0]);
                let e = s.patches.emissions[g.patch as usize];
                gn.dot(nrm) > 0.999
                    && (nrm.dot(c) - off).abs() < 2e-3
                    && e.iter().all(|&x| x <= 0.0)
                    && {
                        let k = g.n.clamp(3, 4) as usize;
                        let m = g.corners[..k]
                            .iter()
                            .map(|&c| DVec3::from_array(c))
                            .sum::<DVec3>()
                            / k as f64;
                        s.outside_solids(m, gn)
                            && !(off == -0.8625 && m.x.abs() < 0.51 && m.z.abs() < 0.51)
                    }
            })
            .collect();
        let pick: Vec<usize> = (0..per.min(cand.len()))
            .map(|i| {
                let r = oracle::unit(oracle::hash3(0xbeef, i as u64, 7));
                cand[((i as f64 + r) / per as f64 * cand.len() as f64) as usize % cand.len()]
            })
            .collect();
        let a = s.trace_rows(&pick, side);
        print(&format!("{name} ({} leaves)", cand.len()), &a);
        print_links(&s, &a);
        let mut top: Vec<_> = a.links.iter().collect();
        top.sort_by(|x, y| (y.1[3] - y.1[2]).abs().total_cmp(&(x.1[3] - x.1[2]).abs()));
        let m0 = s.opts.rays_per_point;
        let seed0 = s.opts.seed;
        let tot_un: f64 = a.links.values().map(|r| r[4]).sum();
        for m in [m0, 8, 16, 1024] {
            s.opts.rays_per_point = m;
            let seeds = if m >= 1024 { 1 } else { 16 };
            let (mut all, mut t4665) = (0.0, [0.0; 6]);
            for k in 0..seeds {
                s.opts.seed = seed0 ^ (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                let c = s.link_coefs(&pick);
                all += c.values().sum::<f64>() / tot_un / seeds as f64;
                for (i, (src, r)) in top.iter().take(6).enumerate() {
                    t4665[i] += c.get(src).copied().unwrap_or(0.0) / r[4].max(1e-30) / seeds as f64;
                }
            }
            eprintln!(
                "  mean over {seeds} seeds, {m} rays/point: all surface links {all:.4}; top {:.3?}",
                t4665
            );
        }
        s.opts.rays_per_point = m0;
        s.opts.seed = seed0;
        // Opened children: the link-level part and the distribution among children.
        let (mut lvl, mut dist) = (0.0, 0.0);
        for r in a.links.values() {
            if r[6] > 0.0 && r[0] > 0.0 {
                let bbar = r[2] / r[0];
                lvl += (r[1] - r[0]) * bbar;
                dist += (r[3] - r[2]) - (r[1] - r[0]) * bbar;
            }
        }
        let ray_tot: f64 = a.ray[..6].iter().sum::<f64>() + a.ray[7];
        eprintln!(
            "  opened sources' gap: link coefficients {:+.3}%, shares among children {:+.3}% of rays",
            100.0 * lvl / ray_tot,
            100.0 * dist / ray_tot
        );
        let hits: f64 = a.links.values().map(|r| r[1]).sum();
        let coef: f64 = a.links.values().map(|r| r[0]).sum();
        let un: f64 = a.links.values().map(|r| r[4]).sum();
        eprintln!(
            "  rows' vis (all surface links) {:.4}, rays' {:.4}",
            coef / un,
            hits / un
        );
    }
}
