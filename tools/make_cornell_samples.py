#!/usr/bin/env python3
"""Writes the Cornell box with blocks as OBJ + MTL and as glTF, from the native
formats/examples/cornell_blocks.json (itself written from the embedded scene, see
formats/scene.md): formats/examples/cornell_blocks.obj, cornell_blocks.mtl and
cornell_blocks.gltf. tests/it/scene/loaders.rs checks that both load to the embedded
scene within f32 precision, so the three readers agree on one known scene.

Mapping used (the inverse of the readers' mapping, formats/scene.md):
- OBJ: one `o` per object, faces as written (quads stay quads); Kd = reflectance,
  Ke = exitance.
- glTF: one node + mesh + primitive per object; a quad (a, b, c, d) becomes the
  triangles (a, b, c), (a, c, d), which the reader merges back; emission E is
  written as radiance L = E / pi split into emissiveFactor (max channel 1) times
  KHR_materials_emissive_strength; the camera node sits at the eye, turned 180
  degrees about +y so that its -z axis looks along +z.

Usage: python3 tools/make_cornell_samples.py [EXAMPLES_DIR]
"""

import base64
import json
import math
import os
import struct
import sys


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "formats", "examples")
    with open(os.path.join(out, "cornell_blocks.json")) as f:
        scene = json.load(f)
    names = list(scene["materials"].keys())  # JSON object order = sorted names
    mats = scene["materials"]

    # --- OBJ + MTL ---
    with open(os.path.join(out, "cornell_blocks.mtl"), "w") as f:
        f.write("# Cornell box materials (rhier sample). Kd = reflectance, Ke = exitance.\n")
        for n in names:
            f.write("\nnewmtl %s\nKd %r %r %r\n" % (n, *mats[n]["reflectance"]))
            if "emission" in mats[n]:
                f.write("Ke %r %r %r\n" % tuple(mats[n]["emission"]))
    lines = [
        "# The published Cornell box with blocks, millimetres (rhier sample written by",
        "# tools/make_cornell_samples.py from cornell_blocks.json).",
        "mtllib cornell_blocks.mtl",
    ]
    base = 1
    for o in scene["objects"]:
        lines.append("o %s" % o["name"])
        current = None
        for p in o["polygons"]:
            if p["material"] != current:
                current = p["material"]
                lines.append("usemtl %s" % current)
            for v in p["vertices"]:
                lines.append("v %r %r %r" % tuple(v))
            lines.append("f " + " ".join(str(base + k) for k in range(len(p["vertices"]))))
            base += len(p["vertices"])
    with open(os.path.join(out, "cornell_blocks.obj"), "w") as f:
        f.write("\n".join(lines) + "\n")

    # --- glTF (embedded buffer) ---
    blob = bytearray()
    views, accessors, meshes, nodes = [], [], [], []
    for o in scene["objects"]:
        positions, indices = [], []
        for p in o["polygons"]:
            start = len(positions)
            positions.extend(p["vertices"])
            for k in range(1, len(p["vertices"]) - 1):
                indices.extend([start, start + k, start + k + 1])
        pos_bytes = struct.pack("<%df" % (3 * len(positions)), *[c for v in positions for c in v])
        idx_bytes = struct.pack("<%dH" % len(indices), *indices)
        for data, target in ((pos_bytes, 34962), (idx_bytes, 34963)):
            while len(blob) % 4:
                blob.append(0)
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
            blob.extend(data)
        accessors.append({
            "bufferView": len(views) - 2, "componentType": 5126, "count": len(positions), "type": "VEC3",
            "min": [min(v[i] for v in positions) for i in range(3)],
            "max": [max(v[i] for v in positions) for i in range(3)],
        })
        accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": len(indices), "type": "SCALAR"})
        material = names.index(o["polygons"][0]["material"])
        assert all(p["material"] == o["polygons"][0]["material"] for p in o["polygons"])
        meshes.append({"name": o["name"], "primitives": [{
            "attributes": {"POSITION": len(accessors) - 2}, "indices": len(accessors) - 1, "material": material}]})
        nodes.append({"name": o["name"], "mesh": len(meshes) - 1})
    while len(blob) % 4:
        blob.append(0)

    gltf_materials = []
    for n in names:
        m = {"name": n, "pbrMetallicRoughness": {"baseColorFactor": mats[n]["reflectance"] + [1.0]}}
        e = mats[n].get("emission", [0.0, 0.0, 0.0])
        peak = max(e)
        if peak > 0:
            m["emissiveFactor"] = [c / peak for c in e]
            m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": peak / math.pi}}
        gltf_materials.append(m)

    cam = scene["camera"]
    nodes.append({"name": "camera", "camera": 0, "translation": cam["eye"], "rotation": [0.0, 1.0, 0.0, 0.0]})
    gltf = {
        "asset": {"version": "2.0", "generator": "rhier tools/make_cornell_samples.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": math.radians(cam["fov_y_degrees"]), "znear": 1.0, "aspectRatio": 1.0}}],
        "meshes": meshes,
        "materials": gltf_materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
    }
    with open(os.path.join(out, "cornell_blocks.gltf"), "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
