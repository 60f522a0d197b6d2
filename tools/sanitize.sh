#!/usr/bin/env bash
# The unit suite built with AddressSanitizer (leaks included) and UndefinedBehaviorSanitizer, in its own
# build directory, and run: any report fails the run. Usage: tools/sanitize.sh [BUILD_DIR] (default build-asan)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-asan}
# -O1 -g1: line numbers in reports at a fraction of the compile time full debug information costs with
# OpenVDB's templates. No Python module here: a sanitized module needs the sanitizer runtime preloaded into
# python3; its tests run in the Release suite.
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Sanitize -DMPM_BUILD_BENCH=OFF -DMPM_BUILD_PYTHON=OFF -DCMAKE_CXX_FLAGS_SANITIZE="-O1 -g1" \
  -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer" >/dev/null
# Only what the unit suite runs: the engine, the CLI and the test programs (not the report tools).
cmake --build "$build" -j2 --target mpm mpm_tests mpm_io_tests mpm_extra_material_tests
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:halt_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# The scene-length tests (each over 3 s in Release, 30 s to 7 min here) run the same kernels, readers and writers
# as the short ones; under the sanitizers they would take most of CI's time, so they run in Release only. The rank
# tests too: OpenMPI keeps allocations past MPI_Finalize that LeakSanitizer would report as leaks.
slow='^(SceneChecks|Validation|MovingCollider)\.|^Safety\.(Killed|Signals|ACorrupt|FramesAToB|OneRunPerDirectory)|'
slow+='^Ranks\.|^MultiField\.(TwoElastic|ABlock)|^MeshCollider\.WaterAtRest|^VdbCollider\.ARising|^Cli\.ValidateShipped|^RigidRotation\.Apic|^ContinuousSource\.Resuming'
ctest --test-dir "$build" -L unit -E "$slow" --output-on-failure -j2
