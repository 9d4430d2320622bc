#!/usr/bin/env bash
# Installs the dependencies, builds oblong (Release, and ASan+UBSan), and runs the
# unit tests through CTest in both builds.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs=$(nproc)

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$jobs"
(cd build && ctest --output-on-failure -j "$jobs")
experiments/run_all --quick --build build  # the RMIP-paper experiments, tiny sizes (issue 6)

if [ "${OBLONG_SKIP_SANITIZERS:-0}" != 1 ]; then
  # Sanitizer build: unit tests only (benchmarks off), statistics on.
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DOBLONG_SANITIZE=ON \
    -DOBLONG_BUILD_BENCHMARKS=OFF
  cmake --build build-asan -j "$jobs"
  # Leaks inside Debian's assimp and OpenImageIO on bad input are suppressed
  # (tests/lsan.supp says which and why); any other leak fails the test.
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    LSAN_OPTIONS="suppressions=$PWD/../tests/lsan.supp:print_suppressions=0" \
    ctest --output-on-failure -j "$jobs")
fi
