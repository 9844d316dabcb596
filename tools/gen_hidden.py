#!/usr/bin/env python3
"""Writes scenes whose extra geometry no light can reach, to measure what it costs
(issue 48, target 4: "objects nothing can see, and light that cannot reach a surface,
cost nothing").

usage: tools/gen_hidden.py KIND N K OUT.json [--probes P.json] [--dark-probes D.json]

The lit part is always the same: `gen_cubes`' 10 x 4 x 10 m room and lamp with an
N x N grid of cubes in its half x < 5, and a closed crate (1.5 x 1 x 3 m, its faces
turned out) standing on the floor of the other half.  KIND adds, where no light
reaches:
  none   nothing (the baseline);
  crate  K x K cubes inside the crate;
  room   a second room of the same size beyond the wall x = 10, sealed, with no lamp,
         holding K x K cubes (the wall is two faces back to back, one turned into
         each room).
`--probes` writes probe points on the lit part only (floor strips, walls, ceiling,
the crate's top and side), the same for every KIND; `--dark-probes` points where no
light reaches in this KIND (the tops of the cubes in the crate, the dark room's floor
and walls; none for `none`).
"""
import json
import sys

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from gen_cubes import MATERIALS, cube, lamp_panel, quad, room  # noqa: E402


def shift(faces, dx):
    return [
        {"vertices": [[v[0] + dx, v[1], v[2]] for v in f["vertices"]], "material": f["material"]}
        for f in faces
    ]


def grid(n, x0, x1, z0, z1, top):
    """n x n cubes over [x0, x1] x [z0, z1], heights up to `top`."""
    out = []
    px, pz = (x1 - x0) / n, (z1 - z0) / n
    for i in range(n):
        for j in range(n):
            hgt = top * (0.15 + 0.85 * (((i * 7 + j * 13) % 11) / 10.0))
            w = min(px, pz) * 0.6
            out += cube(x0 + i * px + 0.2 * px, z0 + j * pz + 0.2 * pz, w, hgt)
    return out


def crate(x0, z0, wx, wz, h):
    """A closed box, faces turned out (cube() with unequal sides)."""
    x1, z1 = x0 + wx, z0 + wz
    return [
        quad([x0, h, z0], [x0, h, z1], [x1, h, z1], [x1, h, z0], "white"),
        quad([x0, h, z0], [x1, h, z0], [x1, 0, z0], [x0, 0, z0], "white"),
        quad([x1, h, z1], [x0, h, z1], [x0, 0, z1], [x1, 0, z1], "white"),
        quad([x0, h, z1], [x0, h, z0], [x0, 0, z0], [x0, 0, z1], "white"),
        quad([x1, h, z0], [x1, h, z1], [x1, 0, z1], [x1, 0, z0], "white"),
        quad([x1, 0, z0], [x1, 0, z1], [x0, 0, z1], [x0, 0, z0], "white"),
    ]


CRATE = (6.5, 3.5, 1.5, 3.0, 1.0)  # x0, z0, wx, wz, h


def probes(n):
    pts = []
    for i in range(10):
        t = (i + 0.5) / 10
        pts.append({"p": [0.25, 0.0, 0.5 + 9.0 * t], "n": [0, 1, 0]})  # floor strip by the red wall
        pts.append({"p": [5.5 + 4.0 * t, 0.0, 1.0], "n": [0, 1, 0]})  # floor, open half
        pts.append({"p": [0.0, 0.5 + 3.0 * t, 0.5 + 9.0 * t], "n": [1, 0, 0]})  # red wall
        pts.append({"p": [10.0, 0.5 + 3.0 * t, 0.5 + 9.0 * t], "n": [-1, 0, 0]})  # shared wall
        pts.append({"p": [0.5 + 9.0 * t, 4.0, 1.0 + 0.5 * (i % 3)], "n": [0, -1, 0]})  # ceiling
    x0, z0, wx, wz, h = CRATE
    for i in range(5):
        t = (i + 0.5) / 5
        pts.append({"p": [x0 + wx * t, h, z0 + wz * t], "n": [0, 1, 0]})  # crate top
        pts.append({"p": [x0, h * t, z0 + wz * t], "n": [-1, 0, 0]})  # crate side facing the cubes
    return pts


def main():
    args = sys.argv[1:]
    if not args or args[0] in ("-h", "--help"):
        print(__doc__)
        return
    if len(args) < 4 or args[0] not in ("none", "crate", "room") or not (args[1].isdigit() and args[2].isdigit()):
        sys.exit(__doc__)
    kind, n, k, out = args[0], int(args[1]), int(args[2]), args[3]
    size, h = 10.0, 4.0
    objects = [
        {"name": "room", "polygons": room(size, h)},
        {"name": "lamp", "polygons": lamp_panel(h)},
        {"name": "cubes", "polygons": grid(n, 0.5, 4.5, 0.5, 9.5, 0.35)},
        {"name": "crate", "polygons": crate(*CRATE)},
    ]
    x0, z0, wx, wz, ch = CRATE
    if kind == "crate":
        objects.append({"name": "in_crate", "polygons": grid(k, x0 + 0.05, x0 + wx - 0.05, z0 + 0.05, z0 + wz - 0.05, 0.9)})
    elif kind == "room":
        dark = shift(room(size, h), size)
        objects.append({"name": "dark_room", "polygons": dark})
        objects.append({"name": "dark_cubes", "polygons": grid(k, size + 0.5, 2 * size - 0.5, 0.5, 9.5, 0.35)})
    with open(out, "w") as f:
        json.dump({"rhier_scene": 1, "materials": MATERIALS, "objects": objects}, f)
    total = sum(len(o["polygons"]) for o in objects)
    print(f"{total} polygons -> {out}")
    if "--dark-probes" in args:
        p = args[args.index("--dark-probes") + 1]
        dark = []
        if kind == "crate":
            # The tops of the cubes in the crate.
            for f in objects[-1]["polygons"]:
                v = f["vertices"]
                if all(abs(q[1] - v[0][1]) < 1e-12 for q in v) and v[0][1] > 0:
                    c = [sum(q[i] for q in v) / 4 for i in range(3)]
                    n_up = (v[1][0] - v[0][0]) * (v[2][2] - v[1][2]) - (v[1][2] - v[0][2]) * (v[2][0] - v[1][0])
                    if n_up < 0 and len(dark) < 16:
                        dark.append({"p": c, "n": [0, 1, 0]})
        elif kind == "room":
            for i in range(5):
                t = (i + 0.5) / 5
                dark.append({"p": [10.5 + 9.0 * t, 0.0, 0.3], "n": [0, 1, 0]})
                dark.append({"p": [20.0, 0.5 + 3.0 * t, 0.5 + 9.0 * t], "n": [-1, 0, 0]})
                dark.append({"p": [10.0, 0.5 + 3.0 * t, 0.5 + 9.0 * t], "n": [1, 0, 0]})
        with open(p, "w") as f:
            json.dump(dark, f)
    if "--probes" in args:
        p = args[args.index("--probes") + 1]
        with open(p, "w") as f:
            json.dump(probes(n), f)


if __name__ == "__main__":
    main()
