//! A software rasterizer for frames: triangulated leaves, z-buffer, per-pixel
//! perspective-correct interpolation of radiosity, exposure, sRGB, PNG.
//!
//! How it works: [`FrameMesh::build`] turns each live leaf into world-space triangles
//! (a quad leaf `c0 c1 c2 c3` into `c0 c1 c2` and `c0 c2 c3`). With
//! [`Shading::Smooth`] each vertex carries the radiosity of the leaf corners averaged
//! over every leaf corner at the same world position on a surface of the same normal
//! and material (so walls meeting at an edge, or a light and the ceiling around it,
//! are not blurred together); with [`Shading::Flat`] each
//! leaf carries its mean [`crate::solution::Leaf::mean`]. [`render`] projects with a pinhole camera,
//! clips against the near plane, culls back faces (surfaces are lit on their front
//! side only), and fills pixels whose centre is inside a triangle (top-left rule not
//! needed: a z-buffer test with `<` resolves shared edges). [`tone_map`] multiplies by
//! the exposure (default: the 99th-percentile luminance maps to 1) and applies the
//! sRGB transfer function (IEC 61966-2-1).
//!
//! It does not anti-alias, texture or light anything: the radiosity is the picture.

use std::collections::HashMap;

use glam::{DMat4, DVec3, DVec4};

use super::frame::Frame;
use crate::scene::Camera;

/// How radiosity varies over a leaf in the picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// Vertex radiosity averaged over leaves sharing a world position, interpolated.
    #[default]
    Smooth,
    /// One value per leaf, its mean.
    Flat,
}

/// Triangles of a frame with a colour (linear radiosity) per vertex.
#[derive(Clone, Debug, Default)]
pub struct FrameMesh {
    /// World positions.
    pub positions: Vec<DVec3>,
    /// Radiosity per vertex.
    pub colors: Vec<[f64; 3]>,
    /// Triangles, counter-clockwise seen from the lit side.
    pub triangles: Vec<[u32; 3]>,
}

impl FrameMesh {
    /// Triangulates the frame's leaves.
    pub fn build(frame: &Frame, shading: Shading) -> FrameMesh {
        let mut mesh = FrameMesh::default();
        let diag = frame
            .bounds()
            .map_or(1.0, |(lo, hi)| (hi - lo).length().max(1e-300));
        let q = 1e-7 * diag;
        // Smooth: one vertex per (quantised position, quantised normal, material).
        // aHash: std's SipHash was a tenth of `rhier view`'s time per frame.
        let mut shared: HashMap<([i64; 3], [i64; 3], u32), u32, ahash::RandomState> =
            HashMap::with_capacity_and_hasher(
                if shading == Shading::Smooth {
                    4 * frame.leaves.len()
                } else {
                    0
                },
                ahash::RandomState::new(),
            );
        let mut sums: Vec<([f64; 3], f64)> = Vec::new();
        for (p, patch) in frame.patches.iter().enumerate() {
            for leaf in frame.patch_leaves(p) {
                let n = leaf.corners as usize;
                let mean = leaf.mean();
                let mut ids = [0u32; 4];
                for (c, id_slot) in ids.iter_mut().enumerate().take(n) {
                    let (u, v) = (leaf.uv[c][0] as f64, leaf.uv[c][1] as f64);
                    let pos = patch.point(u, v);
                    let b = leaf.b[c].map(f64::from);
                    *id_slot = match shading {
                        Shading::Flat => {
                            mesh.positions.push(pos);
                            mesh.colors.push(mean);
                            (mesh.positions.len() - 1) as u32
                        }
                        Shading::Smooth => {
                            let key = (
                                (pos / q).round().as_i64vec3().to_array(),
                                (patch.normal * 1e4).round().as_i64vec3().to_array(),
                                patch.material,
                            );
                            let id = *shared.entry(key).or_insert_with(|| {
                                mesh.positions.push(pos);
                                sums.push(([0.0; 3], 0.0));
                                (mesh.positions.len() - 1) as u32
                            });
                            let s = &mut sums[id as usize];
                            for (acc, x) in s.0.iter_mut().zip(b) {
                                *acc += x;
                            }
                            s.1 += 1.0;
                            id
                        }
                    };
                }
                mesh.triangles.push([ids[0], ids[1], ids[2]]);
                if n == 4 {
                    mesh.triangles.push([ids[0], ids[2], ids[3]]);
                }
            }
        }
        if shading == Shading::Smooth {
            mesh.colors = sums
                .iter()
                .map(|(s, w)| s.map(|x| x / w.max(1.0)))
                .collect();
        }
        mesh
    }
}

/// A camera framing the frame's bounds: looking down `-z` from in front of the box,
/// 45° vertical field of view.
pub fn auto_camera(frame: &Frame) -> Camera {
    let (lo, hi) = frame
        .bounds()
        .unwrap_or((DVec3::splat(-1.0), DVec3::splat(1.0)));
    let center = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-9);
    let fov_y = 45f64.to_radians();
    let dist = radius / (0.5 * fov_y).sin();
    Camera {
        eye: center + DVec3::Z * dist,
        target: center,
        up: DVec3::Y,
        fov_y,
    }
}

/// Width and height in pixels of `rhier play`'s pictures by default, and of the
/// picture whose 99th percentile sets the automatic exposure ([`auto_exposure`]) in
/// `play` and `view` alike.
pub const DEFAULT_SIZE: [u32; 2] = [640, 480];

/// The camera `rhier play` and `rhier view` start from when none is named: the
/// file's (`stored`), else one inside an interior ([`interior_camera`]), else the
/// bounds seen down `-z` ([`auto_camera`]).
pub fn default_camera(stored: Option<Camera>, frame: &Frame, mesh: &FrameMesh) -> Camera {
    stored
        .or_else(|| interior_camera(mesh))
        .unwrap_or_else(|| auto_camera(frame))
}

/// Fraction of the surface area (facing inward, towards the bounding box's centre)
/// above which a frame counts as an interior for [`interior_camera`].
pub const INTERIOR_FRACTION: f64 = 0.5;

/// A camera inside an interior (a mesh whose surfaces mostly face the centre of its
/// bounding box, as a room's walls do), else `None`. The eye stands near one wall of
/// the bounding box, at mid height (`y` up), looking across at the opposite one,
/// 60° vertical field of view; of the four horizontal directions, the one whose
/// small test picture gathers the most light (the lit side) is taken.
pub fn interior_camera(mesh: &FrameMesh) -> Option<Camera> {
    let (lo, hi) =
        mesh.positions
            .iter()
            .fold(None, |acc: Option<(DVec3, DVec3)>, &p| match acc {
                None => Some((p, p)),
                Some((a, b)) => Some((a.min(p), b.max(p))),
            })?;
    let centre = 0.5 * (lo + hi);
    let (mut inward, mut total) = (0.0, 0.0);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = 0.5 * (b - a).cross(c - a);
        let area = n.length();
        total += area;
        if n.dot(centre - (a + b + c) / 3.0) > 0.0 {
            inward += area;
        }
    }
    if total <= 0.0 || inward <= INTERIOR_FRACTION * total {
        return None;
    }
    let half = 0.5 * (hi - lo);
    let fov_y = 60f64.to_radians();
    [DVec3::X, DVec3::NEG_X, DVec3::Z, DVec3::NEG_Z]
        .into_iter()
        .map(|d| {
            let eye = centre - d * (0.98 * d.abs().dot(half));
            let camera = Camera {
                eye,
                target: eye + d,
                up: DVec3::Y,
                fov_y,
            };
            let light: f64 = render(mesh, &camera, 64, 48)
                .pixels
                .iter()
                .flatten()
                .map(|&c| luminance(c))
                .filter(|l| l.is_finite())
                .sum();
            (camera, light)
        })
        .fold(None, |best: Option<(Camera, f64)>, (c, l)| match best {
            Some((_, bl)) if bl >= l => best,
            _ => Some((c, l)),
        })
        .map(|(c, _)| c)
}

/// Linear radiosity per pixel, row-major from the top-left, `None` where nothing was
/// drawn.
#[derive(Clone, Debug)]
pub struct Picture {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One value per pixel.
    pub pixels: Vec<Option<[f64; 3]>>,
}

/// Rec. 709 luminance.
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Draws `mesh` seen from `camera` into a `width × height` picture.
pub fn render(mesh: &FrameMesh, camera: &Camera, width: u32, height: u32) -> Picture {
    let (w, h) = (width as usize, height as usize);
    let mut pixels = vec![None; w * h];
    let mut depth = vec![f64::INFINITY; w * h];
    let view = view_matrix(camera);
    let aspect = width as f64 / height.max(1) as f64;
    let f = 1.0 / (0.5 * camera.fov_y).tan();
    let near = 1e-6 * (camera.target - camera.eye).length().max(1e-9);
    for tri in &mesh.triangles {
        // View space: camera at the origin looking down -z.
        let vs: Vec<(DVec3, [f64; 3])> = tri
            .iter()
            .map(|&i| {
                (
                    view.transform_point3(mesh.positions[i as usize]),
                    mesh.colors[i as usize],
                )
            })
            .collect();
        let normal = (vs[1].0 - vs[0].0).cross(vs[2].0 - vs[0].0);
        if normal.dot(vs[0].0) >= 0.0 {
            continue; // back face or edge-on
        }
        let poly = clip_near(&vs, near);
        if poly.len() < 3 {
            continue;
        }
        // Screen coordinates (pixel units, y down), 1/z for perspective correction.
        let scr: Vec<(f64, f64, f64, [f64; 3])> = poly
            .iter()
            .map(|(p, c)| {
                let iz = 1.0 / -p.z;
                let x = (p.x * f / aspect * iz + 1.0) * 0.5 * w as f64;
                let y = (1.0 - p.y * f * iz) * 0.5 * h as f64;
                (x, y, iz, *c)
            })
            .collect();
        for k in 1..scr.len() - 1 {
            fill(&scr[0], &scr[k], &scr[k + 1], w, h, &mut pixels, &mut depth);
        }
    }
    Picture {
        width,
        height,
        pixels,
    }
}

type ScreenVertex = (f64, f64, f64, [f64; 3]);

fn fill(
    a: &ScreenVertex,
    b: &ScreenVertex,
    c: &ScreenVertex,
    w: usize,
    h: usize,
    pixels: &mut [Option<[f64; 3]>],
    depth: &mut [f64],
) {
    let area = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
    if area.abs() < 1e-12 {
        return;
    }
    let x0 = a.0.min(b.0).min(c.0).floor().max(0.0) as usize;
    let x1 = (a.0.max(b.0).max(c.0).ceil().min(w as f64)) as usize;
    let y0 = a.1.min(b.1).min(c.1).floor().max(0.0) as usize;
    let y1 = (a.1.max(b.1).max(c.1).ceil().min(h as f64)) as usize;
    for y in y0..y1 {
        let py = y as f64 + 0.5;
        for x in x0..x1 {
            let px = x as f64 + 0.5;
            let wa = ((b.0 - px) * (c.1 - py) - (c.0 - px) * (b.1 - py)) / area;
            let wb = ((c.0 - px) * (a.1 - py) - (a.0 - px) * (c.1 - py)) / area;
            let wc = 1.0 - wa - wb;
            if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                continue;
            }
            let iz = wa * a.2 + wb * b.2 + wc * c.2;
            let z = 1.0 / iz;
            let i = y * w + x;
            if z >= depth[i] {
                continue;
            }
            depth[i] = z;
            // Perspective-correct: interpolate colour / z, divide by 1 / z.
            let mut col = [0.0; 3];
            for (k, o) in col.iter_mut().enumerate() {
                *o = (wa * a.3[k] * a.2 + wb * b.3[k] * b.2 + wc * c.3[k] * c.2) * z;
            }
            pixels[i] = Some(col);
        }
    }
}

/// Clips a view-space polygon against the plane `z = -near` (Sutherland–Hodgman).
fn clip_near(poly: &[(DVec3, [f64; 3])], near: f64) -> Vec<(DVec3, [f64; 3])> {
    let inside = |p: &DVec3| p.z <= -near;
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, cp) = poly[i];
        let (q, cq) = poly[(i + 1) % poly.len()];
        if inside(&p) {
            out.push((p, cp));
        }
        if inside(&p) != inside(&q) {
            let s = (-near - p.z) / (q.z - p.z);
            let col = [0, 1, 2].map(|k| cp[k] + s * (cq[k] - cp[k]));
            out.push((p + s * (q - p), col));
        }
    }
    out
}

/// The exposure that maps the 99th-percentile luminance of the drawn pixels to 1
/// (1 if nothing positive was drawn).
pub fn auto_exposure(picture: &Picture) -> f64 {
    let mut lum: Vec<f64> = picture
        .pixels
        .iter()
        .flatten()
        .map(|&c| luminance(c))
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    if lum.is_empty() {
        return 1.0;
    }
    let k = ((lum.len() as f64 * 0.99).ceil() as usize).clamp(1, lum.len()) - 1;
    let (_, p99, _) = lum.select_nth_unstable_by(k, f64::total_cmp);
    1.0 / *p99
}

/// The sRGB transfer function of a linear value in `[0, 1]` (IEC 61966-2-1).
pub fn srgb_oetf(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB image of a picture after `exposure`; undrawn pixels are `background`.
pub fn tone_map(picture: &Picture, exposure: f64, background: [u8; 3]) -> image::RgbImage {
    let mut img = image::RgbImage::new(picture.width, picture.height);
    for (i, px) in img.pixels_mut().enumerate() {
        *px = image::Rgb(match picture.pixels[i] {
            Some(c) => c.map(|x| (srgb_oetf(x * exposure) * 255.0).round() as u8),
            None => background,
        });
    }
    img
}

/// World → view transform of a camera: right-handed, camera at the origin looking down
/// `-z`, `+y` up.
pub fn view_matrix(camera: &Camera) -> DMat4 {
    let f = (camera.target - camera.eye).normalize_or(DVec3::NEG_Z);
    let s = f.cross(camera.up).normalize_or(DVec3::X);
    let u = s.cross(f);
    DMat4::from_cols(
        DVec4::new(s.x, u.x, -f.x, 0.0),
        DVec4::new(s.y, u.y, -f.y, 0.0),
        DVec4::new(s.z, u.z, -f.z, 0.0),
        DVec4::new(
            -s.dot(camera.eye),
            -u.dot(camera.eye),
            f.dot(camera.eye),
            1.0,
        ),
    )
}

/// Perspective transform used by [`render`], for tests and exports: world point →
/// normalised device coordinates `(x, y)` in `[-1, 1]` and view depth.
pub fn project(camera: &Camera, aspect: f64, p: DVec3) -> (f64, f64, f64) {
    let view = view_matrix(camera);
    let v = view * DVec4::new(p.x, p.y, p.z, 1.0);
    let f = 1.0 / (0.5 * camera.fov_y).tan();
    (v.x * f / aspect / -v.z, v.y * f / -v.z, -v.z)
}
