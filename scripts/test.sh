#!/usr/bin/env bash
# Installs the dependencies, builds oblong (Release, and ASan+UBSan), and runs the
# unit tests through CTest in both builds.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs=$(nproc)

# The options are forced (scripts/configure.sh): `build/` may have been configured by
# demo.sh without tests. A build without tests must fail here, not pass with none run.
bash scripts/configure.sh release build
cmake --build build -j "$jobs"
(cd build && ctest --output-on-failure --no-tests=error -j "$jobs")
experiments/run_all --quick --build build  # the RMIP-paper experiments, tiny sizes
# The fuzzers, briefly (docs/bad_input.md): any crash, hang or leak fails the run.
OBLONG_SKIP_SETUP=1 bash scripts/fuzz.sh "${OBLONG_FUZZ_SECONDS:-30}"

if [ "${OBLONG_SKIP_SANITIZERS:-0}" != 1 ]; then
  bash scripts/configure.sh asan build-asan
  cmake --build build-asan -j "$jobs"
  # Leaks inside Debian's assimp and OpenImageIO on bad input are suppressed
  # (tests/lsan.supp says which and why); any other leak fails the test.
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    LSAN_OPTIONS="suppressions=$PWD/../tests/lsan.supp:print_suppressions=0" \
    ctest --output-on-failure --no-tests=error -j "$jobs")
fi
