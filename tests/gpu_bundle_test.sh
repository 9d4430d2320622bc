#!/usr/bin/env bash
# scripts/gpu_bundle.sh and its run.sh --quick on lavapipe, as a GPU machine would run
# them: a bundle of the tiled quad (both methods: the canonical traversal and tfdm,
# xz-compressed), whose run reproduces the CPU's hit checksums (SAME), exits 0 and
# writes table.md with a row per method.
#
#   bash tests/gpu_bundle_test.sh BUILD_DIR SOURCE_DIR      (CTest: label `vulkan`)
set -euo pipefail

BUILD="$(realpath "${1:?usage: gpu_bundle_test.sh BUILD_DIR SOURCE_DIR}")"
SRC="$(realpath "${2:?}")"
export GALLIVM_PERF="${GALLIVM_PERF:-nopt}"
export MESA_SHADER_CACHE_DIR="${MESA_SHADER_CACHE_DIR:-${TMPDIR:-/tmp}/oblong_vulkan_test_shader_cache}"
fail() { echo "gpu_bundle_test: FAIL: $*" >&2; exit 1; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

OBLONG_BUNDLE_SCENES=quad_tiled OBLONG_PARITY_SIZE=48x32 bash "$SRC/scripts/gpu_bundle.sh" "$TMP/bundle" "$BUILD" \
  >"$TMP/bundle.log" 2>&1 || { cat "$TMP/bundle.log"; fail "gpu_bundle.sh failed"; }
[ -f "$TMP/bundle/scenes/quad_tiled.oblg.xz" ] && [ -f "$TMP/bundle/scenes/quad_tiled-tfdm.oblg.xz" ] ||
  { cat "$TMP/bundle.log"; fail "the bundle lacks a method's scene"; }
[ "$(wc -l <"$TMP/bundle/cpu_reference.tsv")" = 3 ] || fail "cpu_reference.tsv: $(cat "$TMP/bundle/cpu_reference.tsv")"
rc=0
OBLONG_RUN_SIZE=64 "$TMP/bundle/run.sh" --quick "$TMP/results" >"$TMP/run.log" 2>&1 || rc=$?
cat "$TMP/run.log"
[ "$rc" = 0 ] || fail "run.sh --quick exited $rc"
[ "$(grep -c ': SAME$' "$TMP/results/summary.txt")" = 2 ] || fail "expected two SAME parity lines"
grep -q '^| quad_tiled | canonical | ' "$TMP/results/table.md" || fail "table.md has no canonical row"
grep -q '^| quad_tiled | tfdm | ' "$TMP/results/table.md" || fail "table.md has no tfdm row"
[ ! -e "$TMP/results/.scenes" ] || fail "run.sh left its unpacked scenes behind"
echo "gpu_bundle_test: ok"
