#!/usr/bin/env bash
# Installs what a first render needs (scripts/setup.sh --minimal), builds the `oblong`
# program alone (build/oblong) and renders the built-in default scene at 16 samples per
# pixel (at 1, path tracing's noise reads as holes): writes
# out/default.png and out/default_stats.json and prints the summary and what was built.
# The tests, benchmarks, Vulkan path and Python module are scripts/test.sh's.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --minimal
bash scripts/configure.sh demo build
cmake --build build -j "$(nproc)" --target oblong
mkdir -p out
./build/oblong render --spp 16 -o out/default.png --stats out/default_stats.json
./build/oblong info
