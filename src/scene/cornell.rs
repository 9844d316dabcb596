//! The embedded Cornell box: the scene `rhier solve` solves when given no scene file.
//!
//! Geometry is the published "Cornell Box" data of the Cornell University Program of
//! Computer Graphics (<https://www.graphics.cornell.edu/online/box/data.html>), in
//! millimetres, with its exact vertex coordinates and vertex order (counter-clockwise
//! seen from inside the box, block faces counter-clockwise seen from outside). Two
//! changes keep every polygon valid for [`super::validate`] without moving a vertex:
//!
//! - the ceiling is a frame of 4 quads around a hole in which the light quad sits
//!   (coplanar at y = 548.8, facing down), so that no two polygons overlap;
//! - the published left (red) wall is bent: its fourth vertex lies 3.2 mm off the plane
//!   of the other three (4e-3 of its diameter, beyond the planarity tolerance), so it
//!   is given as the two triangles of the published quad.
//!
//! The camera is the published one: eye (278, 273, -800) looking along +z, up +y,
//! a 35 mm lens on a 25 mm film, so `fov_y = 2 atan(12.5 / 35)` (39.3 degrees).
//! Materials are the usual RGB approximations of the measured spectra; the light's
//! exitance is [17, 12, 4] (unitless). This module holds data only, no loader logic.

use glam::DVec3;

use super::model::{Camera, Material, MaterialId, Object, Polygon, Scene, TimeDomain};

/// Material ids of [`cornell_box`] (materials are sorted by name, as the native JSON
/// reader returns them).
const GREEN: MaterialId = MaterialId(0);
const LIGHT: MaterialId = MaterialId(1);
const RED: MaterialId = MaterialId(2);
const WHITE: MaterialId = MaterialId(3);

/// Height of the ceiling and the light.
const CEILING_Y: f64 = 548.8;
/// The light's extent in x and z (published light quad).
const LIGHT_X: [f64; 2] = [213.0, 343.0];
const LIGHT_Z: [f64; 2] = [227.0, 332.0];
/// The ceiling's extent in x and z (published ceiling quad).
const CEILING_X: [f64; 2] = [0.0, 556.0];
const CEILING_Z: [f64; 2] = [0.0, 559.2];

fn poly(material: MaterialId, vertices: &[[f64; 3]]) -> Polygon {
    Polygon {
        vertices: vertices.iter().map(|v| DVec3::from_array(*v)).collect(),
        material,
    }
}

/// A ceiling rectangle `[x0, x1] x [z0, z1]` at y = 548.8, counter-clockwise seen from
/// below (the published ceiling's vertex order).
fn ceiling_rect(material: MaterialId, x: [f64; 2], z: [f64; 2]) -> Polygon {
    poly(
        material,
        &[
            [x[1], CEILING_Y, z[0]],
            [x[1], CEILING_Y, z[1]],
            [x[0], CEILING_Y, z[1]],
            [x[0], CEILING_Y, z[0]],
        ],
    )
}

/// The published Cornell box: floor, ceiling (a frame around the light), back, left
/// (red) and right (green) walls, the light, and with `blocks` the short and the tall
/// block. Static; camera = the published camera; no warnings.
pub fn cornell_box(blocks: bool) -> Scene {
    let materials = vec![
        Material::diffuse("green", [0.14, 0.45, 0.091]),
        Material {
            name: "light".into(),
            rho: [0.78, 0.78, 0.78],
            emission: [17.0, 12.0, 4.0],
        },
        Material::diffuse("red", [0.63, 0.065, 0.05]),
        Material::diffuse("white", [0.73, 0.71, 0.68]),
    ];
    let mut objects = vec![
        Object::still(
            "floor",
            vec![poly(
                WHITE,
                &[
                    [552.8, 0.0, 0.0],
                    [0.0, 0.0, 0.0],
                    [0.0, 0.0, 559.2],
                    [549.6, 0.0, 559.2],
                ],
            )],
        ),
        Object::still(
            "ceiling",
            vec![
                // In front of the light (z < 227) and behind it (z > 332), full width.
                ceiling_rect(WHITE, CEILING_X, [CEILING_Z[0], LIGHT_Z[0]]),
                ceiling_rect(WHITE, CEILING_X, [LIGHT_Z[1], CEILING_Z[1]]),
                // Beside the light, between its front and back edges.
                ceiling_rect(WHITE, [CEILING_X[0], LIGHT_X[0]], LIGHT_Z),
                ceiling_rect(WHITE, [LIGHT_X[1], CEILING_X[1]], LIGHT_Z),
            ],
        ),
        Object::still(
            "light",
            vec![poly(
                LIGHT,
                &[
                    [343.0, 548.8, 227.0],
                    [343.0, 548.8, 332.0],
                    [213.0, 548.8, 332.0],
                    [213.0, 548.8, 227.0],
                ],
            )],
        ),
        Object::still(
            "back_wall",
            vec![poly(
                WHITE,
                &[
                    [549.6, 0.0, 559.2],
                    [0.0, 0.0, 559.2],
                    [0.0, 548.8, 559.2],
                    [556.0, 548.8, 559.2],
                ],
            )],
        ),
        Object::still(
            "right_wall",
            vec![poly(
                GREEN,
                &[
                    [0.0, 0.0, 559.2],
                    [0.0, 0.0, 0.0],
                    [0.0, 548.8, 0.0],
                    [0.0, 548.8, 559.2],
                ],
            )],
        ),
        Object::still(
            "left_wall",
            // The published quad 0-1-2-3 split along its diagonal 0-2.
            vec![
                poly(
                    RED,
                    &[
                        [552.8, 0.0, 0.0],
                        [549.6, 0.0, 559.2],
                        [556.0, 548.8, 559.2],
                    ],
                ),
                poly(
                    RED,
                    &[
                        [552.8, 0.0, 0.0],
                        [556.0, 548.8, 559.2],
                        [556.0, 548.8, 0.0],
                    ],
                ),
            ],
        ),
    ];
    if blocks {
        objects.push(Object::still(
            "short_block",
            vec![
                poly(
                    WHITE,
                    &[
                        [130.0, 165.0, 65.0],
                        [82.0, 165.0, 225.0],
                        [240.0, 165.0, 272.0],
                        [290.0, 165.0, 114.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [290.0, 0.0, 114.0],
                        [290.0, 165.0, 114.0],
                        [240.0, 165.0, 272.0],
                        [240.0, 0.0, 272.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [130.0, 0.0, 65.0],
                        [130.0, 165.0, 65.0],
                        [290.0, 165.0, 114.0],
                        [290.0, 0.0, 114.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [82.0, 0.0, 225.0],
                        [82.0, 165.0, 225.0],
                        [130.0, 165.0, 65.0],
                        [130.0, 0.0, 65.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [240.0, 0.0, 272.0],
                        [240.0, 165.0, 272.0],
                        [82.0, 165.0, 225.0],
                        [82.0, 0.0, 225.0],
                    ],
                ),
            ],
        ));
        objects.push(Object::still(
            "tall_block",
            vec![
                poly(
                    WHITE,
                    &[
                        [423.0, 330.0, 247.0],
                        [265.0, 330.0, 296.0],
                        [314.0, 330.0, 456.0],
                        [472.0, 330.0, 406.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [423.0, 0.0, 247.0],
                        [423.0, 330.0, 247.0],
                        [472.0, 330.0, 406.0],
                        [472.0, 0.0, 406.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [472.0, 0.0, 406.0],
                        [472.0, 330.0, 406.0],
                        [314.0, 330.0, 456.0],
                        [314.0, 0.0, 456.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [314.0, 0.0, 456.0],
                        [314.0, 330.0, 456.0],
                        [265.0, 330.0, 296.0],
                        [265.0, 0.0, 296.0],
                    ],
                ),
                poly(
                    WHITE,
                    &[
                        [265.0, 0.0, 296.0],
                        [265.0, 330.0, 296.0],
                        [423.0, 330.0, 247.0],
                        [423.0, 0.0, 247.0],
                    ],
                ),
            ],
        ));
    }
    Scene {
        time: TimeDomain::default(),
        materials,
        objects,
        camera: Some(Camera {
            eye: DVec3::new(278.0, 273.0, -800.0),
            target: DVec3::new(278.0, 273.0, 0.0),
            up: DVec3::Y,
            fov_y: 2.0 * (12.5f64 / 35.0).atan(),
        }),
        warnings: Vec::new(),
    }
}
