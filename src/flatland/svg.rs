//! SVG pictures of a flatland solution: the scene coloured by radiosity and, on
//! request, the visibility complex in the dual plane (as in the paper's Plate 1).
//!
//! How it works: each element is drawn as a thick stroke offset slightly to its lit
//! side, coloured by its radiosity divided by a white point (the 90th percentile of
//! the elements' radiosity, so lights saturate; gamma 1/2.2); the input segments are thin grey lines. The dual panel draws every
//! front-facing cell of the complex as a polygon between its two bounding curves
//! `p = v . n(theta)` (sampled), one colour per face, faces "related to" the moving
//! object in red (§5.1).
//!
//! [`raster`] draws the same picture into an RGB image (saved as PNG by the CLI).
//!
//! What it does not do: no pseudo-3D view, no labels on the faces.

use std::fmt::Write;

use super::FlatSolution;
use super::complex::{Complex, FaceId};
use super::geometry::proj;

const W: f64 = 600.0;

/// The box of `sol`'s segments: its lower corner `[x0, y0]`, its height, and the
/// scale that fits its longer side into the picture's width less its 20-unit
/// margins.
fn frame_of(sol: &FlatSolution) -> ([f64; 2], f64, f64) {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for s in &sol.geom.segments {
        for p in [s.a, s.b] {
            x0 = x0.min(p[0]);
            y0 = y0.min(p[1]);
            x1 = x1.max(p[0]);
            y1 = y1.max(p[1]);
        }
    }
    let span = (x1 - x0).max(y1 - y0).max(1e-300);
    ([x0, y0], y1 - y0, (W - 40.0) / span)
}

/// The scene of `sol` (and, when given, the complex with some faces highlighted).
pub fn draw(sol: &FlatSolution, complex: Option<(&Complex, &[FaceId])>) -> String {
    let g = &sol.geom;
    let ([x0, y0], height, scale) = frame_of(sol);
    let h = height * scale + 40.0;
    let tx = |p: [f64; 2]| (20.0 + (p[0] - x0) * scale, h - 20.0 - (p[1] - y0) * scale);
    let total_w = if complex.is_some() { 2.0 * W + 20.0 } else { W };
    let total_h = h.max(if complex.is_some() { W } else { 0.0 });
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{total_w:.0}" height="{total_h:.0}" viewBox="0 0 {total_w:.0} {total_h:.0}">"#
    );
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#202020"/>"##);
    let bmax = white_point(sol);
    for seg in &g.segments {
        let (a, b) = (tx(seg.a), tx(seg.b));
        let _ = writeln!(
            s,
            r##"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#808080" stroke-width="0.5"/>"##,
            a.0, a.1, b.0, b.1
        );
    }
    for (e, b) in g.elements.iter().zip(&sol.element_b) {
        let n = g.segments[e.segment as usize].n;
        let off = |p: [f64; 2]| {
            let q = tx(p);
            (q.0 + 2.5 * n[0], q.1 - 2.5 * n[1])
        };
        let (a, bb) = (off(e.a), off(e.b));
        let c = |x: f64| (255.0 * (x / bmax).clamp(0.0, 1.0).powf(1.0 / 2.2)).round() as u8;
        let _ = writeln!(
            s,
            r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="rgb({},{},{})" stroke-width="4"/>"#,
            a.0,
            a.1,
            bb.0,
            bb.1,
            c(b[0]),
            c(b[1]),
            c(b[2])
        );
    }
    if let Some((cx, hl)) = complex {
        draw_dual(&mut s, sol, cx, hl, W + 20.0);
    }
    s.push_str("</svg>\n");
    s
}

/// The radiosity drawn as white: the 90th percentile of the elements' brightest
/// channel (lights, much brighter than the rest, saturate).
fn white_point(sol: &FlatSolution) -> f64 {
    let mut v: Vec<f64> = sol
        .element_b
        .iter()
        .map(|b| b[0].max(b[1]).max(b[2]))
        .collect();
    v.sort_by(f64::total_cmp);
    v.get((v.len() * 9) / 10)
        .copied()
        .unwrap_or(1.0)
        .max(1e-300)
}

fn draw_dual(s: &mut String, sol: &FlatSolution, cx: &Complex, hl: &[FaceId], left: f64) {
    let g = &sol.geom;
    let pmax = g
        .points
        .iter()
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max)
        .max(1e-300);
    let map = |th: f64, p: f64| {
        (
            left + (th - cx.theta0) / std::f64::consts::PI * W,
            W / 2.0 - p / pmax * (W / 2.0 - 10.0),
        )
    };
    let _ = writeln!(
        s,
        r##"<rect x="{left:.0}" y="0" width="{W:.0}" height="{W:.0}" fill="#000000"/>"##
    );
    for c in &cx.cells {
        if !c.front || c.theta[1] <= c.theta[0] {
            continue;
        }
        let red = hl.contains(&c.face);
        let hue = (c.face.0.wrapping_mul(2_654_435_761) >> 8) % 360;
        let fill = if red {
            "rgb(230,30,30)".to_string()
        } else {
            format!("hsl({hue},45%,45%)")
        };
        let (lo, up) = (g.points[c.lower as usize], g.points[c.upper as usize]);
        let mut pts = String::new();
        let k = 8;
        for i in 0..=k {
            let th = c.theta[0] + (c.theta[1] - c.theta[0]) * i as f64 / k as f64;
            let q = map(th, proj(up, th));
            let _ = write!(pts, "{:.2},{:.2} ", q.0, q.1);
        }
        for i in (0..=k).rev() {
            let th = c.theta[0] + (c.theta[1] - c.theta[0]) * i as f64 / k as f64;
            let q = map(th, proj(lo, th));
            let _ = write!(pts, "{:.2},{:.2} ", q.0, q.1);
        }
        let _ = writeln!(
            s,
            r#"<polygon points="{pts}" fill="{fill}" fill-opacity="0.8" stroke="none"/>"#
        );
    }
}

/// The same picture as [`draw`], rasterised (for `--svg FILE.png`).
pub fn raster(sol: &FlatSolution, complex: Option<(&Complex, &[FaceId])>) -> image::RgbImage {
    let g = &sol.geom;
    let ([x0, y0], height, scale) = frame_of(sol);
    let h = (height * scale + 40.0).ceil();
    let total_w = if complex.is_some() { 2.0 * W + 20.0 } else { W };
    let total_h = h.max(if complex.is_some() { W } else { 0.0 });
    let mut img =
        image::RgbImage::from_pixel(total_w as u32, total_h as u32, image::Rgb([32, 32, 32]));
    let tx = |p: [f64; 2]| (20.0 + (p[0] - x0) * scale, h - 20.0 - (p[1] - y0) * scale);
    let bmax = white_point(sol);
    let line = |img: &mut image::RgbImage, a: (f64, f64), b: (f64, f64), r: f64, c: [u8; 3]| {
        let n = ((b.0 - a.0).hypot(b.1 - a.1) * 2.0).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let (cx, cy) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            let ri = r.ceil() as i64;
            for dy in -ri..=ri {
                for dx in -ri..=ri {
                    if ((dx * dx + dy * dy) as f64) <= r * r {
                        let (px, py) = (cx.round() as i64 + dx, cy.round() as i64 + dy);
                        if px >= 0
                            && py >= 0
                            && (px as u32) < img.width()
                            && (py as u32) < img.height()
                        {
                            img.put_pixel(px as u32, py as u32, image::Rgb(c));
                        }
                    }
                }
            }
        }
    };
    for seg in &g.segments {
        line(&mut img, tx(seg.a), tx(seg.b), 0.5, [128, 128, 128]);
    }
    for (e, b) in g.elements.iter().zip(&sol.element_b) {
        let n = g.segments[e.segment as usize].n;
        let off = |p: [f64; 2]| {
            let q = tx(p);
            (q.0 + 2.5 * n[0], q.1 - 2.5 * n[1])
        };
        let c = |x: f64| (255.0 * (x / bmax).clamp(0.0, 1.0).powf(1.0 / 2.2)).round() as u8;
        line(
            &mut img,
            off(e.a),
            off(e.b),
            2.0,
            [c(b[0]), c(b[1]), c(b[2])],
        );
    }
    if let Some((cx, hl)) = complex {
        let pmax = g
            .points
            .iter()
            .map(|p| p[0].hypot(p[1]))
            .fold(0.0, f64::max)
            .max(1e-300);
        let left = W + 20.0;
        for col in 0..W as u32 {
            let th = cx.theta0 + (col as f64 + 0.5) / W * std::f64::consts::PI;
            for (px, py) in (0..W as u32).map(|r| (left as u32 + col, r)) {
                img.put_pixel(px, py, image::Rgb([0, 0, 0]));
            }
            for c in cx
                .cells
                .iter()
                .filter(|c| c.front && c.theta[0] < th && th < c.theta[1])
            {
                let (lo, up) = (g.points[c.lower as usize], g.points[c.upper as usize]);
                let row = |p: f64| W / 2.0 - p / pmax * (W / 2.0 - 10.0);
                let (r0, r1) = (row(proj(up, th)), row(proj(lo, th)));
                let colour = if hl.contains(&c.face) {
                    [230, 30, 30]
                } else {
                    let hue = c.face.0.wrapping_mul(2_654_435_761);
                    [
                        (hue >> 8) as u8 / 2 + 60,
                        (hue >> 16) as u8 / 2 + 60,
                        (hue >> 24) as u8 / 2 + 60,
                    ]
                };
                for r in r0.max(0.0).round() as u32..(r1.min(W - 1.0).round() as u32) {
                    img.put_pixel(left as u32 + col, r, image::Rgb(colour));
                }
            }
        }
    }
    img
}
