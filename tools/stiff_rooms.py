#!/usr/bin/env python3
"""Stiff scenes: ACTOR's room with every reflectance set to one value, solved by
`rhier solve` and compared with `rhier reference` (BENCHMARKS.md, "Stiff scenes").

The scene is formats/examples/actor.json placed as it stands at t = 0 (the actors
moved and turned there, no motion left), so it is a static scene. For each
reflectance and eps it prints the solver's mean over probe points against the path
tracer's (per channel; points inside a solid left out), the relative RMS error over
points and channels with the path tracer's own share of it (its standard errors, same
measure), the mean and the RMS of the point-by-point relative error (each point
weighs the same), the solver's estimated error and the power the solution absorbs
over the power the scene emits (the solve's summary line). `--rho scene` keeps the
scene's own reflectances. References are kept in --out by a hash of the scene, the
points and the paths, and made again only when one of those changes.

Probe points: `--points` points drawn by area over the room's static polygons
(seeded), the same for every run.

Usage:
  python3 tools/stiff_rooms.py --rhier target/release/rhier --rho 0.5,0.9,0.99 \\
      --eps 0.5,0.25,0.125 --out /tmp/stiff
"""

import argparse
import hashlib
import json
import random
import re
import subprocess
import sys
from pathlib import Path


def rotate(q, v):
    """Vector v turned by the unit quaternion q = [x, y, z, w]."""
    x, y, z, w = q
    # t = 2 q × v; v' = v + w t + q × t
    t = [2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])]
    c = [y * t[2] - z * t[1], z * t[0] - x * t[2], x * t[1] - y * t[0]]
    return [v[i] + w * t[i] + c[i] for i in range(3)]


def placed_at_start(scene):
    """The scene with each moving object placed by its first key, motion removed."""
    for o in scene["objects"]:
        motion = o.pop("motion", None)
        if motion:
            key = motion[0]
            tr, q = key["translation"], key["rotation"]
            for p in o["polygons"]:
                p["vertices"] = [
                    [a + b for a, b in zip(rotate(q, v), tr)] for v in p["vertices"]
                ]
    scene.pop("time", None)
    return scene


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return sum(x * x for x in a) ** 0.5


def area_points(scene, count, seed):
    """`count` points drawn by area over the polygons of the static objects."""
    rng = random.Random(seed)
    tris = []
    for o in scene["objects"]:
        if o["name"].startswith("actor"):
            continue
        for p in o["polygons"]:
            v = p["vertices"]
            n = cross(sub(v[1], v[0]), sub(v[2], v[0]))
            n = [x / norm(n) for x in n]
            for i in range(1, len(v) - 1):
                a = 0.5 * norm(cross(sub(v[i], v[0]), sub(v[i + 1], v[0])))
                tris.append((a, v[0], v[i], v[i + 1], n))
    total = sum(t[0] for t in tris)
    pts = []
    for _ in range(count):
        r = rng.random() * total
        for a, p0, p1, p2, n in tris:
            r -= a
            if r <= 0:
                break
        u, w = rng.random(), rng.random()
        if u + w > 1:
            u, w = 1 - u, 1 - w
        x = [p0[i] + u * (p1[i] - p0[i]) + w * (p2[i] - p0[i]) for i in range(3)]
        pts.append({"p": x, "n": n})
    return pts


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rhier", default="target/release/rhier")
    ap.add_argument("--scene", default="formats/examples/actor.json")
    ap.add_argument("--rho", default="0.5,0.9,0.99",
                    help="comma-separated reflectances; 'scene' keeps the scene's own")
    ap.add_argument("--eps", default="0.5", help="comma-separated eps values")
    ap.add_argument("--points", type=int, default=40)
    ap.add_argument("--paths", type=int, default=20000, help="reference paths per point")
    ap.add_argument("--seed", type=int, default=3, help="seed of the probe points")
    ap.add_argument("--out", default="/tmp/stiff", help="working directory")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    base = placed_at_start(json.loads(Path(a.scene).read_text()))
    pts_path = out / "points.json"
    pts_path.write_text(json.dumps(area_points(base, a.points, a.seed)))
    print("rho,eps,solver_mean_rgb,reference_mean_rgb,ratio_rgb,rms_error,reference_noise,"
          "point_bias,point_rms,estimated_error,absorbed_over_emitted")
    for rho in a.rho.split(","):
        scene = json.loads(json.dumps(base))
        if rho != "scene":
            for m in scene["materials"].values():
                m["reflectance"] = [float(rho)] * 3
        sp = out / f"room_{rho}.json"
        sp.write_text(json.dumps(scene))
        # The reference is kept by what it depends on: the scene, the points, the paths.
        key = hashlib.sha1((sp.read_text() + pts_path.read_text() + str(a.paths)).encode())
        ref_path = out / f"ref_{rho}_{key.hexdigest()[:12]}.json"
        if not ref_path.exists():
            tmp = ref_path.with_suffix(".part")
            subprocess.run(
                [a.rhier, "reference", str(sp), "--points", str(pts_path), "--paths",
                 str(a.paths), "-o", str(tmp)],
                check=True,
            )
            tmp.rename(ref_path)
        refs = json.loads(ref_path.read_text())
        # A point inside a solid (the wall behind the shelf) has no answer: the path
        # tracer finds no facing surface there or no light reaches it (below 1e-3 of
        # the mean); it is left out of the comparison.
        mean = sum(sum(r["B"]) for r in refs) / len(refs)
        keep = [i for i, r in enumerate(refs) if sum(r["B"]) > 1e-3 * mean]
        refs = [refs[i] for i in keep]
        ref = [r["B"] for r in refs]
        den = sum(b[c] ** 2 for b in ref for c in range(3))
        noise = (sum(r["std_error"][c] ** 2 for r in refs for c in range(3)) / den) ** 0.5
        rmean = [sum(b[c] for b in ref) / len(ref) for c in range(3)]
        for eps in [float(x) for x in a.eps.split(",")]:
            rh = out / f"room_{rho}_{eps}.rhier"
            run = subprocess.run(
                [a.rhier, "solve", str(sp), "--eps", str(eps), "-o", str(rh)],
                check=True, capture_output=True, text=True,
            )
            last = run.stderr.strip().splitlines()[-1]
            est = re.search(r"estimated error ([^,;]+)", last).group(1)
            bal = re.search(r"absorbs ([^ ]+) of the emitted power", last)
            pr = subprocess.run(
                [a.rhier, "probe", str(rh), "--points", str(pts_path)],
                check=True, capture_output=True, text=True,
            )
            probed = json.loads(pr.stdout)
            got = [probed[i]["B"] for i in keep]
            smean = [sum(b[c] for b in got) / len(got) for c in range(3)]
            ratio = [smean[c] / rmean[c] for c in range(3)]
            num = sum((g[c] - b[c]) ** 2 for g, b in zip(got, ref) for c in range(3))
            rms = (num / den) ** 0.5
            # Point by point: each point weighs the same, lamp or dark corner.
            rel = [g[c] / b[c] - 1 for g, b in zip(got, ref) for c in range(3)]
            bias_pt = sum(rel) / len(rel)
            rms_pt = (sum(x * x for x in rel) / len(rel)) ** 0.5
            fmt = lambda v: "/".join(f"{x:.4g}" for x in v)
            print(f"{rho},{eps},{fmt(smean)},{fmt(rmean)},{fmt(ratio)},{rms:.4f},{noise:.4f},"
                  f"{bias_pt:+.4f},{rms_pt:.4f},{est},"
                  f"{bal.group(1) if bal else 'n/a'}")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
