//! The embedded animated scenes ACTOR and LIGHT, after the two test scenes of Damez &
//! Sillion, "Space-time hierarchical radiosity" (section 3.1, figure 1; timings in
//! section 6): 3 s or 75 frames at 25 fps, and longer versions with the same motion.
//!
//! Both are a furnished room in metres, `x` in `[0, 5]`, `y` (up) in `[0, 2.7]`, `z`
//! in `[0, 4]`, walls facing inwards, with a ceiling light panel (a hole in the
//! ceiling holding the emitter, coplanar, as in [`super::cornell_box`]), a desk (top
//! and four legs) and, in ACTOR, a shelf against the left wall and a window emitter in
//! the back wall.
//!
//! - **ACTOR** ([`actor_scene`]): two human-sized boxes (`0.5 × 1.8 × 0.3` m, 1 cm
//!   above the floor: feet are not modelled, so no contact line moves across the
//!   floor) walk across the room: A along `z = 1.3` from `x = 1` to `x = 4` (1 m/s)
//!   swaying ±8.7° about the vertical, B diagonally from `(4.3, 3.3)` to `(2.8, 2.2)`
//!   turning between 0° and 32.5°.
//! - **LIGHT** ([`light_scene`]): the same room with two lights, the ceiling panel
//!   and a lower, stronger lamp in the right wall (`x = 5`, `0.6 × 0.6` m at
//!   `y ∈ [0.8, 1.4]`); a board (`1.0 × 1.4 × 0.03` m) slides along the wall 0.45 m
//!   in front of it, from `z = 0.7` to `z = 3.3`, hiding the lamp completely mid-shot:
//!   the direct light on the floor and walls near the lamp, and hence most of the
//!   indirect light, changes over the whole shot (the paper's "lighting conditions
//!   change dramatically in the entire scene").
//!
//! **Length.** `frames` counts frames at 25 fps: the time domain is `[0, frames/25]`
//! s (75 → 3 s, 150 → 6 s, 750 → 30 s). A path is one 3 s *leg*; longer shots walk the
//! legs back and forth at the same speed (forward on even legs, backward on odd ones),
//! so that doubling the length means "equivalent movement" (section 6). Keys are
//! every 1.5 s (half a leg), plus one at the end of the domain when it is not a
//! multiple of 1.5 s.
//!
//! **Exact JSON.** Every number is a short decimal (coordinates chosen, translations
//! rounded to 0.1 mm) and every rotation is a yaw whose quaternion components are
//! short decimals of exact unit length (from Pythagorean triples: `0.07584² + 0.99712²
//! = 1`, `0.28² + 0.96² = 1`), so that `formats/examples/{actor,light}*.json` read back
//! equal to these scenes bit for bit and validation leaves them unchanged.
//!
//! This module holds data only: it does not check that moving objects stay clear of
//! the furniture (`tests/it/scene/animated.rs` does, at 200 times per scene).

use glam::{DQuat, DVec3};

use super::model::{
    Camera, Material, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, TimeDomain,
};

/// Frames per second of the `frames` argument of [`actor_scene`] and [`light_scene`].
pub const SCENE_FPS: f64 = 25.0;

/// Duration of one leg of every path, in seconds (the paper's 3 s shot).
pub const LEG_SECONDS: f64 = 3.0;

/// Time between keys: half a leg.
const KEY_STEP: f64 = LEG_SECONDS / 2.0;

/// Names accepted by [`builtin`] (and by `rhier solve --builtin`).
pub const BUILTIN_NAMES: [&str; 8] = [
    "cornell",
    "cornell-blocks",
    "actor",
    "actor150",
    "actor750",
    "light",
    "light150",
    "light750",
];

/// The embedded scene called `name` (one of [`BUILTIN_NAMES`]): the Cornell box
/// without / with blocks, ACTOR and LIGHT at 75, 150 and 750 frames. `None` for any
/// other name.
pub fn builtin(name: &str) -> Option<Scene> {
    Some(match name {
        "cornell" => super::cornell_box(false),
        "cornell-blocks" => super::cornell_box(true),
        "actor" => actor_scene(75),
        "actor150" => actor_scene(150),
        "actor750" => actor_scene(750),
        "light" => light_scene(75),
        "light150" => light_scene(150),
        "light750" => light_scene(750),
        _ => return None,
    })
}

/// Room extent (interior), metres.
const ROOM_MAX: [f64; 3] = [5.0, 2.7, 4.0];
/// Ceiling light panel: x and z extent at the ceiling.
const LAMP_X: [f64; 2] = [1.9, 3.1];
const LAMP_Z: [f64; 2] = [1.7, 2.3];
/// ACTOR's window in the back wall (z = 4): x and y extent.
const WINDOW_X: [f64; 2] = [2.6, 4.2];
const WINDOW_Y: [f64; 2] = [0.9, 2.1];
/// LIGHT's wall lamp in the right wall (x = 5): z and y extent.
const WALL_LAMP_Z: [f64; 2] = [1.7, 2.3];
const WALL_LAMP_Y: [f64; 2] = [0.8, 1.4];

/// A yaw (rotation about +y) whose quaternion components are exact short decimals of
/// unit length: `(0, s, 0, c)` with `s² + c² = 1` exactly (see the module header).
/// The angle is `2 asin(s)`.
fn yaw(s: f64, c: f64) -> DQuat {
    DQuat::from_xyzw(0.0, s, 0.0, c)
}

/// Rounds to 0.1 mm so that the value is a short decimal (exact through JSON).
fn dec(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

fn quad(material: MaterialId, vertices: [DVec3; 4]) -> Polygon {
    Polygon {
        vertices: vertices.to_vec(),
        material,
    }
}

/// Faces of an axis-aligned box, named by the outward normal.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Face {
    NegX,
    PosX,
    NegY,
    PosY,
    NegZ,
    PosZ,
}

const ALL_FACES: [Face; 6] = [
    Face::NegX,
    Face::PosX,
    Face::NegY,
    Face::PosY,
    Face::NegZ,
    Face::PosZ,
];

/// One face of the box `[lo, hi]`, counter-clockwise seen from the side `outward`
/// says (true: from outside the box, false: from inside). Coordinates are picked from
/// `lo` and `hi`, never computed, so they stay exact decimals.
fn box_face(material: MaterialId, lo: DVec3, hi: DVec3, face: Face, outward: bool) -> Polygon {
    let (a, b) = (lo, hi);
    // Each list is counter-clockwise seen from outside (normal = first edge x second).
    let mut vs = match face {
        Face::NegX => [
            v(a.x, a.y, a.z),
            v(a.x, a.y, b.z),
            v(a.x, b.y, b.z),
            v(a.x, b.y, a.z),
        ],
        Face::PosX => [
            v(b.x, a.y, a.z),
            v(b.x, b.y, a.z),
            v(b.x, b.y, b.z),
            v(b.x, a.y, b.z),
        ],
        Face::NegY => [
            v(a.x, a.y, a.z),
            v(b.x, a.y, a.z),
            v(b.x, a.y, b.z),
            v(a.x, a.y, b.z),
        ],
        Face::PosY => [
            v(a.x, b.y, a.z),
            v(a.x, b.y, b.z),
            v(b.x, b.y, b.z),
            v(b.x, b.y, a.z),
        ],
        Face::NegZ => [
            v(a.x, a.y, a.z),
            v(a.x, b.y, a.z),
            v(b.x, b.y, a.z),
            v(b.x, a.y, a.z),
        ],
        Face::PosZ => [
            v(a.x, a.y, b.z),
            v(b.x, a.y, b.z),
            v(b.x, b.y, b.z),
            v(a.x, b.y, b.z),
        ],
    };
    if !outward {
        vs.reverse();
    }
    quad(material, vs)
}

/// The faces `faces` of the box `[lo, hi]`, lit from outside.
fn solid(material: MaterialId, lo: DVec3, hi: DVec3, faces: &[Face]) -> Vec<Polygon> {
    faces
        .iter()
        .map(|&f| box_face(material, lo, hi, f, true))
        .collect()
}

/// Material ids of the shared room (each scene lists its materials sorted by name, as
/// the native JSON reader returns them).
struct RoomMaterials {
    ceiling: MaterialId,
    desk: MaterialId,
    floor: MaterialId,
    lamp: MaterialId,
    wall: MaterialId,
}

/// The room shell, ceiling light and desk shared by both scenes. The right wall
/// (`x = 5`) and back wall (`z = 4`) are left to the caller (each scene cuts one of
/// them around an emitter).
fn room(m: &RoomMaterials) -> Vec<Object> {
    let [xm, ym, zm] = ROOM_MAX;
    let inner = |mat, face| box_face(mat, v(0.0, 0.0, 0.0), v(xm, ym, zm), face, false);
    // Ceiling frame around the lamp (all at y = 2.7, facing down).
    let ceil = |x: [f64; 2], z: [f64; 2]| {
        box_face(
            m.ceiling,
            v(x[0], 0.0, z[0]),
            v(x[1], ym, z[1]),
            Face::PosY,
            false,
        )
    };
    let desk_lo = v(0.6, 0.72, 2.9);
    let desk_hi = v(2.0, 0.76, 3.6);
    let mut desk = solid(m.desk, desk_lo, desk_hi, &ALL_FACES);
    // Legs: 5 cm square, 5 cm in from the top's corners, floor to the top's underside;
    // no top or bottom faces (they touch the desk top and the floor).
    let sides = [Face::NegX, Face::PosX, Face::NegZ, Face::PosZ];
    for (x0, x1) in [(0.65, 0.7), (1.9, 1.95)] {
        for (z0, z1) in [(2.95, 3.0), (3.5, 3.55)] {
            desk.extend(solid(m.desk, v(x0, 0.0, z0), v(x1, 0.72, z1), &sides));
        }
    }
    vec![
        Object::still("floor", vec![inner(m.floor, Face::NegY)]),
        Object::still(
            "ceiling",
            vec![
                ceil([0.0, xm], [0.0, LAMP_Z[0]]),
                ceil([0.0, xm], [LAMP_Z[1], zm]),
                ceil([0.0, LAMP_X[0]], LAMP_Z),
                ceil([LAMP_X[1], xm], LAMP_Z),
            ],
        ),
        Object::still(
            "ceiling_light",
            vec![ceil_panel(m.lamp, LAMP_X, LAMP_Z, ym)],
        ),
        Object::still("left_wall", vec![inner(m.wall, Face::NegX)]),
        Object::still("front_wall", vec![inner(m.wall, Face::NegZ)]),
        Object::still("desk", desk),
    ]
}

/// A rectangle at height `y` facing down.
fn ceil_panel(material: MaterialId, x: [f64; 2], z: [f64; 2], y: f64) -> Polygon {
    box_face(
        material,
        v(x[0], 0.0, z[0]),
        v(x[1], y, z[1]),
        Face::PosY,
        false,
    )
}

/// The wall `x = 5` (or `z = 4` when `back`), facing into the room, as four quads
/// around the hole `a × y` (`a` along z, or along x when `back`), plus the quad
/// filling the hole with `hole_material`, coplanar.
fn wall_with_hole(
    wall: MaterialId,
    hole_material: MaterialId,
    back: bool,
    a: [f64; 2],
    y: [f64; 2],
) -> (Vec<Polygon>, Polygon) {
    let [xm, ym, zm] = ROOM_MAX;
    let amax = if back { xm } else { zm };
    // A rectangle of the wall spanning a0..a1 along the wall and y0..y1 in height.
    let rect = |mat, a0: f64, a1: f64, y0: f64, y1: f64| {
        if back {
            box_face(mat, v(a0, y0, 0.0), v(a1, y1, zm), Face::PosZ, false)
        } else {
            box_face(mat, v(0.0, y0, a0), v(xm, y1, a1), Face::PosX, false)
        }
    };
    let pieces = vec![
        rect(wall, 0.0, a[0], 0.0, ym),
        rect(wall, a[1], amax, 0.0, ym),
        rect(wall, a[0], a[1], 0.0, y[0]),
        rect(wall, a[0], a[1], y[1], ym),
    ];
    (pieces, rect(hole_material, a[0], a[1], y[0], y[1]))
}

/// A back-and-forth path: keys every [`KEY_STEP`] over `[0, end]`. `leg(j)` gives
/// the pose (translation, rotation) at key `j` of the endless back-and-forth walk;
/// a last key at `end` interpolates when `end` is not a multiple of the step.
fn track(end: f64, pose: impl Fn(u64) -> (DVec3, DQuat)) -> MotionTrack {
    let mut keys = Vec::new();
    let mut j = 0u64;
    loop {
        let t = j as f64 * KEY_STEP;
        if t > end + 1e-9 {
            break;
        }
        let (translation, rotation) = pose(j);
        keys.push(MotionKey {
            t,
            translation,
            rotation,
            scale: DVec3::ONE,
        });
        j += 1;
    }
    let last_t = keys.last().map_or(0.0, |k| k.t);
    if end > last_t + 1e-9 {
        let (p0, r0) = pose(j - 1);
        let (p1, r1) = pose(j);
        let s = (end - last_t) / KEY_STEP;
        let p = p0.lerp(p1, s);
        keys.push(MotionKey {
            t: end,
            translation: v(dec(p.x), dec(p.y), dec(p.z)),
            rotation: r0.slerp(r1, s).normalize(),
            scale: DVec3::ONE,
        });
    }
    MotionTrack { keys }
}

/// Position at key `j` of a back-and-forth walk between `a` and `b` (key 0 at `a`,
/// odd keys at the midpoint, even keys alternately at `b` and `a`).
fn walk(a: DVec3, b: DVec3, j: u64) -> DVec3 {
    if j % 2 == 1 {
        let m = 0.5 * (a + b);
        return v(dec(m.x), dec(m.y), dec(m.z));
    }
    if (j / 2) % 2 == 0 { a } else { b }
}

/// Time domain of a shot of `frames` frames at [`SCENE_FPS`].
fn domain(frames: u32) -> TimeDomain {
    TimeDomain {
        start: 0.0,
        end: frames as f64 / SCENE_FPS,
    }
}

/// The ACTOR scene (module header): a furnished room lit by a ceiling panel and a
/// window, two human-sized boxes walking across it for `frames` frames at 25 fps.
pub fn actor_scene(frames: u32) -> Scene {
    // Sorted by name, as the JSON reader returns them.
    let materials = vec![
        mat("actor_a", [0.6, 0.25, 0.2], [0.0; 3]),
        mat("actor_b", [0.2, 0.3, 0.6], [0.0; 3]),
        mat("ceiling", [0.8, 0.8, 0.8], [0.0; 3]),
        mat("desk", [0.55, 0.4, 0.25], [0.0; 3]),
        mat("floor", [0.45, 0.4, 0.35], [0.0; 3]),
        mat("lamp", [0.8, 0.8, 0.8], [20.0, 19.0, 16.0]),
        mat("wall", [0.75, 0.72, 0.65], [0.0; 3]),
        mat("window", [0.1, 0.1, 0.1], [4.0, 5.0, 6.5]),
    ];
    let id = |i: u32| MaterialId(i);
    let (actor_a, actor_b, window) = (id(0), id(1), id(7));
    let m = RoomMaterials {
        ceiling: id(2),
        desk: id(3),
        floor: id(4),
        lamp: id(5),
        wall: id(6),
    };
    let time = domain(frames);
    let mut objects = room(&m);
    let right = box_face(m.wall, DVec3::ZERO, v(5.0, 2.7, 4.0), Face::PosX, false);
    objects.push(Object::still("right_wall", vec![right]));
    let (back, pane) = wall_with_hole(m.wall, window, true, WINDOW_X, WINDOW_Y);
    objects.push(Object::still("back_wall", back));
    objects.push(Object::still("window", vec![pane]));
    // Shelf against the left wall, on the floor (no back or bottom face).
    objects.push(Object::still(
        "shelf",
        solid(
            m.desk,
            v(0.0, 0.0, 0.5),
            v(0.4, 1.8, 1.4),
            &[Face::PosX, Face::PosY, Face::NegZ, Face::PosZ],
        ),
    ));
    // The actors: boxes centred on the vertical axis, 1 cm above the floor.
    let body = |mat| solid(mat, v(-0.25, 0.01, -0.15), v(0.25, 1.81, 0.15), &ALL_FACES);
    let (a0, a1) = (v(1.0, 0.0, 1.3), v(4.0, 0.0, 1.3));
    let sway = [yaw(0.07584, 0.99712), yaw(-0.07584, 0.99712)];
    objects.push(Object {
        name: "actor_a".into(),
        polygons: body(actor_a),
        motion: Some(track(time.end, |j| {
            (walk(a0, a1, j), sway[(j % 2) as usize])
        })),
    });
    let (b0, b1) = (v(4.3, 0.0, 3.3), v(2.8, 0.0, 2.2));
    let turn = [DQuat::IDENTITY, yaw(0.28, 0.96)];
    objects.push(Object {
        name: "actor_b".into(),
        polygons: body(actor_b),
        motion: Some(track(time.end, |j| {
            (walk(b0, b1, j), turn[(j % 2) as usize])
        })),
    });
    Scene {
        time,
        materials,
        objects,
        camera: Some(Camera {
            eye: v(0.3, 2.2, 0.3),
            target: v(3.2, 0.8, 2.8),
            up: DVec3::Y,
            fov_y: 65f64.to_radians(),
        }),
        warnings: Vec::new(),
    }
}

/// The LIGHT scene (module header): the room with a ceiling panel and a lower wall
/// lamp, and a board sliding in front of the wall lamp for `frames` frames at 25 fps.
pub fn light_scene(frames: u32) -> Scene {
    let materials = vec![
        mat("ceiling", [0.8, 0.8, 0.8], [0.0; 3]),
        mat("desk", [0.55, 0.4, 0.25], [0.0; 3]),
        mat("floor", [0.45, 0.4, 0.35], [0.0; 3]),
        mat("lamp", [0.8, 0.8, 0.8], [10.0, 9.5, 8.0]),
        mat("panel", [0.7, 0.7, 0.7], [0.0; 3]),
        mat("wall", [0.75, 0.72, 0.65], [0.0; 3]),
        mat("wall_lamp", [0.8, 0.8, 0.8], [40.0, 36.0, 30.0]),
    ];
    let id = |i: u32| MaterialId(i);
    let (panel, wall_lamp) = (id(4), id(6));
    let m = RoomMaterials {
        ceiling: id(0),
        desk: id(1),
        floor: id(2),
        lamp: id(3),
        wall: id(5),
    };
    let time = domain(frames);
    let mut objects = room(&m);
    let back = box_face(m.wall, DVec3::ZERO, v(5.0, 2.7, 4.0), Face::PosZ, false);
    objects.push(Object::still("back_wall", vec![back]));
    let (right, lamp) = wall_with_hole(m.wall, wall_lamp, false, WALL_LAMP_Z, WALL_LAMP_Y);
    objects.push(Object::still("right_wall", right));
    objects.push(Object::still("wall_lamp", vec![lamp]));
    // The board: 3 cm thick, 1.4 m tall from y = 0.4, 1 m wide along z; it slides
    // along z at x = 4.55 (its back 0.435 m from the wall lamp).
    let board = solid(panel, v(-0.015, 0.4, -0.5), v(0.015, 1.8, 0.5), &ALL_FACES);
    let (p0, p1) = (v(4.55, 0.0, 0.7), v(4.55, 0.0, 3.3));
    objects.push(Object {
        name: "panel".into(),
        polygons: board,
        motion: Some(track(time.end, |j| (walk(p0, p1, j), DQuat::IDENTITY))),
    });
    Scene {
        time,
        materials,
        objects,
        camera: Some(Camera {
            eye: v(0.3, 1.9, 0.3),
            target: v(4.5, 1.0, 2.6),
            up: DVec3::Y,
            fov_y: 65f64.to_radians(),
        }),
        warnings: Vec::new(),
    }
}

fn mat(name: &str, rho: [f64; 3], emission: [f64; 3]) -> Material {
    Material {
        name: name.to_string(),
        rho,
        emission,
    }
}
