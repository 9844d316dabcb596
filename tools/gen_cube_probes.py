#!/usr/bin/env python3
"""Writes probe points for a `tools/gen_cubes.py N` scene: floor points in the gaps
between cubes, cube tops, cube sides, walls and ceiling (deterministic), as a JSON
array of {"p": [x, y, z], "n": [x, y, z]} for `rhier reference --points` and
`rhier solve --probe`.

usage: tools/gen_cube_probes.py N OUT.json [COUNT] [--block LO HI]
       (COUNT defaults to 100)

With --block (the scene made by `gen_cubes.py N ... --block LO HI`), the gap, top and
side points are on cubes inside the block, one cube in from its edge, so that every
gap and side point lies in a slot between two cubes.
"""
import json
import random
import sys


def main():
    args = sys.argv[1:]
    block = None
    if "--block" in args:
        k = args.index("--block")
        block = (int(args[k + 1]), int(args[k + 2]))
        del args[k : k + 3]
    n, out = int(args[0]), args[1]
    count = int(args[2]) if len(args) > 2 else 100
    if block is not None and not (0 <= block[0] and block[0] + 3 <= block[1] <= n):
        sys.exit(f"--block: expected 0 <= LO, LO + 3 <= HI <= {n}, found {block}")
    size, h = 10.0, 4.0
    pitch = (size - 1.0) / n
    w = pitch * 0.6
    rng = random.Random(12345)
    pts = []

    def height(i, j):
        return 0.05 + 0.3 * (((i * 7 + j * 13) % 11) / 10.0)

    lift = 1e-4
    kinds = ["floor_gap", "top", "side", "wall", "ceiling"]
    for k in range(count):
        kind = kinds[k % len(kinds)]
        if block is None:
            i, j = rng.randrange(n), rng.randrange(n)
        else:
            # The +x neighbour (gap) and the -z neighbour (side) are in the block.
            i = block[0] + 1 + rng.randrange(block[1] - block[0] - 2)
            j = block[0] + 1 + rng.randrange(block[1] - block[0] - 1)
        x0, z0 = 0.5 + i * pitch, 0.5 + j * pitch
        if kind == "floor_gap":
            # Middle of the gap to the +x neighbour, somewhere along the cube.
            x = x0 + w + 0.5 * (pitch - w)
            z = z0 + rng.uniform(0.1, 0.9) * w
            pts.append({"p": [x, lift, z], "n": [0, 1, 0]})
        elif kind == "top":
            x = x0 + rng.uniform(0.2, 0.8) * w
            z = z0 + rng.uniform(0.2, 0.8) * w
            pts.append({"p": [x, height(i, j) + lift, z], "n": [0, 1, 0]})
        elif kind == "side":
            # The -z face, half way up.
            x = x0 + rng.uniform(0.2, 0.8) * w
            y = height(i, j) * rng.uniform(0.3, 0.7)
            pts.append({"p": [x, y, z0 - lift], "n": [0, 0, -1]})
        elif kind == "wall":
            y = rng.uniform(0.5, 3.5)
            t = rng.uniform(0.5, 9.5)
            wall = rng.randrange(4)
            if wall == 0:
                pts.append({"p": [lift, y, t], "n": [1, 0, 0]})
            elif wall == 1:
                pts.append({"p": [size - lift, y, t], "n": [-1, 0, 0]})
            elif wall == 2:
                pts.append({"p": [t, y, lift], "n": [0, 0, 1]})
            else:
                pts.append({"p": [t, y, size - lift], "n": [0, 0, -1]})
        else:
            # Ceiling outside the lamp.
            while True:
                x, z = rng.uniform(0.5, 9.5), rng.uniform(0.5, 9.5)
                if not (3.8 < x < 6.2 and 3.8 < z < 6.2):
                    break
            pts.append({"p": [x, h - lift, z], "n": [0, -1, 0]})
    with open(out, "w") as f:
        json.dump(pts, f)
    print(f"{len(pts)} probe points -> {out}")


if __name__ == "__main__":
    main()
