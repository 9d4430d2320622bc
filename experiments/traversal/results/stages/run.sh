#!/usr/bin/env bash
# Where the canonical traversal's instructions go, per scene and ray family: callgrind
# (instructions only) inside EmbreeScene::traceHits, the self cost of each function grouped
# into the traversal's stages by stages.py; tfdm's total beside it. Grazing: 1 000 of
# bench_traversal's grazing rays (`oblong trace`); camera: `oblong render --integrator
# primary` at 64x48 (3 072 rays). BUILD: a Release, statistics-off build with
# bench_traversal. Two scenes run at once (2 cores). Output: OUT/stages.txt.
set -euo pipefail
BUILD="$(realpath "${1:-build-bench}")"; OUT="${2:-/tmp/stages}"
HERE="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$OUT"
echo 'namespace hwy { namespace platform { double TimerResolution() { return 1e-9; } } }' >"$OUT/hwy.cpp"
c++ -shared -fPIC -O2 "$OUT/hwy.cpp" -o "$OUT/hwy.so"  # experiments/traversal/count_instructions.sh says why
one() {  # scene
  local s=$1 name; name=$(basename "$s")
  "$BUILD/bench_traversal" --scene "scenes/$s.json" --grazing 1000 --write-grazing "$OUT/$name.bin" >/dev/null
  for m in canonical tfdm; do
    local extra=(); [ "$m" = tfdm ] && extra=(--baseline tfdm)
    for fam in grazing camera; do
      local cmd=(trace "scenes/$s.json" --rays "$OUT/$name.bin" -o "$OUT/$name.$m.hits.bin")
      [ "$fam" = camera ] && cmd=(render "scenes/$s.json" --integrator primary --size 64x48 -o "$OUT/$name.$m.exr")
      LD_PRELOAD="$OUT/hwy.so" valgrind --tool=callgrind --collect-atstart=no \
        "--toggle-collect=oblong::EmbreeScene::traceHits*" --callgrind-out-file="$OUT/$name.$m.$fam.cg" \
        "$BUILD/oblong" "${cmd[@]}" --threads 1 -q "${extra[@]}" 2>/dev/null
      callgrind_annotate --threshold=100 "$OUT/$name.$m.$fam.cg" >"$OUT/$name.$m.$fam.txt"
    done
  done
}
scenes=(paper/terracotta_roof paper/diving_helmet paper/creature paper/alien_sphere paper/desert_tire asteroid)
for ((i = 0; i < ${#scenes[@]}; i += 2)); do
  one "${scenes[i]}" & one "${scenes[i+1]}" & wait
done
{
  for s in "${scenes[@]}"; do
    name=$(basename "$s")
    for fam in grazing camera; do
      echo "== $name $fam"
      python3 "$HERE/stages.py" "$OUT/$name.canonical.$fam.txt"
      echo "tfdm total: $(python3 "$HERE/stages.py" "$OUT/$name.tfdm.$fam.txt" | tail -1)"
    done
  done
} >"$OUT/stages.txt"
cat "$OUT/stages.txt"
