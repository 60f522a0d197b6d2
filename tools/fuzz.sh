#!/usr/bin/env bash
# Fuzzes the scene reader and builder with libFuzzer (clang 14 from Debian) for a bounded time, starting from the
# checked-in seed corpus. Usage: tools/fuzz.sh [SECONDS] [BUILD_DIR] [RELEASE_BUILD]   (default 60 s, build-fuzz,
# build). The reader, the budget, the builder and the level sets from files are built here with the fuzzer and
# the sanitizers; the engine they set up (and step once) is linked from the Release build's libraries, which must
# exist (the README's test command makes them). The scenes' files are looked for in scenes/assets.
# Exits non-zero on any finding (the crashing input is left in BUILD_DIR as crash-*); prints executions per
# second, the corpus size and the findings.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
build=${2:-build-fuzz}
release=${3:-build}
for lib in mpm_scene mpm_engine mpm_grid mpm_comm; do
  [ -f "$release/lib$lib.a" ] || { echo "fuzz: $release/lib$lib.a is missing: build the project in $release first" >&2; exit 2; }
done
libs=("$release/libmpm_scene.a" "$release/libmpm_engine.a" "$release/libmpm_grid.a" "$release/libmpm_comm.a" -lassimp -lopenvdb -lImath-3_1 -ltbb -lpthread)
# The engine's ranks (core/Comm.cpp) link MPI when the Release build found it.
if nm -u "$release/libmpm_comm.a" 2>/dev/null | grep MPI_Init_thread >/dev/null && command -v mpicxx >/dev/null; then
  read -r -a mpi <<<"$(mpicxx --showme:link)"
  libs+=("${mpi[@]}")
fi
mkdir -p "$build/corpus"
CXX=${CXX_FUZZ:-clang++-14}
# The Release libraries' target CPU: Eigen aligns its fixed-size types by the vector width, and objects made on one
# side are freed on the other (a rigid body's state is 32-byte aligned under AVX2).
arch=()
if grep -q '^MPM_NATIVE:BOOL=ON' "$release/CMakeCache.txt"; then
  arch=(-march=native)
elif grep -q '^MPM_X86_64_V3:BOOL=ON' "$release/CMakeCache.txt"; then
  arch=(-march=x86-64-v3)
fi
flags=("${arch[@]}" -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -I. -isystem /usr/include/eigen3
  "-DMPM_FUZZ_ASSETS=\"$PWD/scenes/assets\"" -fsanitize-ignorelist=tests/fuzz/sanitizer-ignore.txt
  -fsanitize-coverage-ignorelist=tests/fuzz/coverage-ignore.txt)
srcs=(tests/fuzz/fuzz_scene.cpp io/SceneReader.cpp io/SceneBudget.cpp io/SceneBuilder.cpp io/LevelSets.cpp
  io/MeshThickness.cpp core/Species.cpp)
# The samplers' inner loops (a candidate point's cell and distance lookups, some 10^5 per thousand particles) are
# left out of the coverage instrumentation, which made them 50 times slower than a Release build: a scene of a few
# thousand particles then took longer than the per-input limit. They keep the sanitizers.
uncovered=(io/Sampling.cpp)
# Rebuild only when a source, this script or the Release configuration changed.
if [ ! -x "$build/fuzz_scene" ] || [ -n "$(find "${srcs[@]}" "${uncovered[@]}" io core materials sparse tests/fuzz/sanitizer-ignore.txt tests/fuzz/coverage-ignore.txt tools/fuzz.sh "$release/CMakeCache.txt" "${libs[@]:0:3}" -newer "$build/fuzz_scene" -print -quit)" ]; then
  plain=()  # the flags without the fuzzer's instrumentation
  for f in "${flags[@]}"; do
    case "$f" in
      -fsanitize=fuzzer,address,undefined) plain+=(-fsanitize=address,undefined) ;;
      -fsanitize-coverage-ignorelist=*) ;;
      *) plain+=("$f") ;;
    esac
  done
  objs=()
  for src in "${uncovered[@]}"; do
    obj="$build/$(basename "${src%.cpp}").o"
    "$CXX" "${plain[@]}" -O2 -c "$src" -o "$obj"
    objs+=("$obj")
  done
  "$CXX" "${flags[@]}" "${srcs[@]}" "${objs[@]}" "${libs[@]}" -o "$build/fuzz_scene"
fi
cp -n tests/fuzz/corpus/* "$build/corpus/" 2>/dev/null || true
cd "$build"
set +e
./fuzz_scene -max_total_time="$seconds" -max_len=65536 -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 corpus 2> fuzz.log
rc=$?
set -e
execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' fuzz.log | grep -o '[0-9]*$' || echo 0)
speed=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' fuzz.log | grep -o '[0-9]*$' || echo 0)
findings=$(find . -maxdepth 1 \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
echo "fuzz: $execs executions in ${seconds} s ($speed per second), corpus $(ls corpus | wc -l) inputs, $findings findings"
if [ "$rc" -ne 0 ] || [ "$findings" -ne 0 ]; then
  tail -n 40 fuzz.log
  exit 1
fi
