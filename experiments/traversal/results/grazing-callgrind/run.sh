#!/usr/bin/env bash
# The commands behind totals.txt and *.top.txt (experiments/traversal/README.md, the
# grazing-ray instruction and cache entry): 2 000 grazing rays per scene, traced once by the
# canonical traversal and once by tfdm under callgrind with cache and branch simulation,
# collecting inside EmbreeScene::traceHits only. BUILD: a Release, statistics-off build.
set -euo pipefail
BUILD="${1:-build-bench}"; OUT="${2:-/tmp/grazing-callgrind}"
mkdir -p "$OUT"
echo 'namespace hwy { namespace platform { double TimerResolution() { return 1e-9; } } }' >"$OUT/hwy.cpp"
c++ -shared -fPIC -O2 "$OUT/hwy.cpp" -o "$OUT/hwy.so"  # count_instructions.sh says why
for s in terracotta_roof creature; do
  "$BUILD/bench_traversal" --scene "scenes/paper/$s.json" --grazing 2000 --write-grazing "$OUT/$s.bin"
  for m in canonical tfdm; do
    extra=(); [ "$m" = tfdm ] && extra=(--baseline tfdm)
    LD_PRELOAD="$OUT/hwy.so" valgrind --tool=callgrind --cache-sim=yes --branch-sim=yes --collect-atstart=no \
      "--toggle-collect=oblong::EmbreeScene::traceHits*" --callgrind-out-file="$OUT/$s.$m.cg" \
      "$BUILD/oblong" trace "scenes/paper/$s.json" --rays "$OUT/$s.bin" -o "$OUT/$s.$m.hits.bin" --threads 1 -q "${extra[@]}"
    callgrind_annotate --show=Ir,I1mr,D1mr,Bcm "$OUT/$s.$m.cg" | sed -n '1,45p' >"$OUT/$s.$m.top.txt"
  done
done
