#!/usr/bin/env bash
# scripts/gpu_bundle.sh and its run.sh --quick on lavapipe, as a GPU machine would run
# them: a bundle of the tiled quad, as it is and at level of detail 1 (`quad_tiled@1`),
# both methods (the canonical traversal and tfdm, one tar.xz per scene), whose run reproduces
# the CPU's hit checksums (SAME), exits 0 and writes table.md with a row per method, and
# the pipelines' statistics of the build's shaders and of a baseline commit's (here HEAD's,
# compiled by the bundle from git: the pipelines are created from them on lavapipe, which
# reports no statistics).
#
#   bash tests/gpu_bundle_test.sh BUILD_DIR SOURCE_DIR      (CTest: label `vulkan`)
set -euo pipefail

BUILD="$(realpath "${1:?usage: gpu_bundle_test.sh BUILD_DIR SOURCE_DIR}")"
SRC="$(realpath "${2:?}")"
export GALLIVM_PERF="${GALLIVM_PERF:-nopt}"
fail() { echo "gpu_bundle_test: FAIL: $*" >&2; exit 1; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
export MESA_SHADER_CACHE_DIR="${MESA_SHADER_CACHE_DIR:-$TMP/shader_cache}"

OBLONG_BUNDLE_BASELINE=HEAD OBLONG_BUNDLE_SCENES='quad_tiled quad_tiled@1' OBLONG_PARITY_SIZE=48x32 bash "$SRC/scripts/gpu_bundle.sh" "$TMP/bundle" "$BUILD" \
  >"$TMP/bundle.log" 2>&1 || { cat "$TMP/bundle.log"; fail "gpu_bundle.sh failed"; }
for f in quad_tiled quad_tiled-lod1; do
  [ -f "$TMP/bundle/scenes/$f.tar.xz" ] || { cat "$TMP/bundle.log"; fail "the bundle lacks $f.tar.xz"; }
  [ "$(tar -tJf "$TMP/bundle/scenes/$f.tar.xz" | tr '\n' ' ')" = "$f.oblg $f-tfdm.oblg " ] || fail "$f.tar.xz does not hold both methods"
done
[ "$(wc -l <"$TMP/bundle/cpu_reference.tsv")" = 5 ] || fail "cpu_reference.tsv: $(cat "$TMP/bundle/cpu_reference.tsv")"
rc=0
OBLONG_RUN_SIZE=64 "$TMP/bundle/run.sh" --quick "$TMP/results" >"$TMP/run.log" 2>&1 || rc=$?
cat "$TMP/run.log"
[ "$rc" = 0 ] || fail "run.sh --quick exited $rc"
[ "$(grep -c ': SAME$' "$TMP/results/summary.txt")" = 4 ] || fail "expected four SAME parity lines"
for s in quad_tiled quad_tiled-lod1; do
  grep -q "^| $s | canonical | " "$TMP/results/table.md" || fail "table.md has no canonical row for $s"
  grep -q "^| $s | tfdm | " "$TMP/results/table.md" || fail "table.md has no tfdm row for $s"
done
[ "$(ls "$TMP/bundle/shaders_baseline"/*.spv | wc -l)" = 6 ] || { cat "$TMP/bundle.log"; fail "the bundle lacks the baseline's six stages"; }
for p in pipelines pipelines_baseline; do
  python3 - "$TMP/results/$p.json" <<'PY' || fail "$p.json"
import json, sys
j = json.load(open(sys.argv[1]))
assert [(p["method"], p["stage"]) for p in j["programs"]] == [("canonical", "prism.rint"), ("tfdm", "tfdm.rint")], j
assert isinstance(j["supported"], bool) and j["device"]["name"]
# Where the driver reports statistics, every program has an executable with some.
assert not j["supported"] or all(any(e["statistics"] for e in p["executables"]) for p in j["programs"]), j
PY
done
grep -q "^Pipelines" "$TMP/results/table.md" || fail "table.md has no pipelines section"
[ ! -e "$TMP/results/.scenes" ] || fail "run.sh left its unpacked scenes behind"
echo "gpu_bundle_test: ok"
