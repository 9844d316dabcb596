#!/usr/bin/env python3
"""Writes the animated glTF sample scene formats/examples/moving_cube.{gltf,glb}
(+ moving_cube_external.gltf with its buffer in moving_cube.bin).

Scene (metres, y up): a closed 4 x 3 x 4 room whose node is translated by (-2, 0, -2)
(static: the loader bakes it), a lamp quad 1 cm under the ceiling (emissiveFactor
[1, 0.9, 0.8] x KHR_materials_emissive_strength 5, base colour white 1.0 so that the
loader clamps it to 0.999 with a warning), and a cube of half-size 1 scaled by 0.5 under
a parent node "mover". "mover" translates (LINEAR) through (-1, 0.5, 0) at t = 0,
(0, 0.5, 0.5) at t = 1 and (1, 0.5, 0) at t = 2; "cube" rotates (LINEAR, slerp) about +y
from 0 to 90 degrees over [0, 2]. A perspective camera at (0, 1.5, 1.9) looks along -z.

Room triangles are indexed with u16, lamp with u32, the cube is not indexed. Every
triangle is counter-clockwise seen from its lit side (room: inside; cube: outside).
Usage: python3 tools/make_moving_cube_gltf.py [OUT_DIR]   (default formats/examples)
"""

import base64
import json
import math
import os
import struct
import sys


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def oriented(quad, normal):
    """The quad's corners ordered counter-clockwise seen from the side `normal` points to."""
    if dot(cross(sub(quad[1], quad[0]), sub(quad[2], quad[0])), normal) < 0:
        return list(reversed(quad))
    return quad


def box_faces(lo, hi, inward):
    """Six quads of the box [lo, hi], facing inward or outward."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [
        ([[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]], [0, -1, 0]),  # bottom
        ([[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]], [0, 1, 0]),  # top
        ([[x0, y0, z0], [x0, y1, z0], [x0, y1, z1], [x0, y0, z1]], [-1, 0, 0]),  # -x
        ([[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]], [1, 0, 0]),  # +x
        ([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]], [0, 0, -1]),  # -z
        ([[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], [0, 0, 1]),  # +z
    ]
    sign = -1 if inward else 1
    return [oriented(q, [sign * c for c in n]) for q, n in faces]


class Builder:
    def __init__(self):
        self.bin = bytearray()
        self.views = []
        self.accessors = []

    def _view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            view["target"] = target
        self.bin.extend(data)
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, fmt, values, ctype, kind, target=None, minmax=False):
        flat = [x for v in values for x in (v if isinstance(v, (list, tuple)) else [v])]
        view = self._view(struct.pack("<%d%s" % (len(flat), fmt), *flat), target)
        acc = {"bufferView": view, "componentType": ctype, "count": len(values), "type": kind}
        if minmax:
            acc["min"] = [min(v[i] for v in values) for i in range(3)]
            acc["max"] = [max(v[i] for v in values) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


FLOAT, U16, U32 = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def build():
    b = Builder()

    # Room: indexed (u16), 2 triangles per quad.
    room_pos, room_idx = [], []
    for q in box_faces([0, 0, 0], [4, 3, 4], inward=True):
        base = len(room_pos)
        room_pos.extend(q)
        room_idx.extend([base, base + 1, base + 2, base, base + 2, base + 3])
    room_p = b.accessor("f", room_pos, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True)
    room_i = b.accessor("H", room_idx, U16, "SCALAR", ELEMENT_ARRAY_BUFFER)

    # Lamp: one quad facing down at y = 2.99 (in room coordinates, node at origin).
    lamp = oriented([[-0.5, 2.99, -0.5], [0.5, 2.99, -0.5], [0.5, 2.99, 0.5], [-0.5, 2.99, 0.5]], [0, -1, 0])
    lamp_p = b.accessor("f", lamp, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True)
    lamp_i = b.accessor("I", [0, 1, 2, 0, 2, 3], U32, "SCALAR", ELEMENT_ARRAY_BUFFER)

    # Cube: not indexed, half-size 1, outward.
    cube_pos = []
    for q in box_faces([-1, -1, -1], [1, 1, 1], inward=False):
        cube_pos.extend([q[0], q[1], q[2], q[0], q[2], q[3]])
    cube_p = b.accessor("f", cube_pos, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True)

    # Animation: mover translation (3 keys), cube rotation (2 keys).
    t3 = b.accessor("f", [0.0, 1.0, 2.0], FLOAT, "SCALAR")
    b.accessors[-1].update({"min": [0.0], "max": [2.0]})
    tr = b.accessor("f", [[-1, 0.5, 0], [0, 0.5, 0.5], [1, 0.5, 0]], FLOAT, "VEC3")
    t2 = b.accessor("f", [0.0, 2.0], FLOAT, "SCALAR")
    b.accessors[-1].update({"min": [0.0], "max": [2.0]})
    h = math.sqrt(0.5)
    rot = b.accessor("f", [[0, 0, 0, 1], [0, h, 0, h]], FLOAT, "VEC4")

    gltf = {
        "asset": {"version": "2.0", "generator": "rhier tools/make_moving_cube_gltf.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 4]}],
        "nodes": [
            {"name": "room", "mesh": 0, "translation": [-2, 0, -2]},
            {"name": "lamp", "mesh": 1},
            {"name": "mover", "children": [3]},
            {"name": "cube", "mesh": 2, "scale": [0.5, 0.5, 0.5]},
            {"name": "camera", "camera": 0, "translation": [0, 1.5, 1.9]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01, "aspectRatio": 1.0}}],
        "meshes": [
            {"name": "room", "primitives": [{"attributes": {"POSITION": room_p}, "indices": room_i, "material": 0}]},
            {"name": "lamp", "primitives": [{"attributes": {"POSITION": lamp_p}, "indices": lamp_i, "material": 1}]},
            {"name": "cube", "primitives": [{"attributes": {"POSITION": cube_p}, "material": 2}]},
        ],
        "materials": [
            {"name": "white", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}},
            {
                "name": "lamp",
                "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0]},
                "emissiveFactor": [1.0, 0.9, 0.8],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}},
            },
            {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.1, 0.1, 1.0]}},
        ],
        "animations": [
            {
                "name": "move",
                "samplers": [
                    {"input": t3, "output": tr, "interpolation": "LINEAR"},
                    {"input": t2, "output": rot, "interpolation": "LINEAR"},
                ],
                "channels": [
                    {"sampler": 0, "target": {"node": 2, "path": "translation"}},
                    {"sampler": 1, "target": {"node": 3, "path": "rotation"}},
                ],
            }
        ],
        "accessors": b.accessors,
        "bufferViews": b.views,
    }
    while len(b.bin) % 4:
        b.bin.append(0)
    return gltf, bytes(b.bin)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "formats", "examples")
    gltf, blob = build()

    embedded = dict(gltf, buffers=[{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}])
    with open(os.path.join(out, "moving_cube.gltf"), "w") as f:
        json.dump(embedded, f, indent=1)
        f.write("\n")

    external = dict(gltf, buffers=[{"byteLength": len(blob), "uri": "moving_cube.bin"}])
    with open(os.path.join(out, "moving_cube_external.gltf"), "w") as f:
        json.dump(external, f, indent=1)
        f.write("\n")
    with open(os.path.join(out, "moving_cube.bin"), "wb") as f:
        f.write(blob)

    # GLB: 12-byte header, JSON chunk (space padded), BIN chunk (zero padded).
    binary = dict(gltf, buffers=[{"byteLength": len(blob)}])
    js = json.dumps(binary, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    with open(os.path.join(out, "moving_cube.glb"), "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(blob), b"BIN\0") + blob)


if __name__ == "__main__":
    main()
