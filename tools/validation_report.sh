#!/usr/bin/env bash
# One command for the validation report: builds mpm_report, runs every validation case over resolutions
# and accuracy/speed choices and the stability sweep, and writes docs/validation/ (CSV, PNG, report.md).
# Usage: bash tools/validation_report.sh [--quick]   (about 30 minutes on a 2-core machine; --quick: ~3)
set -euo pipefail
cd "$(dirname "$0")/.."
out=docs/validation
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j2 --target mpm_report
mkdir -p "$out"
rm -f "$out/notes.md"  # every row comes from this run: no row was run apart
./build/bench/validation/mpm_report accuracy -o "$out" "$@"
./build/bench/validation/mpm_report stability -o "$out" "$@"
/usr/bin/python3 tools/validation_report.py "$out"
