#!/usr/bin/env bash
# Instructions per camera ray (valgrind's cachegrind, no cache simulation): a measure of
# the tracing work that other processes on a shared machine cannot disturb. Each
# configuration renders the scene's primary rays at two image sizes in one thread; the
# difference of the two totals divided by the difference in rays removes start-up, scene
# loading and acceleration-structure builds.
#
#   experiments/traversal/count_instructions.sh [BUILD_DIR] [SCENE]
# (BUILD_DIR default build; a -DOBLONG_STATS=OFF build measures what a timing build runs)
set -euo pipefail
cd "$(dirname "$0")/../.."
build="${1:-build}"
scene="${2:-scenes/asteroid.json}"
command -v valgrind >/dev/null || { echo "count_instructions.sh: needs valgrind" >&2; exit 1; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# Debian's OpenImageIO pulls in libhwy, whose load-time timer probe executes rdtscp,
# which valgrind 3.19 does not decode: the process dies before main with an illegal
# opcode. A stand-in for that one function (preloaded) lets it run; it only affects
# libhwy's own timer.
preload=""
if ldd "$build/oblong" | grep libhwy >/dev/null; then
  echo 'namespace hwy { namespace platform { double TimerResolution() { return 1e-9; } } }' >"$tmp/hwy_timer.cpp"
  c++ -shared -fPIC -O2 "$tmp/hwy_timer.cpp" -o "$tmp/hwy_timer.so"
  preload="$tmp/hwy_timer.so"
fi

irefs() {  # SIZE FLAGS...
  local size="$1"; shift
  local log="$tmp/valgrind.log"
  if ! LD_PRELOAD="$preload" valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
    "$build/oblong" render "$scene" --size "$size" --threads 1 -q -o "$tmp/ir.png" \
    --integrator primary --spp 1 "$@" >"$log" 2>&1; then
    echo "count_instructions.sh: oblong render under valgrind failed:" >&2
    grep -v "^==" "$log" | tail -3 >&2; grep -m3 "Illegal\|unhandled" "$log" >&2
    exit 1
  fi
  grep "I *refs" "$log" | tr -d ',' | awk '{print $NF}'
}

echo "| configuration | instructions per camera ray |"
echo "|---|---|"
run() {  # NAME FLAGS...
  local name="$1"; shift
  local a c
  a=$(irefs 64x48 "$@")
  c=$(irefs 256x192 "$@")
  echo "| $name | $(( (c - a) / (256 * 192 - 64 * 48) )) |"
}
run canonical
run driver_mipmap --range minmax_mipmap --splitter quadtree --inversion-in-traversal false --marching-scale 1
run tessellated --baseline tessellated
