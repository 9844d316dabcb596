//! Contact meshing on the Cornell box with blocks: the floor is cut along the block
//! bases, the pieces under the blocks are dropped, and what remains of the floor has
//! exactly the floor's area minus the two footprints.

use glam::DVec3;
use rhier::geometry::{Patches, split_at_contacts};
use rhier::scene::{Material, Object, Scene};

use crate::common;

fn footprint_area(patches: &Patches, floor_y: f64) -> f64 {
    // Block tops are horizontal quads above the floor facing up; their footprint is
    // their projection (the Cornell blocks are prisms).
    (0..patches.len())
        .filter(|&i| {
            patches.normals[i].y > 0.99
                && patches.polys[i].v[0].y > floor_y + 1.0
                && patches.polys[i].v[0].y < 500.0
        })
        .map(|i| patches.areas[i])
        .sum()
}

#[test]
fn floor_is_cut_at_the_block_bases_and_hidden_pieces_dropped() {
    let scene = rhier::scene::cornell_box(true);
    let before = Patches::at_time(&scene, 0.0);
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    assert!(stats.patches_cut >= 1, "{stats:?}");
    assert!(stats.pieces_hidden >= 2, "{stats:?}");
    let floor = |p: &Patches| -> f64 {
        (0..p.len())
            .filter(|&i| p.normals[i].y > 0.99 && p.polys[i].v[0].y.abs() < 1e-6)
            .map(|i| p.areas[i])
            .sum()
    };
    let expected = floor(&before) - footprint_area(&before, 0.0);
    let got = floor(&after);
    assert!(
        (got - expected).abs() / expected < 1e-9,
        "floor area {got} vs {expected}"
    );
    // Every piece is a planar triangle or quad facing like its patch.
    for i in 0..after.len() {
        assert!(after.polys[i].n == 3 || after.polys[i].n == 4);
        assert!(after.areas[i] > 0.0);
    }
    // Nothing else changed: the walls are not cut (their contacts run along their edges).
    let walls = |p: &Patches| {
        (0..p.len())
            .filter(|&i| p.normals[i].x.abs() > 0.99)
            .count()
    };
    assert_eq!(walls(&before), walls(&after));
}

/// A 10 × 4 × 10 room with a 3 × 3 grid of boxes on its floor (as
/// `tools/gen_cubes.py 3`), and a thin two-sided panel (two coincident quads facing
/// opposite ways) floating at y = 2.
fn boxes_and_panel() -> Scene {
    let mut polys = common::closed_box(DVec3::ZERO, DVec3::new(10.0, 4.0, 10.0), 1, |_| 0);
    let pitch = 3.0;
    for i in 0..3 {
        for j in 0..3 {
            let lo = DVec3::new(0.5 + i as f64 * pitch, 0.0, 0.5 + j as f64 * pitch);
            let h = 0.05 + 0.3 * (((i * 7 + j * 13) % 11) as f64 / 10.0);
            let mut faces = common::closed_box(lo, lo + DVec3::new(1.8, h, 1.8), 1, |_| 0);
            // closed_box faces inwards; a solid's faces look out.
            for f in &mut faces {
                f.vertices.reverse();
            }
            polys.extend(faces);
        }
    }
    let panel = |flip: bool| {
        let mut v = vec![
            DVec3::new(4.0, 2.0, 4.0),
            DVec3::new(6.0, 2.0, 4.0),
            DVec3::new(6.0, 2.0, 6.0),
            DVec3::new(4.0, 2.0, 6.0),
        ];
        if flip {
            v.reverse();
        }
        rhier::scene::Polygon {
            vertices: v,
            material: rhier::scene::MaterialId(0),
        }
    };
    polys.push(panel(false));
    polys.push(panel(true));
    Scene {
        materials: vec![Material::diffuse("white", [0.7; 3])],
        objects: vec![Object::still("room", polys)],
        ..Default::default()
    }
}

/// Every box's footprint and its bottom are dropped, whatever the triangulation of
/// the box top above the footprint's centre (the test ray once ran along the top's
/// diagonal and missed it for some boxes); the floating two-sided panel is kept.
#[test]
fn every_box_on_a_floor_loses_its_footprint_and_its_bottom() {
    let scene = boxes_and_panel();
    let before = Patches::at_time(&scene, 0.0);
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    assert_eq!(stats.pieces_hidden, 18, "{stats:?}");
    let floor_area: f64 = (0..after.len())
        .filter(|&i| after.normals[i].y > 0.99 && after.polys[i].v[0].y.abs() < 1e-9)
        .map(|i| after.areas[i])
        .sum();
    let expected = 100.0 - 9.0 * 1.8 * 1.8;
    assert!(
        (floor_area - expected).abs() < 1e-9,
        "floor area {floor_area} vs {expected}"
    );
    // The boxes' 6 x and 6 z edge lines (each met by three boxes in a row, and by a
    // box's bottom and its sides) cut the floor into 7 × 7 rectangles; the 9 under
    // the boxes are dropped.
    let floor: Vec<usize> = (0..after.len())
        .filter(|&i| after.normals[i].y > 0.99 && after.polys[i].v[0].y.abs() < 1e-9)
        .collect();
    assert_eq!(floor.len(), 49 - 9);
    for &i in &floor {
        let c = after.polys[i].corners();
        assert_eq!(c.len(), 4, "floor piece {i} is not a rectangle");
        let (lo, hi) = c
            .iter()
            .fold((c[0], c[0]), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(
            ((hi.x - lo.x) * (hi.z - lo.z) - after.areas[i]).abs() < 1e-9,
            "floor piece {i} is not axis-aligned"
        );
    }
    let bottoms = (0..after.len())
        .filter(|&i| after.normals[i].y < -0.99 && after.polys[i].v[0].y.abs() < 1e-9)
        .count();
    assert_eq!(bottoms, 0, "box bottoms left on the floor");
    let panel_faces = (0..after.len())
        .filter(|&i| (after.polys[i].v[0].y - 2.0).abs() < 1e-9 && after.normals[i].y.abs() > 0.99)
        .count();
    assert_eq!(panel_faces, 2, "the two-sided panel lost a face");
}

/// The room of `tests/data/hung_lamp_room.json` with its lamp hung `gap` under the
/// ceiling (y = 4).
fn hung_lamp_room(gap: f64) -> Scene {
    let path = std::path::Path::new("tests/data/hung_lamp_room.json");
    let mut scene = rhier::scene::load(path).unwrap();
    for v in &mut scene.objects[1].polygons[0].vertices {
        v.y = 4.0 - gap;
    }
    scene
}

/// A lamp hung 1 cm under a ceiling, its back to it: the ceiling is cut along the
/// lamp's outline (a covered region, almost unlit, apart from the rest of the
/// ceiling) and the covered piece is kept, not dropped as the footprint of a solid
/// would be (a probe there must find the ceiling, not the lamp). Hung lower, where
/// light reaches under it (60 cm, 30% of the 2 m lamp's size), the ceiling is left
/// whole.
#[test]
fn a_lamp_hung_just_under_the_ceiling_cuts_it_along_its_outline() {
    let ceiling = |p: &Patches| -> Vec<usize> {
        (0..p.len())
            .filter(|&i| p.normals[i].y < -0.99 && (p.polys[i].v[0].y - 4.0).abs() < 1e-9)
            .collect()
    };
    let scene = hung_lamp_room(0.01);
    let before = Patches::at_time(&scene, 0.0);
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    assert_eq!(stats.pieces_hidden, 0, "{stats:?}");
    let pieces = ceiling(&after);
    assert_eq!(
        pieces.len(),
        9,
        "the lamp's four edges cut the ceiling in a 3 × 3 grid"
    );
    let area: f64 = pieces.iter().map(|&i| after.areas[i]).sum();
    assert!((area - 100.0).abs() < 1e-9, "ceiling area {area}");
    let covered = pieces.iter().filter(|&&i| {
        let c = after.polys[i].centroid();
        (after.areas[i] - 4.0).abs() < 1e-9 && (c.x - 5.0).abs() < 1e-9 && (c.z - 5.0).abs() < 1e-9
    });
    assert_eq!(covered.count(), 1, "no piece is exactly the lamp's outline");

    let scene = hung_lamp_room(0.6);
    let before = Patches::at_time(&scene, 0.0);
    let (after, _) = split_at_contacts(&scene, &before, 0.0);
    assert_eq!(ceiling(&after).len(), 1);
}

/// Whether a polygon covers a patch is decided by its gap against its own size,
/// not the scene's: the 2 m lamp of the hung-lamp room 10 cm under its ceiling (5%
/// of its size, past 1e-3 of the room's 14.7 m diameter, the scene rule that left
/// a one-quad ceiling whole over a 1 m lamp hung 1 cm in a 6 m room and made that
/// room 2–5% dark; `solver::tiled_lamp`) cuts the ceiling in a 3 × 3 grid, and so
/// does the same room scaled by 1000 or by 1/1000; 60 cm under (30%, past
/// `NEAR_GAP_OF_SIZE`'s 25%) it does not.
#[test]
fn the_covering_gap_is_measured_against_the_lamp_alone() {
    let ceiling_pieces = |scene: &Scene, y: f64| {
        let before = Patches::at_time(scene, 0.0);
        let (after, stats) = split_at_contacts(scene, &before, 0.0);
        assert_eq!(stats.pieces_hidden, 0, "{stats:?}");
        (0..after.len())
            .filter(|&i| after.normals[i].y < -0.99 && (after.polys[i].v[0].y - y).abs() < 1e-9 * y)
            .count()
    };
    let scaled = |gap: f64, s: f64| {
        let mut scene = hung_lamp_room(gap);
        for o in &mut scene.objects {
            for p in &mut o.polygons {
                for v in &mut p.vertices {
                    *v *= s;
                }
            }
        }
        scene
    };
    for s in [1.0, 1e3, 1e-3] {
        assert_eq!(ceiling_pieces(&scaled(0.1, s), 4.0 * s), 9, "scale {s}");
        assert_eq!(ceiling_pieces(&scaled(0.6, s), 4.0 * s), 1, "scale {s}");
    }
}

/// A flat box (2 cm high, 1 m wide) resting on a floor: its top covers the floor
/// (gap 2% of its size) and its bottom rests there; the floor under it lies inside
/// a solid and is dropped, as under any box, not kept as a covered region.
#[test]
fn the_footprint_of_a_flat_box_is_dropped_though_its_top_covers_it() {
    use crate::common::shapes::{self, Tiling};
    use rhier::scene::MaterialId;
    let m = MaterialId(0);
    let mut polygons = shapes::tiled_rect(
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::Z * 4.0,
        DVec3::X * 4.0,
        Tiling::Quads(1),
        m,
    );
    assert!(polygons[0].vertices.len() == 4);
    polygons.extend(shapes::tiled_box(
        DVec3::new(1.5, 0.0, 1.5),
        DVec3::new(2.5, 0.02, 2.5),
        Tiling::Quads(1),
        false,
        m,
    ));
    let scene = Scene {
        materials: vec![Material {
            name: "white".into(),
            rho: [0.5; 3],
            emission: [1.0; 3],
        }],
        objects: vec![Object {
            name: "floor and slab".into(),
            polygons,
            motion: None,
        }],
        ..Default::default()
    };
    let before = Patches::at_time(&scene, 0.0);
    assert!(before.normals[0].y > 0.99, "the floor faces up");
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    let floor: Vec<usize> = (0..after.len())
        .filter(|&i| after.normals[i].y > 0.99 && after.polys[i].v[0].y.abs() < 1e-12)
        .collect();
    let area: f64 = floor.iter().map(|&i| after.areas[i]).sum();
    eprintln!("{stats:?}, {} floor pieces, area {area}", floor.len());
    assert_eq!(floor.len(), 8, "the floor around the slab");
    assert!((area - 15.0).abs() < 1e-9, "floor area {area}");
}

/// A pillar from floor to ceiling modelled by its four sides only (its ends would
/// lie on the floor and ceiling): the floor and ceiling under it lie inside it and
/// are dropped, though straight above the floor's footprint is the ceiling's
/// footprint, a front face (every slanted ray meets the sides' backs). Kept, they
/// lost their light on those backs and the room read open (`solver::enclosures`).
#[test]
fn the_footprints_of_a_pillar_without_ends_are_dropped_from_floor_and_ceiling() {
    use crate::common::shapes::{self, Tiling};
    use rhier::scene::MaterialId;
    let m = MaterialId(0);
    let polygons = shapes::room_with_pillar_and_box(Tiling::Quads(6), m);
    let scene = shapes::uniform_scene(polygons, 0.5, 1.0);
    let before = Patches::at_time(&scene, 0.0);
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    // Floor (y = 0, facing up) and ceiling (y = 3, facing down) areas.
    let area = |p: &Patches, y: f64, up: f64| -> f64 {
        (0..p.len())
            .filter(|&i| p.normals[i].y * up > 0.99 && (p.polys[i].v[0].y - y).abs() < 1e-9)
            .map(|i| p.areas[i])
            .sum()
    };
    eprintln!("{stats:?}");
    let footprint = 0.8 * 0.8;
    for (y, up) in [(0.0, 1.0), (3.0, -1.0)] {
        let (was, is) = (area(&before, y, up), area(&after, y, up));
        assert!((was - 36.0).abs() < 1e-9, "{was}");
        assert!((is - (36.0 - footprint)).abs() < 1e-9, "y = {y}: {is}");
    }
    assert_eq!(stats.pieces_hidden, 2, "{stats:?}");
}

/// A round leg (an 8-sided prism, 3 cm in radius) standing on a one-quad 4 × 4 m
/// floor: its 8 base edges cut the floor near the leg only
/// (`geometry::contact::cut_by_lines`). Cut along their whole lines, they crossed
/// the whole floor, into slivers metres from the leg: the 49 room polygons of
/// `tools/gen_furnished.py --detail 0.15 --static` became 8 684 patches that way
/// (h48furn). The floor keeps its area less the leg's footprint, the footprint is
/// dropped, and few pieces lie wholly farther than 10 cm from the leg. (Eight
/// sides, not more: a 12-sided footprint is a 12-cornered piece, and `Poly` holds
/// 8, so 1.5e-4 m² of floor went with it, whole lines or not.)
#[test]
fn a_round_leg_cuts_the_floor_near_itself_only() {
    use rhier::scene::{MaterialId, Polygon};
    let m = MaterialId(0);
    let floor = Polygon {
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 4.0),
            DVec3::new(4.0, 0.0, 4.0),
            DVec3::new(4.0, 0.0, 0.0),
        ],
        material: m,
    };
    let (c, r, h, k) = (DVec3::new(1.3, 0.0, 2.1), 0.03, 0.7, 8);
    let rim = |i: usize, y: f64| {
        let a = std::f64::consts::TAU * i as f64 / k as f64;
        c + DVec3::new(r * a.cos(), y, -r * a.sin())
    };
    let mut polygons = vec![floor];
    for i in 0..k {
        let j = (i + 1) % k;
        // Counter-clockwise seen from outside.
        polygons.push(Polygon {
            vertices: vec![rim(i, 0.0), rim(j, 0.0), rim(j, h), rim(i, h)],
            material: m,
        });
        let top = c + DVec3::Y * h;
        polygons.push(Polygon {
            vertices: vec![top, rim(i, h), rim(j, h)],
            material: m,
        });
    }
    let scene = rhier::scene::Scene {
        materials: vec![Material::diffuse("white", [0.5; 3])],
        objects: vec![Object::still("floor and leg", polygons)],
        ..Default::default()
    };
    let before = Patches::at_time(&scene, 0.0);
    assert!(before.normals[0].y > 0.99, "the floor faces up");
    assert!(
        before.normals[1].dot(rim(0, 0.0) - c) > 0.0,
        "the leg faces out"
    );
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    let floor: Vec<usize> = (0..after.len())
        .filter(|&i| after.normals[i].y > 0.99 && after.polys[i].v[0].y.abs() < 1e-12)
        .collect();
    let area: f64 = floor.iter().map(|&i| after.areas[i]).sum();
    let footprint = 0.5 * k as f64 * r * r * (std::f64::consts::TAU / k as f64).sin();
    let far = |i: usize| {
        after.polys[i]
            .corners()
            .iter()
            .all(|v| (*v - c).length() > 0.1)
    };
    let far_pieces = floor.iter().filter(|&&i| far(i)).count();
    let smallest = floor
        .iter()
        .map(|&i| after.areas[i])
        .fold(f64::INFINITY, f64::min);
    eprintln!(
        "{stats:?}, {} floor pieces, {far_pieces} far, smallest {smallest:e}, area {area}",
        floor.len()
    );
    assert!(
        (area - (16.0 - footprint)).abs() < 1e-9,
        "floor area {area}"
    );
    assert_eq!(stats.pieces_hidden, 1, "{stats:?}");
    // 24 pieces (those of more than 4 corners fanned), 2 of them the large ones
    // wholly away from the leg: the first cut crosses the whole quad, as the
    // first cut of a convex piece must.
    assert_eq!(floor.len(), 24, "floor pieces");
    assert_eq!(far_pieces, 2, "pieces wholly away from the leg");
}

/// A closed box sunk halfway into a one-quad floor (its sides cross the floor's
/// plane; no edge of it lies there): the floor is cut along where the sides
/// cross it and the piece inside the box is dropped, and each side is cut at the
/// floor into the part in the room and the part under it. Before, only edges in
/// a patch's plane cut it: the floor and the sides stayed whole (issue 45,
/// part 4: Blender's slabs pass through each other so).
#[test]
fn a_box_sunk_into_the_floor_cuts_it_where_its_sides_cross() {
    use crate::common::shapes::{self, Tiling};
    use rhier::scene::{MaterialId, Polygon};
    let m = MaterialId(0);
    let floor = Polygon {
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 4.0),
            DVec3::new(4.0, 0.0, 4.0),
            DVec3::new(4.0, 0.0, 0.0),
        ],
        material: m,
    };
    let mut polygons = vec![floor];
    polygons.extend(shapes::tiled_box(
        DVec3::new(1.2, -0.5, 1.6),
        DVec3::new(2.0, 0.5, 2.3),
        Tiling::Quads(1),
        false,
        m,
    ));
    let scene = Scene {
        materials: vec![Material::diffuse("white", [0.5; 3])],
        objects: vec![Object::still("floor and box", polygons)],
        ..Default::default()
    };
    let before = Patches::at_time(&scene, 0.0);
    assert!(before.normals[0].y > 0.99, "the floor faces up");
    let (after, stats) = split_at_contacts(&scene, &before, 0.0);
    eprintln!("{stats:?}, {} patches", after.len());
    let floor_area: f64 = (0..after.len())
        .filter(|&i| after.normals[i].y > 0.99 && after.polys[i].v[0].y.abs() < 1e-12)
        .map(|i| after.areas[i])
        .sum();
    assert!(
        (floor_area - (16.0 - 0.8 * 0.7)).abs() < 1e-9,
        "the floor keeps {floor_area} m²"
    );
    // Every side piece lies wholly above or wholly below the floor.
    let sides: Vec<usize> = (0..after.len())
        .filter(|&i| after.normals[i].y.abs() < 1e-9)
        .collect();
    for &i in &sides {
        let ys = after.polys[i].corners().iter().map(|v| v.y);
        let (lo, hi) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
        assert!(lo >= -1e-12 || hi <= 1e-12, "a side piece spans {lo}..{hi}");
    }
    let above: f64 = sides
        .iter()
        .filter(|&&i| after.polys[i].corners().iter().all(|v| v.y >= -1e-12))
        .map(|&i| after.areas[i])
        .sum();
    assert!((above - 0.5 * 2.0 * (0.8 + 0.7)).abs() < 1e-9, "{above}");
    assert_eq!(stats.pieces_hidden, 1, "{stats:?}");
}
