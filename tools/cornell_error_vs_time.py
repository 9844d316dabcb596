#!/usr/bin/env python3
"""Error against run time on the Cornell box, whole process, versus the path-traced
reference (`rhier reference`). Writes a CSV and prints a table.

usage: tools/cornell_error_vs_time.py RHIER_BINARY OUT_DIR [--paths N] [--threads T]
                                        [--runs R] [--eps LIST] [--scenes LIST]
                                        [-- SOLVE_ARGS...]

--eps takes a comma-separated list (default 1,0.5,0.25,0.1,0.05,0.02), --scenes
`empty`, `blocks` or both (default `empty,blocks`).

Each setting runs R times (default 3); the table gives the best wall time and the
least processor time (user + system of the solve process), which a loaded machine
inflates less than the wall time.

Arguments after `--` go to every `rhier solve` (e.g. `-- --recon-tol 0.02
--no-contact-meshing`, to measure a setting against the default).

The worst point: of the grid points off the lamp (and apart, of the contact
points), the one whose largest channel is furthest from the reference, relative
to the reference's largest channel.

Probe points: a 3 x 3 grid on every published polygon (inset, triangles strictly
inside), plus, with the
blocks, points on the floor 2, 5, 10, 20, 40 mm from the middle of every block base
edge and on the block sides at those heights (where published hierarchical systems
are 25-65% too dark). The reference is computed once per scene and cached in OUT_DIR.
"""
import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time


def grid_points(polys, k=3):
    pts = []
    for p in polys:
        v = p["vertices"]
        n = normal(v)
        for a in range(k):
            for b in range(k):
                u, w = (a + 0.5) / k, (b + 0.5) / k
                if len(v) == 3:
                    # Square to triangle, strictly inside (folding the square at
                    # u + w = 1 put a third of the points on the long edge: on the
                    # Cornell left wall, in the corners with the back wall and ceiling).
                    u, w = 1 - math.sqrt(u), math.sqrt(u) * w
                    x = [v[0][i] + u * (v[1][i] - v[0][i]) + w * (v[2][i] - v[0][i]) for i in range(3)]
                else:
                    x = [(1 - u) * (1 - w) * v[0][i] + u * (1 - w) * v[1][i] + u * w * v[2][i] + (1 - u) * w * v[3][i] for i in range(3)]
                pts.append({"p": x, "n": n})
    return pts


def normal(v):
    s = [0.0, 0.0, 0.0]
    for i in range(1, len(v) - 1):
        a = [v[i][k] - v[0][k] for k in range(3)]
        b = [v[i + 1][k] - v[0][k] for k in range(3)]
        c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        s = [s[k] + c[k] for k in range(3)]
    l = math.sqrt(sum(x * x for x in s))
    return [x / l for x in s]


def contact_points(polys, ds=(2.0, 5.0, 10.0, 20.0, 40.0)):
    pts = []
    for p in polys:
        v = p["vertices"]
        n = normal(v)
        if abs(n[1]) > 0.1:
            continue
        for k in range(len(v)):
            a, b = v[k], v[(k + 1) % len(v)]
            if abs(a[1]) < 1e-6 and abs(b[1]) < 1e-6:
                m = [(a[i] + b[i]) / 2 for i in range(3)]
                h = math.hypot(n[0], n[2])
                out = [n[0] / h, 0.0, n[2] / h]
                for d in ds:
                    pts.append({"p": [m[0] + out[0] * d, 0.0, m[2] + out[2] * d], "n": [0, 1, 0]})
                    pts.append({"p": [m[0], d, m[2]], "n": n})
    return pts


def rel_rms(b, r):
    num = sum((x - y) ** 2 for bb, rr in zip(b, r) for x, y in zip(bb, rr))
    den = sum(y * y for rr in r for y in rr)
    return math.sqrt(num / den)


def worst_point(b, r, idx):
    """The point of `idx` whose largest channel difference is largest against its
    reference's largest channel: (relative error, index)."""
    best = (0.0, -1)
    for i in idx:
        d = max(abs(x - y) for x, y in zip(b[i], r[i])) / max(max(r[i]), 1e-12)
        best = max(best, (d, i))
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rhier")
    ap.add_argument("out")
    ap.add_argument("--paths", type=int, default=100000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--eps", default="1,0.5,0.25,0.1,0.05,0.02", help="comma-separated eps values")
    ap.add_argument("--scenes", default="empty,blocks", help="empty, blocks or both, comma-separated")
    argv, solve_args = sys.argv[1:], []
    if "--" in argv:
        i = argv.index("--")
        argv, solve_args = argv[:i], argv[i + 1:]
    args = ap.parse_args(argv)
    eps_list = [float(e) for e in args.eps.split(",")]
    scenes = args.scenes.split(",")
    if not scenes or any(sc not in ("empty", "blocks") for sc in scenes):
        ap.error(f"--scenes: expected empty, blocks or both, found {args.scenes}")
    os.makedirs(args.out, exist_ok=True)
    here = os.path.dirname(os.path.abspath(__file__))
    rows = []
    for blocks in [sc == "blocks" for sc in scenes]:
        name = "cornell_blocks" if blocks else "cornell"
        scene = json.load(open(os.path.join(here, "..", "formats", "examples", name + ".json")))
        polys = [p for o in scene["objects"] for p in o["polygons"]]
        pts = grid_points(polys)
        n_grid = len(pts)
        # Points on emitters (B = E + a little) dominate a relative RMS: the error
        # on the lit surfaces alone is reported too.
        emits = [("emission" in scene["materials"][p["material"]]) for p in polys for _ in range(9)]
        if blocks:
            pts += contact_points(polys)
        ppath = os.path.join(args.out, name + "_points.json")
        json.dump(pts, open(ppath, "w"))
        rpath = os.path.join(args.out, f"{name}_reference_{args.paths}.json")
        if not os.path.exists(rpath):
            flag = ["--blocks"] if blocks else []
            subprocess.run([args.rhier, "reference", *flag, "--points", ppath, "--paths", str(args.paths), "-o", rpath], check=True)
        ref = [r["B"] for r in json.load(open(rpath))]
        for eps in eps_list:
            out = os.path.join(args.out, "probe.json")
            flag = ["--blocks"] if blocks else []
            cmd = [args.rhier, "solve", *flag, "--eps", str(eps), "--threads", str(args.threads), "--quiet",
                   "--probe", ppath, "--probe-out", out, "-o", os.path.join(args.out, "tmp.rhier"), *solve_args]
            best, cpu = None, None
            for _ in range(args.runs):
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True)
                dt = time.perf_counter() - t0
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                c = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
                best = dt if best is None else min(best, dt)
                cpu = c if cpu is None else min(cpu, c)
            b = [r["B"] for r in json.load(open(out))]
            err = rel_rms(b, ref)
            err_grid = rel_rms(b[:n_grid], ref[:n_grid])
            err_contact = rel_rms(b[n_grid:], ref[n_grid:]) if len(b) > n_grid else float("nan")
            lit = [i for i in range(len(b)) if i >= n_grid or not emits[i]]
            err_lit = rel_rms([b[i] for i in lit], [ref[i] for i in lit])
            at = lambda i: "(" + " ".join(f"{c:.0f}" for c in pts[i]["p"]) + ")"
            worst, wi = worst_point(b, ref, [i for i in lit if i < n_grid])
            line = f"worst grid point {worst:.4f} at {at(wi)}"
            worst_c, wc = worst_point(b, ref, range(n_grid, len(b)))
            if wc >= 0:
                line += f", worst contact point {worst_c:.4f} at {at(wc)}"
            rows.append((name, eps, best, cpu, err, err_grid, err_contact, err_lit, worst, at(wi), worst_c if wc >= 0 else float("nan")))
            print(f"{name:15s} eps {eps:<5} {best:7.3f} s  cpu {cpu:7.3f} s  off the lamp {err_lit:.4f}  contact {err_contact:.4f}  {line}  (all points {err:.4f}, grid {err_grid:.4f})", flush=True)
    with open(os.path.join(args.out, "cornell_error_vs_time.csv"), "w") as f:
        f.write("scene,eps,seconds,cpu_seconds,error,error_grid,error_contact,error_non_emitters,worst_grid_error,worst_grid_point,worst_contact_error\n")
        for r in rows:
            f.write(",".join(str(x) for x in r) + "\n")


if __name__ == "__main__":
    main()
