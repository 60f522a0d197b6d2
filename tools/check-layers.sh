#!/usr/bin/env bash
# Fails (exit 1) when a source folder includes a header of a folder above it, naming the file and the include.
# The layers, bottom up (docs/architecture.md): base (math types, the scene-key vocabulary), sparse (the grid),
# materials, core (the engine), io (scenes, files, runs); apps, python, bench and tests sit on top and may include
# any of them. A folder may include its own headers and those of the layers below.
set -euo pipefail
cd "$(dirname "$0")/.."
layers=(base sparse materials core io)
status=0
for ((i = 0; i < ${#layers[@]}; i++)); do
  folder=${layers[$i]}
  above=("${layers[@]:$((i + 1))}")
  [ "${#above[@]}" -eq 0 ] && continue
  pattern="#include \"($(IFS='|'; echo "${above[*]}"))/"
  while IFS= read -r hit; do
    included=${hit#*#include \"}
    echo "check-layers: $hit: $folder/ may not include ${included%%/*}/, a layer above it"
    status=1
  done < <(grep -rnE "$pattern" "$folder" --include='*.h' --include='*.cpp' || true)
done
# An include through ../ would pass the check above unseen: the layered folders write theirs from the root.
while IFS= read -r hit; do
  echo "check-layers: $hit: write the include from the repository root (\"core/...\"), not with ../"
  status=1
done < <(grep -rnE '#include "\.\./' "${layers[@]}" --include='*.h' --include='*.cpp' || true)
[ "$status" -eq 0 ] && echo "check-layers: every include runs down (${layers[*]})"
exit "$status"
