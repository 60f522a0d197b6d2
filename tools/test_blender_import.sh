#!/usr/bin/env bash
# CTest test (label "blender"): runs a small scene (water and a jelly, a floor, a box moving at 1 m/s) with PLY
# frames, loads the output directory with tools/blender_import.py in headless Blender and checks what arrived
# against the files: frame range, one meshed surface sequence per material (changing over time), the particles
# with their attributes and values, the collider moved by v t (mpm's Y-up turned to Blender's Z-up), both with the
# particles stored in the .blend (the default) and streamed from the PLYs; then opens the saved .blend with scripts
# disabled (-Y) and checks that its particles still change with the frame. Exits 77 (skipped) without Blender.  Usage: test_blender_import.sh MPM_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
mpm="$1"; src="$2"; work="$3"
if ! command -v blender >/dev/null 2>&1; then
  echo "SKIPPED: blender is not installed (bash tools/setup-debian.sh --with-blender installs it)"
  exit 77
fi
rm -rf "$work"; mkdir -p "$work"
cat >"$work/pour.json" <<'SCENE'
{ "simulation": { "frames": 6, "dx": 0.04, "substeps": 2 }, "output": { "ply": true, "surface_group": "material" },
  "sets": [ { "name": "pool", "material": "water", "shape": { "type": "box", "min": [0,0.05,0], "max": [0.3,0.3,0.3] } },
            { "name": "cube", "material": "jelly", "shape": { "type": "box", "min": [0.5,0.05,0], "max": [0.7,0.25,0.2] } } ],
  "colliders": [ { "type": "plane" },
                 { "type": "box", "name": "paddle", "center": [-0.2, 0.1, 0.15], "size": [0.1, 0.2, 0.3], "motion": { "velocity": [1, 0, 0] } } ] }
SCENE
"$mpm" run "$work/pour.json" -o "$work/out" --quiet
# The checks below read the run's PLY frames with this.
cat >"$work/plyframes.py" <<'READER'
import os
import numpy as np
def ply(work, frame):
    """The vertex element of out/pour_NNNN.ply (binary little-endian, as mpm writes it) as a numpy structured array."""
    with open(os.path.join(work, "out", "pour_%04d.ply" % frame), "rb") as f:
        names, n = [], 0
        types = {"double": "<f8", "float": "<f4", "int": "<i4", "uchar": "u1"}
        while True:
            line = f.readline().decode().strip()
            if line.startswith("element vertex"): n = int(line.split()[2])
            elif line.startswith("property"): names.append((line.split()[2], types[line.split()[1]]))
            elif line == "end_header": break
        return np.fromfile(f, dtype=np.dtype(names), count=n)
READER
for mode in auto stream; do
status=0
blender -b --factory-startup --python-exit-code 1 -P "$src/tools/blender_import.py" -- "$work/out" --save "$work/pour_$mode.blend" \
  --summary "$work/summary.json" --particles $mode >"$work/blender.log" 2>&1 || status=$?
grep -E "blender_import|Error" "$work/blender.log" || true
[ $status -eq 0 ] || exit $status
/usr/bin/python3 - "$work" $mode <<'CHECK'
import json, os, sys
import numpy as np
work, mode = sys.argv[1], sys.argv[2]
sys.path.insert(0, work)
from plyframes import ply
s = json.load(open(os.path.join(work, "summary.json")))
check_mode = {"auto": "embed", "stream": "stream"}[mode]
fail = []
def check(ok, what):
    print(("ok: " if ok else "FAILED: ") + what)
    ok or fail.append(what)
check(s["frame_start"] == 1 and s["frame_end"] == 6, "frame range 1..6 (file N is frame N), got %d..%d" % (s["frame_start"], s["frame_end"]))
check(abs(s["fps"] - 24.0) < 1e-9, "24 fps")
check(sorted(s["surfaces"]) == ["mpm_surface_jelly", "mpm_surface_water"], "one surface per material: %s" % s["surfaces"])
sv = s["surface_vertices"]["mpm_surface_water"]
check(sv["1"] > 0 and sv["6"] > 0 and sv["1"] != sv["6"], "the water surface is meshed and follows the sequence: %s" % sv)
for f in (1, 6):
    v, p = ply(work, f), s["particles"][str(f)]
    check(p["vertices"] == len(v), "frame %d: %d particles, as in the PLY" % (f, len(v)))
    check(set(["velocity", "id", "material", "set", "pscale", "Cd"]) <= set(p["attributes"]), "frame %d attributes %s" % (f, p["attributes"]))
    check(p["first_id"] == int(v["id"][0]), "frame %d: the first vertex is particle %d" % (f, v["id"][0]))
    check(np.allclose(p["first_co"], [v["x"][0], v["y"][0], v["z"][0]], atol=1e-6), "frame %d: position as in the file (mesh space)" % f)
    check(np.allclose(p["first_velocity"], [v["vx"][0], v["vy"][0], v["vz"][0]], atol=1e-7), "frame %d: velocity as in the file" % f)
check("paddle" in s["colliders"], "the box is named as the scene names it: %s" % sorted(s["colliders"]))
box = s["colliders"]["paddle"]
moved = np.array(box["6"]) - np.array(box["1"])
# 5 frames at 1 m/s along mpm's x, which stays Blender's x; mpm's y (up) is Blender's z.
check(np.allclose(moved, [5 / 24.0, 0, 0], atol=1e-6), "the box moved by v t = 5/24 m along x: %s" % moved)
check(np.allclose(box["1"], [-0.2 + 1 / 24.0, -0.15, 0.1], atol=1e-6), "Y-up to Z-up: mpm (x, 0.1, 0.15) is Blender (x, -0.15, 0.1): %s" % box["1"])
check("collider_0_plane" in s["colliders"], "the floor plane is drawn")
check(s["particle_mode"] == check_mode, "--particles %s: the particles are %s (%s)" % (mode, check_mode, s["particle_mode"]))
check(os.path.getsize(os.path.join(work, "pour_%s.blend" % mode)) > 0, "the .blend was saved")
sys.exit(1 if fail else 0)
CHECK
done
# The stored particles play with the file's scripts disabled: each frame shows its own PLY's count, first id and position.
blender -b -Y "$work/pour_auto.blend" --python-exit-code 1 --python-expr '
import bpy, sys
o = bpy.data.objects["mpm_particles"]
for f in range(1, 7):
    bpy.context.scene.frame_set(f)
    m = o.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    c = m.vertices[0].co
    print("replayed frame %d: %d particles, first id %d at %.7f %.7f %.7f" % (f, len(m.vertices), m.attributes["id"].data[0].value, c.x, c.y, c.z))
' >"$work/replay.log" 2>&1
grep "replayed" "$work/replay.log"
/usr/bin/python3 - "$work" <<'CHECK'
import os, re, sys
work = sys.argv[1]
sys.path.insert(0, work)
import numpy as np
from plyframes import ply
said = {int(m.group(1)): (int(m.group(2)), int(m.group(3)), [float(m.group(k)) for k in (4, 5, 6)])
        for m in re.finditer(r"replayed frame (\d+): (\d+) particles, first id (-?\d+) at (\S+) (\S+) (\S+)",
                             open(os.path.join(work, "replay.log")).read())}
fail = []
for f in range(1, 7):
    v = ply(work, f)
    n, first, x = len(v), int(v["id"][0]), [float(v[k][0]) for k in ("x", "y", "z")]
    got = said.get(f)
    ok = got is not None and got[0] == n and got[1] == first and np.allclose(got[2], x, atol=1e-6)
    print(("ok: " if ok else "FAILED: ") + "frame %d replays without scripts: %s against the PLY's %d particles, id %d at %s" % (f, got, n, first, x))
    ok or fail.append(f)
sys.exit(1 if fail else 0)
CHECK
