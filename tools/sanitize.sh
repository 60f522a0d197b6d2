#!/usr/bin/env bash
# The unit suite built with AddressSanitizer (leaks included) and UndefinedBehaviorSanitizer, in its own
# build directory, and run: any report fails the run. Usage: tools/sanitize.sh [BUILD_DIR] (default build-asan)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-asan}
# -O1 -g1: line numbers in reports at a fraction of the compile time full debug information costs with
# OpenVDB's templates.
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Sanitize -DMPM_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS_SANITIZE="-O1 -g1" \
  -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer" >/dev/null
cmake --build "$build" -j2
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:halt_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir "$build" -L unit --output-on-failure -j2
