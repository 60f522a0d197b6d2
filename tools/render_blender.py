"""Headless Blender render of mpm's VDB output (Debian's Blender 3.4).

    blender -b --factory-startup --python-exit-code 1 -P tools/render_blender.py -- \
        --vdb out/dam_break/dam_break_0012.vdb --out dam.png [--frames 0:48] [options]

Imports the .vdb as a Volume object, turns its `surface` level set into a mesh with a Volume to Mesh
modifier (threshold 0: the zero crossing of the signed distance), frames the result with a camera,
lights it and renders PNGs. mpm writes Y-up (Houdini's convention); the volume is rotated +90 degrees
about X so that Y becomes Blender's Z.

With --frames A:B, --vdb names frame A and the file's number is replaced for each frame; --out then
gets the frame number appended (dam_0012.png). --check-not-empty exits 1 when the surface covers less
than --min-coverage of the image (used by the CTest test labelled `blender`).
"""
import argparse
import math
import os
import re
import sys

import bpy
from mathutils import Vector


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="render_blender.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--vdb", required=True, help="a frame file written by mpm (holding the `surface` grid)")
    p.add_argument("--out", required=True, help="PNG to write")
    p.add_argument("--frames", default="", help="A:B renders frames A..B, numbering files like --vdb")
    p.add_argument("--grid", default="surface", help="level-set grid to mesh (default: surface)")
    p.add_argument("--engine", choices=["CYCLES", "BLENDER_EEVEE"], default="CYCLES")
    p.add_argument("--samples", type=int, default=32)
    p.add_argument("--resolution", default="960x540", help="WxH in pixels")
    p.add_argument("--color", default="0.15,0.4,0.9", help="surface base colour, r,g,b in 0..1")
    p.add_argument("--floor", action="store_true", help="add a grey floor at the lowest point of the surface")
    p.add_argument("--check-not-empty", action="store_true", help="exit 1 if the rendered surface is missing")
    p.add_argument("--min-coverage", type=float, default=0.01, help="least image fraction the surface covers")
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


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)


def surface_material(rgb):
    mat = bpy.data.materials.new("mpm_surface")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.25
    return mat


def import_surface(path, grid, rgb):
    """A Volume object for `path` and a mesh object showing its level set `grid`."""
    if not os.path.isfile(path):
        fail("no such file: " + path)
    volume = bpy.data.volumes.new(os.path.basename(path))
    volume.filepath = os.path.abspath(path)
    vol_obj = bpy.data.objects.new("mpm_volume", volume)
    bpy.context.scene.collection.objects.link(vol_obj)
    vol_obj.rotation_euler = (math.radians(90.0), 0.0, 0.0)  # Y-up (mpm) to Z-up (Blender)
    vol_obj.hide_render = True
    volume.grids.load()
    names = [g.name for g in volume.grids]
    if grid not in names:
        fail("%s has no grid '%s' (grids: %s)" % (path, grid, ", ".join(names) or "none"))

    mesh_obj = bpy.data.objects.new("mpm_surface", bpy.data.meshes.new("mpm_surface"))
    bpy.context.scene.collection.objects.link(mesh_obj)
    mod = mesh_obj.modifiers.new("surface", "VOLUME_TO_MESH")
    mod.object = vol_obj
    mod.grid_name = grid
    mod.threshold = 0.0  # the zero crossing of a signed distance; the default 0.1 is empty for a narrow band
    mod.adaptivity = 0.0
    mesh_obj.matrix_world = vol_obj.matrix_world.copy()
    mesh_obj.data.materials.append(surface_material(rgb))
    return mesh_obj


def world_bounds(obj):
    deps = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(deps)
    if len(ev.data.vertices) == 0:
        return None
    corners = [ev.matrix_world @ Vector(c) for c in ev.bound_box]
    lo = Vector((min(c.x for c in corners), min(c.y for c in corners), min(c.z for c in corners)))
    hi = Vector((max(c.x for c in corners), max(c.y for c in corners), max(c.z for c in corners)))
    return lo, hi


def stage(lo, hi, floor):
    """Camera looking at the bounds from the front-right and above, a sun and a sky colour."""
    centre = (lo + hi) / 2
    radius = max((hi - lo).length / 2, 1e-3)
    direction = Vector((0.9, -1.6, 0.9)).normalized()
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = 40.0
    cam = bpy.data.objects.new("camera", cam_data)
    bpy.context.scene.collection.objects.link(cam)
    # Distance so the bounding sphere fits the narrower field of view.
    fov = min(cam_data.angle_x, cam_data.angle_y) if hasattr(cam_data, "angle_y") else cam_data.angle
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
        grey = bpy.data.materials.new("floor")
        grey.diffuse_color = (0.3, 0.3, 0.32, 1.0)
        grey.use_nodes = True
        grey.node_tree.nodes.get("Principled BSDF").inputs["Base Color"].default_value = (0.3, 0.3, 0.32, 1.0)
        bpy.context.active_object.data.materials.append(grey)


def render(path, args):
    scene = bpy.context.scene
    scene.render.engine = args.engine
    if args.engine == "CYCLES":
        scene.cycles.samples = args.samples
        scene.cycles.device = "CPU"
        scene.cycles.use_denoising = False  # Debian's Blender is built without OpenImageDenoise
    w, h = (int(v) for v in args.resolution.lower().split("x"))
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.film_transparent = False
    scene.render.filepath = os.path.abspath(path)
    bpy.ops.render.render(write_still=True)
    print("render_blender: wrote " + path)


def surface_coverage(path):
    """Fraction of pixels that differ clearly from the corner pixel (the sky)."""
    img = bpy.data.images.load(os.path.abspath(path))
    w, h = img.size
    px = list(img.pixels)
    sky = px[0:3]
    hits = sum(1 for i in range(0, len(px), 4)
               if abs(px[i] - sky[0]) + abs(px[i + 1] - sky[1]) + abs(px[i + 2] - sky[2]) > 0.15)
    return hits / float(w * h)


def render_one(vdb, out, args):
    clear_scene()
    rgb = tuple(float(c) for c in args.color.split(","))
    mesh = import_surface(vdb, args.grid, rgb)
    bounds = world_bounds(mesh)
    if bounds is None:
        fail("the '%s' level set in %s gives an empty mesh" % (args.grid, vdb))
    stage(*bounds, args.floor)
    render(out, args)
    if args.check_not_empty:
        cov = surface_coverage(out)
        print("render_blender: surface covers %.1f%% of %s" % (100 * cov, out))
        if cov < args.min_coverage:
            fail("surface covers %.2f%% of the image, less than %.2f%%" % (100 * cov, 100 * args.min_coverage))


def main():
    args = parse_args()
    if not args.frames:
        render_one(args.vdb, args.out, args)
        return
    a, b = (int(v) for v in args.frames.split(":"))
    stem, ext = os.path.splitext(args.out)
    for f in range(a, b + 1):
        render_one(frame_file(args.vdb, f), "%s_%04d%s" % (stem, f, ext or ".png"), args)


main()
