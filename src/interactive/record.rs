//! The session file (`rhier interact -o SESSION.rhier`): the session as an
//! animation that `rhier play`, `probe --time` and `inspect` read, move `i` at time
//! `i / fps` (frame 0 the scene as solved before the first move).
//!
//! How it works: each move's stored leaves are kept in memory zstd-compressed with
//! the poses that move left; [`Recorder::write`] writes the whole file at once
//! through the store's `FrameWriter` (which finishes it atomically: a temporary
//! file renamed at the end), each object that ever moved given a track with one
//! key per frame, each frame one chunk over its interval ([`frame_times`]). The
//! command writes it after the last move, and after the last good move when a move
//! fails, so the file on disk is always a complete, valid session.

use std::path::Path;

use super::moves::Pose;
use super::stage::{Stage, key};
use crate::scene::{MotionTrack, TimeDomain};
use crate::solution::{Leaf, Solution, SolveStats};
use crate::solver::frames::frame_times;
use crate::store::WriteOptions;
use crate::store::writer::FrameWriter;
use crate::{Error, Result};

/// One recorded frame.
struct Frame {
    poses: Vec<Pose>,
    leaves: Vec<u8>,
    count: usize,
}

/// The frames of a session, kept until the file is written.
pub struct Recorder {
    fps: f64,
    frames: Vec<Frame>,
    patches: Vec<crate::solution::PatchGeometry>,
    stats: SolveStats,
}

impl Recorder {
    /// A recorder at `fps` frames per second.
    pub fn new(fps: f64) -> Self {
        Recorder {
            fps,
            frames: Vec::new(),
            patches: Vec::new(),
            stats: SolveStats::default(),
        }
    }

    /// Frames recorded.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// True if nothing is recorded.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Records the next frame: `solution` with the objects at `poses`.
    pub fn push(&mut self, poses: &[Pose], solution: &Solution) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(&solution.leaves);
        let leaves = zstd::bulk::compress(bytes, 1)
            .map_err(|e| Error::Usage(format!("compressing a recorded move: {e}")))?;
        if self.frames.is_empty() {
            self.patches = solution.patches.clone();
        }
        self.stats = solution.stats.clone();
        self.frames.push(Frame {
            poses: poses.to_vec(),
            leaves,
            count: solution.leaves.len(),
        });
        Ok(())
    }

    /// Writes every recorded frame of `stage`'s session to `path`.
    pub fn write(&self, path: &Path, stage: &Stage) -> Result<()> {
        let n = self.frames.len();
        if n == 0 {
            return Err(Error::Usage("no move to record".into()));
        }
        let end = (n - 1) as f64 / self.fps;
        let mut scene = stage.scene.clone();
        scene.time = TimeDomain { start: 0.0, end };
        let times: Vec<(f64, [f64; 2])> = if n == 1 {
            vec![(0.0, [0.0, 0.0])]
        } else {
            frame_times(scene.time, self.fps)?
        };
        for (o, obj) in scene.objects.iter_mut().enumerate() {
            let moved = self.frames.iter().any(|f| f.poses[o] != Pose::IDENTITY);
            obj.motion = moved.then(|| MotionTrack {
                keys: self
                    .frames
                    .iter()
                    .zip(&times)
                    .map(|(f, &(t, _))| key(t, &f.poses[o]))
                    .collect(),
            });
        }
        let mut w = FrameWriter::new(path, WriteOptions::default());
        for (i, (f, &(t, range))) in self.frames.iter().zip(&times).enumerate() {
            let raw = zstd::bulk::decompress(&f.leaves, f.count * std::mem::size_of::<Leaf>())
                .map_err(|e| Error::Usage(format!("a recorded move could not be read: {e}")))?;
            let mut leaves: Vec<Leaf> = bytemuck::pod_collect_to_vec(&raw);
            for l in &mut leaves {
                l.time = [range[0] as f32, range[1] as f32];
            }
            let sol = Solution {
                scene: scene.clone(),
                patches: self.patches.clone(),
                leaves,
                stats: self.stats.clone(),
            };
            w.push(&scene, (i as u32, t, range), &sol)?;
        }
        w.finish(&self.stats)
    }
}
