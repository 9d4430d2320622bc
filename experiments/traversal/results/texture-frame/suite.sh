#!/bin/bash
# suite.sh OUTDIR SIZE GRAZING SCENES... : old (wt-e9) and new (main) bench_traversal, canonical + tfdm
OUT=$1; SIZE=$2; G=$3; shift 3
mkdir -p $OUT
for s in "$@"; do
  n=$(basename $s .json)
  for b in new old; do
    B=/work/main/build-bench/bench_traversal; [ $b = old ] && B=/work/wt-e9/build-bench/bench_traversal
    (cd /work/main && $B --scene $s --size $SIZE --grazing $G --benchmark_filter='/(canonical|tfdm)/' --benchmark_repetitions=1 --benchmark_out=$OUT/$n.$b.json --benchmark_out_format=json > $OUT/$n.$b.log 2>&1)
  done
done
