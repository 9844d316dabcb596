#!/usr/bin/env python3
"""The 100k-polygon benchmark of issue 48 end to end (BENCHMARKS.md, "Scale"):
generate `tools/gen_cubes.py N` and its 100 probes, solve under `/usr/bin/time -v`,
path-trace the probes with `rhier reference`, and print one table row: polygons,
seconds, peak RSS, links, the error off the emitters (`tools/cube_error.py`: RMS over
the probes, none of which lies on the lamp) with the worst point beside it.

usage: tools/scale_bench.py RHIER N OUTDIR [--paths P] [--threads T]
                            [--label L] [-- SOLVE FLAGS...]

  RHIER    the rhier binary (target/release/rhier)
  N        boxes per side (129: 99 853 polygons; 65: 25 357)
  OUTDIR   where the scene, probes, reference and solve outputs go; a reference
           already there for the same N and P is reused (path tracing is the
           slow part at small N)
  --paths  paths per probe of the reference (default 50000: standard errors
           below 0.5%)
  --threads  solver threads (default 2)
  --label  the row's first column (default `gen_cubes N`)
  flags after `--` go to `rhier solve` (e.g. `-- --eps 0.25`)
"""
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cube_error  # noqa: E402


def run(cmd, log):
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({r.returncode}); see {log}")


def main():
    args = sys.argv[1:]
    extra = []
    if "--" in args:
        k = args.index("--")
        args, extra = args[:k], args[k + 1 :]
    opts = {"--paths": "50000", "--threads": "2", "--label": None}
    rest = []
    i = 0
    while i < len(args):
        if args[i] in opts:
            if i + 1 >= len(args):
                sys.exit(f"{args[i]}: expected a value\n{__doc__}")
            opts[args[i]] = args[i + 1]
            i += 2
        else:
            rest.append(args[i])
            i += 1
    if len(rest) != 3:
        sys.exit(__doc__)
    rhier, n, out = rest[0], int(rest[1]), rest[2]
    os.makedirs(out, exist_ok=True)
    scene = os.path.join(out, f"cubes{n}.json")
    probes = os.path.join(out, f"probes{n}.json")
    ref = os.path.join(out, f"ref{n}_{opts['--paths']}.json")
    res = os.path.join(out, f"solve{n}.json")
    run([sys.executable, os.path.join(HERE, "gen_cubes.py"), str(n), scene], scene + ".log")
    run([sys.executable, os.path.join(HERE, "gen_cube_probes.py"), str(n), probes], probes + ".log")
    polygons = sum(len(o["polygons"]) for o in json.load(open(scene))["objects"])

    solve_log = os.path.join(out, f"solve{n}.log")
    report = os.path.join(out, f"solve{n}_rounds.csv")
    cmd = ["/usr/bin/time", "-v", rhier, "solve", scene, "--threads", opts["--threads"],
           "--probe", probes, "--probe-out", res, "--report", report, "--stats",
           "-o", os.devnull] + extra
    t0 = time.time()
    run(cmd, solve_log)
    wall = time.time() - t0
    log = open(solve_log).read()
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", log)
    peak_mb = int(m.group(1)) / 1024 if m else float("nan")

    if not os.path.exists(ref):
        run([rhier, "reference", scene, "--points", probes, "--paths", opts["--paths"],
             "-o", ref], ref + ".log")
    err = cube_error.error(json.load(open(ref)), json.load(open(res)))

    rows = list(open(report).read().splitlines())
    links = ""
    if len(rows) > 1:
        head = rows[0].split(",")
        last = dict(zip(head, rows[-1].split(",")))
        if "links_active" in last:
            links = f"{int(last['links_active']) / 1e6:.1f}M / {int(last['links_passive']) / 1e6:.1f}M"
        solve_s = float(last.get("seconds", "nan"))
    else:
        solve_s = float("nan")
    label = opts["--label"] or f"`gen_cubes {n}`" + (f" `{' '.join(extra)}`" if extra else "")
    w = err["worst"]
    print(f"# rounds {solve_s:.0f} s, reconstruction and write {wall - solve_s:.0f} s; "
          f"{err['line']}")
    print(f"| {label} | {polygons} | {wall:.0f} | "
          f"{peak_mb:.0f} MB | {links} | **{err['rms']:.2f}%** | "
          f"{w['kind']} {w['off']:+.1f}% at ({w['p'][0]:.2f}, {w['p'][1]:.2f}, {w['p'][2]:.2f}) |")


if __name__ == "__main__":
    main()
