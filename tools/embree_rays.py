#!/usr/bin/env python3
"""Embree side of the visibility-throughput comparison (BENCHMARKS.md, "Visibility throughput").

Reads the triangles and occlusion rays that `benches/visibility.rs` exports with
`RHIER_EXPORT_RAYS=DIR cargo bench --bench visibility` (tris.bin: f32 x 9 per triangle;
rays.bin: f32 x 8 per ray = origin, direction, tmin, tmax; occluded.bin: u8 per ray, the
bare obvhs loop's answer; meta.json: counts and the Rust rays/s), builds an Embree scene
with embreex (`pip install embreex numpy`), casts the same rays as occlusion queries
(rtcOccluded1, one ray at a time, in embreex's Cython loop), and prints build time,
median cast time over several repetitions, rays/s, the ratios to the Rust loops, and how
many rays Embree answers differently from the bare obvhs loop.

embreex's `run` always sets tnear = 0, so each ray's origin is moved to origin + tmin * dir
and tfar = tmax - tmin (same segment, same parameterisation; f32 rounding may flip a
grazing ray or two). embreex creates its device with rtcNewDevice(NULL), i.e. one
build thread per core it may run on; ray casting is a serial loop on the calling thread.
Run under `taskset -c 0` for a single-thread build too (the script reports the CPU set
and CPU time / wall time of both phases).

It does not: use Embree's packet/stream APIs (embreex exposes only the single-ray calls),
or time anything in Rust (the bench does that).

Usage: python3 tools/embree_rays.py DIR [--reps N]
"""

import argparse
import json
import os
import sys
import time

import numpy as np

try:
    from embreex import mesh_construction, rtcore, rtcore_scene
except ImportError as e:  # pragma: no cover - environment check
    sys.exit(f"embree_rays.py: cannot import embreex ({e}); pip install embreex numpy")


def load(d):
    """Returns (triangles (N,3,3) f32, rays (M,8) f32, bare answers (M,) bool, meta dict)."""
    def floats(name, width):
        path = os.path.join(d, name)
        a = np.fromfile(path, dtype="<f4")
        if a.size % width:
            sys.exit(f"{path}: expected a multiple of {width} f32 values, found {a.size}")
        return a.reshape(-1, width)

    tris = floats("tris.bin", 9).reshape(-1, 3, 3)
    rays = floats("rays.bin", 8)
    path = os.path.join(d, "occluded.bin")
    answers = np.fromfile(path, dtype=np.uint8)
    if answers.size != rays.shape[0]:
        sys.exit(f"{path}: expected {rays.shape[0]} bytes (one per ray), found {answers.size}")
    with open(os.path.join(d, "meta.json")) as f:
        meta = json.load(f)
    return tris, rays, answers.astype(bool), meta


def clocked(fn):
    """Runs fn(); returns (result, wall seconds, process CPU seconds)."""
    w, c = time.perf_counter(), time.process_time()
    r = fn()
    return r, time.perf_counter() - w, time.process_time() - c


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir", help="directory written by RHIER_EXPORT_RAYS")
    ap.add_argument("--reps", type=int, default=15, help="timed repetitions (median)")
    args = ap.parse_args()

    tris, rays, bare, meta = load(args.dir)
    origins = np.ascontiguousarray(rays[:, 0:3] + rays[:, 6:7] * rays[:, 3:6], dtype=np.float32)
    dirs = np.ascontiguousarray(rays[:, 3:6], dtype=np.float32)
    tfar = np.ascontiguousarray(rays[:, 7] - rays[:, 6], dtype=np.float32)
    one = (origins[:1], dirs[:1], tfar[:1].copy())

    print(f"{repr(rtcore.EmbreeDevice()).strip()}; embreex {__import__('embreex').__version__}")
    print(f"CPUs this process may run on: {len(os.sched_getaffinity(0))} of {os.cpu_count()}")
    print(f"scene: {tris.shape[0]} triangles, {rays.shape[0]} rays")

    # Build: geometry upload (TriangleMesh) + BVH build (commit, done by the first run()).
    scene = rtcore_scene.EmbreeScene()
    _, up_wall, up_cpu = clocked(lambda: mesh_construction.TriangleMesh(scene, tris))
    _, commit_wall, commit_cpu = clocked(lambda: scene.run(*one[:2], dists=one[2], query="OCCLUDED"))
    print(
        f"build: upload {up_wall * 1e3:.1f} ms, commit (BVH build) {commit_wall * 1e3:.1f} ms wall, "
        f"{commit_cpu * 1e3:.1f} ms CPU (CPU/wall {commit_cpu / max(commit_wall, 1e-9):.2f})"
    )

    # Binding floor: the same loop on a committed scene with one far-away triangle.
    empty = rtcore_scene.EmbreeScene()
    far = np.array([[[1e6, 1e6, 1e6], [1e6 + 1, 1e6, 1e6], [1e6, 1e6 + 1, 1e6]]], dtype=np.float32)
    mesh_construction.TriangleMesh(empty, far)

    def cast(s):
        return s.run(origins, dirs, dists=tfar, query="OCCLUDED")

    cast(scene)  # warm-up
    walls, cpus = [], []
    for _ in range(args.reps):
        res, w, c = clocked(lambda: cast(scene))
        walls.append(w)
        cpus.append(c)
    floor = float(np.median([clocked(lambda: cast(empty))[1] for _ in range(args.reps)]))
    wall = float(np.median(walls))
    occluded = res != -1  # embreex returns -1 for an unoccluded ray, a geometry id else
    n = rays.shape[0]
    rate = n / wall
    print(
        f"cast: median {wall * 1e3:.2f} ms / {n} rays over {args.reps} runs "
        f"(min {min(walls) * 1e3:.2f}, max {max(walls) * 1e3:.2f}; CPU/wall "
        f"{sum(cpus) / sum(walls):.2f}) = {rate / 1e6:.3f} M rays/s single thread"
    )
    print(
        f"binding floor (same loop, scene with one far triangle): {floor * 1e3:.2f} ms; "
        f"Embree minus floor: {n / max(wall - floor, 1e-9) / 1e6:.3f} M rays/s"
    )
    mism = int(np.count_nonzero(occluded != bare))
    print(
        f"occluded: Embree {int(occluded.sum())}, bare obvhs {int(bare.sum())} "
        f"(meta: bare {meta['occluded_bare_obvhs']}, rhier {meta['occluded_rhier']}); "
        f"rays answered differently from bare obvhs: {mism}"
    )
    best = n / min(walls)
    for label, e, suffix in (("median", rate, ""), ("best", best, "_best")):
        ob, rh = meta["rays_per_s_bare_obvhs" + suffix], meta["rays_per_s_rhier" + suffix]
        print(
            f"rays/s (M, {label}): Embree {e / 1e6:.3f}, bare obvhs {ob / 1e6:.3f}, "
            f"rhier {rh / 1e6:.3f} (Rust numbers from the export run); "
            f"Embree/obvhs {e / ob:.2f}, rhier/obvhs {rh / ob:.2f}"
        )


if __name__ == "__main__":
    main()
