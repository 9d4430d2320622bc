#!/usr/bin/env bash
# The README's order, demo.sh then test.sh, must run the tests: a folder configured for
# the demo (no tests) is switched to the test configuration by scripts/configure.sh.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
cache() { grep -E "^$1:" "$dir/CMakeCache.txt" | cut -d= -f2; }
bash "$root/scripts/configure.sh" demo "$dir" > /dev/null
[ "$(cache OBLONG_BUILD_TESTS)" = OFF ] || { echo "demo configuration has tests on"; exit 1; }
bash "$root/scripts/configure.sh" release "$dir" > /dev/null
for o in OBLONG_BUILD_TESTS OBLONG_BUILD_BENCHMARKS; do
  [ "$(cache $o)" = ON ] || { echo "after demo then release: $o is $(cache $o), expected ON"; exit 1; }
done
[ "$(cache CMAKE_BUILD_TYPE)" = Release ] || { echo "build type $(cache CMAKE_BUILD_TYPE)"; exit 1; }
bash "$root/scripts/configure.sh" asan "$dir" > /dev/null
[ "$(cache OBLONG_SANITIZE)" = ON ] && [ "$(cache OBLONG_BUILD_BENCHMARKS)" = OFF ] || { echo "asan options not set"; exit 1; }
# ...and test.sh runs CTest so that a folder without tests fails instead of passing.
grep -q -- '--no-tests=error' "$root/scripts/test.sh" || { echo "test.sh runs ctest without --no-tests=error"; exit 1; }
echo "build options: demo -> release -> asan switch as expected"
