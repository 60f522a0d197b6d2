#!/usr/bin/env bash
# CTest test (label "blender"): simulates the first frames of a shipped scene, renders one frame with
# headless Blender and checks that the surface is in the image. Exits 77 (skipped) without Blender.
# Usage: test_blender_render.sh MPM_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
mpm="$1"; src="$2"; work="$3"
if ! command -v blender >/dev/null 2>&1; then
  echo "SKIPPED: blender is not installed (bash tools/setup-debian.sh --with-blender installs it)"
  exit 77
fi
rm -rf "$work"; mkdir -p "$work"
"$mpm" run "$src/scenes/dam_break.json" -o "$work" --frames 3:3 --quiet
status=0
blender -b --factory-startup --python-exit-code 1 -P "$src/tools/render_blender.py" -- \
  --vdb "$work/dam_break_0003.vdb" --out "$work/dam_break_0003.png" --samples 8 --resolution 320x180 \
  --check-not-empty --min-coverage 0.02 >"$work/blender.log" 2>&1 || status=$?
grep -E "render_blender|Error" "$work/blender.log" || true
exit $status
