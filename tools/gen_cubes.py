#!/usr/bin/env python3
"""Writes a native rhier scene: a closed room with a lamp and an N x N grid of small
cubes on the floor (6 quads each), for scale benchmarks.

usage: tools/gen_cubes.py N OUT.json [--block LO HI]
       (N=129 gives 6*129*129 + 10 ≈ 100k polygons)

--block LO HI keeps only the cubes of rows and columns LO..HI-1 of the N x N grid,
the rest of the room unchanged: `--block 0 20` of N=129 is a corner of the 100k
scene (2 410 polygons) whose shadowed gaps show the same fault in seconds
(BENCHMARKS.md, "Scale").
"""
import json
import sys


def quad(a, b, c, d, m):
    return {"vertices": [a, b, c, d], "material": m}


# The room's materials (tools/gen_curved.py shares them, its room and its lamp).
MATERIALS = {
    "white": {"reflectance": [0.7, 0.7, 0.7]},
    "red": {"reflectance": [0.6, 0.1, 0.1]},
    "green": {"reflectance": [0.1, 0.6, 0.1]},
    "lamp": {"reflectance": [0.5, 0.5, 0.5], "emission": [20.0, 20.0, 20.0]},
}
# The lamp's extent in x and z: a 2 x 2 m square 1 cm under the ceiling.
LAMP = (4.0, 6.0)


def lamp_panel(h):
    l0, l1 = LAMP
    return [quad([l0, h - 0.01, l0], [l1, h - 0.01, l0], [l1, h - 0.01, l1], [l0, h - 0.01, l1], "lamp")]


def room(size, h):
    s = size
    return [
        quad([0, 0, 0], [0, 0, s], [s, 0, s], [s, 0, 0], "white"),  # floor, +y
        quad([0, h, 0], [s, h, 0], [s, h, s], [0, h, s], "white"),  # ceiling, -y
        quad([0, 0, s], [0, h, s], [s, h, s], [s, 0, s], "white"),  # back z=s, -z
        quad([0, 0, 0], [s, 0, 0], [s, h, 0], [0, h, 0], "white"),  # front z=0, +z
        quad([0, 0, 0], [0, h, 0], [0, h, s], [0, 0, s], "red"),    # x=0, +x
        quad([s, 0, 0], [s, 0, s], [s, h, s], [s, h, 0], "green"),  # x=s, -x
    ]


def cube(x0, z0, w, hgt):
    """The six faces of a box, each counter-clockwise seen from outside."""
    x1, z1, y1 = x0 + w, z0 + w, hgt
    return [
        quad([x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0], "white"),  # top +y
        quad([x0, y1, z0], [x1, y1, z0], [x1, 0, z0], [x0, 0, z0], "white"),    # -z
        quad([x1, y1, z1], [x0, y1, z1], [x0, 0, z1], [x1, 0, z1], "white"),    # +z
        quad([x0, y1, z1], [x0, y1, z0], [x0, 0, z0], [x0, 0, z1], "white"),    # -x
        quad([x1, y1, z0], [x1, y1, z1], [x1, 0, z1], [x1, 0, z0], "white"),    # +x
        quad([x1, 0, z0], [x1, 0, z1], [x0, 0, z1], [x0, 0, z0], "white"),      # bottom -y
    ]


def outward(faces, centre):
    """True if every face's normal (counter-clockwise rule) points away from `centre`."""
    for f in faces:
        a, b, c = f["vertices"][0], f["vertices"][1], f["vertices"][2]
        e1 = [b[i] - a[i] for i in range(3)]
        e2 = [c[i] - b[i] for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        mid = [sum(v[i] for v in f["vertices"]) / 4 for i in range(3)]
        if sum(n[i] * (mid[i] - centre[i]) for i in range(3)) <= 0:
            return False
    return True


def block(args, n):
    """The grid rows/columns `--block LO HI` asks for (all of them without it)."""
    if not args:
        return 0, n
    if len(args) != 3 or args[0] != "--block":
        sys.exit(f"expected --block LO HI, found {' '.join(args)}")
    lo, hi = int(args[1]), int(args[2])
    if not 0 <= lo < hi <= n:
        sys.exit(f"--block: expected 0 <= LO < HI <= {n}, found {lo} {hi}")
    return lo, hi


def main():
    if len(sys.argv) > 1 and sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return
    if len(sys.argv) < 3 or not sys.argv[1].isdigit():
        sys.exit(__doc__)
    n, out = int(sys.argv[1]), sys.argv[2]
    lo, hi = block(sys.argv[3:], n)
    size, h = 10.0, 4.0
    polys = room(size, h)
    lamp = lamp_panel(h)
    cubes = []
    pitch = (size - 1.0) / n
    for i in range(lo, hi):
        for j in range(lo, hi):
            hgt = 0.05 + 0.3 * (((i * 7 + j * 13) % 11) / 10.0)
            x0, z0, w = 0.5 + i * pitch, 0.5 + j * pitch, pitch * 0.6
            faces = cube(x0, z0, w, hgt)
            assert outward(faces, [x0 + w / 2, hgt / 2, z0 + w / 2])
            cubes += faces
    scene = {
        "rhier_scene": 1,
        "materials": MATERIALS,
        "objects": [
            {"name": "room", "polygons": polys},
            {"name": "lamp", "polygons": lamp},
            {"name": "cubes", "polygons": cubes},
        ],
    }
    with open(out, "w") as f:
        json.dump(scene, f)
    print(f"{len(polys) + len(lamp) + len(cubes)} polygons -> {out}")


if __name__ == "__main__":
    main()
