#!/usr/bin/env bash
# Configures a build folder for one purpose; every option a purpose needs is set
# explicitly, so that a folder configured for another purpose before (the demo's
# test-less build, say) is switched over instead of silently reused.
#   scripts/configure.sh demo|release|asan BUILD_DIR
set -euo pipefail
cd "$(dirname "$0")/.."
purpose="${1:?usage: scripts/configure.sh demo|release|asan BUILD_DIR}"
dir="${2:?usage: scripts/configure.sh demo|release|asan BUILD_DIR}"
case "$purpose" in
  # The Python module is built wherever pybind11 is found (the demo's folder then becomes
  # the tests' without recompiling: the same position-independent code); the tests'
  # build requires it (OBLONG_REQUIRE_PYTHON) and tests it.
  demo)    opts=(-DCMAKE_BUILD_TYPE=Release -DOBLONG_SANITIZE=OFF -DOBLONG_BUILD_TESTS=OFF -DOBLONG_BUILD_BENCHMARKS=OFF -DOBLONG_PYTHON=ON -DOBLONG_REQUIRE_PYTHON=OFF) ;;
  release) opts=(-DCMAKE_BUILD_TYPE=Release -DOBLONG_SANITIZE=OFF -DOBLONG_BUILD_TESTS=ON -DOBLONG_BUILD_BENCHMARKS=ON -DOBLONG_REQUIRE_VULKAN=ON -DOBLONG_PYTHON=ON -DOBLONG_REQUIRE_PYTHON=ON) ;;
  # Sanitizer build: unit tests only (benchmarks off), statistics on. The tests' builds
  # require the Vulkan path (OBLONG_REQUIRE_VULKAN): without it the GPU tests would vanish.
  # No Python module (CMakeLists.txt says why). -O1 -g1 instead of RelWithDebInfo's -O2 -g:
  # a test file compiles in 29 s instead of 73 s under the sanitizers, and the reports
  # still name file and line.
  asan)    opts=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" -DOBLONG_SANITIZE=ON -DOBLONG_BUILD_TESTS=ON -DOBLONG_BUILD_BENCHMARKS=OFF -DOBLONG_REQUIRE_VULKAN=ON -DOBLONG_PYTHON=OFF -DOBLONG_REQUIRE_PYTHON=OFF) ;;
  *) echo "scripts/configure.sh: unknown purpose '$purpose' (demo | release | asan)" >&2; exit 1 ;;
esac
cmake -S . -B "$dir" -G Ninja -DOBLONG_STATS=ON "${opts[@]}"
