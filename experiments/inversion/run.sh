#!/usr/bin/env bash
# Error against run time of the inverters (docs/inversion.md). Builds bench_inversion in a timing
# build (statistics counters compiled out), then writes into this directory:
#   stiff_report.md  the stiff-case table (also recorded in docs/inversion.md)
#   errors.csv       accuracy of every variant on every dataset (against ceres)
#   timings.json     Google Benchmark output (ns per inversion, median of 5 repetitions)
#   results.csv      errors.csv joined with the timings
#   error_vs_time.png
# Usage: experiments/inversion/run.sh   (BUILD_DIR, JOBS, BENCH_ARGS may be set)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${BUILD_DIR:-$root/build-bench-inversion}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DOBLONG_STATS=OFF \
  -DOBLONG_BUILD_TESTS=OFF -DOBLONG_BUILD_BENCHMARKS=ON >/dev/null
cmake --build "$build" --target bench_inversion -j "${JOBS:-2}"
"$build/bench_inversion" --stiff-report > "$here/stiff_report.md"
"$build/bench_inversion" --errors="$here/errors.csv"
# shellcheck disable=SC2086
"$build/bench_inversion" --benchmark_out="$here/timings.json" --benchmark_out_format=json \
  --benchmark_min_time=0.2 --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
  ${BENCH_ARGS:-}
# Debian's matplotlib lives in the system interpreter; `python3` on PATH may be another.
/usr/bin/python3 "$here/plot.py" "$here"
