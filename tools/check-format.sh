#!/usr/bin/env bash
# Fails (exit 1) when a tracked C++ file differs from what clang-format-14 makes of it under .clang-format,
# naming each such file. Run from anywhere; `clang-format-14 -i FILE` formats one.
set -euo pipefail
cd "$(dirname "$0")/.."
status=0
while IFS= read -r f; do
  if ! clang-format-14 --dry-run -Werror "$f" >/dev/null 2>&1; then
    echo "check-format: $f differs from clang-format-14's formatting (clang-format-14 -i $f)"
    status=1
  fi
done < <(git ls-files '*.cpp' '*.h' '*.hpp' '*.cc')
[ "$status" -eq 0 ] && echo "check-format: every C++ file is formatted"
exit "$status"
