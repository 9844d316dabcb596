//! Evaluation of a solved hierarchy: the frame at time `t`, probes, pictures, exports.
//!
//! Everything here runs on a [`SolutionView`], implemented both by an in-memory
//! [`Solution`] and by an opened `.rhier` [`Reader`], so that `solve --probe` and
//! `rhier probe FILE` share one code path and agree by construction. A [`Frame`] holds
//! the world-space patches at `t` and the leaves live at `t` grouped per patch; the
//! [`mod@probe`] engine finds, per point, the nearest patch facing the point's normal
//! through a bounding-volume hierarchy ([`nearest`]), maps the point to the patch's
//! parameters (inverse bilinear for quads, barycentric for triangles) and evaluates the
//! leaf there ([`Leaf::eval`]). [`raster`] draws a frame with a software z-buffer and
//! [`export`] writes it as glTF.
//!
//! It does not solve anything and keeps no state between calls: each call builds the
//! frame it needs.

pub mod export;
pub mod frame;
pub mod nearest;
pub mod probe;
pub mod raster;

use std::path::Path;

use glam::DAffine3;

use crate::error::Result;
use crate::scene::{Camera, TimeDomain};
use crate::solution::{Leaf, PatchGeometry, Solution};
use crate::store::{Live, Reader};

pub use frame::{Frame, WorldPatch};
pub use probe::{ProbePoint, probe, read_probe_points, write_probe_results};

/// What playback needs from a solution, wherever it lives.
pub trait SolutionView {
    /// Name used in error messages (the file, or `<solution>`).
    fn name(&self) -> &Path;
    /// The scene's time domain.
    fn time_domain(&self) -> TimeDomain;
    /// The scene's camera, if any.
    fn camera(&self) -> Option<Camera>;
    /// Patches, in solver order.
    fn patches(&self) -> &[PatchGeometry];
    /// Object → world map of `object` at time `t`.
    fn object_to_world(&self, object: u32, t: f64) -> DAffine3;
    /// The leaves live at `t` ([`Leaf::is_live`]) in canonical order, with the stretch
    /// of time over which they are the live ones ([`Live`]); an error if `t` is
    /// outside the time domain or the data behind the view is corrupt.
    fn live_at(&self, t: f64) -> Result<Live>;

    /// The leaves of [`SolutionView::live_at`], copied.
    fn leaves_at(&self, t: f64) -> Result<Vec<Leaf>> {
        Ok(self.live_at(t)?.leaves.to_vec())
    }
}

impl SolutionView for Solution {
    fn name(&self) -> &Path {
        Path::new("<solution>")
    }

    fn time_domain(&self) -> TimeDomain {
        self.scene.time
    }

    fn camera(&self) -> Option<Camera> {
        self.scene.camera
    }

    fn patches(&self) -> &[PatchGeometry] {
        &self.patches
    }

    fn object_to_world(&self, object: u32, t: f64) -> DAffine3 {
        self.scene
            .objects
            .get(object as usize)
            .map_or(DAffine3::IDENTITY, |o| o.to_world(t))
    }

    fn live_at(&self, t: f64) -> Result<Live> {
        crate::store::reader::check_time(self.name(), self.scene.time, t)?;
        Ok(Live::scan(&self.leaves, t, self.scene.time.end))
    }
}

impl SolutionView for Reader {
    fn name(&self) -> &Path {
        self.path()
    }

    fn time_domain(&self) -> TimeDomain {
        Reader::time_domain(self)
    }

    fn camera(&self) -> Option<Camera> {
        Reader::camera(self)
    }

    fn patches(&self) -> &[PatchGeometry] {
        Reader::patches(self)
    }

    fn object_to_world(&self, object: u32, t: f64) -> DAffine3 {
        self.objects()
            .get(object as usize)
            .map_or(DAffine3::IDENTITY, |o| o.to_world(t))
    }

    fn live_at(&self, t: f64) -> Result<Live> {
        Reader::live_at(self, t)
    }
}
