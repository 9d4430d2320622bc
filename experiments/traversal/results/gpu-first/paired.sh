#!/bin/bash
# paired.sh OLD_BENCH NEW_BENCH OUTDIR [ROUNDS] [SCENE...]: bench_traversal (Release,
# statistics on, as scripts/configure.sh release builds it) of two builds, canonical and
# tfdm, camera, secondary and grazing rays, rounds interleaved (new, old per scene), one
# thread. Run from the repository root. Scenes: the paper suite's curved alien_sphere and
# desert_tire, the roof and the creature, unless named.
OLD=$1; NEW=$2; OUT=$3; ROUNDS=${4:-3}; shift 4 2>/dev/null
SCENES=${*:-scenes/paper/alien_sphere.json scenes/paper/desert_tire.json scenes/paper/terracotta_roof.json scenes/paper/creature.json}
mkdir -p "$OUT"
for round in $(seq 1 "$ROUNDS"); do
  for s in $SCENES; do
    n=$(basename $s .json)
    for b in new old; do
      B=$NEW; [ $b = old ] && B=$OLD
      $B --scene $s --size 160x120 --grazing 2000 --benchmark_filter='^(primary|secondary|grazing)/(canonical|tfdm)/' \
        --benchmark_min_time=1 --benchmark_out="$OUT/$n.$b.$round.json" --benchmark_out_format=json > /dev/null 2>&1
    done
  done
  echo "round $round done $(date -u +%H:%M) load $(cut -d' ' -f1 /proc/loadavg)"
done
