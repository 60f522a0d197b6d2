"""Headless Blender render of mpm's output, with the scene's colliders (Debian's Blender 3.4).

    blender -b --factory-startup --python-exit-code 1 -P tools/render_blender.py -- \
        --vdb out/dam_break/dam_break_0012.vdb --out dam.png [--frames 1:48] [options]

Imports the frame's .vdb as a Volume and meshes every surface grid in it (`surface`, or `surface_<material>`
/ `surface_<set>` with output.surface_group) with a Volume to Mesh modifier at threshold 0, the zero
crossing of the signed distance, in its sets' own colour (`color`) or else its material's. The colliders come from the run's `scene.json`
(beside the frame; its `scene_file` locates the assets), placed where their motion has them at the frame's
time: planes as a finite floor or wall, boxes, cylinders, spheres, meshes from their files (OBJ, PLY, STL)
and VDB colliders from their level set (a `$F` sequence at the frame's file). Planes and containers
(`"inside": true`) and colliders around the material (a glass, a bowl) are drawn as cutaways: the side facing the camera is see-through, so a wall in front of
the material or a tank's near side never hides it. mpm writes Y-up (Houdini's convention); everything is
placed under one object turned +90 degrees about X, so that Y becomes Blender's Z.

With --frames A:B, --vdb names any frame and the file's number is replaced for each; --out gets the frame
number appended (dam_0012.png), and the camera stays where it is for the whole sequence: it is framed
once on the material over all the frames and on the colliders. --check-not-empty renders a flat-colour
pass after the image and exits 1 when the material (or, where the scene has any, the colliders) covers
less than --min-coverage of it (the CTest tests labelled `blender`).
"""
import argparse
import colorsys
import csv
import glob
import json
import math
import os
import re
import sys

import bpy
from mathutils import Matrix, Quaternion, Vector

# Base colours per material (linear RGB), a copy of the materials' kColour (materials/*.h; tests/test_python.py
# compares them); sets of other materials take the palette in order.
MATERIAL_COLOURS = {"water": (0.15, 0.4, 0.9), "jelly": (0.85, 0.2, 0.25), "rubber": (0.55, 0.25, 0.7),
                    "snow": (0.92, 0.94, 0.97), "sand": (0.76, 0.6, 0.38),
                    "metal": (0.72, 0.74, 0.78), "viscous": (0.8, 0.45, 0.05)}
PALETTE = [(0.2, 0.65, 0.35), (0.9, 0.6, 0.1), (0.3, 0.7, 0.8), (0.6, 0.6, 0.2)]
COLLIDER_COLOUR = (0.42, 0.4, 0.38)
# Rigid bodies (colliders with "dynamic") stand apart from the walls around them: drawn in the walls' grey, a box
# in a tank vanished against the tank's far wall from a front view.
BODY_COLOUR = (0.75, 0.42, 0.18)
# A collider's drawn extent is clipped to the material's bounds grown by this many times their size, so a
# drum 1 m long around a 4 cm slab of sand does not shrink the material to a speck.
COLLIDER_FRAMING_MARGIN = 0.5
# --check-colours: a pixel counts towards a surface's colour when its saturation is at least SATURATED and its
# hue within HUE_TOLERANCE (of the hue circle) of the colour's. Shaded under Filmic, the jelly balls' red and blue
# keep their hues to about 0.02 (measured on jelly_bounce); grey walls and the sky stay under 0.25 saturation.
SATURATED, HUE_TOLERANCE = 0.25, 0.06
# Flat colours of the coverage pass.
ID_MATERIAL, ID_COLLIDER = (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="render_blender.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--vdb", required=True, help="a frame file written by mpm (holding the surface grids)")
    p.add_argument("--out", required=True, help="PNG to write")
    p.add_argument("--frames", default="", help="A:B renders frames A..B, numbering files like --vdb")
    p.add_argument("--grid", default="", help="mesh only this level-set grid (default: every surface grid)")
    p.add_argument("--scene", default="", help="resolved scene (default: scene.json beside --vdb)")
    p.add_argument("--no-colliders", action="store_true", help="draw the material only")
    p.add_argument("--view", default="0.9,0.9,1.6",
                   help="direction from the material to the camera, x,y,z in the scene's (Y-up) axes")
    p.add_argument("--engine", choices=["CYCLES", "BLENDER_EEVEE"], default="CYCLES")
    p.add_argument("--samples", type=int, default=32)
    p.add_argument("--resolution", default="960x540", help="WxH in pixels")
    p.add_argument("--color", default="", help="one colour r,g,b in 0..1 for every surface (default: the sets' colours, else per material)")
    p.add_argument("--floor", action="store_true",
                   help="add a grey floor under the material when the scene has no floor plane")
    p.add_argument("--check-not-empty", action="store_true",
                   help="exit 1 if the material or the colliders are missing from the image")
    p.add_argument("--min-coverage", type=float, default=0.01, help="least image fraction each must cover")
    p.add_argument("--check-colours", action="store_true",
                   help="exit 1 unless every set with a colour shows in the image in its hue (over --min-coverage / 2 "
                        "shared among the sets)")
    return p.parse_args(argv)


def fail(msg):
    print("render_blender: error: " + msg, file=sys.stderr)
    sys.exit(1)


def frame_file(template, frame):
    """Replaces the trailing frame number of `template` (name_0012.vdb) by `frame`, keeping its width."""
    m = re.search(r"(\d+)(\.vdb)$", template)
    if not m:
        fail("--frames needs a --vdb whose name ends in a frame number, got " + template)
    width = len(m.group(1))
    return template[:m.start(1)] + str(frame).zfill(width) + m.group(2)


def vec(v):
    return Vector((float(v[0]), float(v[1]), float(v[2])))


# ---------------------------------------------------------------------------------------------- scene

class Scene:
    """The parts of the resolved scene the render needs."""

    def __init__(self, path):
        self.colliders, self.fps, self.base, self.set_material, self.set_colour = [], 24.0, "", {}, {}
        if not path or not os.path.isfile(path):
            return
        with open(path) as f:
            s = json.load(f)
        self.fps = float(s.get("simulation", {}).get("fps", 24.0))
        self.colliders = s.get("colliders", [])
        self.set_material = {st.get("name", ""): st.get("material", "") for st in s.get("sets", [])}
        # A set's own colour (its points' Cd, linear RGB), where the scene gives one.
        self.set_colour = {st.get("name", ""): tuple(float(c) for c in st["color"])
                           for st in s.get("sets", []) if len(st.get("color", [])) == 3}
        # The rigid bodies' poses by collider and frame, from the run's bodies.csv beside scene.json.
        self.bodies = {}
        bodies = os.path.join(os.path.dirname(os.path.abspath(path)), "bodies.csv")
        if os.path.isfile(bodies):
            with open(bodies) as f:
                for row in csv.DictReader(f):
                    pose = (Vector(tuple(float(row[k]) for k in ("x", "y", "z"))),
                            Quaternion(tuple(float(row[k]) for k in ("qw", "qx", "qy", "qz"))))
                    self.bodies.setdefault(int(row["collider"]), {})[int(row["frame"])] = pose
        source = s.get("scene_file", "")
        if source:
            self.base = os.path.dirname(source)
        elif any(c.get("file") for c in self.colliders):
            print("render_blender: warning: %s has no scene_file; file colliders are looked for beside it" % path)
            self.base = os.path.dirname(os.path.abspath(path))

    def body_pose(self, collider, frame):
        """A rigid body's centre of mass and turn from the scene's placement at the frame (the last row at or before
        it); None for a collider that is not a body of this run."""
        rows = self.bodies.get(collider)
        if not rows:
            return None
        done = [f for f in rows if f <= frame]
        return rows[max(done) if done else min(rows)]

    def body_rest_centre(self, collider, c):
        """A rigid body's centre of mass in the scene's placement (c_rest), from its first row: there its turn is the
        motion's (an animated body) or none, so the motion's inverse takes the centre back. None where that row does
        not allow it (a run resumed without its first frames)."""
        rows = self.bodies.get(collider)
        if not rows:
            return None
        first = min(rows)
        centre, turn = rows[first]
        t = first / self.fps
        animated = t < float(c.get("dynamic", {}).get("animated_until", 0.0))
        placed = motion_matrix(c.get("motion"), t, self.fps) if animated else Matrix.Identity(4)
        if placed.to_quaternion().rotation_difference(turn).angle > 1e-6:
            return None
        return placed.inverted() @ centre

    def asset(self, name):
        return name if os.path.isabs(name) else os.path.join(self.base, name)

    def colour_of_grid(self, grid, index):
        """The colour of a surface grid: its sets' own colour where they share one, else their material's."""
        key = grid[len("surface_"):] if grid.startswith("surface_") else ""
        if key in self.set_material:
            sets = [key]  # surface_group "set"
        elif key:
            sets = [n for n, m in self.set_material.items() if m == key]  # surface_group "material"
        else:
            sets = list(self.set_material)  # one surface for every set
        own = {self.set_colour.get(n) for n in sets}
        if len(own) == 1 and None not in own:
            return own.pop()
        if len(own - {None}) > 1:
            print("render_blender: warning: grid '%s' is the surface of sets of different colours (%s); it is drawn "
                  "in one colour. Write one surface per set with \"output\": {\"surface_group\": \"set\"}"
                  % (grid, ", ".join(sorted(sets))))
        materials = {self.set_material[n] for n in sets}
        material = key if key in MATERIAL_COLOURS else (materials.pop() if len(materials) == 1 else "")
        return MATERIAL_COLOURS.get(material, PALETTE[index % len(PALETTE)])


def collider_matrix(scene, index, c, frame, rest):
    """What places collider `index` (object at its rest placement `rest`) at the frame: its motion, or for a rigid
    body its pose from bodies.csv: x = x_com + R (x_rest - c_rest), the rest centre of mass c_rest from the body's first
    row (a mesh's or level set's centre of mass need not be where its transform puts the file's origin), else where
    `rest` puts the object's origin (a box's, sphere's or cylinder's centre)."""
    pose = scene.body_pose(index, frame) if c.get("dynamic") else None
    if pose is None:
        return motion_matrix(c.get("motion"), frame / scene.fps, scene.fps)
    centre, turn = pose
    c_rest = scene.body_rest_centre(index, c)
    if c_rest is None:
        c_rest = rest.translation
    return Matrix.Translation(centre) @ turn.to_matrix().to_4x4() @ Matrix.Translation(-c_rest)


def motion_matrix(motion, t, fps):
    """The collider's pose at time t as mpm's Motion computes it: x = R x_rest + T."""
    if not motion:
        return Matrix.Identity(4)
    keys = motion.get("keyframes", [])
    pivot = vec(motion.get("pivot", [0, 0, 0]))
    if keys:
        f = t * fps
        k = 0
        while k + 1 < len(keys) and keys[k + 1]["frame"] <= f:
            k += 1

        def quat(key):
            r = key.get("rotation", {"axis": [0, 1, 0], "degrees": 0})
            return Quaternion(vec(r["axis"]).normalized(), math.radians(r["degrees"]))

        p, q = vec(keys[k]["position"]), quat(keys[k])
        if k + 1 < len(keys) and f > keys[k]["frame"]:
            s = (f - keys[k]["frame"]) / (keys[k + 1]["frame"] - keys[k]["frame"])
            p = p.lerp(vec(keys[k + 1]["position"]), s)
            q = q.slerp(quat(keys[k + 1]), s)
        R = q.to_matrix()
        T = p - R @ pivot
    else:
        w, v = vec(motion.get("angular_velocity", [0, 0, 0])), vec(motion.get("velocity", [0, 0, 0]))
        R = Matrix.Rotation(w.length * t, 3, w.normalized()) if w.length > 0 else Matrix.Identity(3)
        T = pivot + v * t - R @ pivot
    m = R.to_4x4()
    m.translation = T
    return m


# ------------------------------------------------------------------------------------------- materials

def principled(name, rgb, roughness):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    return mat


def cutaway(mat, hide_front):
    """Makes the faces that face the camera (hide_front) or those facing away see-through."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    out = nodes.get("Material Output")
    shader = out.inputs["Surface"].links[0].from_node
    geometry = nodes.new("ShaderNodeNewGeometry")
    clear = nodes.new("ShaderNodeBsdfTransparent")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
    first, second = (clear, shader) if hide_front else (shader, clear)
    links.new(first.outputs[0], mix.inputs[1])
    links.new(second.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs["Surface"])
    mat.blend_method = "HASHED"  # EEVEE honours the transparent side too


def cut_towards(mat, centre, towards):
    """Makes the part of the object on the camera's side of the plane through `centre` (normal `towards`, the
    direction to the camera) see-through: a section of a glass or a bowl, whose near wall's inside faces would
    hide its contents from a cutaway by facing alone."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    out = nodes.get("Material Output")
    shader = out.inputs["Surface"].links[0].from_node
    geometry = nodes.new("ShaderNodeNewGeometry")
    offset = nodes.new("ShaderNodeVectorMath")
    offset.operation = "SUBTRACT"
    offset.inputs[1].default_value = centre
    side = nodes.new("ShaderNodeVectorMath")
    side.operation = "DOT_PRODUCT"
    side.inputs[1].default_value = towards
    near = nodes.new("ShaderNodeMath")
    near.operation = "GREATER_THAN"
    near.inputs[1].default_value = 0.0
    clear = nodes.new("ShaderNodeBsdfTransparent")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(geometry.outputs["Position"], offset.inputs[0])
    links.new(offset.outputs["Vector"], side.inputs[0])
    links.new(side.outputs["Value"], near.inputs[0])
    links.new(near.outputs["Value"], mix.inputs["Fac"])
    links.new(shader.outputs[0], mix.inputs[1])
    links.new(clear.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs["Surface"])
    mat.blend_method = "HASHED"


def flatten(mat, rgb):
    """The coverage pass: the material's shader becomes a flat emission of `rgb`, cutaways kept."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes.get("Principled BSDF")
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (*rgb, 1.0)
    for link in list(bsdf.outputs[0].links):
        links.new(emit.outputs[0], link.to_socket)


# ---------------------------------------------------------------------------------------------- objects

def world_root():
    """Everything from mpm hangs under this: Y-up (mpm) turned to Z-up (Blender)."""
    root = bpy.data.objects.new("mpm_world", None)
    root.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    bpy.context.scene.collection.objects.link(root)
    return root


def adopt(obj, root):
    obj.parent = root
    obj.matrix_parent_inverse = Matrix.Identity(4)


def level_set_mesh(path, grid, root, name):
    """A hidden Volume object of `path` and a mesh object showing the zero crossing of its level set `grid`;
    None when the file lacks the grid."""
    volume = bpy.data.volumes.new(os.path.basename(path))
    volume.filepath = os.path.abspath(path)
    vol_obj = bpy.data.objects.new(name + "_volume", volume)
    bpy.context.scene.collection.objects.link(vol_obj)
    adopt(vol_obj, root)
    vol_obj.hide_render = True
    volume.grids.load()
    if grid not in [g.name for g in volume.grids]:
        return None
    mesh_obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
    bpy.context.scene.collection.objects.link(mesh_obj)
    adopt(mesh_obj, root)
    mod = mesh_obj.modifiers.new("surface", "VOLUME_TO_MESH")
    mod.object = vol_obj
    mod.grid_name = grid
    mod.threshold = 0.0  # the zero crossing of a signed distance; the default 0.1 is empty for a narrow band
    mod.adaptivity = 0.0
    return mesh_obj, vol_obj


def surface_grids(path):
    volume = bpy.data.volumes.new("probe")
    volume.filepath = os.path.abspath(path)
    volume.grids.load()
    names = [g.name for g in volume.grids]
    bpy.data.volumes.remove(volume)
    return names


def import_surfaces(path, args, scene, root):
    """One mesh per surface grid of the frame file, coloured per material."""
    if not os.path.isfile(path):
        fail("no such file: " + path)
    names = surface_grids(path)
    grids = [args.grid] if args.grid else [n for n in names if n == "surface" or n.startswith("surface_")]
    if not grids or any(g not in names for g in grids):
        fail("%s has no grid '%s' (grids: %s)" % (path, args.grid or "surface", ", ".join(names) or "none"))
    meshes = []
    for i, grid in enumerate(grids):
        mesh_obj, _ = level_set_mesh(path, grid, root, "mpm_" + grid)
        rgb = tuple(float(c) for c in args.color.split(",")) if args.color else scene.colour_of_grid(grid, i)
        mesh_obj.data.materials.append(principled("mpm_" + grid, rgb, 0.25))
        print("render_blender: surface %s colour %s" % (grid, ",".join("%.3f" % c for c in rgb)))
        meshes.append(mesh_obj)
    return meshes


def mesh_from_data(name, verts, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in verts], [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def box_object(c):
    size = vec(c.get("size", [0, 0, 0]))
    if size.length > 0:
        centre, r = vec(c["center"]), c.get("rotation", {"axis": [0, 1, 0], "degrees": 0})
        rot = Matrix.Rotation(math.radians(r["degrees"]), 4, vec(r["axis"]).normalized())
    else:
        lo, hi = vec(c["min"]), vec(c["max"])
        centre, size, rot = (lo + hi) / 2, hi - lo, Matrix.Identity(4)
    h = size / 2
    verts = [Vector((sx * h.x, sy * h.y, sz * h.z)) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    obj = mesh_from_data("box", verts, faces)
    return obj, Matrix.Translation(centre) @ rot


def tube_mesh(radius, inner, height, around=96):
    """A tube about z: its outer and inner walls and the two rings between them, faces facing out of the wall."""
    verts, faces = [], []
    for r in (radius, inner):
        for z in (-0.5 * height, 0.5 * height):
            for k in range(around):
                a = 2 * math.pi * k / around
                verts.append((r * math.cos(a), r * math.sin(a), z))
    at = lambda wall, top, k: (wall * 2 + top) * around + k % around  # noqa: E731
    for k in range(around):
        faces.append((at(0, 0, k), at(0, 0, k + 1), at(0, 1, k + 1), at(0, 1, k)))  # outer wall
        faces.append((at(1, 0, k), at(1, 1, k), at(1, 1, k + 1), at(1, 0, k + 1)))  # inner wall, facing the axis
        faces.append((at(0, 1, k), at(0, 1, k + 1), at(1, 1, k + 1), at(1, 1, k)))  # top ring
        faces.append((at(0, 0, k), at(1, 0, k), at(1, 0, k + 1), at(0, 0, k + 1)))  # bottom ring
    return mesh_from_data("tube", verts, faces)


def cylinder_object(c):
    if float(c.get("inner_radius", 0)) > 0:
        obj = tube_mesh(float(c["radius"]), float(c["inner_radius"]), float(c["height"]))
    else:
        bpy.ops.mesh.primitive_cylinder_add(vertices=96, radius=float(c["radius"]), depth=float(c["height"]))
        obj = bpy.context.active_object
    turn = Vector((0, 0, 1)).rotation_difference(vec(c.get("axis", [0, 1, 0])).normalized()).to_matrix().to_4x4()
    return obj, Matrix.Translation(vec(c["center"])) @ turn


def sphere_object(c):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=float(c["radius"]))
    obj = bpy.context.active_object
    obj.data.polygons.foreach_set("use_smooth", [True] * len(obj.data.polygons))
    return obj, Matrix.Translation(vec(c["center"]))


def file_mesh_object(path):
    """A mesh file through Blender's importers, its axes kept as they are (mpm's)."""
    ext = os.path.splitext(path)[1].lower()
    before = set(bpy.data.objects)
    if ext == ".obj":
        bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    elif ext == ".ply":
        bpy.ops.import_mesh.ply(filepath=path)
    elif ext == ".stl":
        bpy.ops.import_mesh.stl(filepath=path, axis_forward="Y", axis_up="Z")
    else:
        print("render_blender: warning: %s is not drawn (the render reads OBJ, PLY and STL colliders)" % path)
        return None
    new = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if not new:
        return None
    for o in new[1:]:  # several objects in one file: one collider
        o.select_set(True)
    bpy.context.view_layer.objects.active = new[0]
    if len(new) > 1:
        bpy.ops.object.join()
    obj = new[0]
    obj.matrix_world = Matrix.Identity(4)
    return obj


def sequence_file(pattern, frame):
    """The file of a `$F` / `$F4` sequence holding `frame`, clamped to the frames that exist."""
    m = re.search(r"\$F(\d?)", pattern)
    if not m:
        return pattern
    width = int(m.group(1) or 1)
    rx = re.compile(re.escape(pattern[:m.start()]) + r"(\d+)" + re.escape(pattern[m.end():]) + "$")
    frames = sorted(int(rx.match(p).group(1)) for p in glob.glob(pattern[:m.start()] + "*") if rx.match(p))
    if frames:
        frame = min(max(frame, frames[0]), frames[-1])
    return pattern[:m.start()] + str(frame).zfill(width) + pattern[m.end():]


def placement_matrix(t):
    """A file shape's `transform`: x = translate + R (scale x_file)."""
    if not t:
        return Matrix.Identity(4)
    r = t.get("rotate", {"axis": [0, 1, 0], "degrees": 0})
    rot = Matrix.Rotation(math.radians(r["degrees"]), 4, vec(r["axis"]).normalized())
    return Matrix.Translation(vec(t.get("translate", [0, 0, 0]))) @ rot @ Matrix.Scale(float(t.get("scale", 1.0)), 4)


def collider_name(i, c):
    """The Blender object name of collider i: the name the scene gave it, else collider_<i>_<type>."""
    name = c.get("name", "")
    return name if name and name != "collider%d" % i else "collider_%d_%s" % (i, c.get("type"))


def collider_object(c, scene, frame, root):
    """The collider's object at its rest placement and the matrix placing it; None for planes and for what
    cannot be drawn."""
    kind = c.get("type")
    if kind == "box":
        return box_object(c)
    if kind == "cylinder":
        return cylinder_object(c)
    if kind == "sphere":
        return sphere_object(c)
    if kind == "mesh":
        path = scene.asset(c["file"])
        if not os.path.isfile(path):
            print("render_blender: warning: collider mesh %s not found; not drawn" % path)
            return None
        obj = file_mesh_object(path)
        return (obj, placement_matrix(c.get("transform"))) if obj else None
    if kind == "vdb":
        path = sequence_file(scene.asset(c["file"]), frame)
        if not os.path.isfile(path):
            print("render_blender: warning: collider level set %s not found; not drawn" % path)
            return None
        made = level_set_mesh(path, c.get("grid", "surface"), root, "collider_vdb")
        return (made[0], placement_matrix(c.get("transform"))) if made else None
    return None


def holds(bounds, point):
    return bounds is not None and all(l <= c <= h for l, c, h in zip(bounds[0], point, bounds[1]))


def add_colliders(scene, frame, root, material=None, towards=None):
    """Every bounded collider, posed at the frame's time. A container (`"inside": true`) is drawn with its faces
    towards the camera see-through; a collider around the material (its box holds the middle of `material`'s
    bounds: a glass, a bowl) is cut by the plane through that middle facing the camera (`towards`), so that the
    near side of neither hides what it holds. A rigid body (`dynamic`) is never cut: it holds no material, it
    floats or sinks in it."""
    out = []
    for i, c in enumerate(scene.colliders):
        made = collider_object(c, scene, frame, root)
        if not made:
            continue
        obj, rest = made
        obj.name = collider_name(i, c)
        if obj.parent is not root:
            adopt(obj, root)
        obj.matrix_basis = collider_matrix(scene, i, c, frame, rest) @ rest
        mat = principled("collider_%d" % i, BODY_COLOUR if c.get("dynamic") else COLLIDER_COLOUR, 0.6)
        middle = (material[0] + material[1]) / 2 if material else None
        if c.get("inside"):
            cutaway(mat, hide_front=True)
            obj.visible_shadow = False  # a closed container would leave its inside in the dark
        elif middle is not None and towards is not None and not c.get("dynamic") and holds(world_bounds([obj]), middle):
            cut_towards(mat, middle, towards)
        obj.data.materials.clear()
        obj.data.materials.append(mat)
        out.append(obj)
    return out


def to_mpm(v):
    return Vector((v.x, v.z, -v.y))


def add_planes(scene, frame, root, lo, hi):
    """Each plane collider as a square about the framed bounds, its front on the material's side."""
    t = frame / scene.fps
    centre = to_mpm((lo + hi) / 2)
    half = 1.5 * max((hi - lo).length, 1e-3)
    planes = []
    for i, c in enumerate(scene.colliders):
        if c.get("type") != "plane":
            continue
        pose = motion_matrix(c.get("motion"), t, scene.fps)
        n = (pose.to_3x3() @ vec(c.get("normal", [0, 1, 0]))).normalized()
        p = pose @ vec(c.get("point", [0, 0, 0]))
        foot = centre - n * n.dot(centre - p)
        u = n.orthogonal().normalized()
        w = n.cross(u)
        verts = [foot + (su * u + sw * w) * half for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        obj = mesh_from_data("collider_%d_plane" % i, verts, [(0, 1, 2, 3)])
        adopt(obj, root)
        mat = principled("collider_%d" % i, COLLIDER_COLOUR, 0.6)
        cutaway(mat, hide_front=False)  # seen from behind (the solid side), a wall is see-through
        obj.visible_shadow = False  # walls all round would leave the material in their shade
        obj.data.materials.append(mat)
        planes.append(obj)
    return planes


def has_floor(scene):
    return any(c.get("type") == "plane" and vec(c.get("normal", [0, 1, 0])).normalized().y > 0.7
               for c in scene.colliders)


# ---------------------------------------------------------------------------------------------- framing

def world_bounds(objs):
    deps = bpy.context.evaluated_depsgraph_get()
    lo = hi = None
    for obj in objs:
        ev = obj.evaluated_get(deps)
        if ev.type == "MESH" and len(ev.data.vertices) == 0:
            continue
        for c in ev.bound_box:
            p = ev.matrix_world @ Vector(c)
            lo = p.copy() if lo is None else Vector(map(min, lo, p))
            hi = p.copy() if hi is None else Vector(map(max, hi, p))
    return (lo, hi) if lo is not None else None


def union(a, b):
    if a is None:
        return b
    if b is None:
        return a
    return Vector(map(min, a[0], b[0])), Vector(map(max, a[1], b[1]))


def clip(bounds, around):
    grow = COLLIDER_FRAMING_MARGIN * max(around[1] - around[0])
    lo = Vector(map(max, bounds[0], around[0] - Vector((grow,) * 3)))
    hi = Vector(map(min, bounds[1], around[1] + Vector((grow,) * 3)))
    return (lo, hi) if all(l <= h for l, h in zip(lo, hi)) else None


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.volumes, bpy.data.materials):
        for block in list(coll):
            coll.remove(block)


def material_bounds(vdb, args, scene):
    clear_scene()
    root = world_root()
    return world_bounds(import_surfaces(vdb, args, scene, root))


def framing(files, frames, args, scene):
    """Bounds the camera is framed on: the material over every frame, and the colliders near it."""
    mat = None
    for vdb in files:
        mat = union(mat, material_bounds(vdb, args, scene))
    if mat is None:
        fail("the surface grids of %s give an empty mesh" % (files[0] if len(files) == 1 else "every frame"))
    bounds = mat
    if not args.no_colliders:
        # Moving and deforming colliders are framed at every frame, still ones once.
        changing = any(c.get("motion", {}).get("keyframes") or vec(c.get("motion", {}).get("velocity", [0, 0, 0])).length
                       or vec(c.get("motion", {}).get("angular_velocity", [0, 0, 0])).length or "$F" in c.get("file", "")
                       for c in scene.colliders)
        for f in frames if changing else frames[:1]:
            clear_scene()
            root = world_root()
            for obj in add_colliders(scene, f, root):
                b = world_bounds([obj])
                bounds = union(bounds, clip(b, mat) if b else None)
    return bounds


def camera_direction(view):
    """--view (Y-up, from the material to the camera) in Blender's Z-up axes, unit length."""
    return Vector((view.x, -view.z, view.y)).normalized()


def stage(lo, hi, floor, view):
    """Camera looking at the bounds along `view` (by default from the front-right and above), a sun and a sky
    colour."""
    centre = (lo + hi) / 2
    radius = max((hi - lo).length / 2, 1e-3)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = 40.0
    cam = bpy.data.objects.new("camera", cam_data)
    bpy.context.scene.collection.objects.link(cam)
    # Distance so the bounding sphere fits the narrower field of view.
    fov = min(cam_data.angle_x, cam_data.angle_y) if hasattr(cam_data, "angle_y") else cam_data.angle
    direction = camera_direction(view)
    cam.location = centre + direction * (radius / math.sin(fov / 2) * 1.05)
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam_data.clip_end = max(1000.0, 10 * radius)
    bpy.context.scene.camera = cam

    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 4.0
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
    bpy.context.scene.collection.objects.link(sun)

    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.8, 0.85, 0.9, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    bpy.context.scene.world = world

    if floor:
        bpy.ops.mesh.primitive_plane_add(size=20 * radius, location=(centre.x, centre.y, lo.z))
        bpy.context.active_object.data.materials.append(principled("floor", (0.3, 0.3, 0.32), 0.6))


# ----------------------------------------------------------------------------------------------- render

def render(path, args, samples):
    scene = bpy.context.scene
    scene.render.engine = args.engine
    if args.engine == "CYCLES":
        scene.cycles.samples = samples
        scene.cycles.device = "CPU"
        scene.cycles.use_denoising = False  # Debian's Blender is built without OpenImageDenoise
    else:
        scene.eevee.taa_render_samples = samples
    w, h = (int(v) for v in args.resolution.lower().split("x"))
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.film_transparent = False
    scene.render.filepath = os.path.abspath(path)
    bpy.ops.render.render(write_still=True)


def coverage(path):
    """Fractions of the image in the coverage pass's material and collider colours."""
    img = bpy.data.images.load(os.path.abspath(path))
    px = img.pixels[:]
    n = len(px) // 4
    blue = sum(1 for i in range(0, len(px), 4) if px[i + 2] > 0.5 and px[i] < 0.25 and px[i + 1] < 0.25)
    red = sum(1 for i in range(0, len(px), 4) if px[i] > 0.5 and px[i + 1] < 0.25 and px[i + 2] < 0.25)
    bpy.data.images.remove(img)
    return blue / n, red / n


def hue_coverage(path, colours):
    """For each colour (linear RGB), the fraction of the image's saturated pixels within HUE_TOLERANCE of its
    hue. Hue survives the view transform and shading far better than the colour itself."""
    img = bpy.data.images.load(os.path.abspath(path))
    px = img.pixels[:]
    n = len(px) // 4
    wanted = [colorsys.rgb_to_hsv(*c)[0] for c in colours]
    counts = [0] * len(colours)
    for i in range(0, len(px), 4):
        h, s, _ = colorsys.rgb_to_hsv(px[i], px[i + 1], px[i + 2])
        if s < SATURATED:
            continue
        for k, w in enumerate(wanted):
            if min(abs(h - w), 1.0 - abs(h - w)) < HUE_TOLERANCE:
                counts[k] += 1
    bpy.data.images.remove(img)
    return [c / n for c in counts]


def check_colours(out, args, scene):
    """Checks that every set the scene gives a colour shows in the rendered image in that colour's hue."""
    names = sorted(scene.set_colour)
    if not names:
        fail("--check-colours: the scene gives no set a colour")
    shares = hue_coverage(out, [scene.set_colour[n] for n in names])
    least = args.min_coverage / (2 * len(names))  # the sets share the material's coverage
    for name, share in zip(names, shares):
        print("render_blender: set %s in its colour's hue covers %.2f%% of %s" % (name, 100 * share, out))
        if share < least:
            fail("set %s's colour covers %.2f%% of the image, less than %.2f%%" % (name, 100 * share, 100 * least))


def check_coverage(out, args, surfaces, colliders):
    """Renders the scene again in flat colours and checks what the image shows."""
    for obj in surfaces + colliders:
        rgb = ID_MATERIAL if obj in surfaces else ID_COLLIDER
        for mat in obj.data.materials:
            flatten(mat, rgb)
    scene = bpy.context.scene
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.view_settings.view_transform = "Standard"  # Filmic would tint the flat colours
    for obj in scene.objects:
        if obj.type == "MESH" and obj not in surfaces and obj not in colliders:
            obj.hide_render = True  # the --floor plane
    check = os.path.splitext(out)[0] + "_coverage.png"
    render(check, args, 4)
    material, collider = coverage(check)
    print("render_blender: material covers %.1f%%, colliders %.1f%% of %s" % (100 * material, 100 * collider, out))
    if material < args.min_coverage:
        fail("the material covers %.2f%% of the image, less than %.2f%%" % (100 * material, 100 * args.min_coverage))
    if colliders and collider < args.min_coverage:
        fail("the colliders cover %.2f%% of the image, less than %.2f%%" % (100 * collider, 100 * args.min_coverage))


def render_one(vdb, frame, out, args, scene, bounds):
    clear_scene()
    root = world_root()
    surfaces = import_surfaces(vdb, args, scene, root)
    view = vec([float(c) for c in args.view.split(",")])
    colliders = [] if args.no_colliders else add_colliders(scene, frame, root, world_bounds(surfaces), camera_direction(view))
    if not args.no_colliders:
        colliders += add_planes(scene, frame, root, *bounds)
    stage(*bounds, args.floor and (args.no_colliders or not has_floor(scene)), view)
    render(out, args, args.samples)
    print("render_blender: wrote " + out)
    if args.check_colours:
        check_colours(out, args, scene)
    if args.check_not_empty:
        check_coverage(out, args, surfaces, colliders)


def frame_number(path):
    m = re.search(r"(\d+)\.vdb$", path)
    return int(m.group(1)) if m else 0


def main():
    args = parse_args()
    scene = Scene(args.scene or os.path.join(os.path.dirname(os.path.abspath(args.vdb)), "scene.json"))
    if args.frames:
        a, b = (int(v) for v in args.frames.split(":"))
        frames = list(range(a, b + 1))
        files = [frame_file(args.vdb, f) for f in frames]
        stem, ext = os.path.splitext(args.out)
        outs = ["%s_%04d%s" % (stem, f, ext or ".png") for f in frames]
    else:
        frames, files, outs = [frame_number(args.vdb)], [args.vdb], [args.out]
    bounds = framing(files, frames, args, scene)
    for f, vdb, out in zip(frames, files, outs):
        render_one(vdb, f, out, args, scene, bounds)


if __name__ == "__main__":  # tools/blender_import.py imports the collider and volume helpers
    main()
