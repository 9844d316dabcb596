//! The persisted hierarchy (issue 49: `rhier interact --from` starts "from a stored
//! solution solved with `--keep-links` (the persisted hierarchy: no solve at
//! start-up)").
//!
//! [`Solver::hierarchy`] hands out the element and link pools as a solve left them,
//! with the radiosities and directions its last leaf rows were built at (the rows'
//! cluster parts aim their rays by the radiosity, and the last solve started from
//! it: [`Solver::keep_restore_point`] keeps them each round). [`Solver::from_hierarchy`]
//! builds the solver of the same scene (patches, BVH, clusters and patch roots, as
//! [`Solver::new`] makes them, deterministically), checks the stored pools as
//! untrusted input against it, installs them with the leaf rows of the last
//! round (kept too, so no ray is cast: building them again was half the solve's
//! time on the interactive bench room) and solves the leaf system once from where
//! the last round started: no refinement, no link evaluated again. Given the
//! pools of a solve at the same settings, the radiosity is the solve's, bit for
//! bit (GMRES adds in a fixed order). A hierarchy without rows has them built
//! again from the stored radiosities, the same rows as the solve's last round.

use std::path::Path;

use glam::DVec3;

use super::{CLOSURE_SAMPLES, FastMap, SolveOptions, Solver};
use crate::pools::elements::{ElementKind, Emission};
use crate::pools::{ElementId, ElementPool, LinkPool};
use crate::scene::Scene;
use crate::store::Hierarchy;
use crate::{Error, Result};

/// The radiosities and directions of the element pool when the leaf rows of the
/// last round were built ([`Solver::keep_restore_point`]).
#[derive(Default)]
pub(super) struct RestorePoint {
    radiosities: Vec<[f32; 3]>,
    directions: Vec<Emission>,
}

/// The solve settings as [`Hierarchy::options`] keeps them: `opts` as JSON
/// without its storage (where the pools live does not change them) and without
/// `keep_passive` and `sealed_regions` (a session sets them whatever it was given).
pub fn options_text(opts: &SolveOptions) -> String {
    let mut v = serde_json::to_value(opts).unwrap_or(serde_json::Value::Null);
    if let Some(m) = v.as_object_mut() {
        m.remove("storage");
        m.remove("keep_passive");
        m.remove("sealed_regions");
    }
    v.to_string()
}

/// The settings of `stored` (an [`options_text`]) that differ from `opts`, as
/// `name: stored here, given there` items; `None` when they agree.
pub fn options_differ(stored: &str, opts: &SolveOptions) -> Option<String> {
    let ours: serde_json::Value =
        serde_json::from_str(&options_text(opts)).unwrap_or(serde_json::Value::Null);
    let theirs: serde_json::Value = serde_json::from_str(stored).unwrap_or(serde_json::Value::Null);
    if ours == theirs {
        return None;
    }
    let (Some(a), Some(b)) = (theirs.as_object(), ours.as_object()) else {
        return Some(format!("stored {stored}"));
    };
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    let items: Vec<String> = keys
        .into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            let show = |v: Option<&serde_json::Value>| v.map_or("none".into(), |v| v.to_string());
            format!(
                "{k}: {} in the file, {} here",
                show(a.get(k)),
                show(b.get(k))
            )
        })
        .collect();
    Some(items.join("; "))
}

impl<'a> Solver<'a> {
    /// Makes [`Solver::run`] keep, each round, the radiosities and directions
    /// the leaf rows are built at, for [`Solver::hierarchy`] (two copies of two
    /// element columns a round, 48 bytes an element).
    pub fn keep_restore_point(&mut self) {
        self.restore_point = Some(RestorePoint::default());
    }

    /// Called by [`Solver::run`] before each round's leaf rows.
    pub(super) fn mark_restore_point(&mut self) {
        if let Some(r) = &mut self.restore_point {
            r.radiosities = self.elems.radiosities.as_slice().to_vec();
            r.directions = self.elems.directions.as_slice().to_vec();
        }
    }

    /// The pools as the last round left them, for the hierarchy section; `None`
    /// unless [`Solver::keep_restore_point`] was called before a run that solved.
    /// `movable`: the names of the objects the session may move.
    pub fn hierarchy(&self, movable: Vec<String>) -> Option<Hierarchy> {
        let r = self.restore_point.as_ref()?;
        if r.radiosities.len() != self.elems.len() {
            return None;
        }
        Some(Hierarchy {
            movable,
            options: options_text(&self.opts),
            nodes: self.elems.nodes.as_slice().to_vec(),
            geoms: self.elems.geoms.as_slice().to_vec(),
            times: self.elems.times.as_slice().to_vec(),
            radiosities: r.radiosities.clone(),
            directions: r.directions.clone(),
            ends: self.links.ends.as_slice().to_vec(),
            transports: self.links.transports.as_slice().to_vec(),
            row_start: self.sys.row_start.clone(),
            row_sources: self.sys.row_sources.clone(),
            row_coefs: self.sys.row_coefs.clone(),
            row_links: self.row_links(),
        })
    }

    /// The leaf rows' entries by chain link as [`Hierarchy::row_links`] keeps
    /// them (each a range of its row); empty when a cache entry is not one.
    fn row_links(&self) -> Vec<[u32; 4]> {
        let mut leaves: Vec<&u32> = self.sys.move_cluster_cache.keys().collect();
        leaves.sort_unstable();
        let mut out = Vec::new();
        for &leaf in leaves {
            let li = self.sys.leaf_index.get(leaf as usize).copied();
            let Some(li) = li.filter(|&x| (x as usize) + 1 < self.sys.row_start.len()) else {
                return Vec::new();
            };
            let (r0, r1) = (
                self.sys.row_start[li as usize] as usize,
                self.sys.row_start[li as usize + 1] as usize,
            );
            // Where each (source, coefficient) starts in the row, so a link's range
            // is found by its first entry, not by a scan of the row per link.
            let mut starts: FastMap<(u32, u64), Vec<usize>> = FastMap::default();
            for k in r0..r1 {
                let key = (self.sys.row_sources[k], self.sys.row_coefs[k].to_bits());
                starts.entry(key).or_default().push(k);
            }
            for (link, entries) in &self.sys.move_cluster_cache[&leaf] {
                // The entries are a copy of the row's from where the link's began
                // (rows.rs, `leaf_row`).
                let fits = |k: usize| {
                    k + entries.len() <= r1
                        && entries.iter().enumerate().all(|(j, e)| {
                            self.sys.row_sources[k + j] == e.0
                                && self.sys.row_coefs[k + j].to_bits() == e.1.to_bits()
                        })
                };
                let found = match entries.first() {
                    None => Some(r0),
                    Some(e0) => starts
                        .get(&(e0.0, e0.1.to_bits()))
                        .and_then(|ks| ks.iter().copied().find(|&k| fits(k))),
                };
                let Some(k) = found else {
                    return Vec::new();
                };
                out.push([leaf, *link, (k - r0) as u32, entries.len() as u32]);
            }
        }
        out
    }

    /// The solver of `scene` (as [`Solver::new`] builds it) with the stored pools
    /// of `h` in place of a solve (module docs): the leaf rows built and the leaf
    /// system solved once. `h` is untrusted: it must hold the scene's clusters and
    /// patch roots as [`Solver::new`] makes them, below them only surface elements
    /// of the same patch in the plane of their parent, child ranges consistent with
    /// their parents, finite values, and links between existing elements; else the
    /// error names `file`, the hierarchy section, the element or link, what was
    /// expected and what was found. The settings must be those `h` was solved at
    /// ([`options_differ`] is the caller's check; this one makes no assumption).
    pub fn from_hierarchy(
        scene: &'a Scene,
        opts: SolveOptions,
        h: &Hierarchy,
        file: &Path,
    ) -> Result<Self> {
        let mut s = Solver::new(scene, opts)?;
        check(&s, h, file)?;
        let mut elems = ElementPool::new(&s.opts.storage)?;
        for i in 0..h.nodes.len() {
            elems.push(h.nodes[i], h.geoms[i], h.times[i])?;
        }
        elems
            .radiosities
            .as_mut_slice()
            .copy_from_slice(&h.radiosities);
        elems
            .directions
            .as_mut_slice()
            .copy_from_slice(&h.directions);
        let mut links = LinkPool::new(&s.opts.storage)?;
        for (e, t) in h.ends.iter().zip(&h.transports) {
            links.push(ElementId(e.receiver), ElementId(e.source), *t)?;
        }
        // The pools' own invariants (children's parents, areas summing to the
        // parent's, finite coefficients), named as the file's.
        let in_file = |e: Error| match e {
            Error::Invalid {
                place,
                expected,
                found,
                ..
            } => Error::invalid(file, format!("hierarchy section, {place}"), expected, found),
            other => other,
        };
        elems.validate().map_err(in_file)?;
        links.validate(elems.len()).map_err(in_file)?;
        s.elems = elems;
        s.links = links;
        let around = s.error_samples(CLOSURE_SAMPLES);
        s.closed = (!around.is_empty()).then(|| s.closed_around(&around));
        s.drop_passive_links();
        s.index_links();
        let residual = if h.row_start.is_empty() {
            s.solve_rows()?
        } else {
            s.install_rows(h, file)?;
            if !s.st.balance_fixed {
                s.sys.balancing = false;
            }
            s.solve_balanced()?
        };
        s.check_sound(residual)?;
        Ok(s)
    }
}

impl Solver<'_> {
    /// Installs the stored leaf rows of `h` (checked: one row per leaf, starts
    /// rising to the entry count, sources existing elements (or facets), finite
    /// coefficients, chain-link ranges inside their row and naming existing links).
    fn install_rows(&mut self, h: &Hierarchy, file: &Path) -> Result<()> {
        let bad =
            |place: String, expected: String, found: String| invalid(file, place, expected, found);
        let nl = self.sys.leaves.len();
        let ne = h.row_sources.len();
        if h.row_start.len() != nl + 1 || h.row_coefs.len() != ne {
            return bad(
                "leaf rows".into(),
                format!(
                    "{} row starts (one per leaf and one more) and one coefficient per entry",
                    nl + 1
                ),
                format!(
                    "{} row starts, {ne} sources, {} coefficients",
                    h.row_start.len(),
                    h.row_coefs.len()
                ),
            );
        }
        let rising = h.row_start[0] == 0
            && h.row_start.windows(2).all(|w| w[0] <= w[1])
            && h.row_start[nl] as usize == ne;
        if !rising {
            return bad(
                "leaf rows".into(),
                format!("row starts rising from 0 to {ne}"),
                "starts out of order or out of range".into(),
            );
        }
        let (n, facets) = (self.elems.len(), self.facets.count());
        let fb = super::facets::FACET_BIT;
        for (k, (&src, c)) in h.row_sources.iter().zip(&h.row_coefs).enumerate() {
            let ok = if src & fb != 0 {
                ((src & !fb) as usize) < facets
            } else {
                (src as usize) < n
            };
            if !ok || !c.is_finite() {
                return bad(
                    format!("leaf row entry {k}"),
                    format!("a source below {n} and a finite coefficient"),
                    format!("source {src}, coefficient {c}"),
                );
            }
        }
        let nlinks = self.links.len();
        let mut cache: super::FastMap<u32, Vec<(u32, super::rows::RowEntries)>> =
            super::FastMap::default();
        let mut last = None;
        for (k, &[leaf, link, first, count]) in h.row_links.iter().enumerate() {
            let li = self.sys.leaf_index.get(leaf as usize).copied();
            let range = li.filter(|&x| x != u32::MAX).and_then(|li| {
                let (r0, r1) = (
                    h.row_start[li as usize] as u64,
                    h.row_start[li as usize + 1] as u64,
                );
                let (a, b) = (r0 + first as u64, r0 + first as u64 + count as u64);
                (b <= r1).then_some(a as usize..b as usize)
            });
            let sorted = last.is_none_or(|p| p < (leaf, link));
            let Some(range) = range.filter(|_| sorted && (link as usize) < nlinks) else {
                return bad(
                    format!("leaf row link {k}"),
                    format!("a leaf, a link below {nlinks} and a range of its row, sorted"),
                    format!("leaf {leaf}, link {link}, entries {first} + {count}"),
                );
            };
            last = Some((leaf, link));
            let entries: super::rows::RowEntries = h.row_sources[range.clone()]
                .iter()
                .copied()
                .zip(h.row_coefs[range].iter().copied())
                .collect();
            cache.entry(leaf).or_default().push((link, entries));
        }
        self.sys.row_start = h.row_start.clone();
        self.sys.row_sources = h.row_sources.clone();
        self.sys.row_coefs = h.row_coefs.clone();
        self.sys.move_cluster_cache = cache;
        Ok(())
    }
}

/// The checks of [`Solver::from_hierarchy`] that the pools' own `validate` does not make.
fn check(s: &Solver, h: &Hierarchy, file: &Path) -> Result<()> {
    let bad =
        |place: String, expected: String, found: String| invalid(file, place, expected, found);
    let n = h.nodes.len();
    let cols = [
        ("geoms", h.geoms.len()),
        ("times", h.times.len()),
        ("radiosities", h.radiosities.len()),
        ("directions", h.directions.len()),
    ];
    for (name, len) in cols {
        if len != n {
            return bad(
                format!("column {name}"),
                format!("{n} records"),
                len.to_string(),
            );
        }
    }
    if h.transports.len() != h.ends.len() {
        return bad(
            "column transports".into(),
            format!("{} records (one per link)", h.ends.len()),
            h.transports.len().to_string(),
        );
    }
    if n >= u32::MAX as usize || h.ends.len() >= u32::MAX as usize {
        return bad(
            "columns".into(),
            "fewer than 2^32 - 1 elements and links".into(),
            format!("{n} elements, {} links", h.ends.len()),
        );
    }
    // The scene's clusters and patch roots, as `Solver::new` made them.
    let n0 = s.elems.len();
    if n < n0 {
        return bad(
            "elements".into(),
            format!("at least the {n0} clusters and patch roots the scene makes"),
            n.to_string(),
        );
    }
    let fresh_nodes = s.elems.nodes.as_slice();
    let fresh_geoms = s.elems.geoms.as_slice();
    for i in 0..n0 {
        let (a, b) = (&h.nodes[i], &fresh_nodes[i]);
        let same_children = b.child_count == 0
            || (a.first_child == b.first_child && a.child_count == b.child_count);
        let same = a.parent == b.parent
            && a.kind == b.kind
            && a.depth == b.depth
            && same_children
            && bytemuck::bytes_of(&h.geoms[i]) == bytemuck::bytes_of(&fresh_geoms[i]);
        if !same {
            return bad(
                format!("element {i}"),
                "the cluster or patch root this scene makes there (a file solved from \
                 this scene, with the same --movable objects and --two-sided)"
                    .into(),
                format!(
                    "another element (parent {}, {} children, patch {}, area {})",
                    a.parent, a.child_count, h.geoms[i].patch, h.geoms[i].area
                ),
            );
        }
    }
    let patches = s.patches.len() as u32;
    let time = s.time;
    let tol = 1e-6 * s.patches.diameter.max(f64::MIN_POSITIVE);
    let finite3 = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
    for i in 0..n {
        let (node, g) = (&h.nodes[i], &h.geoms[i]);
        if node.kind > ElementKind::Surface as u8 {
            return bad(
                format!("element {i}"),
                "kind 0 (cluster) or 1 (surface)".into(),
                node.kind.to_string(),
            );
        }
        if node.child_count > 0 {
            let end = node.first_child as u64 + node.child_count as u64;
            let surface = node.kind == ElementKind::Surface as u8;
            if (node.first_child as usize) <= i
                || end > n as u64
                || (surface && node.child_count > 4)
            {
                return bad(
                    format!("element {i}"),
                    format!("children after it, below {n}, at most 4 for a surface"),
                    format!("{}..{end}", node.first_child),
                );
            }
        }
        if h.times[i] != time {
            return bad(
                format!("element {i}"),
                format!("time range {time:?}"),
                format!("{:?}", h.times[i]),
            );
        }
        let b_ok = h.radiosities[i].iter().all(|b| b.is_finite() && *b >= 0.0);
        let d = &h.directions[i];
        let d_ok = d.normal.iter().chain(&d.axes).all(|x| x.is_finite());
        if !b_ok || !d_ok {
            return bad(
                format!("element {i}"),
                "finite radiosity >= 0 and finite directions".into(),
                format!("{:?}, {:?}", h.radiosities[i], d),
            );
        }
        if i < n0 {
            continue;
        }
        // Below the scene's: a surface element subdivided from its parent.
        let p = node.parent as usize;
        let parent_ok = p < i && {
            let pn = &h.nodes[p];
            pn.kind == ElementKind::Surface as u8
                && (pn.first_child as usize..pn.first_child as usize + pn.child_count as usize)
                    .contains(&i)
                && node.depth == pn.depth.wrapping_add(1)
        };
        if node.kind != ElementKind::Surface as u8 || !parent_ok {
            return bad(
                format!("element {i}"),
                "a surface element among its parent's children, one level below it".into(),
                format!(
                    "kind {}, parent {}, depth {}",
                    node.kind, node.parent, node.depth
                ),
            );
        }
        let pg = &h.geoms[p];
        let k = g.n as usize;
        let geometry_ok = g.patch < patches
            && g.patch == pg.patch
            && (3..=4).contains(&k)
            && g.corners.iter().all(finite3)
            && finite3(&g.normal)
            && g.uv.iter().flatten().all(|x| x.is_finite())
            && g.area.is_finite()
            && g.area > 0.0
            && g.area <= pg.area;
        let on_plane = geometry_ok && {
            let o = DVec3::from_array(pg.corners[0]);
            let nrm = DVec3::from_array(pg.normal);
            g.corners[..k]
                .iter()
                .all(|c| (DVec3::from_array(*c) - o).dot(nrm).abs() <= tol)
        };
        if !on_plane {
            return bad(
                format!("element {i}"),
                format!(
                    "{} or 4 finite corners in the plane of parent {p}, its patch {}, an area in (0, {}]",
                    3, pg.patch, pg.area
                ),
                format!("{} corners, patch {}, area {}", g.n, g.patch, g.area),
            );
        }
    }
    for (i, (e, t)) in h.ends.iter().zip(&h.transports).enumerate() {
        let flags_ok = t.flags[0] <= 1;
        if e.receiver as usize >= n || e.source as usize >= n {
            return bad(
                format!("link {i}"),
                format!("ends below {n}"),
                format!("{} -> {}", e.source, e.receiver),
            );
        }
        if !flags_ok || !t.visibility.is_finite() {
            return bad(
                format!("link {i}"),
                "state 0 (active) or 1 (passive) and a finite visibility".into(),
                format!("flags {:?}, visibility {}", t.flags, t.visibility),
            );
        }
    }
    Ok(())
}

/// The error for a bad `place` of the hierarchy section of `file`.
fn invalid<T>(file: &Path, place: String, expected: String, found: String) -> Result<T> {
    Err(Error::invalid(
        file,
        format!("hierarchy section, {place}"),
        expected,
        found,
    ))
}
