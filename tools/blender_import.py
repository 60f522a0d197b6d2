"""Loads a whole mpm output directory into Blender (Debian's Blender 3.4) as an animated scene.

    blender [-b] --factory-startup --python-exit-code 1 -P tools/blender_import.py -- OUT_DIR \
        [--save scene.blend] [--summary summary.json] [--particles auto|embed|stream]

- the surfaces: the frame files <scene>_NNNN.vdb as one Volume sequence per surface grid, meshed at threshold 0
  (the zero crossing of the signed distance) by a Volume to Mesh modifier, in its sets' colour (`color`) or its
  material's;
- the particles: when the run wrote PLY frames ("output": {"ply": true}; Blender cannot read VDB points), one
  point-cloud mesh `mpm_particles` carrying every point attribute of the file: `velocity` (vx, vy, vz), `id`,
  `material`, `set`, `pscale`, `Cd` (a colour attribute) and J, Jp, stress_norm, plastic_strain, F and the
  material parameters (density, youngs_modulus, ...) when written. Either stored in
  the .blend (embed: a mesh per frame, shown in turn by a geometry-node modifier; plays without scripts) or
  reloaded from <scene>_NNNN.ply at each frame change by a text block registered as a module (stream: plays when
  the file's scripts are allowed to run); auto embeds up to EMBED_LIMIT particles over all frames;
- the colliders from the run's scene.json (meshes, boxes, cylinders, spheres, VDB level sets, planes), keyframed
  along their motion at every frame; rigid bodies (`dynamic`) at their poses in the run's bodies.csv;
- Y-up (mpm, Houdini) turned to Z-up once: everything hangs under `mpm_world`, turned +90 degrees about X;
- the scene's frame range and frame rate from the files and the scene: file N is frame N.

--summary writes what was loaded as JSON (for the `blender`-labelled CTest test)."""
import argparse
import glob
import json
import math
import os
import re
import sys

import bpy
from mathutils import Matrix

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import render_blender as rb  # noqa: E402  (the collider, volume and material helpers)

# The particle loader, stored in the .blend as a text block so that the saved scene animates on its own.
LOADER = r'''
import os
import bpy
import numpy as np

PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "<i2", "ushort": "<u2", "int": "<i4", "uint": "<u4",
             "float": "<f4", "double": "<f8", "int8": "i1", "uint8": "u1", "int16": "<i2", "uint16": "<u2",
             "int32": "<i4", "uint32": "<u4", "float32": "<f4", "float64": "<f8"}


def read_ply(path):
    """The vertex element of a binary little-endian PLY (as mpm writes it) as a numpy structured array."""
    with open(path, "rb") as f:
        names, count = [], 0
        while True:
            line = f.readline().decode("ascii", "replace").strip()
            if line.startswith("element vertex"):
                count = int(line.split()[2])
            elif line.startswith("property"):
                _, kind, name = line.split()
                names.append((name, PLY_TYPES[kind]))
            elif line == "end_header":
                break
        return np.fromfile(f, dtype=np.dtype(names), count=count)


def srgb_to_linear(c):
    c = c / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def load_particles(scene=None, *args):
    """Fills the mesh of `mpm_particles` from the PLY of the current frame."""
    scene = scene or bpy.context.scene
    obj = bpy.data.objects.get("mpm_particles")
    if obj is None or "mpm_ply_pattern" not in obj:
        return
    path = obj["mpm_ply_pattern"] % scene.frame_current
    if os.path.isfile(path):
        fill_mesh(obj.data, read_ply(path))


def fill_mesh(mesh, v):
    """The PLY's vertices (a read_ply array) as the mesh's points, with their attributes."""
    mesh.clear_geometry()
    mesh.vertices.add(len(v))
    P = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float32)
    mesh.vertices.foreach_set("co", P.ravel())
    def attribute(name, kind, values):
        a = mesh.attributes.get(name) or mesh.attributes.new(name, kind, "POINT")
        field = {"FLOAT": "value", "INT": "value", "FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color"}[kind]
        a.data.foreach_set(field, np.ascontiguousarray(values).ravel())
    fields = v.dtype.names
    attribute("velocity", "FLOAT_VECTOR", np.stack([v["vx"], v["vy"], v["vz"]], axis=1).astype(np.float32))
    for name in ("id", "material", "set"):
        if name in fields:
            attribute(name, "INT", v[name].astype(np.int32))
    for name in ("pscale", "J", "Jp", "stress_norm", "plastic_strain", "density", "youngs_modulus", "poisson_ratio",
                 "bulk_modulus", "viscosity", "yield_stress"):
        if name in fields:
            attribute(name, "FLOAT", v[name].astype(np.float32))
    if "red" in fields:
        rgb = np.stack([srgb_to_linear(v[c].astype(np.float32)) for c in ("red", "green", "blue")], axis=1)
        attribute("Cd", "FLOAT_COLOR", np.concatenate([rgb, np.ones((len(v), 1))], axis=1).astype(np.float32))
    for r in range(3):
        for c in range(3):
            name = "F%d%d" % (r, c)
            if name in fields:
                attribute(name, "FLOAT", v[name].astype(np.float32))
    mesh.update()


def register():
    if bpy.data.objects.get("mpm_particles") is None or "mpm_ply_pattern" not in bpy.data.objects["mpm_particles"]:
        return  # the particles are stored in the file (--particles embed): nothing to load
    handlers = bpy.app.handlers.frame_change_post
    for h in list(handlers):
        if getattr(h, "__name__", "") == "load_particles":
            handlers.remove(h)
    handlers.append(load_particles)


register()
'''


# --particles auto stores at most this many particles (summed over the frames) in the .blend: about 50 bytes each
# with the attributes mpm writes, so some 250 MB.
EMBED_LIMIT = 5_000_000
STORED_ID = "mpm_id"  # the particles' ids in the stored frames (see frame_switch_nodes)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="blender_import.py", description="Load an mpm output directory into Blender")
    p.add_argument("directory", help="the run's output directory (frames, scene.json)")
    p.add_argument("--save", default="", help="save the scene as this .blend")
    p.add_argument("--summary", default="", help="write what was loaded as JSON")
    p.add_argument("--particles", choices=("auto", "embed", "stream"), default="auto",
                   help="embed: store every frame's particles in the .blend (plays anywhere, without scripts); stream: "
                        "reload each frame's PLY with a script (small file; needs scripts allowed and the PLYs in place); "
                        "auto (default): embed up to %d particles over all frames" % EMBED_LIMIT)
    return p.parse_args(argv)


def frames_of(directory):
    """The scene's name and its numbered frame files: {frame: path} of the volumes and of the PLYs."""
    vdbs, plys, name = {}, {}, ""
    rx = re.compile(r"^(.+?)_(\d{4,})\.(vdb|ply)$")
    for path in glob.glob(os.path.join(directory, "*_[0-9][0-9][0-9][0-9]*.*")):
        m = rx.match(os.path.basename(path))
        if not m or m.group(1).endswith(("_points", "_checkpoint")):
            continue
        name = name or m.group(1)
        (vdbs if m.group(3) == "vdb" else plys)[int(m.group(2))] = path
    return name, vdbs, plys


def import_surface_sequences(vdbs, scene, root):
    """One Volume sequence per surface grid of the first frame, each meshed by a Volume to Mesh modifier."""
    first = min(vdbs)
    names = rb.surface_grids(vdbs[first])
    grids = [n for n in names if n == "surface" or n.startswith("surface_")]
    meshes = []
    for i, grid in enumerate(grids):
        mesh_obj, vol_obj = rb.level_set_mesh(vdbs[first], grid, root, "mpm_" + grid)
        volume = vol_obj.data
        volume.is_sequence = True
        volume.frame_start = first  # file N shows at frame N
        volume.frame_duration = max(vdbs) - first + 1
        volume.sequence_mode = "CLIP"
        mesh_obj.data.materials.append(rb.principled("mpm_" + grid, scene.colour_of_grid(grid, i), 0.25))
        meshes.append(mesh_obj)
    return meshes


def ply_vertex_count(path):
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"element vertex"):
                return int(line.split()[2])
            if line.startswith(b"end_header"):
                return 0
    return 0


def frame_switch_nodes(frames):
    """A geometry-node tree showing one child of the collection `frames` (the one at input "Frame index", in name
    order) as points: the stored animation plays without any script."""
    ng = bpy.data.node_groups.new("mpm_particle_frames", "GeometryNodeTree")
    ng.inputs.new("NodeSocketGeometry", "Geometry")
    index_in = ng.inputs.new("NodeSocketInt", "Frame index")
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    n = ng.nodes
    group_in, group_out = n.new("NodeGroupInput"), n.new("NodeGroupOutput")
    info = n.new("GeometryNodeCollectionInfo")
    info.transform_space = "ORIGINAL"
    info.inputs["Collection"].default_value = frames
    info.inputs["Separate Children"].default_value = True
    info.inputs["Reset Children"].default_value = True
    index = n.new("GeometryNodeInputIndex")
    other = n.new("FunctionNodeCompare")
    other.data_type, other.operation = "INT", "NOT_EQUAL"
    delete = n.new("GeometryNodeDeleteGeometry")
    delete.domain = "INSTANCE"
    realize = n.new("GeometryNodeRealizeInstances")
    ints = [s for s in other.inputs if s.type == "INT"]
    links = ng.links
    links.new(index.outputs["Index"], ints[0])
    links.new(group_in.outputs["Frame index"], ints[1])
    links.new(info.outputs[0], delete.inputs["Geometry"])
    links.new(other.outputs["Result"], delete.inputs["Selection"])
    links.new(delete.outputs["Geometry"], realize.inputs["Geometry"])
    # Realizing instances hashes an `id` attribute with the instance's own id; the frames keep the particles' ids as
    # `mpm_id`, stored back under `id` after it.
    read = n.new("GeometryNodeInputNamedAttribute")
    read.data_type = "INT"
    read.inputs["Name"].default_value = STORED_ID
    store = n.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "INT", "POINT"
    store.inputs["Name"].default_value = "id"
    remove = n.new("GeometryNodeRemoveAttribute")
    remove.inputs["Name"].default_value = STORED_ID
    links.new(realize.outputs["Geometry"], store.inputs["Geometry"])
    links.new([o for o in read.outputs if o.type == "INT" and o.enabled][0],
              [i for i in store.inputs if i.type == "INT" and i.enabled][0])
    links.new(store.outputs["Geometry"], remove.inputs["Geometry"])
    links.new(remove.outputs["Geometry"], group_out.inputs["Geometry"])
    return ng, index_in.identifier


def import_particles(plys, root, mode, loader):
    """`mpm_particles`, animated from the PLY frames: `embed` stores every frame's points in the .blend (a mesh per
    frame in the hidden collection mpm_particle_frames, shown in turn by a geometry-node modifier whose frame index is
    keyframed): it plays wherever the file goes, no script needed. `stream` reloads the current frame's PLY at each
    frame change (a small .blend, but the PLYs must stay where they are, and Blender must be allowed to run scripts)."""
    if not plys:
        print("blender_import: no PLY frames (set \"output\": {\"ply\": true}); the particles are not loaded: Blender cannot "
              "read VDB points")
        return None, None
    points = sum(ply_vertex_count(p) for p in plys.values())
    if mode == "auto":
        mode = "embed" if points <= EMBED_LIMIT else "stream"
        if mode == "stream":
            print("blender_import: %d particles over %d frames is more than --particles auto stores in a .blend (%d); they "
                  "stream from the PLYs (--particles embed stores them anyway)" % (points, len(plys), EMBED_LIMIT))
    obj = bpy.data.objects.new("mpm_particles", bpy.data.meshes.new("mpm_particles"))
    bpy.context.scene.collection.objects.link(obj)
    rb.adopt(obj, root)
    if mode == "stream":
        first = plys[min(plys)]
        obj["mpm_ply_pattern"] = re.sub(r"_(\d{4,})\.ply$", lambda m: "_%%0%dd.ply" % len(m.group(1)), os.path.abspath(first))
        text = bpy.data.texts.new("mpm_particles.py")
        text.write(LOADER)
        text.use_module = True  # registered when the .blend is opened with scripts allowed
        return obj, mode
    frames = bpy.data.collections.new("mpm_particle_frames")
    bpy.context.scene.collection.children.link(frames)
    # Hidden from view and render: the frame meshes show only through mpm_particles' modifier.
    bpy.context.view_layer.layer_collection.children[frames.name].exclude = True
    for f in sorted(plys):
        mesh = bpy.data.meshes.new("mpm_particles_%06d" % f)
        loader["fill_mesh"](mesh, loader["read_ply"](plys[f]))
        if "id" in mesh.attributes:
            mesh.attributes["id"].name = STORED_ID
        frames.objects.link(bpy.data.objects.new(mesh.name, mesh))
    ng, socket = frame_switch_nodes(frames)
    mod = obj.modifiers.new("mpm_frames", "NODES")
    mod.node_group = ng
    # File N shows from frame N until the next file's frame (frames without a file hold the one before).
    path = 'modifiers["mpm_frames"]["%s"]' % socket
    for i, f in enumerate(sorted(plys)):
        mod[socket] = i
        obj.keyframe_insert(path, frame=f)
    for fc in obj.animation_data.action.fcurves:
        for k in fc.keyframe_points:
            k.interpolation = "CONSTANT"
    return obj, mode


def keyframed_colliders(scene, first, last, root):
    """Every bounded collider, keyframed at each frame where it moves."""
    out = []
    for i, c in enumerate(scene.colliders):
        made = rb.collider_object(c, scene, first, root)
        if not made:
            continue
        obj, rest = made
        obj.name = rb.collider_name(i, c)
        if obj.parent is not root:
            rb.adopt(obj, root)
        obj.rotation_mode = "QUATERNION"
        motion = c.get("motion")
        moving = bool(motion) and (motion.get("keyframes") or any(
            abs(x) > 0 for key in ("velocity", "angular_velocity") for x in motion.get(key, [0, 0, 0])))
        moving = moving or scene.body_pose(i, first) is not None  # a rigid body: posed from bodies.csv
        for f in (range(first, last + 1) if moving else [first]):
            obj.matrix_basis = rb.collider_matrix(scene, i, c, f, rest) @ rest
            if moving:
                for path in ("location", "rotation_quaternion", "scale"):
                    obj.keyframe_insert(path, frame=f)
        mat = rb.principled("collider_%d" % i, rb.BODY_COLOUR if c.get("dynamic") else rb.COLLIDER_COLOUR, 0.6)
        if c.get("inside"):
            rb.cutaway(mat, hide_front=True)
        obj.data.materials.clear()
        obj.data.materials.append(mat)
        out.append(obj)
    return out


def main():
    args = parse_args()
    if not os.path.isdir(args.directory):
        rb.fail("no such output directory: " + args.directory)
    scene = rb.Scene(os.path.join(args.directory, "scene.json"))
    name, vdbs, plys = frames_of(args.directory)
    if not vdbs and not plys:
        rb.fail(args.directory + ": no frame files (<scene>_NNNN.vdb or .ply) here")
    numbers = sorted(set(vdbs) | set(plys))
    first, last = numbers[0], numbers[-1]
    rb.clear_scene()
    root = rb.world_root()
    bl = bpy.context.scene
    bl.frame_start, bl.frame_end = first, last
    bl.render.fps = max(1, int(round(scene.fps)))
    bl.render.fps_base = bl.render.fps / scene.fps
    surfaces = import_surface_sequences(vdbs, scene, root) if vdbs else []
    loader = {"__name__": "mpm_particles"}
    exec(compile(LOADER, "mpm_particles.py", "exec"), loader)
    particles, mode = import_particles(plys, root, args.particles, loader)
    if mode == "stream":
        loader["register"]()
    colliders = keyframed_colliders(scene, first, last, root)
    bl.frame_set(first)
    # Planes are drawn as squares about the material (static planes; a moving plane is posed at the first frame).
    bounds = rb.world_bounds(surfaces + ([particles] if particles else []))
    if bounds:
        colliders += rb.add_planes(scene, first, root, *bounds)
    summary = {"scene": name, "frame_start": bl.frame_start, "frame_end": bl.frame_end, "fps": bl.render.fps / bl.render.fps_base,
               "surfaces": [o.name for o in surfaces], "colliders": {}, "particles": {}, "particle_mode": mode}
    for f in (first, last):
        bl.frame_set(f)
        if particles:
            mesh = particles.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
            entry = {"vertices": len(mesh.vertices), "attributes": sorted(a.name for a in mesh.attributes if not a.name.startswith("."))}
            if len(mesh.vertices):
                entry["first_co"] = list(mesh.vertices[0].co)
                entry["first_velocity"] = list(mesh.attributes["velocity"].data[0].vector)
                entry["first_id"] = mesh.attributes["id"].data[0].value
            summary["particles"][str(f)] = entry
        for o in colliders:
            summary["colliders"].setdefault(o.name, {})[str(f)] = list(o.matrix_world.translation)
        for o in surfaces:
            summary.setdefault("surface_vertices", {}).setdefault(o.name, {})[str(f)] = len(
                o.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh().vertices)
    bl.frame_set(first)
    if args.summary:
        with open(args.summary, "w") as f:
            json.dump(summary, f, indent=1)
    if args.save:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save))
        print("blender_import: saved " + args.save)
        if mode == "embed":
            print("blender_import: its particles are stored in it and play without scripts")
        elif mode == "stream":
            # Blender runs a .blend's scripts only when allowed; without them the particles stay at this frame.
            print("blender_import: its particles animate only when Blender may run the file's scripts: open it with "
                  "`blender -y %s`, or tick Preferences > Save & Load > Auto Run Python Scripts "
                  "(the surfaces and colliders animate either way)" % args.save)
    print("blender_import: frames %d-%d, %d surfaces, %s, %d colliders from %s" % (
        first, last, len(surfaces), "particles from PLY (%s)" % mode if particles else "no particles", len(colliders), args.directory))


main()
