#!/usr/bin/python3
"""Makes the assets of the shipped scenes in scenes/assets/: closed triangle meshes written as OBJ (a glass, a
bulldozer blade, a torus, a hopper and the sand in it) and a rock as a VDB level set (through Debian's python3-openvdb, from a noisy icosphere).
Deterministic: the same files every run. Usage: /usr/bin/python3 tools/make_assets.py [OUT_DIR]"""
import math
import os
import random
import sys


def write_obj(path, vertices, faces, comment):
    with open(path, "w") as f:
        f.write(f"# {comment}\n# made by tools/make_assets.py\n")
        for v in vertices:
            f.write("v %.6f %.6f %.6f\n" % v)
        for t in faces:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def revolve(profile, segments, closed=True):
    """A surface of revolution about +Y of a loop of (r, y) points (r > 0): closed, or open between its last
    and first points (the caller closes it)."""
    verts, faces = [], []
    n = len(profile)
    for s in range(segments):
        a = 2 * math.pi * s / segments
        for r, y in profile:
            verts.append((r * math.cos(a), y, r * math.sin(a)))
    for s in range(segments):
        s1 = (s + 1) % segments
        for i in range(n if closed else n - 1):
            i1 = (i + 1) % n
            a, b, c, d = s * n + i, s * n + i1, s1 * n + i1, s1 * n + i
            faces += [(a, d, c), (a, c, b)]
    return verts, faces


def glass(out):
    # A tumbler: outer radius 6 cm, wall 5 mm, floor 6 mm, 12 cm tall, as the solid of its walls.
    ro, ri, h, floor = 0.06, 0.055, 0.12, 0.006
    profile = [(0.004, 0.0), (ro, 0.0), (ro, h), (ri, h), (ri, floor), (0.004, floor)]
    # The axis must stay closed: a small disk of radius 4 mm closes the floor in the middle.
    verts, faces = revolve(profile, 96, closed=False)
    # Close the hole at the axis with two fans (floor bottom and floor top).
    n, segments = len(profile), 96
    bottom, top = len(verts), len(verts) + 1
    verts += [(0.0, 0.0, 0.0), (0.0, floor, 0.0)]
    for s in range(segments):
        s1 = (s + 1) % segments
        faces.append((bottom, s * n + 0, s1 * n + 0))
        faces.append((top, s1 * n + 5, s * n + 5))
    faces = [(a, c, b) for a, b, c in faces]  # outward normals
    write_obj(os.path.join(out, "glass.obj"), verts, faces, "a glass tumbler, r = 6 cm, h = 12 cm, walls 5 mm (closed solid of its walls)")


def blade(out):
    # A curved blade: an arc of 90 degrees and radius 0.15 m, 0.4 m wide (z), 2 cm thick, extruded.
    verts, faces = [], []
    r0, r1, width, arcs = 0.15, 0.17, 0.4, 24
    ring = []
    for i in range(arcs + 1):
        a = math.pi / 2 * i / arcs
        ring.append((r0 * math.cos(a), r0 * math.sin(a)))
    outer = [(r1 * math.cos(math.pi / 2 * i / arcs), r1 * math.sin(math.pi / 2 * i / arcs)) for i in range(arcs + 1)]
    loop = ring + outer[::-1]  # the blade's cross-section in (x, y), closed
    m = len(loop)
    for z in (-width / 2, width / 2):
        for x, y in loop:
            verts.append((-x, y, z))  # concave side towards +x, the way it pushes
    for i in range(m):
        i1 = (i + 1) % m
        faces += [(i, i1, m + i1), (i, m + i1, m + i)]
    # The end caps: the cross-section is a thick arc, so strips between the inner and the outer arc close it.
    for base, flip in ((0, True), (m, False)):
        for i in range(arcs):
            quad = [(base + i, base + i + 1, base + m - 2 - i), (base + i, base + m - 2 - i, base + m - 1 - i)]
            faces += [(t[0], t[2], t[1]) if flip else t for t in quad]
    write_obj(os.path.join(out, "blade.obj"), verts, faces, "a bulldozer blade: a 90-degree arc of radius 15 cm, 2 cm thick, 40 cm wide")


def rock(out):
    import pyopenvdb as vdb

    # A noisy icosphere of radius about 0.25 m: each vertex pushed along its normal by a fixed random sum of waves.
    t = (1 + 5 ** 0.5) / 2
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1),
         (-t, 0, -1), (-t, 0, 1)]
    V = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in V]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4),
         (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(4):
        cache, G = {}, []
        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                p = [(V[a][i] + V[b][i]) / 2 for i in range(3)]
                l = math.sqrt(sum(x * x for x in p))
                V.append(tuple(x / l for x in p))
                cache[k] = len(V) - 1
            return cache[k]
        for a, b, c in F:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            G += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = G
    rng = random.Random(7)
    waves = [(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(2, 6), rng.uniform(0, 6.28)) for _ in range(8)]
    pts = []
    for x, y, z in V:
        d = sum(0.012 * math.sin(f * (a * x + b * y + c * z) + p) for a, b, c, f, p in waves)
        r = 0.25 + d
        pts.append((r * x, r * y * 0.7 + 0.1, r * z))  # flattened, its top at about 0.28 m
    xform = vdb.createLinearTransform(voxelSize=0.01)
    import numpy
    grid = vdb.FloatGrid.createLevelSetFromPolygons(numpy.array(pts, dtype=numpy.float32), triangles=numpy.array(F, dtype=numpy.uint32),
                                                    transform=xform, halfWidth=3.0)
    grid.name = "surface"
    vdb.write(os.path.join(out, "rock.vdb"), grids=[grid])
    write_obj(os.path.join(out, "rock.obj"), pts, F, "the rock of rock.vdb, as a mesh (for renders)")


def torus(out):
    # A ring in file units (major radius 1, minor 0.4, about +Y): a shape no box or sphere makes; the scene
    # places and scales it with "transform".
    R, r, nu, nv = 1.0, 0.4, 64, 24
    verts = [((R + r * math.cos(b)) * math.cos(a), r * math.sin(b), (R + r * math.cos(b)) * math.sin(a))
             for a in (2 * math.pi * i / nu for i in range(nu)) for b in (2 * math.pi * j / nv for j in range(nv))]
    faces = []
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j, i * nv + (j + 1) % nv
            c, d = ((i + 1) % nu) * nv + (j + 1) % nv, ((i + 1) % nu) * nv + j
            faces += [(a, b, c), (a, c, d)]
    write_obj(os.path.join(out, "torus.obj"), verts, faces, "a torus, major radius 1, minor radius 0.4, file units")


def signed_volume(verts, faces):
    return sum(
        (verts[a][0] * (verts[b][1] * verts[c][2] - verts[b][2] * verts[c][1]) - verts[a][1] * (verts[b][0] * verts[c][2] - verts[b][2] * verts[c][0])
         + verts[a][2] * (verts[b][0] * verts[c][1] - verts[b][1] * verts[c][0])) / 6 for a, b, c in faces)


def outward(verts, faces):
    """The faces wound so that their normals point out of the solid (positive enclosed volume)."""
    return faces if signed_volume(verts, faces) > 0 else [(a, c, b) for a, b, c in faces]


def capped(profile, segments):
    """A solid of revolution about +Y of an open (r, y) profile whose first and last points lie on the axis side:
    the profile revolved, and fans at its first and last points' heights closing it at the axis."""
    verts, faces = revolve(profile, segments, closed=False)
    n = len(profile)
    first, last = len(verts), len(verts) + 1
    verts += [(0.0, profile[0][1], 0.0), (0.0, profile[-1][1], 0.0)]
    for s in range(segments):
        s1 = (s + 1) % segments
        faces.append((first, s1 * n, s * n))
        faces.append((last, s * n + n - 1, s1 * n + n - 1))
    return verts, outward(verts, faces)


# The hopper: a bin of inner radius 10 cm over a cone of 30 degrees from the vertical down to an outlet of radius
# 3.5 cm at 0.3 m above the floor; walls 2 cm thick (two cells of its scene's dx, so the wall's level set has an
# inside on the grid).
HOPPER_OUTLET, HOPPER_BIN, HOPPER_BOTTOM, HOPPER_TOP, HOPPER_WALL = 0.035, 0.10, 0.30, 0.60, 0.02
HOPPER_CONE_TOP = HOPPER_BOTTOM + (HOPPER_BIN - HOPPER_OUTLET) / math.tan(math.radians(30))


def hopper(out):
    t = HOPPER_WALL
    outer_outlet = HOPPER_OUTLET + t / math.cos(math.radians(30))
    outer_cone_top = HOPPER_BOTTOM + (HOPPER_BIN + t - outer_outlet) / math.tan(math.radians(30))
    profile = [(HOPPER_OUTLET, HOPPER_BOTTOM), (outer_outlet, HOPPER_BOTTOM), (HOPPER_BIN + t, outer_cone_top),
               (HOPPER_BIN + t, HOPPER_TOP), (HOPPER_BIN, HOPPER_TOP), (HOPPER_BIN, HOPPER_CONE_TOP)]
    verts, faces = revolve(profile, 96)
    faces = outward(verts, faces)
    write_obj(os.path.join(out, "hopper.obj"), verts, faces,
              "a hopper: bin r = 10 cm over a 30-degree cone to an outlet of r = 3.5 cm at y = 0.3 m; walls 2 cm (closed solid of its walls)")
    # The sand it holds: the inside of the cone and the bin up to 0.52 m, 5 mm in from the walls.
    inset, fill = 0.005, 0.52
    profile = [(0.0, HOPPER_BOTTOM + 0.002), (HOPPER_OUTLET - inset, HOPPER_BOTTOM + 0.002), (HOPPER_BIN - inset, HOPPER_CONE_TOP + 0.003),
               (HOPPER_BIN - inset, fill), (0.0, fill)]
    verts, faces = capped(profile[1:-1], 96)
    write_obj(os.path.join(out, "hopper_fill.obj"), verts, faces, "the sand in hopper.obj: its cone and bin up to y = 0.52 m, 5 mm in from the walls")


if __name__ == "__main__":
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "scenes", "assets")
    os.makedirs(out, exist_ok=True)
    glass(out)
    blade(out)
    rock(out)
    torus(out)
    hopper(out)
    print("wrote", ", ".join(sorted(os.listdir(out))), "in", os.path.abspath(out))
