#!/usr/bin/env python3
"""The interactive benchmark (issue 49): a furnished room with a chair moved along
a straight, a curved and a jittery path, run through `rhier interact` with the
shafts stored three ways, update time per move (median, 95th percentile), resident
shaft bytes and shafts built on the fly side by side.

usage: tools/interactive_bench.py OUT_DIR [--tables N] [--moves M] [--eps E] [--rhier BIN]
                                  [--paths straight,curved,jittery] [--modes all,budget,none,budget-mean,budget-matrix]
                                  [--scene chair|door] [--stats-only]

Writes OUT_DIR/room.json (a 6 x 6 m room, a lamp, N x N tables of 4 legs and a top,
a chair of 5 boxes, each box's faces cut in 2 x 2 quads: N = 15, the default, gives
10 489 polygons), OUT_DIR/{straight,curved,jittery}.jsonl and OUT_DIR/<path>-<mode>.jsonl
(the stats), and prints one table row per path and mode (`--modes`, default
all,budget,none):

- all:     every shaft kept (no budget, max age huge), no prediction;
- budget:  --shaft-budget 1 MB, linear prediction (eq. 1);
- none:    no shaft stored (--shaft-store none --max-age 0), no prediction;
- budget-mean, budget-matrix: the budget with `--predict mean:4` (eq. 2) or
  `matrix` (eq. 3).

With `--stats-only`, the runs are not made again: the rows are read from the
OUT_DIR/<path>-<mode>.jsonl files an earlier run wrote.

--scene door (issue 49's second scene, a large object moving): the same room and
tables with the chair left out and a 0.9 x 2 m door, 4 cm thick, 1 cm over the floor
beside the tables (x 4.6-5.5 at z = 3, each face cut 2 x 2), swung on its hinge
(the vertical line x = 4.6, z = 3) from 0 to 1.5 rad in M equal steps: path
"swing" (OUT_DIR/swing.jsonl), object "door". `--tables 3` gives 889 polygons.
"""
import json
import math
import os
import random
import statistics
import subprocess
import sys


MATERIALS = {
    "white": {"reflectance": [0.7, 0.7, 0.7]},
    "red": {"reflectance": [0.6, 0.1, 0.1]},
    "green": {"reflectance": [0.1, 0.6, 0.1]},
    "wood": {"reflectance": [0.5, 0.35, 0.2]},
    "blue": {"reflectance": [0.1, 0.2, 0.6]},
    "lamp": {"reflectance": [0.5, 0.5, 0.5], "emission": [20.0, 20.0, 20.0]},
}


def quad(a, b, c, d, m):
    return {"vertices": [a, b, c, d], "material": m}


def lerp(a, b, t):
    return [a[i] + (b[i] - a[i]) * t for i in range(3)]


def tiled(a, b, c, d, m, n):
    """Quad a b c d (counter-clockwise from the front) cut into n x n quads."""
    out = []
    for i in range(n):
        for j in range(n):
            p = lambda u, v: lerp(lerp(a, b, u), lerp(d, c, u), v)
            u0, u1, v0, v1 = i / n, (i + 1) / n, j / n, (j + 1) / n
            out.append(quad(p(u0, v0), p(u1, v0), p(u1, v1), p(u0, v1), m))
    return out


def box(lo, hi, m, n=2):
    """A box's six faces, facing out, each cut n x n."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return (
        tiled([x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0], m, n)  # +y
        + tiled([x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1], m, n)  # -y
        + tiled([x0, y1, z0], [x1, y1, z0], [x1, y0, z0], [x0, y0, z0], m, n)  # -z
        + tiled([x1, y1, z1], [x0, y1, z1], [x0, y0, z1], [x1, y0, z1], m, n)  # +z
        + tiled([x0, y1, z1], [x0, y1, z0], [x0, y0, z0], [x0, y0, z1], m, n)  # -x
        + tiled([x1, y1, z0], [x1, y1, z1], [x1, y0, z1], [x1, y0, z0], m, n)  # +x
    )


def scene(tables, door=False):
    s, h = 6.0, 2.6
    room = (
        tiled([0, 0, 0], [0, 0, s], [s, 0, s], [s, 0, 0], "white", 8)
        + tiled([0, h, 0], [s, h, 0], [s, h, s], [0, h, s], "white", 8)
        + tiled([0, 0, s], [0, h, s], [s, h, s], [s, 0, s], "white", 8)
        + tiled([0, 0, 0], [s, 0, 0], [s, h, 0], [0, h, 0], "white", 8)
        + tiled([0, 0, 0], [0, h, 0], [0, h, s], [0, 0, s], "red", 8)
        + tiled([s, 0, 0], [s, 0, s], [s, h, s], [s, h, 0], "green", 8)
    )
    lamp = [quad([2.5, h - 0.01, 2.5], [3.5, h - 0.01, 2.5], [3.5, h - 0.01, 3.5], [2.5, h - 0.01, 3.5], "lamp")]
    furniture = []
    pitch = 4.0 / tables
    for i in range(tables):
        for j in range(tables):
            x0, z0, w = 1.0 + i * pitch, 1.0 + j * pitch, pitch * 0.5
            if 0.35 * tables <= i <= 0.65 * tables and 0.35 * tables <= j <= 0.65 * tables:
                continue  # an aisle the chair moves in
            leg = w * 0.12
            for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)]:
                lx, lz = x0 + a * (w - leg), z0 + b * (w - leg)
                furniture += box([lx, 0, lz], [lx + leg, 0.4, lz + leg], "wood", 1)
            furniture += box([x0, 0.4, z0], [x0 + w, 0.45, z0 + w], "wood", 2)
    if door:
        leaf = box([4.6, 0.01, 2.98], [5.5, 2.0, 3.02], "blue", 2)
        objects = [
            {"name": "room", "polygons": room},
            {"name": "lamp", "polygons": lamp},
            {"name": "furniture", "polygons": furniture},
            {"name": "door", "polygons": leaf},
        ]
        return {"rhier_scene": 1, "materials": MATERIALS, "objects": objects}, len(room) + 1 + len(furniture) + len(leaf)
    chair = []
    c0 = [2.6, 0.0, 2.6]
    for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)]:
        lx, lz = c0[0] + a * 0.36, c0[2] + b * 0.36
        chair += box([lx, 0, lz], [lx + 0.04, 0.45, lz + 0.04], "blue", 1)
    chair += box([c0[0], 0.45, c0[2]], [c0[0] + 0.4, 0.5, c0[2] + 0.4], "blue", 2)
    chair += box([c0[0], 0.5, c0[2] + 0.36], [c0[0] + 0.4, 0.95, c0[2] + 0.4], "blue", 2)
    return {
        "rhier_scene": 1,
        "materials": MATERIALS,
        "objects": [
            {"name": "room", "polygons": room},
            {"name": "lamp", "polygons": lamp},
            {"name": "furniture", "polygons": furniture},
            {"name": "chair", "polygons": chair},
        ],
    }, len(room) + 1 + len(furniture) + len(chair)


def paths(moves):
    rnd = random.Random(49)
    out = {}
    out["straight"] = [[0.01 * k, 0.0, 0.005 * k] for k in range(1, moves + 1)]
    out["curved"] = [
        [0.4 * math.sin(2 * math.pi * k / moves), 0.0, 0.4 * (1 - math.cos(2 * math.pi * k / moves))]
        for k in range(1, moves + 1)
    ]
    x = [0.0, 0.0, 0.0]
    jit = []
    for k in range(moves):
        x = [x[0] + 0.008 + rnd.uniform(-0.01, 0.01), 0.0, x[2] + rnd.uniform(-0.01, 0.01)]
        jit.append(list(x))
    out["jittery"] = jit
    return out


def swing(moves, hinge=(4.6, 3.0), top=1.5):
    """The door's poses: turned about the vertical line through `hinge` by
    `top * k / moves`, k = 1..moves (a rotation about y as a quaternion, and the
    translation that keeps the hinge in place)."""
    out = []
    for k in range(1, moves + 1):
        a = top * k / moves
        c, s = math.cos(a), math.sin(a)
        x, z = hinge
        t = [x - (c * x + s * z), 0.0, z - (-s * x + c * z)]
        out.append({"object": "door", "translation": t, "rotation": [0.0, math.sin(a / 2), 0.0, math.cos(a / 2)]})
    return out


MODES = {
    "all": ["--predict", "none", "--max-age", "1000000"],
    "budget": ["--predict", "linear", "--shaft-budget", "1000000"],
    "none": ["--predict", "none", "--shaft-store", "none", "--max-age", "0"],
    # The budget with the other predictors (not run unless named in --modes).
    "budget-mean": ["--predict", "mean:4", "--shaft-budget", "1000000"],
    "budget-matrix": ["--predict", "matrix", "--shaft-budget", "1000000"],
}
DEFAULT_MODES = "all,budget,none"


def row(name, mode, rows):
    """One table row from a run's per-move statistics: the update's wall time
    (median, 95th percentile), the shaft and row parts of it (medians), the shafts
    kept against all, those built on the fly after move 2, and the fraction of the
    shafts a move needed that were ready (kept or predicted) when it came."""
    ms = lambda key: sorted(r[key] * 1000 for r in rows)
    times = ms("total_s")
    p95 = times[min(len(times) - 1, int(0.95 * len(times)))]
    later = rows[2:]
    built = sum(r["shafts_built"] for r in later)
    ready = sum(r["shafts_existing"] for r in later)
    frac = f"{100 * ready / (ready + built):.1f}%" if ready + built else "–"
    return (f"| {name} | {mode} | {statistics.median(times):.1f} | {p95:.1f} | "
            f"{statistics.median(ms('shaft_s')):.2f} | {statistics.median(ms('rows_s')):.0f} | "
            f"{rows[-1]['resident_shaft_bytes'] / 1024:.0f} | {rows[-1]['all_shaft_bytes'] / 1024:.0f} | "
            f"{built} | {frac} |")


def main():
    args = sys.argv[1:]
    if not args:
        print(__doc__)
        sys.exit(2)
    out = args[0]
    opt = lambda k, d: args[args.index(k) + 1] if k in args else d
    tables, moves, eps = int(opt("--tables", "15")), int(opt("--moves", "100")), opt("--eps", "1")
    rhier = opt("--rhier", "target/release/rhier")
    os.makedirs(out, exist_ok=True)
    door = opt("--scene", "chair") == "door"
    sc, n = scene(tables, door)
    path = os.path.join(out, "room.json")
    with open(path, "w") as f:
        json.dump(sc, f)
    print(f"{n} polygons -> {path}", file=sys.stderr)
    print("| path | shafts | median ms | p95 ms | shaft ms (median) | rows ms (median) | "
          "resident KiB (last) | all shafts KiB | built on the fly (after move 2) | ready (after move 2) |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    want_paths = opt("--paths", "straight,curved,jittery").split(",")
    want_modes = opt("--modes", DEFAULT_MODES).split(",")
    if door:
        runs = {"swing": swing(moves)}
        want_paths = ["swing"]
    else:
        runs = {name: [{"object": "chair", "translation": t} for t in ts] for name, ts in paths(moves).items()}
    movable = "door" if door else "chair"
    for name, lines in runs.items():
        if name not in want_paths:
            continue
        mv = os.path.join(out, f"{name}.jsonl")
        with open(mv, "w") as f:
            for line in lines:
                f.write(json.dumps(line) + "\n")
        for mode, flags in MODES.items():
            if mode not in want_modes:
                continue
            st = os.path.join(out, f"{name}-{mode}.jsonl")
            cmd = [rhier, "interact", path, "--movable", movable, "--moves", mv, "--stats", st,
                   "--eps", eps, "-q"] + flags
            if "--stats-only" not in args:
                subprocess.run(cmd, check=True)
            rows = [json.loads(l) for l in open(st)]
            print(row(name, mode, rows))


if __name__ == "__main__":
    main()
