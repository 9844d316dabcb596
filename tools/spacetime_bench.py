#!/usr/bin/env python3
"""Error against run time of animation solvers on ACTOR / LIGHT (issue 4 benchmarks).

For one scene it
  1. builds a probe grid over the static surfaces (floor, walls, ceiling, furniture):
     N points, area-weighted, deterministic, written as P.json ([{"p":..,"n":..}]);
  2. makes a fine reference with the per-frame solver
     (`rhier solve SCENE --per-frame --fps REF_FPS --eps REF_EPS --seed S`), one per
     seed of --ref-seeds, cached in OUTDIR, probes each at every reference frame time
     (`rhier probe --time T`) and averages them. The seeds must differ from the
     methods' (the solver's default, 24301): a reference that draws the same rays as
     the method it measures shares its visibility noise and flatters it (ACTOR,
     per-frame eps 0.25: 0.98% against a same-seed reference, 1.35% with --seed 7).
     The RMS difference of two seeds' references, halved, is the averaged
     reference's own noise; it is printed and kept in the CSV's `ref` column;
  3. runs a METHOD command at each eps (placeholders below), --repeat times with the
     eps values interleaved (the median time is kept: on a shared 2-core VM identical
     runs differ by up to 20%), measuring wall time and
     peak RSS of the whole process (/usr/bin/time, else getrusage of the children),
     probes the result at the same times and computes the relative RMS error
         sqrt( sum (B - Bref)^2 / sum Bref^2 )  over points, channels and times,
     and the same at each time alone, whose largest is `error_worst_frame`: an
     error of one instant that the mean over all times would dilute (a moving
     shadow's edge placed late, the paper's "stains", §5.2);
  4. does the same on the moving objects' surfaces (--moving-points points, drawn in
     each object's own space and placed by its motion at every reference time, so a
     probe follows the surface it sits on): `error_moving`, the error a viewer sees
     on the actors and the board, which the static grid does not (0: not measured);
  5. appends rows (method, scene, eps, seconds, peak_rss_mb, error, ...) to a CSV and
     redraws the plots of error (and peak RSS) against run time for every (method,
     scene) in it: the untagged methods, and of the methods tagged with a build
     ("name (hash)") those of the last build in the CSV (`latest_build`).

The method command is a template; placeholders: {rhier} (the binary), {scene} (the
scene file), {eps}, {fps}, {out} (the .rhier file the command must write). Default:
    {rhier} solve {scene} --per-frame --fps {fps} --eps {eps} -o {out} -q
so a space-time solver plugs in as e.g.
    --name space-time --method "{rhier} solve {scene} --eps {eps} -o {out} -q"

Usage:
    python3 tools/spacetime_bench.py --rhier target/release/rhier --scene actor \
        --eps 1.0,0.5 --out-dir out/bench [--fps 25] [--ref-fps 5] [--ref-eps 0.1] \
        [--ref-seeds 1,2] \
        [--points 200] [--csv tools/spacetime_bench.csv] [--name per-frame] \
        [--method TEMPLATE] [--threads 2] [--repeat 1]

--scene takes a builtin name with a JSON example (actor, actor150, actor750, light,
light150, light750: formats/examples/NAME.json) or any native JSON scene path.
    python3 tools/spacetime_bench.py --plot-only [--csv tools/spacetime_bench.csv]

The measurement needs only the standard library. The plots are redrawn from the whole
CSV after every run: an SVG written by hand, and a PNG (one panel per scene, error
against run time and peak RSS against run time) with matplotlib when it is installed
(`pip install matplotlib`; without it only the SVG is written, with a note).
"""

import argparse
import csv
import json
import math
import os
import random
import resource
import shlex
import shutil
import subprocess
import statistics
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_METHOD = "{rhier} solve {scene} --per-frame --fps {fps} --eps {eps} -o {out} -q"
CSV_FIELDS = ["method", "scene", "eps", "seconds", "peak_rss_mb", "error", "frames_compared",
              "ref", "command", "runs", "error_moving", "error_worst_frame"]


def scene_path(name):
    if os.path.exists(name):
        return os.path.abspath(name)
    path = os.path.join(ROOT, "formats", "examples", name + ".json")
    if not os.path.exists(path):
        sys.exit(f"spacetime_bench: no scene file {name!r} and no {path}")
    return path


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return math.sqrt(a[0] ** 2 + a[1] ** 2 + a[2] ** 2)


def probe_grid(scene, n, seed=1):
    """n points on static, non-emitting polygons, area-weighted, inset 5% from the
    edges; points inside another static object's box (a solid resting on a wall or
    the floor) are skipped."""
    mats = scene["materials"]
    static = [o for o in scene["objects"] if not o.get("motion")]

    def box(o):
        vs = [v for p in o["polygons"] for v in p["vertices"]]
        lo = [min(v[k] for v in vs) for k in range(3)]
        hi = [max(v[k] for v in vs) for k in range(3)]
        return lo, hi

    solids = [(o["name"], box(o)) for o in static]
    solids = [(nm, b) for nm, b in solids if all(b[1][k] - b[0][k] > 1e-9 for k in range(3))]
    polys = []
    for o in static:
        for p in o["polygons"]:
            if any(e > 0 for e in mats[p["material"]].get("emission", [0, 0, 0])):
                continue
            area, nrm = polygon_area_normal(p["vertices"])
            if area > 0:
                polys.append((o["name"], p["vertices"], nrm, area))
    draws = surface_points(polys, random.Random(seed))
    points = []
    tries = 0
    while polys and len(points) < n and tries < 100 * n:
        tries += 1
        name, p, nrm = next(draws)
        inside = any(nm != name and all(lo[k] - 1e-9 <= p[k] <= hi[k] + 1e-9 for k in range(3))
                     for nm, (lo, hi) in solids)
        if not inside:
            points.append({"p": p, "n": nrm})
    return points


def surface_points(polys, rng):
    """Endless draws on polygons [(tag, vertices, unit normal, area)] (at least one),
    area-weighted, inset 5% from the edges: (tag, point, normal)."""
    total = sum(p[3] for p in polys)
    while True:
        r = rng.random() * total
        for tag, v, nrm, area in polys:
            r -= area
            if r <= 0:
                break
        u, w = 0.05 + 0.9 * rng.random(), 0.05 + 0.9 * rng.random()
        if len(v) == 4:
            p = [(1 - u) * (1 - w) * v[0][k] + u * (1 - w) * v[1][k] + u * w * v[2][k]
                 + (1 - u) * w * v[3][k] for k in range(3)]
        else:
            if u + w > 1:
                u, w = 1 - u, 1 - w
            p = [v[0][k] + u * (v[1][k] - v[0][k]) + w * (v[2][k] - v[0][k]) for k in range(3)]
        yield tag, p, nrm


def polygon_area_normal(v):
    a = cross(sub(v[1], v[0]), sub(v[2], v[0]))
    if len(v) == 4:
        b = cross(sub(v[2], v[0]), sub(v[3], v[0]))
        a = [a[k] + b[k] for k in range(3)]
    area = 0.5 * norm(a)
    return area, ([x / (2 * area) for x in a] if area > 0 else None)


def moving_grid(scene, n, seed=3):
    """n points on the moving objects' non-emitting polygons, in each object's own
    space: [(object index, point, normal)]."""
    mats = scene["materials"]
    polys = []
    for i, o in enumerate(scene["objects"]):
        if not o.get("motion") or len(o["motion"]) < 2:
            continue
        for p in o["polygons"]:
            if any(e > 0 for e in mats[p["material"]].get("emission", [0, 0, 0])):
                continue
            area, nrm = polygon_area_normal(p["vertices"])
            if area > 0:
                polys.append((i, p["vertices"], nrm, area))
    draws = surface_points(polys, random.Random(seed))
    return [next(draws) for _ in range(n)] if polys else []


def quat_rotate(q, v):
    x, y, z, w = q
    u = [x, y, z]
    t = [2 * c for c in cross(u, v)]
    return [v[k] + w * t[k] + cross(u, t)[k] for k in range(3)]


def key_at(keys, t):
    """The object's placement at t as the solver interpolates its keys (translation and
    scale linear, rotation slerp, held before the first key and after the last)."""
    if len(keys) == 1 or t <= keys[0]["t"]:
        k = keys[0]
        return k["translation"], k["rotation"], k.get("scale", [1, 1, 1])
    if t >= keys[-1]["t"]:
        k = keys[-1]
        return k["translation"], k["rotation"], k.get("scale", [1, 1, 1])
    i = max(1, sum(1 for k in keys if k["t"] <= t))
    k0, k1 = keys[i - 1], keys[i]
    s = (t - k0["t"]) / (k1["t"] - k0["t"])
    lerp = lambda a, b: [a[j] + s * (b[j] - a[j]) for j in range(3)]
    a, b = list(k0["rotation"]), list(k1["rotation"])
    dot = sum(a[j] * b[j] for j in range(4))
    if dot < 0:
        b, dot = [-x for x in b], -dot
    if dot > 1 - 1e-12:
        q = [a[j] + s * (b[j] - a[j]) for j in range(4)]
    else:
        th = math.acos(dot)
        s0, s1 = math.sin(th * (1 - s)) / math.sin(th), math.sin(th * s) / math.sin(th)
        q = [s0 * a[j] + s1 * b[j] for j in range(4)]
    ql = math.sqrt(sum(x * x for x in q))
    return (lerp(k0["translation"], k1["translation"]), [x / ql for x in q],
            lerp(k0.get("scale", [1, 1, 1]), k1.get("scale", [1, 1, 1])))


def placed(scene, grid, t):
    """The moving grid's points in the world at time t (normals by the inverse
    transpose of the scale, then the rotation)."""
    out = []
    for i, p, n in grid:
        tr, q, sc = key_at(scene["objects"][i]["motion"], t)
        wp = quat_rotate(q, [p[k] * sc[k] for k in range(3)])
        wn = quat_rotate(q, [n[k] / sc[k] for k in range(3)])
        ln = norm(wn)
        out.append({"p": [wp[k] + tr[k] for k in range(3)], "n": [x / ln for x in wn]})
    return out


def frame_times(start, end, fps):
    last = math.floor((end - start) * fps + 1e-9)
    return [min(start + i / fps, end) for i in range(last + 1)]


def run_measured(cmd, log):
    """Runs cmd (a list), returns (wall seconds, peak RSS in MiB)."""
    seconds, rss_mb, _ = run_timed(cmd, log)
    return seconds, rss_mb


def run_timed(cmd, log):
    """Runs cmd (a list), returns (wall seconds, peak RSS in MiB, CPU seconds).

    The CPU seconds (user + system, from /usr/bin/time; None without it) over the
    wall seconds is how many cores the run kept busy."""
    rss_file = log + ".rss"
    timer = shutil.which("time") or ("/usr/bin/time" if os.path.exists("/usr/bin/time") else None)
    full = [timer, "-f", "%M %U %S", "-o", rss_file] + cmd if timer else cmd
    t0 = time.monotonic()
    with open(log, "w") as f:
        proc = subprocess.run(full, stdout=f, stderr=subprocess.STDOUT)
    seconds = time.monotonic() - t0
    if proc.returncode != 0:
        sys.exit(f"spacetime_bench: command failed ({proc.returncode}): {shlex.join(cmd)}; see {log}")
    cpu = None
    if timer:
        with open(rss_file) as f:
            # The last line: a notice of the child's exit status may come first.
            kb, user, system = f.read().strip().splitlines()[-1].split()
        rss_mb = int(kb) / 1024.0
        cpu = float(user) + float(system)
    else:
        # Largest child so far (Linux: kilobytes).
        rss_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    return seconds, rss_mb, cpu


def probe_all(rhier, rhier_file, points_file, times):
    """Probes at every time; `points_file` is one file, or one per time."""
    out = []
    for i, t in enumerate(times):
        pf = points_file[i] if isinstance(points_file, list) else points_file
        res = subprocess.run([rhier, "probe", rhier_file, "--points", pf,
                              "--time", repr(t)], capture_output=True, text=True)
        if res.returncode != 0:
            sys.exit(f"spacetime_bench: probe of {rhier_file} at t = {t} failed: {res.stderr}")
        out.append([r["B"] for r in json.loads(res.stdout)])
    return out


def average(runs):
    """Point-wise mean of several probe results (times x points x channels)."""
    return [[[sum(run[i][j][k] for run in runs) / len(runs) for k in range(3)]
             for j in range(len(runs[0][i]))] for i in range(len(runs[0]))]


def relative_rms(values, ref):
    num = den = 0.0
    for vf, rf in zip(values, ref):
        for b, br in zip(vf, rf):
            for k in range(3):
                num += (b[k] - br[k]) ** 2
                den += br[k] ** 2
    return math.sqrt(num / den) if den > 0 else float("nan")


def expand(template, **kw):
    return [part.format(**kw) for part in shlex.split(template)]


def write_svg(rows, path):
    """Error against seconds, log-log, one polyline per (method, scene)."""
    series = {}
    for r in rows:
        try:
            s, e = float(r["seconds"]), float(r["error"])
        except ValueError:
            continue
        if s > 0 and e > 0:
            series.setdefault((r["method"], r["scene"]), []).append((s, e, r["eps"]))
    if not series:
        return
    W, H, L, R, T, B = 820, 460, 80, 300, 30, 60
    xs = [p[0] for v in series.values() for p in v]
    ys = [p[1] for v in series.values() for p in v]
    x0, x1 = math.floor(math.log10(min(xs))), math.ceil(math.log10(max(xs)))
    y0, y1 = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    x1, y1 = max(x1, x0 + 1), max(y1, y0 + 1)

    def px(x):
        return L + (math.log10(x) - x0) / (x1 - x0) * (W - L - R)

    def py(y):
        return H - B - (math.log10(y) - y0) / (y1 - y0) * (H - T - B)

    colours = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
           f'font-family="sans-serif" font-size="12">',
           f'<rect width="{W}" height="{H}" fill="white"/>']
    for d in range(x0, x1 + 1):
        x = L + (d - x0) / (x1 - x0) * (W - L - R)
        out.append(f'<line x1="{x:.1f}" y1="{T}" x2="{x:.1f}" y2="{H - B}" stroke="#ddd"/>')
        out.append(f'<text x="{x:.1f}" y="{H - B + 18}" text-anchor="middle">1e{d} s</text>')
    for d in range(y0, y1 + 1):
        y = H - B - (d - y0) / (y1 - y0) * (H - T - B)
        out.append(f'<line x1="{L}" y1="{y:.1f}" x2="{W - R}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{L - 6}" y="{y + 4:.1f}" text-anchor="end">1e{d}</text>')
    out.append(f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - B}" fill="none" stroke="black"/>')
    out.append(f'<text x="{(L + W - R) / 2}" y="{H - 15}" text-anchor="middle">run time (s, whole process)</text>')
    out.append(f'<text x="18" y="{(T + H - B) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 18 {(T + H - B) / 2})">relative RMS error vs reference</text>')
    for i, ((method, scene), pts) in enumerate(sorted(series.items())):
        c = colours[i % len(colours)]
        pts.sort()
        line = " ".join(f"{px(s):.1f},{py(e):.1f}" for s, e, _ in pts)
        out.append(f'<polyline points="{line}" fill="none" stroke="{c}" stroke-width="2"/>')
        for s, e, eps in pts:
            out.append(f'<circle cx="{px(s):.1f}" cy="{py(e):.1f}" r="4" fill="{c}"/>')
            out.append(f'<text x="{px(s) + 6:.1f}" y="{py(e) - 6:.1f}" fill="{c}">{eps}</text>')
        ly = T + 20 + 20 * i
        out.append(f'<line x1="{W - R + 15}" y1="{ly}" x2="{W - R + 40}" y2="{ly}" stroke="{c}" stroke-width="2"/>')
        out.append(f'<text x="{W - R + 46}" y="{ly + 4}">{method} / {scene}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def write_png(rows, path):
    """One column per scene: error against run time (top), peak RSS against run time
    (bottom), log-log, one curve per method, each point labelled with its eps."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import FuncFormatter
    except ImportError:
        print(f"spacetime_bench: matplotlib not installed, {path} not written "
              "(pip install matplotlib)", file=sys.stderr)
        return
    data = {}
    for r in rows:
        try:
            s, e, m = float(r["seconds"]), float(r["error"]), float(r["peak_rss_mb"])
        except (ValueError, KeyError):
            continue
        if s > 0 and e > 0 and m > 0:
            data.setdefault(r["scene"], {}).setdefault(r["method"], []).append((s, e, m, r["eps"]))
    if not data:
        return
    scenes = sorted(data)
    fig, axes = plt.subplots(2, len(scenes), figsize=(5.6 * len(scenes), 10), squeeze=False)
    # A family per method ("per-frame", "space-time"), its variants ("space-time,
    # recon-tol 0.04") in lighter shades of its colour and other line styles.
    families = {"per-frame": (["#1f77b4", "#3b8fd0", "#6aaee0", "#9fcbed"], "o"),
                "space-time": (["#d62728", "#e0504f", "#e9807f", "#f2b0af"], "s")}
    extra = ["#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"]
    dashes = ["-", "--", ":", "-."]

    def style(method, k):
        family = method.split(",")[0].strip()
        if family not in families:
            return extra[k % len(extra)], "^", "-"
        shades, marker = families[family]
        variants = sorted({m for rs in data.values() for m in rs if m.split(",")[0].strip() == family})
        i = variants.index(method) if method in variants else 0
        return shades[i % len(shades)], marker, dashes[i % len(dashes)]
    for j, scene in enumerate(scenes):
        top, bottom = axes[0][j], axes[1][j]
        for k, (method, pts) in enumerate(sorted(data[scene].items())):
            colour, marker, dash = style(method, k)
            pts.sort()
            xs = [p[0] for p in pts]
            top.plot(xs, [100 * p[1] for p in pts], marker=marker, color=colour, linestyle=dash,
                     label=method)
            bottom.plot(xs, [p[2] for p in pts], marker=marker, color=colour, linestyle=dash,
                        label=method)
            for s, e, m, eps in pts:
                top.annotate(f"eps {eps}", (s, 100 * e), textcoords="offset points",
                             xytext=(5, 4), fontsize=8, color=colour)
        top.set_title(scene)
        top.set_ylabel("relative RMS error vs reference (%)")
        bottom.set_ylabel("peak RSS (MiB)")
        bottom.set_xlabel("run time (s, whole process)")
        for ax in (top, bottom):
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(True, which="both", color="#ddd", linewidth=0.6)
            plain = FuncFormatter(lambda v, _: f"{v:g}")
            for axis in (ax.xaxis, ax.yaxis):
                axis.set_major_formatter(plain)
                axis.set_minor_formatter(plain)
        bottom.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=2)
    fig.suptitle("untagged curves: earlier builds (BENCHMARKS.md); tagged points: the last build "
                 "measured on each scene",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def read_rows(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return list(csv.DictReader(f))


def latest_build(rows):
    """Rows of curves (methods without a build tag) and, per scene, of the last build
    measured on it (methods ending in "(<hash>)"): older snapshots stay in the CSV,
    not the plot."""
    tag = lambda m: m[m.rfind("(") + 1:-1] if m.endswith(")") and "(" in m else None
    last = {}
    for r in rows:
        if tag(r["method"]):
            last[r["scene"]] = tag(r["method"])
    return [r for r in rows if tag(r["method"]) in (None, last.get(r["scene"]))]


def plot(rows, csv_path):
    rows = latest_build(rows)
    stem = os.path.splitext(csv_path)[0]
    write_svg(rows, stem + ".svg")
    write_png(rows, stem + ".png")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rhier", default=os.path.join(ROOT, "target", "release", "rhier"))
    ap.add_argument("--scene", help="scene to measure (required unless --plot-only)")
    ap.add_argument("--eps", default="1.0,0.5", help="comma-separated eps values")
    ap.add_argument("--fps", type=float, default=25.0, help="frames per second of the method")
    ap.add_argument("--name", default="per-frame", help="method label in the CSV")
    ap.add_argument("--method", default=DEFAULT_METHOD, help="command template")
    ap.add_argument("--ref-fps", type=float, default=5.0)
    ap.add_argument("--ref-eps", type=float, default=0.1)
    ap.add_argument("--ref-seeds", default="1,2",
                    help="comma-separated seeds of the averaged reference (not the methods' seed)")
    ap.add_argument("--points", type=int, default=200)
    ap.add_argument("--moving-points", type=int, default=100,
                    help="probes on the moving objects' surfaces (0: none)")
    ap.add_argument("--threads", type=int, default=2, help="appended as --threads N (0: not)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs per eps, interleaved across the eps values; the median time is kept")
    ap.add_argument("--out-dir", default="spacetime_bench_out")
    ap.add_argument("--csv", default=os.path.join(ROOT, "tools", "spacetime_bench.csv"))
    ap.add_argument("--plot-only", action="store_true", help="only redraw the plots from --csv")
    args = ap.parse_args()
    if args.plot_only:
        plot(read_rows(args.csv), args.csv)
        return
    if not args.scene:
        ap.error("--scene is required unless --plot-only")

    os.makedirs(args.out_dir, exist_ok=True)
    scene_file = scene_path(args.scene)
    label = os.path.splitext(os.path.basename(scene_file))[0]
    with open(scene_file) as f:
        scene = json.load(f)
    start, end = scene["time"]["start"], scene["time"]["end"]
    threads = ["--threads", str(args.threads)] if args.threads > 0 else []

    points_file = os.path.join(args.out_dir, f"{label}_points.json")
    with open(points_file, "w") as f:
        json.dump(probe_grid(scene, args.points), f)
    times = frame_times(start, end, args.ref_fps)
    grid = moving_grid(scene, args.moving_points)
    moving_files = []
    for i, t in enumerate(times if grid else []):
        mf = os.path.join(args.out_dir, f"{label}_moving_points_t{i}.json")
        with open(mf, "w") as f:
            json.dump(placed(scene, grid, t), f)
        moving_files.append(mf)

    seeds = [int(x) for x in args.ref_seeds.split(",") if x.strip()]
    if not seeds:
        ap.error("--ref-seeds needs at least one seed")
    refs, refs_moving = [], []
    for seed in seeds:
        ref_file = os.path.join(
            args.out_dir, f"{label}_ref_fps{args.ref_fps:g}_eps{args.ref_eps:g}_seed{seed}.rhier")
        if not os.path.exists(ref_file):
            cmd = expand(DEFAULT_METHOD + " --seed {seed}", rhier=args.rhier, scene=scene_file,
                         eps=args.ref_eps, fps=args.ref_fps, out=ref_file, seed=seed) + threads
            s, m = run_measured(cmd, ref_file + ".log")
            print(f"reference: {shlex.join(cmd)}: {s:.1f} s, {m:.0f} MiB", flush=True)
        refs.append(probe_all(args.rhier, ref_file, points_file, times))
        if moving_files:
            refs_moving.append(probe_all(args.rhier, ref_file, moving_files, times))
    ref = average(refs)
    ref_moving = average(refs_moving) if refs_moving else None
    ref_desc = (f"per-frame fps {args.ref_fps:g} eps {args.ref_eps:g} "
                f"seeds {'+'.join(str(x) for x in seeds)}")
    if len(refs) >= 2:
        # Two independent draws differ by sqrt(2) sigma; their mean's noise is sigma / sqrt(2).
        noise = relative_rms(refs[0], refs[1]) / 2.0
        ref_desc += f" (own noise {100 * noise:.2f}%"
        if len(refs_moving) >= 2:
            ref_desc += f", moving {100 * relative_rms(refs_moving[0], refs_moving[1]) / 2.0:.2f}%"
        ref_desc += ")"
        print(f"reference: {ref_desc}", flush=True)

    # Each eps is run --repeat times, the eps values in turn (a, b, a, b, ...), so
    # that a machine whose speed drifts slows every eps alike; the row keeps the
    # median time, the largest peak RSS and every run's time in `runs`. The error is
    # that of the last run: a solve is deterministic for a seed and a thread count,
    # and a run whose error differs is reported.
    eps_list = [float(e) for e in args.eps.split(",") if e.strip()]
    runs = {eps: [] for eps in eps_list}
    for _ in range(max(1, args.repeat)):
        for eps in eps_list:
            out = os.path.join(args.out_dir, f"{label}_{args.name}_eps{eps:g}.rhier")
            cmd = expand(args.method, rhier=args.rhier, scene=scene_file, eps=eps, fps=args.fps,
                         out=out) + threads
            seconds, rss = run_measured(cmd, out + ".log")
            probed = probe_all(args.rhier, out, points_file, times)
            err = relative_rms(probed, ref)
            worst = max(relative_rms([v], [r]) for v, r in zip(probed, ref))
            err_moving = (relative_rms(probe_all(args.rhier, out, moving_files, times), ref_moving)
                          if ref_moving else None)
            if runs[eps] and abs(err - runs[eps][-1][2]) > 1e-9:
                print(f"spacetime_bench: eps {eps:g}: error {err:.5f} differs from an "
                      f"earlier run's {runs[eps][-1][2]:.5f}", file=sys.stderr)
            runs[eps].append((seconds, rss, err, cmd, err_moving, worst))
    new_rows = []
    for eps in eps_list:
        median = statistics.median(r[0] for r in runs[eps])
        rss = max(r[1] for r in runs[eps])
        _, _, err, cmd, err_moving, worst = runs[eps][-1]
        row = {"method": args.name, "scene": label, "eps": f"{eps:g}", "seconds": f"{median:.2f}",
               "peak_rss_mb": f"{rss:.1f}", "error": f"{err:.5f}",
               "frames_compared": len(times), "ref": ref_desc, "command": shlex.join(cmd),
               "runs": " ".join(f"{r[0]:.2f}" for r in runs[eps]),
               "error_moving": "" if err_moving is None else f"{err_moving:.5f}",
               "error_worst_frame": f"{worst:.5f}"}
        print(",".join(str(row[k]) for k in CSV_FIELDS[:7]) + f",runs {row['runs']}"
              + f",moving {row['error_moving'] or '-'},worst frame {row['error_worst_frame']}",
              flush=True)
        new_rows.append(row)

    rows = read_rows(args.csv) + new_rows
    with open(args.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in CSV_FIELDS})
    plot(rows, args.csv)


if __name__ == "__main__":
    main()
