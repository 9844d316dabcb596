#!/usr/bin/env python3
"""What light that cannot reach a surface costs (issue 48, target 4): solves the three
scenes of tools/gen_hidden.py (the lit room alone; with K x K boxes sealed in its
crate; with a sealed dark room of K x K boxes beyond its wall), each at the defaults
and with --no-sealed, and prints a markdown table: CPU seconds (user + sys), peak
RSS, patches, links, the lit probes' error against the path tracer (run once, on the
lit room alone: the lit probes see the same scene in all three), and the largest
value at the probes no light reaches.

usage: tools/hidden_bench.py RHIER N K OUT_DIR [--paths P] [--threads T]
"""
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def run_timed(cmd):
    r = subprocess.run(["/usr/bin/time", "-f", "TIME %U %S %M"] + cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    m = re.search(r"TIME ([\d.]+) ([\d.]+) (\d+)", r.stderr)
    solved = [l for l in r.stderr.splitlines() if l.startswith("solved")]
    return float(m.group(1)) + float(m.group(2)), int(m.group(3)) / 1024, solved[-1] if solved else ""


def values(path):
    return [max(p["B"]) for p in json.load(open(path))]


def rel_rms(a, ref):
    num = sum((x - y) ** 2 for x, y in zip(a, ref))
    den = sum(y * y for y in ref)
    return (num / den) ** 0.5


def main():
    args = sys.argv[1:]
    if len(args) < 4:
        sys.exit(__doc__)
    rhier, n, k, out = args[0], args[1], args[2], args[3]
    paths = args[args.index("--paths") + 1] if "--paths" in args else "50000"
    threads = args[args.index("--threads") + 1] if "--threads" in args else "2"
    os.makedirs(out, exist_ok=True)
    lit, dark = os.path.join(out, "lit.json"), os.path.join(out, "dark.json")
    for kind in ["none", "crate", "room"]:
        subprocess.run(
            ["python3", os.path.join(HERE, "gen_hidden.py"), kind, n, k, os.path.join(out, kind + ".json"),
             "--probes", lit, "--dark-probes", dark + "." + kind],
            check=True, capture_output=True)
    ref = os.path.join(out, "reference.json")
    if not os.path.exists(ref):
        subprocess.run([rhier, "reference", os.path.join(out, "none.json"), "--points", lit, "--paths", paths,
                        "-o", ref], check=True, capture_output=True)
    reference = [max(p["B"]) for p in json.load(open(ref))]
    print("| scene | polygons | setting | CPU s | peak RSS MB | patches (dark) | links active / passive | lit probes off the path tracer | lit probes off the lit room alone | largest B where no light reaches |")
    print("|---|---:|---|---:|---:|---|---|---:|---:|---:|")
    alone = None
    for kind in ["none", "crate", "room"]:
        scene = os.path.join(out, kind + ".json")
        polys = sum(len(o["polygons"]) for o in json.load(open(scene))["objects"])
        for setting in ([], ["--no-sealed"]) if kind != "none" else ([],):
            tag = kind + ("-all" if setting else "")
            pout, rh = os.path.join(out, tag + ".probe.json"), os.path.join(out, tag + ".rhier")
            cpu, rss, line = run_timed([rhier, "solve", scene, "--threads", threads, "--probe", lit,
                                        "--probe-out", pout, "-o", rh] + setting)
            v = values(pout)
            if alone is None:
                alone = v
            m = re.search(r"solved (\d+) patches(?: \((\d+) sealed)?.*?, (\d+) active / (\d+) passive", line)
            patches, darkn, act, pas = m.group(1), m.group(2) or "0", m.group(3), m.group(4)
            dv = "n/a"
            if kind != "none":
                dout = os.path.join(out, tag + ".dark.json")
                subprocess.run([rhier, "probe", rh, "--points", dark + "." + kind, "-o", dout], check=True,
                               capture_output=True)
                dv = "%.3g" % max(values(dout))
            os.remove(rh)
            print(f"| {kind} | {polys} | {'--no-sealed' if setting else 'default'} | {cpu:.1f} | {rss:.0f} | "
                  f"{patches} ({darkn}) | {act} / {pas} | {100 * rel_rms(v, reference):.2f}% | "
                  f"{100 * rel_rms(v, alone):.2f}% | {dv} |", flush=True)


if __name__ == "__main__":
    main()
