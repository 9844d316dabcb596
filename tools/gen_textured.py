#!/usr/bin/env python3
"""Writes the textured test scenes of tests/data/textured/ (issue 47): a 1 x 1 floor
with a checker texture (linear mean 1, 0.216, 0.5), a lamp above it, a
double-sided panel, two cameras and a punctual light that rhier does not read.

    python3 tools/gen_textured.py tests/data/textured
"""
import base64
import json
import struct
import sys
import zlib
from pathlib import Path


def png(path, width, height, texel):
    """An 8-bit RGB PNG whose pixel (x, y) is texel(x, y)."""
    raw = b"".join(
        b"\x00" + b"".join(bytes(texel(x, y)) for x in range(width)) for y in range(height)
    )

    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    path.write_bytes(data)


FLOOR = [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)]  # faces +y
LAMP = [(0.25, 1, 0.25), (0.75, 1, 0.25), (0.75, 1, 0.75), (0.25, 1, 0.75)]  # faces -y
PANEL = [(0, 0.2, 0.2), (0, 0.2, 0.8), (0, 0.8, 0.8), (0, 0.8, 0.2)]  # faces -x, double-sided


def obj(out):
    lines = ["# rhier test scene (tools/gen_textured.py): textured floor, missing texture, lamp", "mtllib textured.mtl"]
    for name, quad, mat in [("floor", FLOOR, "checker"), ("panel", PANEL, "lost"), ("lamp", LAMP, "lamp")]:
        lines.append(f"o {name}")
        lines += [f"v {x} {y} {z}" for x, y, z in quad]
        lines.append(f"usemtl {mat}")
        lines.append("f -4 -3 -2 -1")
    (out / "textured.obj").write_text("\n".join(lines) + "\n")
    (out / "textured.mtl").write_text(
        "newmtl checker\nKd 0.8 0.8 0.8\nmap_Kd checker.png\n\n"
        "newmtl lost\nKd 0.3 0.4 0.5\nmap_Kd missing.png\n\n"
        "newmtl lamp\nKd 0.5 0.5 0.5\nKe 10 10 10\n"
    )


def gltf(out):
    blob = b""
    views, accessors, meshes, nodes = [], [], [], []
    for mi, quad in enumerate([FLOOR, PANEL, LAMP]):
        pos = b"".join(struct.pack("<3f", *v) for v in quad)
        idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3) + b"\x00\x00"
        for data, target in [(pos, 34962), (idx, 34963)]:
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
            blob += data
        lo = [min(v[k] for v in quad) for k in range(3)]
        hi = [max(v[k] for v in quad) for k in range(3)]
        accessors.append({"bufferView": len(views) - 2, "componentType": 5126, "count": 4, "type": "VEC3", "min": lo, "max": hi})
        accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": 6, "type": "SCALAR"})
        meshes.append({"primitives": [{"attributes": {"POSITION": len(accessors) - 2}, "indices": len(accessors) - 1, "material": mi}]})
        nodes.append({"name": ["floor", "panel", "lamp"][mi], "mesh": mi})
    s = 0.7071067811865476
    nodes.append({"name": "top view", "camera": 0, "translation": [0.5, 3, 0.5], "rotation": [-s, 0, 0, s]})
    nodes.append({"name": "side view", "camera": 1, "translation": [0.5, 0.5, 3]})
    nodes.append({"name": "bulb", "translation": [0.5, 0.9, 0.5], "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc = {
        "asset": {"version": "2.0", "generator": "rhier tools/gen_textured.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10}]}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [
            {"name": "top", "type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}},
            {"name": "side", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.01}},
        ],
        "meshes": meshes,
        "materials": [
            {"name": "checker", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "baseColorTexture": {"index": 0}}},
            {"name": "panel", "doubleSided": True, "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}},
            {"name": "lamp", "emissiveFactor": [1, 1, 1], "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}},
        ],
        "textures": [{"source": 0}],
        "images": [{"uri": "checker.png"}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    (out / "textured.gltf").write_text(json.dumps(doc, indent=1) + "\n")


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "tests/data/textured")
    out.mkdir(parents=True, exist_ok=True)
    # 4 x 4 checker of sRGB (255, 128, 0) and (255, 128, 255): linear mean
    # (1, 0.21586, 0.5); the mean of the sRGB values would be (1, 0.502, 0.5).
    png(out / "checker.png", 4, 4, lambda x, y: (255, 128, 255) if (x + y) % 2 else (255, 128, 0))
    obj(out)
    gltf(out)


if __name__ == "__main__":
    main()
