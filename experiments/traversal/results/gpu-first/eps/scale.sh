#!/bin/bash
# ε's share of the canonical traversal's work: P.eps scaled by a factor (eps-scale.patch;
# below 1 the traversal is not exact), bench_traversal's counters and time per factor.
# Usage: scale.sh BENCH OUT   (BENCH built with eps-scale.patch, run from build/)
set -e
B=$1; OUT=$2; : > "$OUT"
for round in 1 2; do
  for f in 1 0.5 0.1 0; do
    for s in desert_tire alien_sphere creature; do
      OBLONG_EPS_SCALE=$f "$B" --scene ../scenes/paper/$s.json --size 160x120 --grazing 2000 \
        --benchmark_filter='^(primary|grazing)/canonical/' --benchmark_min_time=0.01 2>&1 |
        grep -E '^(primary|grazing)' | sed 's|/process_time/real_time||' |
        awk -v r=$round -v f=$f -v s=$s '{c=""; st=""; for (i=1;i<=NF;i++) {if ($i ~ /^cells/) c=$i; if ($i ~ /^steps/) st=$i}; print "round", r, "scale", f, s, $1, $2, "ms", c, st}' >> "$OUT"
    done
  done
done
