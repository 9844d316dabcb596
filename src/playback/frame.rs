//! The frame at time `t`: world-space patches and the leaves live at `t`, grouped per
//! patch (a CSR layout: `first_leaf[p]..first_leaf[p+1]` indexes `leaves`).
//!
//! World corners are the object's `to_world(t)` applied to the patch's object-space
//! corners; since the map is affine, the bilinear (quad) or affine (triangle)
//! parameterisation commutes with it, so [`WorldPatch::point`] is exact.

use std::sync::Arc;

use glam::DVec3;

use super::SolutionView;
use crate::error::Result;
use crate::solution::Leaf;
use crate::store::{Live, Stretch};

/// A patch in world space at the frame's time. 128 bytes (4 + 4 + 4 × 24 + 24).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldPatch {
    /// 3 or 4.
    pub corners: u32,
    /// Material index (smooth shading does not average across materials).
    pub material: u32,
    /// World corners (the 4th unused for triangles).
    pub v: [DVec3; 4],
    /// Unit normal (right-hand rule on the corners; zero for a degenerate patch).
    pub normal: DVec3,
}

const _: () = assert!(std::mem::size_of::<WorldPatch>() == 128);

impl WorldPatch {
    /// World point at parameter `(u, v)`.
    pub fn point(&self, u: f64, v: f64) -> DVec3 {
        crate::solution::param_point(&self.v, self.corners, u, v)
    }

    /// Corners in use.
    pub fn corners(&self) -> &[DVec3] {
        &self.v[..self.corners as usize]
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let c = self.corners();
        let lo = c.iter().fold(DVec3::splat(f64::INFINITY), |a, &b| a.min(b));
        let hi = c
            .iter()
            .fold(DVec3::splat(f64::NEG_INFINITY), |a, &b| a.max(b));
        (lo, hi)
    }
}

/// World patches and live leaves at one time.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The frame's time.
    pub t: f64,
    /// Patches in world space, indexed like the view's patches.
    pub patches: Vec<WorldPatch>,
    /// Leaves live at `t`, in canonical order (by patch first), shared with the
    /// view's other frames of the same stretch.
    pub leaves: Arc<[Leaf]>,
    /// The stretch of time over which these leaves are the live ones.
    pub stretch: Stretch,
    /// `first_leaf[p]..first_leaf[p + 1]` are patch `p`'s leaves (length patches + 1).
    pub first_leaf: Vec<u32>,
}

impl Frame {
    /// Builds the frame of `view` at `t`.
    pub fn build(view: &impl SolutionView, t: f64) -> Result<Frame> {
        // In canonical order (patch, start time, first corner) whatever the view, so
        // that a solution and its file pick the same leaf where two domains touch.
        let Live { stretch, leaves } = view.live_at(t)?;
        let patches: Vec<WorldPatch> = view
            .patches()
            .iter()
            .map(|p| {
                let m = view.object_to_world(p.object, t);
                let v = p.vertices.map(|x| m.transform_point3(x));
                let n = if p.corners == 3 {
                    (v[1] - v[0]).cross(v[2] - v[0])
                } else {
                    (v[2] - v[0]).cross(v[3] - v[1])
                };
                WorldPatch {
                    corners: p.corners,
                    material: p.material,
                    v,
                    normal: n.normalize_or_zero(),
                }
            })
            .collect();
        let mut first_leaf = vec![0u32; patches.len() + 1];
        for l in leaves.iter() {
            if let Some(c) = first_leaf.get_mut(l.patch as usize + 1) {
                *c += 1;
            }
        }
        for i in 0..patches.len() {
            first_leaf[i + 1] += first_leaf[i];
        }
        Ok(Frame {
            t,
            patches,
            leaves,
            stretch,
            first_leaf,
        })
    }

    /// Leaves of patch `p` live at the frame's time.
    pub fn patch_leaves(&self, p: usize) -> &[Leaf] {
        match (self.first_leaf.get(p), self.first_leaf.get(p + 1)) {
            (Some(&a), Some(&b)) => &self.leaves[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Axis-aligned bounds of all patches (`None` if there are none).
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        self.patches
            .iter()
            .map(WorldPatch::bounds)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }
}
