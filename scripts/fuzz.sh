#!/usr/bin/env bash
# Fuzzes the scene loader with libFuzzer, AddressSanitizer and UndefinedBehaviorSanitizer,
# built by Debian's clang in its own build folder (CMake option OBLONG_BUILD_FUZZERS).
#
#   bash scripts/fuzz.sh [SECONDS]      # per target; default 60 (or $FUZZ_SECONDS)
#
# Targets ($FUZZ_TARGETS, default both, run one after the other):
#   fuzz_scene  scene files through loadScene/parseScene (tests/fuzz/fuzz_scene.cpp);
#               seeds tests/fuzz/corpus/, dictionary tests/fuzz/scene.dict
#   fuzz_files  map and mesh files through HeightMap::load/loadMesh
#               (tests/fuzz/fuzz_files.cpp); seeds tests/fuzz/corpus_files/ plus
#               glmark2's asteroid-low.3ds (copied at run time, not committed)
# New inputs go to build-fuzz/corpus_TARGET/ (not the repository); a crash, leak or
# timeout is written to build-fuzz/artifacts/ and makes the script exit non-zero.
# Reproduce one with: build-fuzz/fuzz_scene build-fuzz/artifacts/FILE
# What was run and found: docs/bad_input.md.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-${FUZZ_SECONDS:-60}}"
targets="${FUZZ_TARGETS:-fuzz_scene fuzz_files}"
[ "${OBLONG_SKIP_SETUP:-0}" = 1 ] || bash scripts/setup.sh
build="${FUZZ_BUILD_DIR:-build-fuzz}"

# -O1 and line tables, as libFuzzer's documentation builds its targets: faster to compile
# than RelWithDebInfo's -O2 -g, and the reports still name file and line.
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
  -DCMAKE_CXX_COMPILER=clang++ \
  -DOBLONG_BUILD_FUZZERS=ON -DOBLONG_BUILD_TESTS=OFF -DOBLONG_BUILD_BENCHMARKS=OFF >/dev/null
# shellcheck disable=SC2086
cmake --build "$build" -j "${JOBS:-2}" --target $targets

mkdir -p "$build/artifacts"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Leaks inside Debian's libassimp are known and not ours (tests/lsan.supp).
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$PWD/tests/lsan.supp:print_suppressions=0}"
# The targets' scratch files (temp_directory_path) go to a folder of this run, removed at
# the end: libFuzzer ends a timed run without the targets' static destructors.
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
export TMPDIR="$scratch"
status=0
for t in $targets; do
  corpus="$build/corpus_$t"
  mkdir -p "$corpus"
  case "$t" in
    fuzz_scene) seeds=(tests/fuzz/corpus); extra=(-dict=tests/fuzz/scene.dict -max_len=4096) ;;
    fuzz_files)
      seeds=(tests/fuzz/corpus_files "$build/seeds_files")
      mkdir -p "$build/seeds_files"
      # kind byte 14 = .3ds with uvs required, then the file.
      if [ -f /usr/share/glmark2/models/asteroid-low.3ds ]; then
        { printf '\016'; cat /usr/share/glmark2/models/asteroid-low.3ds; } >"$build/seeds_files/asteroid-low.3ds.seed"
      fi
      extra=(-max_len=65536) ;;
    *) echo "fuzz.sh: unknown target $t" >&2; exit 2 ;;
  esac
  echo "== $t: $seconds s"
  # -timeout: one input may take at most 10 s (shapes are capped at ~8M triangles);
  # -rss_limit_mb: the largest allowed shape or map fits.
  "$build/$t" "$corpus" "${seeds[@]}" "${extra[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=4096 -artifact_prefix="$build/artifacts/" -print_final_stats=1 || status=$?
done
exit "$status"
