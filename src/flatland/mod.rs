//! Flatland: exact 2D radiosity with the visibility complex, and updates when a
//! polygon moves — Orti, Rivière, Durand & Puech, "Radiosity for dynamic scenes in
//! flatland with the visibility complex", Eurographics 1996.
//!
//! Pipeline (one time `t`):
//!
//! ```text
//! scene::load ─▶ FlatScene::posed(t) ─▶ mesh::splits (none | uniform:N | discontinuity, §3.2)
//!   ─▶ geometry::FlatGeometry (elements, points) ─▶ views (rotational sweep per point)
//!   ─▶ radiosity::form_factors (string rule, eq. 2–3) ─▶ radiosity::solve_radiosity
//! (complex::sweep: the dual-plane sweep building faces with chains, §2.3)
//! ```
//!
//! Moving objects: [`dynamic::Dynamic`] applies the visibility events of the motion
//! ([`events`], §5.2) in time order from a priority queue, updating locally the two
//! views each event changes, and re-evaluates only the terms of the points related to
//! the moving object (§5.1); every other form factor is kept. ([`window`] measures the
//! lines meeting a convex region, an earlier form of the update kept as a tool.)
//! Pictures: [`svg`]. The crate's 3D solver does not depend on this module; it is our
//! exact reference for the ideas it borrows (string rule, exact visibility events).
//!
//! Everything is `f64`. What this module does not do: curved objects, participating
//! media, non-diffuse reflection, or the paper's optimal output-sensitive construction
//! (the views cost `O(P^2 log P)`, see [`views`]; the faces with chains
//! `O(P^2 (log P + n))`, see [`complex`]).

pub mod complex;
pub mod dynamic;
pub mod events;
pub mod geometry;
pub mod mesh;
pub mod radiosity;
pub mod scene;
pub mod svg;
pub mod views;
pub mod window;

use geometry::FlatGeometry;
use radiosity::FormFactors;
use scene::FlatScene;

/// A solved flatland scene at one time.
#[derive(Clone, Debug)]
pub struct FlatSolution {
    /// The time.
    pub t: f64,
    /// The posed, meshed geometry.
    pub geom: FlatGeometry,
    /// Radiosity per element.
    pub element_b: Vec<[f64; 3]>,
    /// Length-weighted average radiosity per input segment.
    pub segment_b: Vec<[f64; 3]>,
    /// Non-zero form factors (ordered pairs).
    pub ff_nonzeros: usize,
}

/// Reflectance and emission per element of `geom` (from their segments).
pub fn element_materials(scene: &FlatScene, geom: &FlatGeometry) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let segs: Vec<&scene::FlatSegment> = scene.segments().map(|(_, s)| s).collect();
    let rho = geom
        .elements
        .iter()
        .map(|e| segs[e.segment as usize].rho)
        .collect();
    let em = geom
        .elements
        .iter()
        .map(|e| segs[e.segment as usize].emission)
        .collect();
    (rho, em)
}

/// The posed, meshed geometry of `scene` at `t`.
pub fn geometry_at(scene: &FlatScene, t: f64, mesh: mesh::Mesh) -> FlatGeometry {
    let posed = scene.posed(t);
    let sp = mesh::splits(&posed, &dynamic::emitters(scene), mesh);
    FlatGeometry::new(posed, &sp)
}

/// Solves the radiosity of `geom` with form factors `ff`.
pub fn solve_with(scene: &FlatScene, t: f64, geom: FlatGeometry, ff: &FormFactors) -> FlatSolution {
    let (rho, em) = element_materials(scene, &geom);
    let element_b = radiosity::solve_radiosity(ff, &rho, &em);
    let mut segment_b = vec![[0.0; 3]; geom.segments.len()];
    for (e, b) in geom.elements.iter().zip(&element_b) {
        let s = &mut segment_b[e.segment as usize];
        for c in 0..3 {
            s[c] += b[c] * e.len;
        }
    }
    for (s, seg) in segment_b.iter_mut().zip(&geom.segments) {
        for x in s.iter_mut() {
            *x /= seg.len;
        }
    }
    FlatSolution {
        t,
        geom,
        element_b,
        segment_b,
        ff_nonzeros: ff.nonzeros(),
    }
}

/// Solves `scene` at time `t` from scratch with `mesh`.
pub fn solve(scene: &FlatScene, t: f64, mesh: mesh::Mesh) -> FlatSolution {
    let geom = geometry_at(scene, t, mesh);
    let (ff, _) = radiosity::form_factors(&geom);
    solve_with(scene, t, geom, &ff)
}
