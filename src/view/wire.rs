//! The binary messages of `rhier view` (formats/view.md): a span's mesh, sent once
//! per span of time ([`super::span`]), and a frame's colours, sent per frame.
//! Little-endian throughout.
//!
//! How it works: [`mesh_bytes`] writes a span's leaves in its order (by object, one
//! group per object): each corner's position in object space (so that a moving
//! object's positions are sent once and placed at each time by its transform), each
//! leaf's `f32` time range and its corner count; the triangles are implied (a quad's
//! `c0 c1 c2`, `c0 c2 c3` as in [`crate::playback::raster::FrameMesh`]) and the page
//! draws those of the leaves live at the shown time. The span's key tells the page
//! when the mesh changed. [`frame_bytes`] writes each object's transform at `t` and
//! the corner colours of the leaves live at `t`, in the span's order
//! ([`color_section`]), taken from the `FrameMesh` that `rhier play` draws (smooth:
//! averaged over the leaf corners that share a world position, normal and material;
//! flat: the leaf's mean), as IEEE half floats of the radiosity over the frame's
//! largest component (`scale`), under a colour id: a client that has that id's colours
//! is not sent them again.

use super::span::Span;
use crate::playback::Frame;
use crate::playback::raster::FrameMesh;
use crate::solution::PatchGeometry;
use crate::store::reader::StoredObject;

/// First bytes of a mesh message.
pub const MESH_MAGIC: [u8; 4] = *b"RHVM";
/// First bytes of a frame message.
pub const FRAME_MAGIC: [u8; 4] = *b"RHVF";
/// Version of both messages.
pub const VERSION: u32 = 2;
/// Bytes of a mesh message's header.
pub const MESH_HEADER: usize = 32;
/// Bytes of a mesh message's group record.
pub const GROUP_BYTES: usize = 20;
/// Bytes of a frame message's header.
pub const FRAME_HEADER: usize = 48;

/// One object's run of leaves and corners in a mesh message. 20 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Group {
    /// Object index.
    pub object: u32,
    /// First corner (vertex) of the group.
    pub first_vertex: u32,
    /// Corners of the group.
    pub vertices: u32,
    /// First leaf of the group.
    pub first_leaf: u32,
    /// Leaves of the group.
    pub leaves: u32,
}

/// The groups of a span's leaves: one per object that has leaves, by increasing object.
pub fn groups(span: &Span) -> Vec<Group> {
    let mut out: Vec<Group> = Vec::new();
    let mut vertex = 0u32;
    for (k, (l, &object)) in span.leaves.iter().zip(&span.objects).enumerate() {
        match out.last_mut() {
            Some(g) if g.object == object => {
                g.vertices += l.corners;
                g.leaves += 1;
            }
            _ => out.push(Group {
                object,
                first_vertex: vertex,
                vertices: l.corners,
                first_leaf: k as u32,
                leaves: 1,
            }),
        }
        vertex += l.corners;
    }
    out
}

fn put_u32(out: &mut Vec<u8>, x: u32) {
    out.extend_from_slice(&x.to_le_bytes());
}

/// The mesh message of a span: object-space corner positions, leaf time ranges and
/// corner counts.
pub fn mesh_bytes(span: &Span, patches: &[PatchGeometry]) -> Vec<u8> {
    let groups = groups(span);
    let vertices: u32 = groups.iter().map(|g| g.vertices).sum();
    let leaves = span.leaves.len();
    let mut out = Vec::with_capacity(
        MESH_HEADER + GROUP_BYTES * groups.len() + 12 * vertices as usize + 9 * leaves + 3,
    );
    out.extend_from_slice(&MESH_MAGIC);
    put_u32(&mut out, VERSION);
    out.extend_from_slice(&span.key.to_le_bytes());
    for x in [groups.len() as u32, vertices, leaves as u32, 0] {
        put_u32(&mut out, x);
    }
    for g in &groups {
        for x in [g.object, g.first_vertex, g.vertices, g.first_leaf, g.leaves] {
            put_u32(&mut out, x);
        }
    }
    for l in &span.leaves {
        let p = &patches[l.patch as usize];
        for uv in &l.uv[..l.corners as usize] {
            let x = p.point(uv[0] as f64, uv[1] as f64);
            for c in x.to_array() {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
    }
    for l in &span.leaves {
        for t in l.time {
            out.extend_from_slice(&t.to_le_bytes());
        }
    }
    out.extend(span.leaves.iter().map(|l| l.corners as u8));
    while out.len() % 4 != 0 {
        out.push(0);
    }
    out
}

/// Each live leaf's corner colours as `rhier play` draws them (`mesh`, `frame`'s
/// [`FrameMesh`] in some shading), in frame leaf order: corner `c` of leaf `k` is
/// `[k][c]`.
pub fn corner_colors(frame: &Frame, mesh: &FrameMesh) -> Vec<[[f64; 3]; 4]> {
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

/// The colour section of a frame message: the corners of `frame`'s live leaves, in
/// the frame's order grouped by object (the order of its span's mesh, restricted to
/// them: [`super::span`]), as 3 half floats each, padded to 4 bytes; and its `scale`.
/// `mesh` is `frame`'s [`FrameMesh`] in the shading sent.
pub fn color_section(frame: &Frame, mesh: &FrameMesh, patches: &[PatchGeometry]) -> (f32, Vec<u8>) {
    let mut order: Vec<usize> = (0..frame.leaves.len()).collect();
    let object = |k: &usize| {
        patches
            .get(frame.leaves[*k].patch as usize)
            .map_or(0, |p| p.object)
    };
    order.sort_by_key(object);
    let colors = corner_colors(frame, mesh);
    let scale = colors
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |a, &b| a.max(b.abs()))
        .max(f64::MIN_POSITIVE) as f32;
    let corners: usize = frame.leaves.iter().map(|l| l.corners as usize).sum();
    let mut out = Vec::with_capacity(6 * corners + 2);
    for k in order {
        let l = &frame.leaves[k];
        for c in &colors[k][..l.corners as usize] {
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
/// ([`color_section`], `colors`, empty to leave it out) of the leaves live at `t`,
/// whose set is named `live` ([`crate::store::Stretch::id`]), for the mesh of span
/// `key`, with its colour id and scale `(id, scale)`.
pub fn frame_bytes(
    objects: &[StoredObject],
    t: f64,
    (key, live): (u64, u64),
    (id, scale): (u32, f32),
    colors: &[u8],
) -> Vec<u8> {
    let mut out = Vec::with_capacity(FRAME_HEADER + 48 * objects.len() + colors.len());
    out.extend_from_slice(&FRAME_MAGIC);
    put_u32(&mut out, VERSION);
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(&live.to_le_bytes());
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
