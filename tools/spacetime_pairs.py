#!/usr/bin/env python3
"""Paired timing of space-time against per-frame (issue 4's speed and memory ratios).

On a shared VM the wall time of one command moves by 10-20% from one minute to the
next, for both methods alike. A ratio taken from runs made at different times then
measures the minutes as much as the methods. This script runs the two commands in
alternation, per-frame first, `--pairs` times, and reports each pair's time ratio
and peak-RSS ratio. It measures time and memory only. The error of each setting
comes from `tools/spacetime_bench.py`, which runs the probes; the outputs are
deterministic, so the error of a setting does not change from run to run.

Usage:
    python3 tools/spacetime_pairs.py --rhier target/release/rhier --scene actor \\
        --per-frame "--eps 0.35 --recon-tol 0.16" \\
        --space-time "--eps 1 --recon-tol 0.10 --recon-tol-moving 0.08" \\
        [--pairs 3] [--threads 2] [--fps 25] [--out-dir /tmp/pairs]

--scene takes a builtin name with a JSON example (actor, light, ...:
formats/examples/NAME.json) or a scene path. The per-frame command is
    rhier solve SCENE --per-frame --fps FPS PER_FRAME_ARGS -o OUT -q --threads T
and the space-time command
    rhier solve SCENE SPACE_TIME_ARGS -o OUT -q --threads T
Each run's wall time, peak RSS and CPU time (user + system) come from
/usr/bin/time. The script prints one line per run (with the cores it kept busy)
and, at the end, the ratios per pair and their range, and the CPU-time ratio: the
speed-up both methods would show if they used the cores alike.
"""

import argparse
import os
import shlex
import shutil
import sys
import time

from spacetime_bench import run_timed, scene_path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rhier", required=True, help="the rhier binary to time")
    ap.add_argument("--scene", required=True, help="a scene of formats/examples by name (actor, light, ...) or a file")
    ap.add_argument(
        "--per-frame",
        required=True,
        help='per-frame\'s settings, e.g. "--eps 0.35 --recon-tol 0.16" '
        "(the tool adds the scene, --per-frame --fps, -o, -q and --threads)",
    )
    ap.add_argument(
        "--space-time",
        required=True,
        help='space-time\'s settings, e.g. "--eps 1 --recon-tol 0.10" '
        "(the tool adds the scene, -o, -q and --threads)",
    )
    ap.add_argument("--pairs", type=int, default=3, help="pairs of runs, alternated")
    ap.add_argument("--threads", type=int, default=2, help="--threads of both methods")
    ap.add_argument("--fps", type=float, default=25.0, help="per-frame's --fps")
    ap.add_argument("--out-dir", default="/tmp/spacetime_pairs", help="the runs' files and logs")
    a = ap.parse_args()
    if a.pairs < 1:
        sys.exit("spacetime_pairs: --pairs must be at least 1")
    # Without it run_timed falls back to the largest child so far, not each run's.
    if not (shutil.which("time") or os.path.exists("/usr/bin/time")):
        sys.exit("spacetime_pairs: needs /usr/bin/time for each run's peak RSS")
    os.makedirs(a.out_dir, exist_ok=True)
    scene = scene_path(a.scene)
    common = ["-q", "--threads", str(a.threads)]
    pf_out = os.path.join(a.out_dir, "per_frame.rhier")
    st_out = os.path.join(a.out_dir, "space_time.rhier")
    pf_cmd = ([a.rhier, "solve", scene, "--per-frame", "--fps", repr(a.fps)]
              + shlex.split(a.per_frame) + ["-o", pf_out] + common)
    st_cmd = ([a.rhier, "solve", scene] + shlex.split(a.space_time)
              + ["-o", st_out] + common)
    print(f"per-frame:  {shlex.join(pf_cmd)}")
    print(f"space-time: {shlex.join(st_cmd)}")
    print(f"started {time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}")
    ratios = []

    def line(i, name, r):
        busy = f"  {r[2]:7.2f} s CPU ({100 * r[2] / r[0]:.0f}%)" if r[2] is not None else ""
        print(f"pair {i + 1}: {name:<10} {r[0]:7.2f} s  {r[1]:6.1f} MiB{busy}", flush=True)

    for i in range(a.pairs):
        pf = run_timed(pf_cmd, os.path.join(a.out_dir, f"pf{i}.log"))
        line(i, "per-frame", pf)
        st = run_timed(st_cmd, os.path.join(a.out_dir, f"st{i}.log"))
        line(i, "space-time", st)
        cpu = pf[2] / st[2] if pf[2] and st[2] else None
        ratios.append((pf[0] / st[0], st[1] / pf[1], cpu))
    print(f"ended {time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}")
    print("speed-up per pair: " + " / ".join(f"{r[0]:.2f}x" for r in ratios))
    if all(r[2] is not None for r in ratios):
        # The work ratio: what the speed-up would be if both used the cores alike.
        print("CPU-time ratio per pair: " + " / ".join(f"{r[2]:.2f}x" for r in ratios))
    print("peak RSS, space-time / per-frame: " + " / ".join(f"{r[1]:.2f}x" for r in ratios))
    lo, hi = min(r[0] for r in ratios), max(r[0] for r in ratios)
    print(f"speed-up range {lo:.2f}-{hi:.2f}x over {a.pairs} pairs")


if __name__ == "__main__":
    main()
