#!/usr/bin/env python3
"""LIGHT at t = 0: error of the static solve on 50 points of the left wall (facing the
wall lamp) against the path tracer (`rhier reference`), per eps and binary.

usage: tools/light_left_wall.py SCENE_JSON OUT_DIR RHIER [RHIER ...] [--paths N]

SCENE_JSON is LIGHT at t = 0 without motion, written by
`LIGHT_T0_OUT=light_t0.json cargo test --release --test it
solver::cluster_links::write_light_at_t0 -- --ignored`. The reference is cached in OUT_DIR. Prints one line per binary
and eps: relative RMS error and the best of 3 wall-clock run times.
"""
import argparse
import json
import math
import os
import subprocess
import time


def points():
    # 5 heights x 10 depths on the left wall x = 0 (room 5 x 2.7 x 4), inset.
    return [{"p": [0.0, 0.2 + 2.3 * i / 4, 0.2 + 3.6 * k / 9], "n": [1.0, 0.0, 0.0]}
            for i in range(5) for k in range(10)]


def rel_rms(b, r):
    num = sum((x - y) ** 2 for bb, rr in zip(b, r) for x, y in zip(bb, rr))
    den = sum(y * y for rr in r for y in rr)
    return math.sqrt(num / den)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("rhier", nargs="+")
    ap.add_argument("--paths", type=int, default=100000)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    ppath = os.path.join(args.out, "light_left_wall_points.json")
    json.dump(points(), open(ppath, "w"))
    rpath = os.path.join(args.out, f"light_left_wall_reference_{args.paths}.json")
    if not os.path.exists(rpath):
        subprocess.run([args.rhier[0], "reference", args.scene, "--points", ppath,
                        "--paths", str(args.paths), "-o", rpath], check=True)
    ref = [r["B"] for r in json.load(open(rpath))]
    for exe in args.rhier:
        for eps in (0.5, 0.25, 0.1):
            out = os.path.join(args.out, "probe.json")
            cmd = [exe, "solve", args.scene, "--eps", str(eps), "--quiet", "--probe", ppath,
                   "--probe-out", out, "-o", os.path.join(args.out, "tmp.rhier")]
            best = None
            for _ in range(3):
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True)
                dt = time.perf_counter() - t0
                best = dt if best is None else min(best, dt)
            b = [r["B"] for r in json.load(open(out))]
            print(f"{exe} eps {eps:<5} {best:7.3f} s  error {rel_rms(b, ref):.4f}", flush=True)


if __name__ == "__main__":
    main()
