//! Contact meshing on the Cornell box with blocks: the floor is cut along the block
//! bases, the pieces under the blocks are dropped, and what remains of the floor has
//! exactly the floor's area minus the two footprints.

use rhier::geometry::{Patches, split_at_contacts};

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
