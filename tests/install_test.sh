#!/usr/bin/env bash
# `cmake --install` of a build, then a program outside the tree built against it
# (tests/install_consumer/) with the same compiler, generator and build type, and run.
# Everything is written under BUILD_DIR/install_test/, emptied first.
#   tests/install_test.sh BUILD_DIR CONSUMER_DIR CXX GENERATOR BUILD_TYPE
set -euo pipefail
build="${1:?usage: install_test.sh BUILD_DIR CONSUMER_DIR CXX GENERATOR BUILD_TYPE}"
consumer="${2:?}" cxx="${3:?}" generator="${4:?}" type="${5:-Release}"
work="$build/install_test"
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
# Only the prefix may provide the package: no package registry, no other prefix.
cmake -S "$consumer" -B "$work/build" -G "$generator" -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE="$type" \
  -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF \
  -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON > "$work/configure.log" \
  || { cat "$work/configure.log"; exit 1; }
cmake --build "$work/build" > "$work/build.log" 2>&1 || { cat "$work/build.log"; exit 1; }
# The consumer's build used the installed headers, not the source tree's.
root="$(cd "$consumer/../.." && pwd)"
if grep -rhoE -- "(-I|-isystem )[^ ]+" "$work/build" --include=*.ninja --include=flags.make \
    | grep -F "$root" | grep -vF "$(cd "$work" && pwd)"; then
  echo "install_test: the consumer was compiled against the source tree" >&2
  exit 1
fi
"$work/build/consumer"
