#!/usr/bin/env python3
"""Writes a room of finely tessellated curved objects as a native rhier scene, the
second scale scene of issue 48 (target 2: a million polygons).

usage: tools/gen_curved.py N RES OUT.json [--probes P.json]

The room is `tools/gen_cubes.py`'s (10 x 4 x 10 m, red and green side walls, a 2 x 2
m lamp 1 cm under the ceiling). On its floor stand N x N objects in turn a sphere
resting on the floor, a torus lying on it and a vase (a surface of revolution), each
closed, facing out and cut into about RES x RES / 2 polygons (quads, with triangles
at the poles and the caps' fans). N = 20 and RES = 70 give about a million polygons;
N = 8, RES = 24 about 19k.

`--probes P.json` writes 100 probe points: 25 each on the floor between the objects,
the walls, the ceiling and the objects' tops, as [{"p": .., "n": ..}], lifted 0.1 mm.
The polygon count goes to standard output.
"""
import argparse
import json
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen_cubes import LAMP, MATERIALS, lamp_panel, room  # noqa: E402
from gen_furnished import revolve, rnd, sphere  # noqa: E402


def torus(centre, big, small, m, res):
    """A torus about the vertical axis through `centre`, lying on the plane y = cy."""
    n = max(6, res // 2)
    # the tube's circle, counter-clockwise in (r, y) seen with r to the right: starts
    # at its bottom so that the loop faces out
    prof = [(big + small * math.sin(2 * math.pi * i / n), small - small * math.cos(2 * math.pi * i / n)) for i in range(n + 1)]
    return revolve(prof, centre, m, res, caps=False)


def vase(centre, height, radius, m, res):
    n = max(6, res // 2)
    prof = [(0.0, 0.0)]
    for i in range(n + 1):
        t = i / n
        prof.append((radius * (0.55 + 0.45 * math.sin(math.pi * (0.15 + 0.85 * t)) - 0.25 * t), height * t))
    prof.append((0.0, height))
    return revolve(prof, centre, m, res)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("n", type=int)
    ap.add_argument("res", type=int)
    ap.add_argument("out")
    ap.add_argument("--probes")
    args = ap.parse_args()
    if args.n < 1 or args.res < 6:
        ap.error("expected N >= 1 and RES >= 6")
    size, h = 10.0, 4.0
    pitch = (size - 1.0) / args.n
    r = pitch * 0.35
    objects_polys = []
    tops = []
    for i in range(args.n):
        for j in range(args.n):
            cx, cz = 0.5 + (i + 0.5) * pitch, 0.5 + (j + 0.5) * pitch
            kind = (i + 2 * j) % 3
            if kind == 0:
                objects_polys += sphere([cx, r, cz], r, "white", args.res)
                tops.append(([cx, 2 * r, cz], r))
            elif kind == 1:
                objects_polys += torus([cx, 0.0, cz], r * 0.7, r * 0.3, "white", args.res)
                tops.append(([cx + r * 0.7, 0.6 * r, cz], r * 0.3))
            else:
                objects_polys += vase([cx, 0.0, cz], 2.2 * r, r, "white", args.res)
                tops.append(None)
    l0, l1 = LAMP
    lamp = lamp_panel(h)
    walls = room(size, h)
    scene = {
        "rhier_scene": 1,
        "materials": MATERIALS,
        "objects": [
            {"name": "room", "polygons": walls},
            {"name": "lamp", "polygons": lamp},
            {"name": "objects", "polygons": objects_polys},
        ],
    }
    with open(args.out, "w") as f:
        json.dump(scene, f, separators=(",", ":"))
    print(f"{len(walls) + len(lamp) + len(objects_polys)} polygons -> {args.out}")
    if args.probes:
        rng = random.Random(4242)
        lift = 1e-4
        pts = []
        for _ in range(25):  # floor between the objects: the corners of the grid cells
            i, j = rng.randrange(args.n + 1), rng.randrange(args.n + 1)
            pts.append({"p": [0.5 + i * pitch, lift, 0.5 + j * pitch], "n": [0, 1, 0]})
        for k in range(25):  # walls
            u, v = rng.uniform(0.5, size - 0.5), rng.uniform(0.3, h - 0.3)
            wall = k % 4
            p, n = [[lift, v, u], [size - lift, v, u], [u, v, lift], [u, v, size - lift]][wall], [[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]][wall]
            pts.append({"p": rnd(p), "n": n})
        for _ in range(25):  # ceiling, off the lamp
            while True:
                x, z = rng.uniform(0.3, size - 0.3), rng.uniform(0.3, size - 0.3)
                if not (l0 - 0.2 < x < l1 + 0.2 and l0 - 0.2 < z < l1 + 0.2):
                    break
            pts.append({"p": rnd([x, h - lift, z]), "n": [0, -1, 0]})
        candidates = [t for t in tops if t is not None]
        for _ in range(25):  # the tops of spheres and tori
            (x, y, z), _r = rng.choice(candidates)
            pts.append({"p": rnd([x, y + lift, z]), "n": [0, 1, 0]})
        with open(args.probes, "w") as f:
            json.dump(pts, f)
        print(f"{len(pts)} probes -> {args.probes}")


if __name__ == "__main__":
    main()
