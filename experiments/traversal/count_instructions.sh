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

irefs() {  # SIZE FLAGS...
  local size="$1"; shift
  valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
    "$build/oblong" render "$scene" --size "$size" --threads 1 -q -o /tmp/oblong_ir.png \
    --integrator primary --spp 1 "$@" 2>&1 | grep "I *refs" | tr -d ',' | awk '{print $NF}'
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
run tfdm --range minmax_mipmap --splitter quadtree --inversion-in-traversal false --marching-scale 1
run tessellated --baseline tessellated
