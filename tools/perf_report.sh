#!/usr/bin/env bash
# One command for the performance report: builds the benchmarks in Release, runs the Google
# Benchmark kernels and the scene-level suite (each measurement in its own process), and writes
# docs/performance/ (perf.csv, kernels.json, PNG plots, summary.md with every target and its ratio).
# Usage: bash tools/perf_report.sh [--quick]   (about 5 minutes on a 2-core machine; --quick: under 1)
set -euo pipefail
cd "$(dirname "$0")/.."
out=docs/performance
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j2 --target mpm_bench mpm_bench_kernels
mkdir -p "$out"
min_time=0.5
if [ "${1:-}" = "--quick" ]; then min_time=0.05; export MPM_BENCH_PARTICLES=32768; fi
./build/bench/mpm_bench_kernels --benchmark_min_time="$min_time" \
  --benchmark_out="$out/kernels.json" --benchmark_out_format=json
./build/bench/mpm_bench suite -o "$out" "$@"
/usr/bin/python3 tools/perf_report.py "$out"
