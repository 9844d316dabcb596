#!/usr/bin/env python3
"""Stretch a native JSON scene's time by a factor: the same motion, played slower.

Damez & Sillion measure length (section 6) by "doubling the duration of the time
interval (6 seconds, 150 frames) with equivalent movement": the same motion over
twice the time, so twice the frames for the same shadow events, which is what this
writes. (The embedded ACTOR150 / LIGHT150 instead walk their path back and forth at
the same speed: twice the frames *and* twice the motion. BENCHMARKS.md reports
both.)

Multiplies `time.start`, `time.end` and every motion key's `t` by K; nothing else
changes, so the result validates whenever the input does.

Usage:
    python3 tools/stretch_scene.py formats/examples/actor.json 2 actor_x2.json
"""

import json
import sys


def stretch(scene, k):
    """The scene with its time domain and motion keys scaled by `k` (in place)."""
    time = scene.get("time")
    if time is not None:
        time["start"] = time["start"] * k
        time["end"] = time["end"] * k
    for obj in scene.get("objects", []):
        for key in obj.get("motion") or []:
            key["t"] = key["t"] * k
    return scene


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    src, factor, dst = sys.argv[1], sys.argv[2], sys.argv[3]
    try:
        k = float(factor)
    except ValueError:
        sys.exit(f"stretch_scene: factor {factor!r}: expected a number > 0")
    if not k > 0 or k == float("inf"):
        sys.exit(f"stretch_scene: factor {factor!r}: expected a finite number > 0")
    try:
        with open(src) as f:
            scene = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        sys.exit(f"stretch_scene: {src}: {e}")
    with open(dst, "w") as f:
        json.dump(stretch(scene, k), f)


if __name__ == "__main__":
    main()
