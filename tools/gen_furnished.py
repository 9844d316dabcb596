#!/usr/bin/env python3
"""Writes a furnished room as a native rhier scene, tessellated the way exported
scenes are, for the animation and scale benchmarks of issue 48 (target 3).

usage: tools/gen_furnished.py OUT.json [--detail D] [--frames F] [--fps R]
                              [--movers people|door|both|none] [--static]
                              [--probes P.json] [--seed S]

The room is 7 x 2.8 x 5 m, lit by two ceiling panels hung 2 cm under the ceiling.
Its walls, floor and ceiling are cut on jittered grids into triangles of unequal
size (alternating diagonals), so no wall is one polygon and no two tiles are alike.
The furniture is what a dining and living room holds: a table on round legs with
six chairs, a sofa, a bookshelf full of books, a sideboard with vases and bowls
(surfaces of revolution), a round lamp shade and a floor lamp. Curved parts are
finely tessellated meshes of triangles and quads; every solid is closed and faces
out (the counter-clockwise rule of formats/scene.md), and furniture stands on the
floor, so contacts are everywhere.

Movers (`--movers`, default `both`):
- people: two figures (torso, head, arms and legs; about 1.7 m) walk, one round the
  table, one across the room and back, turning to face where they go;
- door: a door in the front wall swings open 80 degrees and closes again.
Their motion spans the animation, `F` frames at `R` frames per second (defaults 250
and 25: 9.96 s), with a key every 0.2 s (translation and a yaw quaternion).
`--static` writes the same room with every mover at its first pose and no motion
(a static frame, for memory and time comparisons).

`--detail D` (default 1.0) scales the segment counts of every curved mesh and the
wall grids: D = 1 gives about 21k polygons, D = 2 about 80k, D = 0.5 about 6k.
`--probes P.json` also writes 200 probe points (area-weighted over the static
surfaces that do not emit, lifted 0.1 mm off them) as [{"p": .., "n": ..}] for
`rhier reference --points` and `rhier solve --probe`.

The polygon count goes to standard output.
"""
import argparse
import json
import math
import random

# --- small vector helpers ---------------------------------------------------------


def add(a, b):
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def mul(a, s):
    return [a[0] * s, a[1] * s, a[2] * s]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def rnd(v):
    return [round(x, 6) for x in v]


def poly(vs, m):
    return {"vertices": [rnd(v) for v in vs], "material": m}


def normal(vs):
    """Newell's normal of a polygon (not normalised): the counter-clockwise side."""
    n = [0.0, 0.0, 0.0]
    for i, a in enumerate(vs):
        b = vs[(i + 1) % len(vs)]
        n[0] += (a[1] - b[1]) * (a[2] + b[2])
        n[1] += (a[2] - b[2]) * (a[0] + b[0])
        n[2] += (a[0] - b[0]) * (a[1] + b[1])
    return n


def area(vs):
    n = normal(vs)
    return 0.5 * math.sqrt(dot(n, n))


def check_outward(polys, centre):
    """Every polygon of a convex-ish solid faces away from `centre`."""
    for p in polys:
        vs = p["vertices"]
        mid = mul([sum(v[i] for v in vs) for i in range(3)], 1.0 / len(vs))
        if dot(normal(vs), sub(mid, centre)) <= 0:
            raise AssertionError(f"a face of the solid around {centre} faces in: {vs}")


def check_closed_outward(polys):
    """A closed mesh faces out when its signed volume (divergence theorem over the
    fan triangles) is positive; each revolved face also faces away from the axis."""
    vol = 0.0
    for p in polys:
        vs = p["vertices"]
        for i in range(1, len(vs) - 1):
            vol += dot(vs[0], cross(vs[i], vs[i + 1])) / 6.0
    if vol <= 0:
        raise AssertionError(f"a closed mesh of {len(polys)} faces has signed volume {vol}")


# --- meshes ---------------------------------------------------------------------


def jittered(n, rng, jitter=0.3):
    """n + 1 increasing cuts of [0, 1], inner ones moved by up to jitter/n."""
    cuts = [0.0] + [(i + rng.uniform(-jitter, jitter)) / n for i in range(1, n)] + [1.0]
    return cuts


def tiled_tris(a, b, c, d, m, nu, nv, rng):
    """The quad a b c d (counter-clockwise from its lit side) cut on a jittered
    nu x nv grid, each cell split into two triangles along alternating diagonals."""
    us, vs = jittered(nu, rng), jittered(nv, rng)

    def p(u, v):
        low = add(a, mul(sub(b, a), u))
        high = add(d, mul(sub(c, d), u))
        return add(low, mul(sub(high, low), v))

    out = []
    for i in range(nu):
        for j in range(nv):
            p00, p10 = p(us[i], vs[j]), p(us[i + 1], vs[j])
            p11, p01 = p(us[i + 1], vs[j + 1]), p(us[i], vs[j + 1])
            if (i + j) % 2 == 0:
                out += [poly([p00, p10, p11], m), poly([p00, p11, p01], m)]
            else:
                out += [poly([p00, p10, p01], m), poly([p10, p11, p01], m)]
    return out


def box(lo, hi, m, n=1):
    """A box's six faces, facing out, each cut n x n into quads."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [
        ([x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]),  # +y
        ([x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]),  # -y
        ([x0, y1, z0], [x1, y1, z0], [x1, y0, z0], [x0, y0, z0]),  # -z
        ([x1, y1, z1], [x0, y1, z1], [x0, y0, z1], [x1, y0, z1]),  # +z
        ([x0, y1, z1], [x0, y1, z0], [x0, y0, z0], [x0, y0, z1]),  # -x
        ([x1, y1, z0], [x1, y1, z1], [x1, y0, z1], [x1, y0, z0]),  # +x
    ]
    out = []
    for a, b, c, d in faces:
        for i in range(n):
            for j in range(n):
                def p(u, v):
                    low = add(a, mul(sub(b, a), u))
                    high = add(d, mul(sub(c, d), u))
                    return add(low, mul(sub(high, low), v))

                u0, u1, v0, v1 = i / n, (i + 1) / n, j / n, (j + 1) / n
                out.append(poly([p(u0, v0), p(u1, v0), p(u1, v1), p(u0, v1)], m))
    check_outward(out, mul(add(lo, hi), 0.5))
    return out


def revolve(profile, centre, m, seg, caps=True):
    """A closed surface of revolution about the vertical axis through `centre`:
    `profile` is [(r, y), ...] from the bottom pole or rim up; rims of radius 0 are
    poles (triangles), the others quads. The ends are closed by fans when their
    radius is not 0 (`caps`; a profile that is a closed loop, a torus's circle run
    counter-clockwise in the (r, y) plane, needs none). Faces out."""
    cx, cy, cz = centre
    rings = []
    for r, y in profile:
        ring = []
        for k in range(seg):
            t = 2 * math.pi * k / seg
            ring.append([cx + r * math.cos(t), cy + y, cz - r * math.sin(t)])
        rings.append((r, ring))
    out = []
    for (r0, ra), (r1, rb) in zip(rings, rings[1:]):
        for k in range(seg):
            k1 = (k + 1) % seg
            if r0 == 0 and r1 == 0:
                continue
            if r0 == 0:
                out.append(poly([ra[k], rb[k1], rb[k]], m))
            elif r1 == 0:
                out.append(poly([ra[k], ra[k1], rb[k]], m))
            else:
                out.append(poly([ra[k], ra[k1], rb[k1], rb[k]], m))
    # caps
    r_bot, bot = rings[0]
    if caps and r_bot > 0:
        c = [cx, cy + profile[0][1], cz]
        for k in range(seg):
            out.append(poly([c, bot[(k + 1) % seg], bot[k]], m))
    r_top, top = rings[-1]
    if caps and r_top > 0:
        c = [cx, cy + profile[-1][1], cz]
        for k in range(seg):
            out.append(poly([c, top[k], top[(k + 1) % seg]], m))
    check_closed_outward(out)
    return out


def cylinder(centre, r, h, m, seg, stacks=1):
    prof = [(r, h * i / stacks) for i in range(stacks + 1)]
    out = revolve(prof, centre, m, seg)
    check_outward(out, add(centre, [0, h / 2, 0]))
    return out


def sphere(centre, r, m, seg):
    rings = max(3, seg // 2)
    prof = [(r * math.sin(math.pi * i / rings), -r * math.cos(math.pi * i / rings)) for i in range(rings + 1)]
    prof[0] = (0.0, -r)
    prof[-1] = (0.0, r)
    out = revolve(prof, centre, m, seg)
    check_outward(out, centre)
    return out


def vase(centre, m, seg, h=0.35, r=0.1):
    prof = []
    n = max(6, seg // 2)
    for i in range(n + 1):
        t = i / n
        prof.append((r * (0.55 + 0.45 * math.sin(math.pi * (0.15 + 0.85 * t)) - 0.25 * t), h * t))
    return revolve(prof, centre, m, seg)


# --- the room and its furniture ---------------------------------------------------

W, H, D = 7.0, 2.8, 5.0
DOOR = (5.2, 6.1, 2.1)  # x from, x to, height: the door's opening in the front wall (z = 0)


def room(rng, detail):
    n = max(2, round(16 * detail))
    out = []
    # floor (+y) and ceiling (-y)
    out += tiled_tris([0, 0, 0], [0, 0, D], [W, 0, D], [W, 0, 0], "floor", n, n, rng)
    out += tiled_tris([0, H, 0], [W, H, 0], [W, H, D], [0, H, D], "ceiling", n, n, rng)
    # back wall z = D (-z), left x = 0 (+x), right x = W (-x)
    out += tiled_tris([0, 0, D], [0, H, D], [W, H, D], [W, 0, D], "wall", n // 2, n, rng)
    out += tiled_tris([0, 0, 0], [0, H, 0], [0, H, D], [0, 0, D], "wall_warm", n // 2, n, rng)
    out += tiled_tris([W, 0, 0], [W, 0, D], [W, H, D], [W, H, 0], "wall", n, n // 2, rng)
    # front wall z = 0 (+z) with the door's opening: three pieces round it
    x0, x1, dh = DOOR
    out += tiled_tris([0, 0, 0], [x0, 0, 0], [x0, H, 0], [0, H, 0], "wall", n, n // 2, rng)
    out += tiled_tris([x1, 0, 0], [W, 0, 0], [W, H, 0], [x1, H, 0], "wall", 2, n // 2, rng)
    out += tiled_tris([x0, dh, 0], [x1, dh, 0], [x1, H, 0], [x0, H, 0], "wall", 2, 2, rng)
    # the corridor behind the door: a dark box open towards the room
    out += [poly([[x0, 0, -1], [x1, 0, -1], [x1, 0, 0], [x0, 0, 0]], "floor")]
    out += [poly([[x0, 0, -1], [x0, dh, -1], [x1, dh, -1], [x1, 0, -1]], "dark")]
    out += [poly([[x0, 0, -1], [x0, 0, 0], [x0, dh, 0], [x0, dh, -1]], "dark")]
    out += [poly([[x1, 0, -1], [x1, dh, -1], [x1, dh, 0], [x1, 0, 0]], "dark")]
    out += [poly([[x0, dh, -1], [x0, dh, 0], [x1, dh, 0], [x1, dh, -1]], "dark")]
    return out


def lamps():
    y = H - 0.02
    out = []
    for cx in (2.3, 4.7):
        a, b = cx - 0.4, cx + 0.4
        out.append(poly([[a, y, 2.1], [b, y, 2.1], [b, y, 2.9], [a, y, 2.9]], "lamp"))
    return out


def table(detail):
    seg = max(8, round(44 * detail))
    out = box([2.2, 0.72, 1.7], [4.8, 0.76, 3.3], "wood", 2)
    for x in (2.35, 4.65):
        for z in (1.85, 3.15):
            out += cylinder([x, 0.0, z], 0.035, 0.72, "wood", seg, 2)
    return out


def chair(x, z, facing, detail):
    """A chair whose back is on the side away from `facing` (+1: faces +z)."""
    seg = max(6, round(22 * detail))
    out = box([x - 0.22, 0.44, z - 0.22], [x + 0.22, 0.48, z + 0.22], "wood", 2)
    bz = z - 0.22 * facing
    out += box([x - 0.22, 0.48, min(bz, bz - 0.03 * facing)], [x + 0.22, 0.95, max(bz, bz - 0.03 * facing)], "wood", 2)
    for dx in (-0.19, 0.19):
        for dz in (-0.19, 0.19):
            out += cylinder([x + dx, 0.0, z + dz], 0.018, 0.44, "wood", seg)
    return out


def sofa(detail):
    n = max(1, round(5 * detail))
    # against the left wall (x = 0) in the back corner, seat facing +x
    x0, x1, z0, z1 = 0.05, 0.9, 3.6, 4.95
    out = box([x0, 0.0, z0], [x1, 0.42, z1], "fabric", n)
    out += box([x0, 0.42, z0], [x0 + 0.2, 0.85, z1], "fabric", n)
    out += box([x0 + 0.2, 0.42, z0], [x1, 0.62, z0 + 0.2], "fabric", n)
    out += box([x0 + 0.2, 0.42, z1 - 0.2], [x1, 0.62, z1], "fabric", n)
    return out


def bookshelf(rng, detail):
    """Against the right wall (x = W): a frame of boards and rows of books."""
    x0, x1, z0, z1 = W - 0.35, W - 0.02, 0.8, 2.6
    out = []
    out += box([x0, 0.0, z0], [x1, 2.0, z0 + 0.02], "wood")
    out += box([x0, 0.0, z1 - 0.02], [x1, 2.0, z1], "wood")
    shelves = [0.0, 0.4, 0.8, 1.2, 1.6, 1.98]
    for y in shelves:
        out += box([x0, y, z0 + 0.02], [x1, y + 0.02, z1 - 0.02], "wood")
    books = 0
    per_row = max(6, round(40 * detail))
    for y in shelves[:-1]:
        z = z0 + 0.03
        for _ in range(per_row):
            t = rng.uniform(0.02, 0.05)
            h = rng.uniform(0.22, 0.34)
            dpt = rng.uniform(0.18, 0.28)
            if z + t > z1 - 0.03:
                break
            colour = ["book_red", "book_blue", "book_cream"][books % 3]
            out += box([x1 - 0.02 - dpt, y + 0.02, z], [x1 - 0.02, y + 0.02 + h, z + t], colour)
            z += t + 0.003
            books += 1
    return out


def sideboard(detail):
    seg = max(8, round(56 * detail))
    out = box([0.02, 0.0, 1.2], [0.5, 0.8, 3.4], "wood", 3)
    out += vase([0.26, 0.8, 1.6], "ceramic", seg)
    out += vase([0.26, 0.8, 3.0], "ceramic", seg, h=0.5, r=0.12)
    out += sphere([0.26, 0.8 + 0.09, 2.3], 0.09, "ceramic", seg)  # a bowl of fruit, as a ball
    out += cylinder([0.26, 0.8, 2.0], 0.06, 0.12, "ceramic", seg, 3)
    out += cylinder([0.26, 0.8, 2.6], 0.06, 0.18, "ceramic", seg, 3)
    return out


def floor_lamp(detail):
    seg = max(8, round(44 * detail))
    out = cylinder([6.3, 0.0, 4.4], 0.18, 0.03, "metal", seg)
    out += cylinder([6.3, 0.03, 4.4], 0.015, 1.45, "metal", seg, 4)
    # the shade: a truncated cone, closed
    prof = [(0.2, 0.0), (0.2, 0.005)] + [(0.2 - 0.08 * i / 6, 0.3 * i / 6) for i in range(1, 7)]
    out += revolve(prof, [6.3, 1.48, 4.4], "shade", seg)
    return out


def pendant(detail):
    """A round shade over the table, hung from the ceiling by a rod (not emitting:
    the light is the panels')."""
    seg = max(12, round(80 * detail))
    out = sphere([3.5, 1.95, 2.5], 0.22, "shade", seg)
    out += cylinder([3.5, 2.17, 2.5], 0.01, H - 2.17, "metal", max(6, seg // 4))
    return out


def person(detail):
    """A figure about 1.7 m tall standing at the origin, facing +z: legs, torso,
    arms and head, each a closed mesh."""
    seg = max(8, round(44 * detail))
    out = []
    out += cylinder([-0.09, 0.0, 0.0], 0.07, 0.82, "cloth_blue", seg, 4)
    out += cylinder([0.09, 0.0, 0.0], 0.07, 0.82, "cloth_blue", seg, 4)
    prof = [(0.17, 0.0), (0.19, 0.2), (0.2, 0.4), (0.18, 0.55), (0.1, 0.6)]
    out += revolve(prof, [0.0, 0.82, 0.0], "cloth_red", seg)
    out += cylinder([-0.25, 0.75, 0.0], 0.045, 0.62, "cloth_red", seg, 3)
    out += cylinder([0.25, 0.75, 0.0], 0.045, 0.62, "cloth_red", seg, 3)
    out += sphere([0.0, 1.58, 0.0], 0.11, "skin", seg)
    return out


def door(detail):
    x0, x1, dh = DOOR
    n = max(1, round(5 * detail))
    # in the door's own space: hinge on the y axis at the origin, leaf along +x, in
    # the wall's plane; placed 4.5 cm from the jamb so that it clears it when open
    return box([0.0, 0.0, -0.04], [x1 - x0 - 0.055, dh - 0.01, 0.0], "door", n)


def yaw(angle):
    """The quaternion (x, y, z, w) of a turn by `angle` about +y."""
    return [0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2)]


def keys_along(path, duration, step=0.2):
    """Motion keys every `step` seconds along `path(s)`, s in [0, 1] -> (x, z),
    turned to face the direction of travel (+z of the figure)."""
    n = max(2, int(round(duration / step)))
    keys, last = [], None
    for i in range(n + 1):
        s = i / n
        x, z = path(s)
        x2, z2 = path(min(1.0, s + 1e-3))
        xb, zb = path(max(0.0, s - 1e-3))
        dx, dz = x2 - xb, z2 - zb
        ang = math.atan2(dx, dz) if dx * dx + dz * dz > 1e-12 else (last or 0.0)
        if last is not None:  # unwrap so the slerp takes the short way
            while ang - last > math.pi:
                ang -= 2 * math.pi
            while ang - last < -math.pi:
                ang += 2 * math.pi
        last = ang
        keys.append({"t": round(s * duration, 6), "translation": rnd([x, 0.0, z]), "rotation": rnd(yaw(ang))})
    return keys


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--detail", type=float, default=1.0)
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--fps", type=float, default=25.0)
    ap.add_argument("--movers", choices=["people", "door", "both", "none"], default="both")
    ap.add_argument("--static", action="store_true", help="movers at their first pose, no motion")
    ap.add_argument("--probes", help="also write 200 probe points here")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    if args.frames < 2 or args.fps <= 0 or args.detail <= 0:
        ap.error("expected --frames >= 2, --fps > 0, --detail > 0")
    rng = random.Random(args.seed)
    duration = (args.frames - 1) / args.fps

    objects = [
        {"name": "room", "polygons": room(rng, args.detail)},
        {"name": "lamps", "polygons": lamps()},
        {"name": "table", "polygons": table(args.detail)},
        {"name": "sofa", "polygons": sofa(args.detail)},
        {"name": "bookshelf", "polygons": bookshelf(rng, args.detail)},
        {"name": "sideboard", "polygons": sideboard(args.detail)},
        {"name": "floor_lamp", "polygons": floor_lamp(args.detail)},
        {"name": "pendant", "polygons": pendant(args.detail)},
    ]
    chairs = []
    for x in (2.7, 3.5, 4.3):
        chairs += chair(x, 1.35, +1, args.detail)
        chairs += chair(x, 3.65, -1, args.detail)
    objects.append({"name": "chairs", "polygons": chairs})

    movers = []
    if args.movers in ("people", "both"):
        # A: once round the table and its chairs on a rounded rectangle (a
        # superellipse), starting at its left end; it clears the chairs' backs.
        def loop(s):
            t = 2 * math.pi * s
            c, n = math.cos(t), math.sin(t)
            return 3.5 - 1.8 * math.copysign(abs(c) ** 0.5, c), 2.5 + 1.75 * math.copysign(abs(n) ** 0.5, n)

        # B: in from the door along the bookshelf to the floor lamp and back, on a
        # bent line that keeps clear of A's round.
        def across(s):
            u = 1 - abs(1 - 2 * s)  # 0 -> 1 -> 0
            return 5.95 + 0.1 * math.sin(math.pi * u), 0.45 + 3.1 * u

        movers.append(("person_a", person(args.detail), keys_along(loop, duration)))
        movers.append(("person_b", person(args.detail), keys_along(across, duration)))
    if args.movers in ("door", "both"):
        x0 = DOOR[0]
        keys = []
        n = max(2, int(round(duration / 0.2)))
        for i in range(n + 1):
            s = i / n
            ang = math.radians(80) * math.sin(math.pi * s) ** 2  # opens into the corridor and shuts
            keys.append({"t": round(s * duration, 6), "translation": [x0 + 0.045, 0.0, 0.0], "rotation": rnd(yaw(ang))})
        movers.append(("door", door(args.detail), keys))
    for name, polys, keys in movers:
        obj = {"name": name, "polygons": polys}
        if args.static:
            k = keys[0]
            obj["motion"] = [{"t": 0.0, "translation": k["translation"], "rotation": k["rotation"]}]
        else:
            obj["motion"] = keys
        objects.append(obj)

    scene = {
        "rhier_scene": 1,
        "time": {"start": 0.0, "end": 0.0 if args.static else round(duration, 6)},
        "camera": {"eye": [3.5, 1.6, -0.9], "target": [3.5, 0.9, 3.0], "fov_y_degrees": 70},
        "materials": {
            "floor": {"reflectance": [0.45, 0.38, 0.3]},
            "ceiling": {"reflectance": [0.82, 0.82, 0.8]},
            "wall": {"reflectance": [0.75, 0.73, 0.68]},
            "wall_warm": {"reflectance": [0.7, 0.45, 0.3]},
            "dark": {"reflectance": [0.1, 0.1, 0.1]},
            "wood": {"reflectance": [0.5, 0.35, 0.22]},
            "fabric": {"reflectance": [0.25, 0.35, 0.55]},
            "book_red": {"reflectance": [0.6, 0.15, 0.12]},
            "book_blue": {"reflectance": [0.12, 0.2, 0.55]},
            "book_cream": {"reflectance": [0.8, 0.75, 0.6]},
            "ceramic": {"reflectance": [0.85, 0.85, 0.82]},
            "metal": {"reflectance": [0.4, 0.4, 0.42]},
            "shade": {"reflectance": [0.85, 0.8, 0.7]},
            "door": {"reflectance": [0.65, 0.55, 0.4]},
            "cloth_blue": {"reflectance": [0.15, 0.2, 0.45]},
            "cloth_red": {"reflectance": [0.6, 0.2, 0.15]},
            "skin": {"reflectance": [0.7, 0.5, 0.4]},
            "lamp": {"reflectance": [0.8, 0.8, 0.8], "emission": [18.0, 17.0, 15.0]},
        },
        "objects": objects,
    }
    with open(args.out, "w") as f:
        json.dump(scene, f, separators=(",", ":"))
    total = sum(len(o["polygons"]) for o in objects)
    moving = sum(len(p) for _, p, _ in movers)
    print(f"{total} polygons ({moving} moving) -> {args.out}")

    if args.probes:
        write_probes(objects, args.probes, rng)


def write_probes(objects, out, rng, count=200):
    """Area-weighted points on the static, non-emitting polygons, lifted 0.1 mm."""
    cands = []
    for o in objects:
        if "motion" in o or o["name"] == "lamps":
            continue
        for p in o["polygons"]:
            cands.append(p["vertices"])
    weights = [area(vs) for vs in cands]
    pts = []
    for vs in rng.choices(cands, weights=weights, k=count):
        n = normal(vs)
        ln = math.sqrt(dot(n, n))
        n = mul(n, 1.0 / ln)
        # a uniform point in the triangle fan's first triangle, or the quad's by two
        tri = vs[:3] if len(vs) == 3 or rng.random() < 0.5 else [vs[0], vs[2], vs[3]]
        u, v = rng.random(), rng.random()
        if u + v > 1:
            u, v = 1 - u, 1 - v
        p = add(tri[0], add(mul(sub(tri[1], tri[0]), u), mul(sub(tri[2], tri[0]), v)))
        pts.append({"p": rnd(add(p, mul(n, 1e-4))), "n": rnd(n)})
    with open(out, "w") as f:
        json.dump(pts, f)
    print(f"{len(pts)} probes -> {out}")


if __name__ == "__main__":
    main()
