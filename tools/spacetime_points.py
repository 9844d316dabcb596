#!/usr/bin/env python3
"""Point by point errors of stored animation solutions (issue 4's stains).

`tools/spacetime_bench.py` reports the relative RMS error over all probe points and
times, and the worst time. A shadow edge that a line in time drags for a few frames
(the paper's "stains", section 5.2) can leave both almost unchanged while one point
is far off. This script probes `.rhier` files at the static probe grid and the
reference times that `spacetime_bench.py` left in OUT_DIR (its cached references,
seeds 1 + 2, averaged as there) and prints, per file:
    rms      relative RMS error over points, channels and times (the bench's error);
    worst    the largest point error: at one point and time, the RMS over the three
             channels of B - B_ref, divided by the RMS of B_ref over everything;
    p99, p999  the 99th and 99.9th percentiles of those point errors;
    moving   where `spacetime_bench.py` left the moving objects' probes
             (NAME_moving_points_tI.json): their relative RMS error (the bench's
             `error_moving`), the share of its squared error on the probes facing
             down (normal y below -0.9: ACTOR's actors' bottom faces, 1 cm over the
             floor, carry 74-93% of it, BENCHMARKS.md "Space-time against frame by
             frame") and the error of the other probes alone.

Usage (after a `spacetime_bench.py` run of the same scene into OUT_DIR):
    python3 tools/spacetime_points.py --rhier target/release/rhier --scene actor \\
        --out-dir /tmp/bench FILE.rhier [FILE.rhier ...] \\
        [--ref-fps 5] [--ref-eps 0.1] [--ref-seeds 1,2]
"""

import argparse
import json
import math
import os
import sys

from spacetime_bench import average, frame_times, probe_all, relative_rms, scene_path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rhier", required=True, help="the rhier binary that probes")
    ap.add_argument("--scene", required=True, help="the scene's name, as given to spacetime_bench.py")
    ap.add_argument("--out-dir", required=True, help="spacetime_bench.py's --out-dir")
    ap.add_argument("--ref-fps", type=float, default=5.0)
    ap.add_argument("--ref-eps", type=float, default=0.1)
    ap.add_argument("--ref-seeds", default="1,2")
    ap.add_argument("files", nargs="+", help=".rhier files to measure")
    a = ap.parse_args()
    scene_file = scene_path(a.scene)
    stem = os.path.splitext(os.path.basename(scene_file))[0]
    points = os.path.join(a.out_dir, f"{stem}_points.json")
    refs = [os.path.join(a.out_dir, f"{stem}_ref_fps{a.ref_fps:g}_eps{a.ref_eps:g}_seed{s}.rhier")
            for s in a.ref_seeds.split(",")]
    for f in [points] + refs:
        if not os.path.exists(f):
            sys.exit(f"spacetime_points: {f} is missing: run tools/spacetime_bench.py "
                     f"--scene {a.scene} --out-dir {a.out_dir} first")
    with open(scene_file) as fh:
        domain = json.load(fh)["time"]
    times = frame_times(domain["start"], domain["end"], a.ref_fps)
    ref = average([probe_all(a.rhier, r, points, times) for r in refs])
    moving = [os.path.join(a.out_dir, f"{stem}_moving_points_t{i}.json") for i in range(len(times))]
    if not all(os.path.exists(m) for m in moving):
        moving = None
    if moving:
        ref_moving = average([probe_all(a.rhier, r, moving, times) for r in refs])
        with open(moving[0]) as fh:
            down = [q["n"][1] < -0.9 for q in json.load(fh)]
    den = sum(b[k] ** 2 for frame in ref for b in frame for k in range(3))
    count = sum(3 for frame in ref for _ in frame)
    rms_ref = math.sqrt(den / count)
    for f in a.files:
        values = probe_all(a.rhier, f, points, times)
        errs = sorted(
            math.sqrt(sum((b[k] - r[k]) ** 2 for k in range(3)) / 3) / rms_ref
            for vf, rf in zip(values, ref)
            for b, r in zip(vf, rf)
        )

        def pick(q):
            return errs[min(len(errs) - 1, int(q * len(errs)))]

        print(f"{os.path.basename(f)}: rms {100 * relative_rms(values, ref):.3f}%  "
              f"worst {100 * errs[-1]:.1f}%  p99 {100 * pick(0.99):.1f}%  "
              f"p999 {100 * pick(0.999):.1f}%" + (moving_errors(a.rhier, f, moving, times, ref_moving, down)
                                                   if moving else ""))


def moving_errors(rhier, f, moving, times, ref, down):
    """The moving probes' RMS error, the share of its square on the probes facing
    down, and the RMS error of the others."""
    values = probe_all(rhier, f, moving, times)
    sq = [0.0, 0.0]
    den = [0.0, 0.0]
    for vf, rf in zip(values, ref):
        for b, r, d in zip(vf, rf, down):
            for k in range(3):
                sq[d] += (b[k] - r[k]) ** 2
                den[d] += r[k] ** 2
    total = sq[0] + sq[1]
    share = sq[1] / total if total > 0 else 0.0
    rest = math.sqrt(sq[0] / den[0]) if den[0] > 0 else 0.0
    return (f"  moving {100 * math.sqrt(total / (den[0] + den[1])):.2f}% "
            f"({sum(down)} facing down: {100 * share:.0f}% of its square; the rest {100 * rest:.2f}%)")


if __name__ == "__main__":
    main()
