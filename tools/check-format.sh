#!/usr/bin/env bash
# Fails (exit 1) when a C++ file of the project differs from what clang-format-14 makes of it under .clang-format,
# naming each such file. Run from anywhere; `clang-format-14 -i FILE` formats one. The files are found on disk
# (every .cpp and .h under the source folders, build folders aside), so the check needs no git.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(find apps base bench core io materials python sparse tests tools -type f \( -name '*.cpp' -o -name '*.h' \) | sort)
if [ "${#files[@]}" -eq 0 ]; then
  echo "check-format: no C++ file found under $(pwd)" >&2
  exit 1
fi
status=0
for f in "${files[@]}"; do
  if ! clang-format-14 --dry-run -Werror "$f" >/dev/null 2>&1; then
    echo "check-format: $f differs from clang-format-14's formatting (clang-format-14 -i $f)"
    status=1
  fi
done
[ "$status" -eq 0 ] && echo "check-format: all ${#files[@]} C++ files are formatted"
exit "$status"
