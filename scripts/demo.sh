#!/usr/bin/env bash
# Installs the dependencies, builds oblong and renders the built-in default scene:
# writes out/default.png and out/default_stats.json and prints the summary.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/configure.sh demo build
cmake --build build -j "$(nproc)" --target oblong
mkdir -p out
./build/oblong render -o out/default.png --stats out/default_stats.json
./build/oblong info
