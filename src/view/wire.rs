//! The binary messages of `rhier view` (formats/view.md): a frame's mesh, sent once
//! per set of live leaves, and its colours, sent per frame. Little-endian throughout.
//!
//! How it works: [`Layout::of`] orders the corners of a frame's live leaves object by
//! object (one group per object, each leaf's corners in order, a quad's two
//! triangles `c0 c1 c2`, `c0 c2 c3` as in [`crate::playback::raster::FrameMesh`]).
//! [`mesh_bytes`] writes the corners in object space, so that a moving object's
//! positions are sent once and placed at each time by its transform; the layout's
//! `key`, the id of the stretch of time over which the live leaves hold
//! ([`crate::store::Stretch::id`]), tells the page when they, and so the mesh,
//! changed. [`frame_bytes`] writes each
//! object's transform at `t` and every corner's linear radiosity, taken from the
//! `FrameMesh` that `rhier play` draws (smooth: averaged over the leaf corners that
//! share a world position, normal and material; flat: the leaf's mean), as IEEE
//! half floats of the radiosity over the frame's largest component (`scale`), under a
//! colour id: a client that has that id's colours is not sent them again.

use crate::playback::Frame;
use crate::playback::raster::{FrameMesh, Shading};
use crate::solution::PatchGeometry;
use crate::store::reader::StoredObject;

/// First bytes of a mesh message.
pub const MESH_MAGIC: [u8; 4] = *b"RHVM";
/// First bytes of a frame message.
pub const FRAME_MAGIC: [u8; 4] = *b"RHVF";
/// Version of both messages.
pub const VERSION: u32 = 1;
/// Bytes of a mesh message's header.
pub const MESH_HEADER: usize = 32;
/// Bytes of a mesh message's group record.
pub const GROUP_BYTES: usize = 20;
/// Bytes of a frame message's header.
pub const FRAME_HEADER: usize = 40;

/// One object's run of corners and triangles in a mesh message. 20 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Group {
    /// Object index.
    pub object: u32,
    /// First corner (vertex) of the group.
    pub first_vertex: u32,
    /// Corners of the group.
    pub vertices: u32,
    /// First triangle index of the group (3 per triangle).
    pub first_index: u32,
    /// Triangle indices of the group, relative to `first_vertex`.
    pub indices: u32,
}

/// The order in which a frame's leaf corners are sent.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// The id of the frame's live-leaf set ([`crate::store::Stretch::id`]).
    pub key: u64,
    /// Groups, by increasing object.
    pub groups: Vec<Group>,
    /// Frame leaf indices in sending order (group by group).
    pub leaves: Vec<u32>,
}

impl Layout {
    /// The layout of `frame`'s live leaves on `patches` (the view's).
    pub fn of(frame: &Frame, patches: &[PatchGeometry]) -> Layout {
        let objects = patches.iter().map(|p| p.object + 1).max().unwrap_or(0) as usize;
        let mut by_object: Vec<Vec<u32>> = vec![Vec::new(); objects];
        for (k, l) in frame.leaves.iter().enumerate() {
            let o = patches.get(l.patch as usize).map_or(0, |p| p.object);
            by_object[o as usize].push(k as u32);
        }
        let (mut groups, mut order) = (Vec::new(), Vec::with_capacity(frame.leaves.len()));
        let (mut v, mut i) = (0u32, 0u32);
        for (object, ls) in by_object.into_iter().enumerate() {
            if ls.is_empty() {
                continue;
            }
            let corners: u32 = ls.iter().map(|&k| frame.leaves[k as usize].corners).sum();
            let tris: u32 = ls
                .iter()
                .map(|&k| frame.leaves[k as usize].corners - 2)
                .sum();
            groups.push(Group {
                object: object as u32,
                first_vertex: v,
                vertices: corners,
                first_index: i,
                indices: 3 * tris,
            });
            v += corners;
            i += 3 * tris;
            order.extend(ls);
        }
        Layout {
            key: frame.stretch.id(),
            groups,
            leaves: order,
        }
    }

    /// Corners in all.
    pub fn vertices(&self) -> u32 {
        self.groups.iter().map(|g| g.vertices).sum()
    }
}

fn put_u32(out: &mut Vec<u8>, x: u32) {
    out.extend_from_slice(&x.to_le_bytes());
}

/// The mesh message of a frame: object-space corner positions and triangles.
pub fn mesh_bytes(frame: &Frame, patches: &[PatchGeometry], layout: &Layout) -> Vec<u8> {
    let vertices = layout.vertices();
    let indices: u32 = layout.groups.iter().map(|g| g.indices).sum();
    let mut out = Vec::with_capacity(
        MESH_HEADER
            + GROUP_BYTES * layout.groups.len()
            + 12 * vertices as usize
            + 4 * indices as usize,
    );
    out.extend_from_slice(&MESH_MAGIC);
    put_u32(&mut out, VERSION);
    out.extend_from_slice(&layout.key.to_le_bytes());
    for x in [layout.groups.len() as u32, vertices, indices, 0] {
        put_u32(&mut out, x);
    }
    for g in &layout.groups {
        for x in [
            g.object,
            g.first_vertex,
            g.vertices,
            g.first_index,
            g.indices,
        ] {
            put_u32(&mut out, x);
        }
    }
    for &k in &layout.leaves {
        let l = &frame.leaves[k as usize];
        let p = &patches[l.patch as usize];
        for uv in &l.uv[..l.corners as usize] {
            let x = p.point(uv[0] as f64, uv[1] as f64);
            for c in x.to_array() {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
    }
    let mut leaves = layout.leaves.iter();
    for g in &layout.groups {
        // Indices relative to the group's first corner.
        let mut base = 0u32;
        while base < g.vertices {
            let Some(&k) = leaves.next() else { break };
            let n = frame.leaves[k as usize].corners;
            for t in [[0, 1, 2], [0, 2, 3]].iter().take(n as usize - 2) {
                for c in t {
                    put_u32(&mut out, base + c);
                }
            }
            base += n;
        }
    }
    out
}

/// Each live leaf's corner colours as `rhier play` draws them, in frame leaf order:
/// corner `c` of leaf `k` is `[k][c]`.
pub fn corner_colors(frame: &Frame, shading: Shading) -> Vec<[[f64; 3]; 4]> {
    let mesh = FrameMesh::build(frame, shading);
    // FrameMesh emits, leaf after leaf in frame order, `c0 c1 c2` then for a quad
    // `c0 c2 c3`: corner 3 is the second triangle's last vertex.
    let mut tri = 0usize;
    frame
        .leaves
        .iter()
        .map(|l| {
            let t = mesh.triangles[tri];
            let mut out = [[0.0; 3]; 4];
            for c in 0..3 {
                out[c] = mesh.colors[t[c] as usize];
            }
            if l.corners == 4 {
                out[3] = mesh.colors[mesh.triangles[tri + 1][2] as usize];
            }
            tri += l.corners as usize - 2;
            out
        })
        .collect()
}

/// The colour section of a frame message (`V` × 3 half floats in layout order,
/// padded to 4 bytes) and its `scale`.
pub fn color_section(frame: &Frame, layout: &Layout, shading: Shading) -> (f32, Vec<u8>) {
    let colors = corner_colors(frame, shading);
    let scale = colors
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(b.abs()))
        .max(f64::MIN_POSITIVE) as f32;
    let mut out = Vec::with_capacity(6 * layout.vertices() as usize + 2);
    for &k in &layout.leaves {
        let l = &frame.leaves[k as usize];
        for c in &colors[k as usize][..l.corners as usize] {
            for x in c {
                let h = half::f16::from_f32((*x / scale as f64) as f32);
                out.extend_from_slice(&h.to_bits().to_le_bytes());
            }
        }
    }
    if out.len() % 4 != 0 {
        out.extend_from_slice(&[0, 0]);
    }
    (scale, out)
}

/// The frame message at `t`: the objects' transforms then the colour section
/// ([`color_section`], `colors`, empty to leave it out) of the leaves whose key is
/// `key`, with its colour id and scale `(id, scale)`.
pub fn frame_bytes(
    objects: &[StoredObject],
    t: f64,
    key: u64,
    (id, scale): (u32, f32),
    colors: &[u8],
) -> Vec<u8> {
    let mut out = Vec::with_capacity(FRAME_HEADER + 48 * objects.len() + colors.len());
    out.extend_from_slice(&FRAME_MAGIC);
    put_u32(&mut out, VERSION);
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(&t.to_le_bytes());
    put_u32(&mut out, objects.len() as u32);
    // Corners: 3 half floats each, the section padded to 4 bytes.
    put_u32(&mut out, (colors.len() / 6) as u32);
    out.extend_from_slice(&scale.to_le_bytes());
    put_u32(&mut out, id);
    for o in objects {
        let m = o.to_world(t);
        for c in m
            .matrix3
            .to_cols_array()
            .into_iter()
            .chain(m.translation.to_array())
        {
            out.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    out.extend_from_slice(colors);
    out
}
