//! Closed shapes and tiled rooms built in code, for known-answer tests: every one is
//! a closed enclosure (each ray leaving a surface meets a front face), so with one
//! material of exitance `E` and reflectance `ρ` everywhere the exact radiosity is
//! `E / (1 − ρ)` at every point, whatever the tiling.

use glam::DVec3;
use rhier::scene::{Material, MaterialId, Object, Polygon, Scene};

/// How a rectangle is cut into polygons.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tiling {
    /// `n × n` equal quads.
    Quads(usize),
    /// `n × n` cells of unequal widths (a geometric progression), each cut into two
    /// triangles along alternating diagonals.
    UnequalTriangles(usize),
    /// `n × n` equal quads, every other row of cells halved again along one edge
    /// only, so that the rows meet in T-junctions.
    TJunctions(usize),
}

/// Breakpoints of `[0, 1]` in `n` steps; `unequal`: widths in the ratio 1 : 1.6 : 1.6² ….
fn steps(n: usize, unequal: bool) -> Vec<f64> {
    let w: Vec<f64> = (0..n)
        .map(|i| if unequal { 1.6f64.powi(i as i32) } else { 1.0 })
        .collect();
    let total: f64 = w.iter().sum();
    let mut at = vec![0.0];
    for x in &w {
        at.push(at.last().copied().unwrap_or(0.0) + x / total);
    }
    at[n] = 1.0;
    at
}

/// The rectangle `o + a u + b v` (`a, b ∈ [0, 1]`, front side `u × v`) cut as `tiling` says.
pub fn tiled_rect(o: DVec3, u: DVec3, v: DVec3, tiling: Tiling, m: MaterialId) -> Vec<Polygon> {
    let at = |a: f64, b: f64| o + a * u + b * v;
    let poly = |vertices: Vec<DVec3>| Polygon {
        vertices,
        material: m,
    };
    let mut out = Vec::new();
    match tiling {
        Tiling::Quads(n) | Tiling::UnequalTriangles(n) => {
            let tri = matches!(tiling, Tiling::UnequalTriangles(_));
            let (sa, sb) = (steps(n, tri), steps(n, tri));
            for i in 0..n {
                for j in 0..n {
                    let (a0, a1, b0, b1) = (sa[i], sa[i + 1], sb[j], sb[j + 1]);
                    let [p00, p10, p11, p01] = [at(a0, b0), at(a1, b0), at(a1, b1), at(a0, b1)];
                    if !tri {
                        out.push(poly(vec![p00, p10, p11, p01]));
                    } else if (i + j) % 2 == 0 {
                        out.push(poly(vec![p00, p10, p11]));
                        out.push(poly(vec![p00, p11, p01]));
                    } else {
                        out.push(poly(vec![p00, p10, p01]));
                        out.push(poly(vec![p10, p11, p01]));
                    }
                }
            }
        }
        Tiling::TJunctions(n) => {
            let s = steps(n, false);
            for j in 0..n {
                let (b0, b1) = (s[j], s[j + 1]);
                // Odd rows: each cell halved along `u`, so their corners meet the
                // even rows' edges in the middle (T-junctions).
                let cuts: Vec<f64> = if j % 2 == 1 {
                    steps(2 * n, false)
                } else {
                    s.clone()
                };
                for w in cuts.windows(2) {
                    out.push(poly(vec![
                        at(w[0], b0),
                        at(w[1], b0),
                        at(w[1], b1),
                        at(w[0], b1),
                    ]));
                }
            }
        }
    }
    out
}

/// An axis-aligned box `[lo, hi]` whose six faces face inwards (`inward`) or
/// outwards, each tiled as `tiling` says.
pub fn tiled_box(
    lo: DVec3,
    hi: DVec3,
    tiling: Tiling,
    inward: bool,
    m: MaterialId,
) -> Vec<Polygon> {
    let d = hi - lo;
    let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
    // Origin, u, v with u × v pointing inwards.
    let faces = [
        (lo, x, y),
        (lo + z, y, x),
        (lo, y, z),
        (lo + x, z, y),
        (lo, z, x),
        (lo + y, x, z),
    ];
    faces
        .iter()
        .flat_map(|&(o, u, v)| {
            if inward {
                tiled_rect(o, u, v, tiling, m)
            } else {
                tiled_rect(o, v, u, tiling, m)
            }
        })
        .collect()
}

/// An icosphere of radius `r` about `c`: the icosahedron with each triangle cut
/// into four `level` times (20 · 4^level triangles), vertices on the sphere,
/// facing inwards (`inward`) or outwards.
pub fn icosphere(c: DVec3, r: f64, level: u32, inward: bool, m: MaterialId) -> Vec<Polygon> {
    rhier::geometry::icosphere(c, r, level)
        .into_iter()
        .map(|t| {
            let mut vertices = t.to_vec();
            if inward {
                vertices.reverse();
            }
            Polygon {
                vertices,
                material: m,
            }
        })
        .collect()
}

/// A closed cylinder about the `y` axis (radius `r`, height `h`, base at `y = 0`):
/// `k` quads around, each cut into `rings` along the height, and two caps of `k`
/// triangles; facing inwards.
pub fn cylinder(r: f64, h: f64, k: usize, rings: usize, m: MaterialId) -> Vec<Polygon> {
    let at = |i: usize, y: f64| {
        let a = std::f64::consts::TAU * i as f64 / k as f64;
        DVec3::new(r * a.cos(), y, -r * a.sin())
    };
    let poly = |vertices: Vec<DVec3>| Polygon {
        vertices,
        material: m,
    };
    let mut out = Vec::new();
    for i in 0..k {
        for j in 0..rings {
            let (y0, y1) = (
                h * j as f64 / rings as f64,
                h * (j + 1) as f64 / rings as f64,
            );
            // Counter-clockwise seen from the axis.
            out.push(poly(vec![
                at(i, y0),
                at(i, y1),
                at(i + 1, y1),
                at(i + 1, y0),
            ]));
        }
        let (b, top) = (DVec3::ZERO, DVec3::new(0.0, h, 0.0));
        out.push(poly(vec![b, at(i, 0.0), at(i + 1, 0.0)]));
        out.push(poly(vec![top, at(i + 1, h), at(i, h)]));
    }
    out
}

/// An L-shaped room of height `h`: the square `[0, 2a]²` less the quarter
/// `[a, 2a] × [a, 2a]` in `x, z`; floor and ceiling in three `a × a` squares,
/// each tiled as `tiling` says, walls in `a`-wide panels; facing inwards.
pub fn l_room(a: f64, h: f64, tiling: Tiling, m: MaterialId) -> Vec<Polygon> {
    let (x, y, z) = (DVec3::X * a, DVec3::Y * h, DVec3::Z * a);
    let mut out = Vec::new();
    for (i, j) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
        let o = i * x + j * z;
        out.extend(tiled_rect(o, z, x, tiling, m)); // floor, +y
        out.extend(tiled_rect(o + y, x, z, tiling, m)); // ceiling, -y
    }
    // The outline, counter-clockwise seen from above (+y): each wall panel faces
    // inwards.
    let outline = [
        DVec3::ZERO,
        2.0 * z,
        2.0 * z + x,
        x + z,
        2.0 * x + z,
        2.0 * x,
    ];
    for i in 0..outline.len() {
        let (p, q) = (outline[i], outline[(i + 1) % outline.len()]);
        let panels = ((q - p).length() / a).round() as usize;
        for s in 0..panels {
            let (p0, p1) = (
                p + (q - p) * s as f64 / panels as f64,
                p + (q - p) * (s + 1) as f64 / panels as f64,
            );
            out.extend(tiled_rect(p0, y, p1 - p0, tiling, m));
        }
    }
    out
}

/// A room `[0, 6] × [0, 3] × [0, 6]` (faces tiled as `tiling` says) with a pillar
/// `[1, 1.8] × [0, 3] × [1, 1.8]` from floor to ceiling (the floor and ceiling
/// left whole under it: the pillar's ends are inside it, the pillar's four sides
/// face out) and a floating box `[3.5, 4.5] × [1, 2] × [3.5, 4.5]` facing out.
pub fn room_with_pillar_and_box(tiling: Tiling, m: MaterialId) -> Vec<Polygon> {
    let mut out = tiled_box(DVec3::ZERO, DVec3::new(6.0, 3.0, 6.0), tiling, true, m);
    let pillar = tiled_box(
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(1.8, 3.0, 1.8),
        Tiling::Quads(2),
        false,
        m,
    );
    // Its sides only (the ends lie on the floor and ceiling, facing into the solid).
    out.extend(pillar.into_iter().filter(|p| {
        let n = p.area_vector();
        n.y.abs() < 1e-9 * n.length()
    }));
    out.extend(tiled_box(
        DVec3::new(3.5, 1.0, 3.5),
        DVec3::new(4.5, 2.0, 4.5),
        Tiling::Quads(2),
        false,
        m,
    ));
    out
}

/// Triangles and quads mixed: a box whose faces alternate between the tilings.
pub fn mixed_box(lo: DVec3, hi: DVec3, n: usize, m: MaterialId) -> Vec<Polygon> {
    let quads = tiled_box(lo, hi, Tiling::Quads(n), true, m);
    let tris = tiled_box(lo, hi, Tiling::UnequalTriangles(n), true, m);
    let per = |v: &[Polygon]| v.len() / 6;
    let (q, t) = (per(&quads), per(&tris));
    (0..6)
        .flat_map(|f| {
            if f % 2 == 0 {
                quads[f * q..(f + 1) * q].to_vec()
            } else {
                tris[f * t..(f + 1) * t].to_vec()
            }
        })
        .collect()
}

/// One object of `polygons` in one material of exitance `e` and reflectance `rho`
/// (grey).
pub fn uniform_scene(polygons: Vec<Polygon>, rho: f64, e: f64) -> Scene {
    Scene {
        materials: vec![Material {
            name: "m".into(),
            rho: [rho; 3],
            emission: [e; 3],
        }],
        objects: vec![Object::still("enclosure", polygons)],
        ..Default::default()
    }
}

/// The walls of a 4 × 2.5 × 4 m room (faces inward, tiled as `tiling`) and its
/// 1 × 1 m ceiling lamp hung 1 cm under the ceiling over `[1.5, 2.5] × [1.5, 2.5]`.
pub fn lit_room(tiling: Tiling, white: MaterialId, lamp: MaterialId) -> Vec<Polygon> {
    let mut room = tiled_box(DVec3::ZERO, DVec3::new(4.0, 2.5, 4.0), tiling, true, white);
    room.extend(tiled_rect(
        DVec3::new(1.5, 2.49, 1.5),
        DVec3::X,
        DVec3::Z,
        Tiling::Quads(1),
        lamp,
    ));
    room
}

/// The materials of [`lit_room`]'s scenes, by index: 0 white walls (`ρ` 0.7), 1 the
/// lamp (`E` 10, black), 2 a coloured object of reflectance `coloured`.
pub fn lit_room_materials(coloured: [f64; 3]) -> Vec<Material> {
    vec![
        Material::diffuse("white", [0.7; 3]),
        Material {
            emission: [10.0; 3],
            ..Material::diffuse("lamp", [0.0; 3])
        },
        Material::diffuse("red", coloured),
    ]
}

/// A 4 × 2.5 × 4 m room lit by a ceiling lamp, with three boxes on the floor: two
/// touching face to face and a third standing on the first. Tessellated as real
/// scenes are: the room's faces in triangles of unequal sizes, the first box's in
/// quads meeting in T-junctions.
pub fn touching_boxes() -> Scene {
    let (white, lamp, red) = (MaterialId(0), MaterialId(1), MaterialId(2));
    let room = lit_room(Tiling::UnequalTriangles(3), white, lamp);
    let mut boxes = tiled_box(
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(1.8, 0.6, 1.8),
        Tiling::TJunctions(2),
        false,
        white,
    );
    boxes.extend(tiled_box(
        DVec3::new(1.8, 0.0, 1.2),
        DVec3::new(2.4, 0.4, 1.7),
        Tiling::Quads(1),
        false,
        red,
    ));
    boxes.extend(tiled_box(
        DVec3::new(1.2, 0.6, 1.2),
        DVec3::new(1.6, 0.9, 1.6),
        Tiling::Quads(1),
        false,
        white,
    ));
    Scene {
        materials: lit_room_materials([0.6, 0.1, 0.1]),
        objects: vec![Object::still("room", room), Object::still("boxes", boxes)],
        ..Default::default()
    }
}

/// [`lit_room`] tiled as `tiling` with one box `[lo, hi]` (one quad a face, facing
/// out, of reflectance 0.6, 0.2, 0.2) as the object `name`: the scene of the
/// interactive and shadow tests, whose box moves or casts the shadow.
pub fn lit_room_with_box(tiling: Tiling, name: &str, lo: DVec3, hi: DVec3) -> Scene {
    let (white, lamp, red) = (MaterialId(0), MaterialId(1), MaterialId(2));
    let walls = lit_room(tiling, white, lamp);
    let b = tiled_box(lo, hi, Tiling::Quads(1), false, red);
    Scene {
        materials: lit_room_materials([0.6, 0.2, 0.2]),
        objects: vec![Object::still("room", walls), Object::still(name, b)],
        ..Default::default()
    }
}

/// `polygons` with every quad cut into four triangles meeting at a point off its
/// centre (weights 0.4, 0.3, 0.2, 0.1 of its corners), so the triangles are of
/// unequal sizes, as a modeller's mesh is: the tessellated twin of a mesh of quads.
/// Other polygons are kept as they are.
pub fn fan_quads(polygons: &[Polygon]) -> Vec<Polygon> {
    polygons
        .iter()
        .flat_map(|p| {
            let v = &p.vertices;
            if v.len() != 4 {
                return vec![p.clone()];
            }
            let c = 0.4 * v[0] + 0.3 * v[1] + 0.2 * v[2] + 0.1 * v[3];
            (0..4)
                .map(|i| Polygon {
                    vertices: vec![v[i], v[(i + 1) % 4], c],
                    material: p.material,
                })
                .collect()
        })
        .collect()
}
