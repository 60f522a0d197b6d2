#!/usr/bin/env bash
# CTest test (label "blender"): simulates the first frames of a shipped scene, renders its last one with
# headless Blender and checks, in a flat-colour pass, that both the material and the colliders are in the
# image. Exits 77 (skipped) without Blender.
# Usage: test_blender_render.sh MPM_BINARY SOURCE_DIR WORK_DIR SCENE FRAME [render_blender.py options]
set -euo pipefail
mpm="$1"; src="$2"; work="$3"; scene="$4"; frame="$5"; shift 5
if ! command -v blender >/dev/null 2>&1; then
  echo "SKIPPED: blender is not installed (bash tools/setup-debian.sh --with-blender installs it)"
  exit 77
fi
rm -rf "$work"; mkdir -p "$work"
"$mpm" run "$src/scenes/$scene.json" -o "$work" --frames "$frame:$frame" --quiet
file=$(printf "%s_%04d" "$scene" "$frame")
status=0
blender -b --factory-startup --python-exit-code 1 -P "$src/tools/render_blender.py" -- \
  --vdb "$work/$file.vdb" --out "$work/$file.png" --samples 8 --resolution 320x180 \
  --check-not-empty --min-coverage 0.02 "$@" >"$work/blender.log" 2>&1 || status=$?
grep -E "render_blender|Error" "$work/blender.log" || true
exit $status
