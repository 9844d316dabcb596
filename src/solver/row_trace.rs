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

/// A patch's place: object name, normal axis, and whether its centroid lies on
/// the room's side of the walls (the room's box, 2 mm slack).
fn patch_class(s: &Solver, scene: &crate::scene::Scene, p: u32) -> String {
    let n = s.patches.normals[p as usize];
    let o = s.patches.objects[p as usize] as usize;
    let name = scene.objects.get(o).map_or("?", |o| o.name.as_str());
    let c = s.patches.polys[p as usize].centroid();
    let axis = if n.x.abs() > 0.99 {
        if n.x > 0.0 { "+x" } else { "-x" }
    } else if n.y.abs() > 0.99 {
        if n.y > 0.0 { "+y" } else { "-y" }
    } else if n.z.abs() > 0.99 {
        if n.z > 0.0 { "+z" } else { "-z" }
    } else {
        "oblique"
    };
    let room = c.x > -1.010 && c.x < 0.9945 && c.y > -0.8688 && c.y < 0.8645 && c.z > -0.8725;
    format!("{name} {axis} {}", if room { "room" } else { "OUT" })
}

#[test]
#[ignore = "scratch tracing of the Blender box's point 28 (issue 45 part 4)"]
fn trace_blender_point28() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender/cornell-box.glb");
    let scene = crate::scene::load(&path).unwrap();
    let opts = SolveOptions {
        eps: 0.5,
        ..SolveOptions::default()
    };
    let mut s = Solver::new(&scene, opts).unwrap();
    s.run(|_, _| {}).unwrap();
    // Objects and their boxes.
    let mut boxes: HashMap<u32, (DVec3, DVec3, usize)> = HashMap::new();
    for p in 0..s.patches.len() {
        let o = s.patches.objects[p];
        let e = boxes
            .entry(o)
            .or_insert((DVec3::splat(1e9), DVec3::splat(-1e9), 0));
        for &v in s.patches.polys[p].corners() {
            e.0 = e.0.min(v);
            e.1 = e.1.max(v);
        }
        e.2 += 1;
    }
    let mut bk: Vec<_> = boxes.into_iter().collect();
    bk.sort_by_key(|b| b.0);
    for (o, (lo, hi, k)) in bk {
        let m = &scene.objects[o as usize];
        eprintln!(
            "object {o} {:?}: {k} patches, box {lo:.4} .. {hi:.4}",
            m.name
        );
    }
    let mut pts: Vec<(DVec3, DVec3)> = vec![
        (DVec3::new(0.8, 0.8625, -0.8), DVec3::NEG_Y), // point 28
        (DVec3::new(0.9, 0.8625, -0.8), DVec3::NEG_Y),
        (DVec3::new(0.8, 0.8625, -0.6), DVec3::NEG_Y),
        (DVec3::new(0.6, 0.8625, -0.8), DVec3::NEG_Y),
        (DVec3::new(0.95, 0.8625, -0.85), DVec3::NEG_Y),
        (DVec3::new(0.8, 0.8625, 0.0), DVec3::NEG_Y), // point 24
        (DVec3::new(0.9925, 0.8, -0.8), DVec3::NEG_X),
        (DVec3::new(0.9925, 0.6, -0.6), DVec3::NEG_X),
        (DVec3::new(0.9925, 0.8, -0.4), DVec3::NEG_X),
        (DVec3::new(0.9925, 0.4, -0.8), DVec3::NEG_X),
        (DVec3::new(0.9925, 0.7, 0.8), DVec3::NEG_X), // point 14
        (DVec3::new(0.8, 0.8, -0.8705), DVec3::Z),
        (DVec3::new(0.6, 0.5, -0.8705), DVec3::Z),
    ];
    if let Some(k) = std::env::var("TRACE_POINTS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        pts.truncate(k);
    }
    let paths: u32 = std::env::var("TRACE_PATHS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4000);
    let reference = crate::reference::radiosity_at(&scene, &pts, paths, 13);
    let sol = s.solution();
    let probes: Vec<crate::playback::probe::ProbePoint> = pts
        .iter()
        .map(|&(p, n)| crate::playback::probe::ProbePoint { p, n })
        .collect();
    let pb = crate::playback::probe::probe(&sol, &probes, 0.0).unwrap();
    let limits = s.gather_limits(s.rms_radiosity(), true);
    let geoms = s.elems.geoms.as_slice();
    let nodes = s.elems.nodes.as_slice();
    let brad = s.elems.radiosities.as_slice();
    let mut root = vec![u32::MAX; s.patches.len()];
    for (e, (g, node)) in geoms.iter().zip(nodes).enumerate() {
        let top = node.parent == u32::MAX || geoms[node.parent as usize].patch == u32::MAX;
        if g.patch != u32::MAX && top {
            root[g.patch as usize] = e as u32;
        }
    }
    let diam = s.patches.diameter;
    for (i, &(x, n)) in pts.iter().enumerate() {
        let r = &reference[i];
        eprintln!(
            "\n#### point {i} {x:.4} n {n}: probe {:.4?} reference {:.4?} ±{:.4?}",
            pb[i], r.b, r.std_error
        );
        let cand: Vec<ElementId> = s
            .sys
            .leaves
            .iter()
            .copied()
            .filter(|l| {
                let g = &geoms[l.ix()];
                let gn = DVec3::from_array(g.normal);
                gn.dot(n) > 0.999
                    && (x - DVec3::from_array(g.corners[0])).dot(gn).abs() < 2e-3
                    && oracle::poly(g).contains(
                        gn,
                        x - (x - DVec3::from_array(g.corners[0])).dot(gn) * gn,
                        1e-6,
                    )
            })
            .collect();
        let Some(&leaf) = cand.first() else {
            eprintln!("  no leaf holds it");
            continue;
        };
        let g = &geoms[leaf.ix()];
        eprintln!(
            "  {} leaves hold it; leaf {} patch {} ({}) area {:.5} B_leaf {:.4?}",
            cand.len(),
            leaf.0,
            g.patch,
            patch_class(&s, &scene, g.patch),
            g.area,
            brad[leaf.ix()]
        );
        let xg = x - (x - DVec3::from_array(g.corners[0])).dot(n) * n;
        // The leaf's chain links and what its kept row says of each.
        let row = s.sys.row_cache.get(&leaf.0);
        eprintln!(
            "  small leaf: row kept {} (area {:.5} < power area {:.5}: {})",
            row.is_some(),
            g.area,
            s.power_area,
            g.area < s.power_area
        );
        for l in s.chain_links(leaf) {
            let src = s.links.ends.as_slice()[l as usize].source as usize;
            let tr = s.links.transports.as_slice()[l as usize];
            let gs = &geoms[src];
            let cls = if gs.patch == u32::MAX {
                "cluster".to_string()
            } else {
                patch_class(&s, &scene, gs.patch)
            };
            let lv = row.and_then(|r| s.leaf_visibility(r, l, src));
            let rv = row.and_then(|r| {
                r.binary_search_by_key(&l, |k| k.link)
                    .ok()
                    .map(|i| r[i].vis)
            });
            eprintln!(
                "    link {l} recv {} src {src} {cls:28} A {:.4} f {:.4} vis {:.3} clear {} row vis {rv:?} -> cheap {lv:?}",
                s.links.ends.as_slice()[l as usize].receiver,
                gs.area,
                tr.f,
                tr.visibility,
                tr.shaft_clear(),
            );
        }
        // The stored cells of the patch that hold the point.
        {
            let pc = s.patches.polys[g.patch as usize].corners();
            let mut vv = [DVec3::ZERO; 4];
            for (k, c) in pc.iter().take(4).enumerate() {
                vv[k] = *c;
            }
            let wp = crate::playback::frame::WorldPatch {
                corners: pc.len().min(4) as u32,
                material: 0,
                v: vv,
                normal: s.patches.normals[g.patch as usize],
            };
            let (u, v) = crate::playback::probe::patch_params(&wp, xg);
            for c in sol.leaves.iter().filter(|c| c.patch == g.patch) {
                let (mut u0, mut u1, mut v0, mut v1) = (9.0f32, -9.0f32, 9.0f32, -9.0f32);
                for k in 0..c.corners as usize {
                    u0 = u0.min(c.uv[k][0]);
                    u1 = u1.max(c.uv[k][0]);
                    v0 = v0.min(c.uv[k][1]);
                    v1 = v1.max(c.uv[k][1]);
                }
                if (u as f32) >= u0 && (u as f32) <= u1 && (v as f32) >= v0 && (v as f32) <= v1 {
                    eprintln!(
                        "    stored cell uv {:?} b {:?} (point uv {u:.4},{v:.4})",
                        c.uv, c.b
                    );
                }
            }
        }
        // The green wall's room-side sources of the leaf's chain, one by one.
        for l in s.chain_links(leaf) {
            let src = s.links.ends.as_slice()[l as usize].source as usize;
            let gs = &geoms[src];
            if gs.patch == u32::MAX
                || !patch_class(&s, &scene, gs.patch).starts_with("GreenWall -x room")
            {
                continue;
            }
            let ps = oracle::poly(gs);
            {
                let r = oracle::PointRays {
                    x: xg,
                    n,
                    gs,
                    pols: &ps,
                    ns: DVec3::from_array(gs.normal),
                    m: s.opts.corner_rays,
                    key: 12345,
                    skip: [g.patch, gs.patch],
                };
                let v = oracle::visible_fraction(&s.bvh, &r);
                eprintln!("    rays to {src}: {} rays, visible {v:.3}", r.m);
                for j in 0..r.m.min(8) {
                    let h = oracle::hash3(12345, j as u64, 0x9e37);
                    let side = (r.m as f64).sqrt().ceil() as u32;
                    let su =
                        ((j % side) as f64 + (h & 0xffff_ffff) as f64 / 4294967296.0) / side as f64;
                    let sv = ((j / side) as f64 + (h >> 32) as f64 / 4294967296.0) / side as f64;
                    let y = oracle::point_in(gs, &ps, su, sv.min(1.0));
                    let hit = s.bvh.intersect(xg, y - xg, 1e-10, 1.0 - 1e-9);
                    let hit2 = s.bvh.intersect(xg, y - xg, 1e-3, 1.0 - 1e-9);
                    let occ = s.bvh.occluded_between(
                        xg,
                        y,
                        [g.patch, gs.patch],
                        crate::geometry::Parts::All,
                        &mut Default::default(),
                    );
                    eprintln!(
                        "      occluded_between {occ}; hit from 1e-3: {:?}",
                        hit2.map(|h| (h.patch, patch_class(&s, &scene, h.patch), h.t))
                    );
                    eprintln!(
                        "      ray {j} to {y:.4}: hit {:?}",
                        hit.map(|h| (h.patch, patch_class(&s, &scene, h.patch), h.t))
                    );
                }
            }
            let mut t = gather::Terms::default();
            s.point_terms(xg, n, g.patch, src, true, false, 0, None, &limits, &mut t);
            let node = nodes[src];
            eprintln!(
                "    green src {src}: corners {:.4?} children {} F(x) {:.5} exact {:.5}; point_terms fixed {} Σf {:.5}",
                ps.corners(),
                node.child_count,
                point_to_polygon(xg, n, &ps),
                crate::geometry::point_to_polygon_exact(xg, n, &ps),
                t.fixed.len(),
                t.fixed.iter().map(|x| x.1).sum::<f64>()
            );
        }
        for (dx, dz) in [
            (0.0, 0.0),
            (0.01, 0.0),
            (-0.01, 0.0),
            (0.0, 0.01),
            (0.0, -0.01),
            (0.003, 0.007),
        ] {
            let off = if n.y.abs() > 0.5 {
                DVec3::new(dx, 0.0, dz)
            } else if n.x.abs() > 0.5 {
                DVec3::new(0.0, dx, dz)
            } else {
                DVec3::new(dx, dz, 0.0)
            };
            let (bo, vo, _) = s.gather_point(
                leaf,
                xg + off,
                None,
                ((g.patch, 999, 1 + i as u32), ANY_LEAF),
                false,
                &limits,
            );
            eprintln!("    gather at x+{off:.3}: {bo:.4?} valid {vo}");
        }
        gather::TRACE_TERMS.with(|t| *t.borrow_mut() = Some(Vec::new()));
        let (bx, valid, _) = s.gather_point(
            leaf,
            xg,
            None,
            ((g.patch, 4242, 77 + i as u32), ANY_LEAF),
            false,
            &limits,
        );
        let terms = gather::TRACE_TERMS
            .with(|t| t.borrow_mut().take())
            .unwrap_or_default();
        let near = gather::TRACE_NEAR.with(|t| t.borrow_mut().take());
        eprintln!("  gather at x: {bx:.4?} valid {valid}; far H and near {near:.4?}");
        // By class.
        let mut by: HashMap<String, ([f64; 3], f64, usize)> = HashMap::new();
        let mut rows: Vec<(u32, u32, f64, [f64; 3], String)> = Vec::new();
        for &(src, e, f) in &terms {
            let (b, cls) = if e & FACET_BIT != 0 {
                let fi = e & !FACET_BIT;
                (s.facet_b[fi as usize].map(f64::from), "facet".to_string())
            } else {
                let ge = &geoms[e as usize];
                let b = brad[e as usize].map(f64::from);
                if ge.patch == u32::MAX {
                    (b, "cluster".to_string())
                } else {
                    (b, patch_class(&s, &scene, ge.patch))
                }
            };
            let a = by.entry(cls.clone()).or_default();
            for k in 0..3 {
                a.0[k] += f * b[k];
            }
            a.1 += f;
            a.2 += 1;
            rows.push((src, e, f, b, cls));
        }
        let mut byv: Vec<_> = by.into_iter().collect();
        byv.sort_by(|a, b| (b.1).0[1].total_cmp(&(a.1).0[1]));
        eprintln!("  final gather by source class: Σf·B (rgb), Σf, terms");
        for (c, (h, f, k)) in &byv {
            eprintln!("    {c:40} {h:.4?} f {f:.4} ({k})");
        }
        rows.sort_by(|a, b| (b.2 * b.3[1]).total_cmp(&(a.2 * a.3[1])));
        for (src, e, f, b, cls) in rows.iter().take(12) {
            let ge = if e & FACET_BIT != 0 {
                None
            } else {
                Some(&geoms[*e as usize])
            };
            let c = ge
                .map(|ge| oracle::poly(ge).centroid())
                .unwrap_or(DVec3::NAN);
            eprintln!(
                "     link {src:6} elem {e:6} {cls:32} c {c:.3} A {:.4} f {f:.5} B {b:.3?} fB_g {:.4}",
                ge.map_or(0.0, |g| g.area),
                f * b[1]
            );
        }
        // Cosine rays over the leaf field.
        let side = 256usize;
        let mut rb: HashMap<String, ([f64; 3], f64)> = HashMap::new();
        let mut tot = [0.0; 3];
        let w = 1.0 / (side * side) as f64;
        for j in 0..side * side {
            let h = |k: u64| oracle::unit(oracle::hash3(0x28 ^ i as u64, j as u64, k));
            let u1 = ((j % side) as f64 + h(0)) / side as f64;
            let u2 = ((j / side) as f64 + h(1)) / side as f64;
            let dir = cosine_direction(n, u1, u2);
            let hit = s.bvh.intersect_front_first(xg, dir * diam * 2.0, 1e-6, 1.0);
            let Some(hit) = hit else {
                rb.entry("miss".into()).or_default().1 += w;
                continue;
            };
            let back = s.patches.normals[hit.patch as usize].dot(dir) >= 0.0;
            let cls = format!(
                "{}{}",
                patch_class(&s, &scene, hit.patch),
                if back { " BACKFACE" } else { "" }
            );
            let top = root[hit.patch as usize];
            let b = if back || top == u32::MAX {
                [0.0; 3]
            } else {
                let y = xg + dir * diam * 2.0 * hit.t;
                brad[s.leaf_at(ElementId(top), y).ix()].map(f64::from)
            };
            let a = rb.entry(cls).or_default();
            for k in 0..3 {
                a.0[k] += w * b[k];
                tot[k] += w * b[k];
            }
            a.1 += w;
        }
        let rho = s.patches.rhos[g.patch as usize];
        eprintln!(
            "  cosine rays over the leaf field: H {tot:.4?} -> B {:.4?}",
            [rho[0] * tot[0], rho[1] * tot[1], rho[2] * tot[2]]
        );
        let mut rv: Vec<_> = rb.into_iter().collect();
        rv.sort_by(|a, b| (b.1).0[1].total_cmp(&(a.1).0[1]));
        for (c, (h, f)) in &rv {
            eprintln!("    {c:40} {h:.4?} frac {f:.4}");
        }
    }
}

#[test]
#[ignore = "scratch: rays out of the crevice behind the green slab"]
fn scratch_crevice_rays() {
    use crate::geometry::{LastHit, Parts};
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender/cornell-box.glb");
    let scene = crate::scene::load(&path).unwrap();
    let solver = Solver::new(&scene, SolveOptions::default()).unwrap();
    let patches = &solver.patches;
    let bvh = &solver.bvh;
    eprintln!("diameter {}", patches.diameter);
    for p in [79usize, 2314, 21] {
        let c = patches.polys[p].corners();
        eprintln!("patch {p} object {} normal {:.4} corners {c:?}", patches.objects[p], patches.polys[p].normal());
    }
    let tw = crate::geometry::twin_patches(patches);
    eprintln!("twins 79 {} 2314 {} 21 {}", tw[79], tw[2314], tw[21]);
    let z = patches.polys[2314].corners()[0].z;
    for (a, b) in [
        (DVec3::new(1.0, 0.95, z), DVec3::new(0.96, 0.8625, -0.84)),
        (DVec3::new(1.0, 0.95, z), DVec3::new(0.5, 0.8625, -0.5)),
        (DVec3::new(1.0, 0.5, z), DVec3::new(0.5, 0.8625, -0.5)),
        (DVec3::new(1.05, 0.5, z), DVec3::new(0.0, -0.8668, 0.0)),
    ] {
        let occ = bvh.occluded_between(a, b, [2314, 21], Parts::All, &mut LastHit::default());
        let occ2 = bvh.occluded_by(a, b, [2314, 21], Parts::All);
        let hit = bvh.intersect(a, b - a, 1e-9, 1.0).map(|h| (h.patch, h.t));
        eprintln!("{a:.5} -> {b:.4}: occluded_between {occ}, occluded_by {occ2}, hit {hit:?}");
    }
}
