#!/usr/bin/env bash
# Compares what two runs wrote: every frame file bit for bit (an OpenVDB file's random archive UUID, 36
# characters at byte 21, aside) and stats.csv without its wall-time column. Exits 1 naming what differs.
# Usage: tools/compare_runs.sh DIR_A DIR_B
set -euo pipefail
a=$1 b=$2 bad=0 n=0
vdbBody() { head -c 21 "$1"; tail -c +58 "$1"; }
for f in "$a"/*; do
  name=$(basename "$f")
  case $name in *checkpoint* | stats.csv | scene.json | *.tmp*) continue ;; esac
  [ -f "$b/$name" ] || { echo "compare_runs: $b/$name is missing"; bad=1; continue; }
  if [[ $name == *.vdb ]]; then cmp -s <(vdbBody "$f") <(vdbBody "$b/$name") || { echo "compare_runs: $name differs"; bad=1; }
  else cmp -s "$f" "$b/$name" || { echo "compare_runs: $name differs"; bad=1; }; fi
  n=$((n + 1))
done
# stats.csv without its wall_seconds column (the last one, unless rigid bodies' columns follow it).
noWall() { awk -F, -v OFS=, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "wall_seconds") w = i } { $w = ""; print }' "$1"; }
cmp -s <(noWall "$a/stats.csv") <(noWall "$b/stats.csv") || { echo "compare_runs: stats.csv differs"; bad=1; }
echo "compare_runs: $n frame files and stats.csv compared, $([ $bad = 0 ] && echo same || echo DIFFERENT)"
exit $bad
