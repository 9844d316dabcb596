#!/usr/bin/env python3
"""Error of a cube-room solve against its path-traced reference, as BENCHMARKS.md
("Scale") reports it: the RMS over the probes of the difference in each point's
largest reference channel, over the RMS reference; then per kind of point
(`tools/gen_cube_probes.py` cycles floor gap, box top, box side, wall, ceiling) the
RMS difference (same denominator) and the bias (mean difference over mean
reference), both in percent; and the worst point (largest difference over the RMS
reference). No probe lies on the lamp: the error is off the emitters.

usage: tools/cube_error.py REFERENCE.json OUT.json
  REFERENCE.json  `rhier reference SCENE --points PROBES -o REFERENCE.json`
  OUT.json        `rhier solve SCENE --probe PROBES --probe-out OUT.json`
"""
import json
import math
import sys

KINDS = ["gaps", "tops", "sides", "walls", "ceiling"]


def error(ref, out):
    """`{"rms": %, "line": the printed summary, "worst": {"kind", "p", "off": %}}`."""
    if len(ref) != len(out):
        raise ValueError(f"{len(out)} points, the reference has {len(ref)}")
    diffs, refs = [], []
    for r, o in zip(ref, out):
        c = max(range(3), key=lambda k: r["B"][k])
        diffs.append(o["B"][c] - r["B"][c])
        refs.append(r["B"][c])
    rms = lambda v: math.sqrt(sum(x * x for x in v) / len(v))
    scale = rms(refs)
    parts = []
    for k, name in enumerate(KINDS):
        d, r = diffs[k :: len(KINDS)], refs[k :: len(KINDS)]
        if d:
            parts.append(f"{name} {100 * rms(d) / scale:.1f} ({100 * sum(d) / sum(r):+.1f})")
    w = max(range(len(diffs)), key=lambda i: abs(diffs[i]))
    worst = {"kind": KINDS[w % len(KINDS)], "p": ref[w]["p"], "off": 100 * diffs[w] / scale}
    total = 100 * rms(diffs) / scale
    line = (
        f"error {total:.2f}%  RMS (bias) %: " + ", ".join(parts)
        + f"; worst {worst['kind']} {worst['off']:+.1f}% at {worst['p']}"
    )
    return {"rms": total, "line": line, "worst": worst}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    ref = json.load(open(sys.argv[1]))
    out = json.load(open(sys.argv[2]))
    try:
        print(error(ref, out)["line"])
    except ValueError as e:
        sys.exit(f"{sys.argv[2]}: {e}")


if __name__ == "__main__":
    main()
