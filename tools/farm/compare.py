#!/usr/bin/env python3
"""Compares two `.rhier` files of one animation frame by frame (issue 50: a farm's
merged file against the single-machine solve).

Probes both at every frame (`--fps`, the solve's) at 200 points on the static,
non-emitting surfaces and 100 on the moving objects (the grids of
`tools/spacetime_bench.py`), and prints per frame the relative RMS difference
(sqrt(sum (B_a - B_b)^2 / sum B_b^2) over points and channels), then the worst and
mean frames. Exits 1 if a frame differs by more than `--tol` (default 0.005).

First it compares the two files' chunks (the leaves of each window, as stored):
if every chunk is byte for byte the same, every probe is too, and it says so
without probing (unless `--probe`).

Usage: python3 tools/farm/compare.py --rhier BIN --scene SCENE.json [--fps 25]
           [--every K] [--tol 0.005] [--probe] MERGED.rhier SINGLE.rhier
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from spacetime_bench import frame_times, moving_grid, placed, probe_all, probe_grid, relative_rms  # noqa: E402


def chunks(rhier, path):
    """The stored bytes of every chunk section of `path`, in file order."""
    out = subprocess.run([rhier, "inspect", "--json", "--no-verify", path],
                         check=True, capture_output=True, text=True).stdout
    with open(path, "rb") as f:
        data = f.read()
    return [data[s["offset"]:s["offset"] + s["stored_bytes"]]
            for s in json.loads(out)["memory"]["sections"] if s["kind"] == "chunk"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rhier", required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--fps", type=float, default=25.0)
    ap.add_argument("--every", type=int, default=1, help="probe every K-th frame")
    ap.add_argument("--tol", type=float, default=0.005)
    ap.add_argument("--quiet", action="store_true", help="print the summary only")
    ap.add_argument("--probe", action="store_true", help="probe even if the chunks are the same")
    ap.add_argument("a")
    ap.add_argument("b", help="the reference (the single-machine solve)")
    args = ap.parse_args()
    ca, cb = chunks(args.rhier, args.a), chunks(args.rhier, args.b)
    if ca == cb and not args.probe:
        print(f"{len(ca)} chunks, byte for byte the same: every frame identical")
        return
    with open(args.scene) as f:
        scene = json.load(f)
    times = frame_times(scene["time"]["start"], scene["time"]["end"], args.fps)[:: args.every]
    tmp = tempfile.mkdtemp(prefix="rhier-compare-")
    static = os.path.join(tmp, "static.json")
    with open(static, "w") as f:
        json.dump(probe_grid(scene, 200), f)
    grid = moving_grid(scene, 100)
    files = []
    for i, t in enumerate(times):
        pf = os.path.join(tmp, f"t{i}.json")
        with open(pf, "w") as f:
            json.dump(json.load(open(static)) + (placed(scene, grid, t) if grid else []), f)
        files.append(pf)
    va = probe_all(args.rhier, args.a, files, times)
    vb = probe_all(args.rhier, args.b, files, times)
    errs = [relative_rms([fa], [fb]) for fa, fb in zip(va, vb)]
    if not args.quiet:
        for t, e in zip(times, errs):
            print(f"t = {t:8.3f}  relative RMS difference {100 * e:.4f}%")
    worst = max(range(len(errs)), key=lambda i: errs[i])
    mean = sum(errs) / len(errs)
    exact = sum(1 for e in errs if e == 0.0)
    print(f"{len(times)} frames: worst {100 * errs[worst]:.4f}% at t = {times[worst]:.3f}, "
          f"mean {100 * mean:.4f}%, {exact} frames identical, overall {100 * relative_rms(va, vb):.4f}%")
    sys.exit(1 if errs[worst] > args.tol else 0)


if __name__ == "__main__":
    main()
