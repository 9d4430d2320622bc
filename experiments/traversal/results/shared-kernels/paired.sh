#!/bin/bash
# paired.sh OLD_BENCH NEW_BENCH OUTDIR: bench_traversal (Release, statistics off) of two
# builds, canonical only, three rounds interleaved (new, old per scene), one thread.
OLD=$1; NEW=$2; OUT=$3
mkdir -p "$OUT"
for round in 1 2 3; do
  for s in scenes/asteroid.json scenes/paper/terracotta_roof.json scenes/paper/creature.json; do
    n=$(basename $s .json)
    for b in new old; do
      B=$NEW; [ $b = old ] && B=$OLD
      $B --scene $s --size 160x120 --grazing 2000 --benchmark_filter='^(primary|secondary|grazing)/canonical/' \
        --benchmark_min_time=1.5 --benchmark_out="$OUT/$n.$b.$round.json" --benchmark_out_format=json > /dev/null 2>&1
    done
  done
done
