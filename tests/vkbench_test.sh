#!/usr/bin/env bash
# oblong bake + oblong_vkbench on lavapipe: on the asteroid and the tiled quad, the
# camera rays oblong_vkbench generates (2 spp: centres and jittered samples) give
# byte-identical hit files from oblong_vkbench and `oblong trace --device vulkan`, and
# the same hit checksum; a ray list stored by `bake --rays` gives it too; the path
# integrator runs its shadow and bounce passes; truncated, foreign and corrupt baked
# files end with one error line; oblong_vkbench needs no library but the Vulkan loader
# and the C/C++ runtime.
#
#   bash tests/vkbench_test.sh OBLONG OBLONG_VKBENCH SOURCE_DIR TEST_DATA      (CTest: label `vulkan`)
# TEST_DATA: the build's test_data/ (tests/test_data.cmake), whose scenes/ holds the
# shipped scenes that name Debian's glmark2 data, pointed at the build's copy of it.
set -euo pipefail

OBLONG="$(realpath "${1:?usage: vkbench_test.sh OBLONG OBLONG_VKBENCH SOURCE_DIR TEST_DATA}")"
VKBENCH="$(realpath "${2:?}")"
SRC="$(realpath "${3:?}")"
DATA="$(realpath "${4:?}")"
scene_file() { if [ -f "$DATA/scenes/$1.json" ]; then echo "$DATA/scenes/$1.json"; else echo "$SRC/scenes/$1.json"; fi; }
SKIP=77
# As tests/vulkan_test.cpp: lavapipe without LLVM's optimisation passes (same bits, the
# pipeline compiles in seconds) into the tests' own shader cache (CTest's, or this run's).
export GALLIVM_PERF="${GALLIVM_PERF:-nopt}"

say() { echo "vkbench_test: $*"; }
fail() { echo "vkbench_test: FAIL: $*" >&2; exit 1; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
export MESA_SHADER_CACHE_DIR="${MESA_SHADER_CACHE_DIR:-$TMP/shader_cache}"
cd "$TMP"

# Only the Vulkan loader and the C/C++ runtime.
libs="$(ldd "$VKBENCH" | awk '{print $1}' | sed 's/\.so.*//')"
for l in $libs; do
  case "$l" in
    linux-vdso | /lib64/ld-linux-x86-64 | ld-linux* | libvulkan | libc | libm | libstdc++ | libgcc_s | libdl | libpthread | librt) ;;
    libasan | libubsan | liblsan) ;;  # the sanitizer build's runtimes
    *) fail "oblong_vkbench links $l (ldd): only the Vulkan loader and the C/C++ runtime are allowed" ;;
  esac
done
say "ldd: $(echo $libs | tr '\n' ' ')"

# One error line and exit status 1, mentioning $2.
expect_error() {
  local what="$1" words="$2"; shift 2
  local rc=0
  "$@" >out.txt 2>err.txt || rc=$?
  [ "$rc" = 1 ] || fail "$what: exit status $rc, expected 1 ($(cat err.txt))"
  [ "$(wc -l <err.txt)" = 1 ] || fail "$what: expected one error line, got: $(cat err.txt)"
  grep -q -- "$words" err.txt || fail "$what: expected '$words' in: $(cat err.txt)"
  say "$what: $(cat err.txt)"
}

for scene in asteroid quad_tiled; do
  "$OBLONG" bake "$(scene_file "$scene")" -o "$scene.oblg" --size 40x30 >/dev/null
  rc=0
  "$VKBENCH" "$scene.oblg" --spp 2 --repeat 2 --out "$scene.json" --hits "$scene.vk.csv" --rays-out "$scene.rays.bin" \
    >out.txt 2>err.txt || rc=$?
  if [ "$rc" != 0 ]; then
    if grep -q "no Vulkan driver found\|no Vulkan device supports ray tracing" err.txt; then
      say "SKIP: $(cat err.txt)"
      exit $SKIP
    fi
    fail "oblong_vkbench $scene: $(cat err.txt)"
  fi
  "$OBLONG" trace "$(scene_file "$scene")" --rays "$scene.rays.bin" --device vulkan -o "$scene.ref.csv" >/dev/null
  cmp -s "$scene.vk.csv" "$scene.ref.csv" || fail "$scene: oblong_vkbench's hits differ from oblong trace --device vulkan's"
  sum="$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["hit_checksum"])' "$scene.json")"
  [ "$("$VKBENCH" --checksum "$scene.ref.csv")" = "$sum" ] || fail "$scene: hit checksum differs"
  hits="$(python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print(j["hits"], j["camera_rays"]["count"], j["deterministic"])' "$scene.json")"
  set -- $hits
  [ "$1" -gt 0 ] && [ "$2" = 2400 ] && [ "$3" = True ] || fail "$scene: hits/rays/deterministic = $hits"
  say "$scene: $2 rays, $1 hits, same hits as oblong trace --device vulkan (checksum $sum)"
done

# A baked ray list is traced as it is.
"$OBLONG" bake "$(scene_file asteroid)" -o listed.oblg --rays asteroid.rays.bin >/dev/null
"$VKBENCH" listed.oblg --repeat 1 --hits listed.csv >/dev/null 2>&1
cmp -s listed.csv asteroid.ref.csv || fail "bake --rays: hits differ"
say "bake --rays: same hits"

# The path integrator: camera, shadow and bounce passes, each timed.
"$VKBENCH" asteroid.oblg --integrator path --size 16x12 --repeat 2 --out path.json >/dev/null 2>&1
python3 - path.json <<'PY' || fail "path integrator: $(cat path.json)"
import json, sys
j = json.load(open(sys.argv[1]))
assert set(j["passes"]) == {"camera", "shadow", "bounce"}, j["passes"].keys()
assert all(p["rays"] > 0 and len(p["gpu_seconds"]) == 2 for p in j["passes"].values())
assert j["deterministic"] and j["rays_per_repeat"] > 192
PY
say "path: camera, shadow and bounce passes"

# Bad files: one line each.
head -c 1000 asteroid.oblg >truncated.oblg
head -c 20 asteroid.oblg >header.oblg
python3 - asteroid.oblg corrupt.oblg <<'PY'
import sys
b = bytearray(open(sys.argv[1], "rb").read())
b[len(b) // 2] ^= 0x40  # one bit in the middle of the texels or the RMIP words
open(sys.argv[2], "wb").write(b)
PY
expect_error "truncated" "truncated" "$VKBENCH" truncated.oblg
expect_error "truncated header" "truncated" "$VKBENCH" header.oblg
expect_error "foreign" "not an oblong baked scene" "$VKBENCH" "$(scene_file asteroid)"
expect_error "corrupt" "corrupt" "$VKBENCH" corrupt.oblg
expect_error "missing" "cannot open" "$VKBENCH" missing.oblg

# --pipeline-stats: both pipelines created (lavapipe reports no statistics: supported
# false), from the built-in SPIR-V; --spirv reads another folder's, one line on a bad one.
"$VKBENCH" --pipeline-stats --out stats.json >out.txt 2>err.txt || fail "--pipeline-stats: $(cat err.txt)"
python3 - stats.json <<'PY' || fail "--pipeline-stats: $(cat stats.json)"
import json, sys
j = json.load(open(sys.argv[1]))
assert [p["method"] for p in j["programs"]] == ["canonical", "tfdm"] and j["spirv"] == "built in", j
PY
mkdir -p spirv
printf 'not spir-v' >spirv/trace.rgen.spv
expect_error "--spirv missing" "cannot open the SPIR-V module" "$VKBENCH" --pipeline-stats --spirv nowhere
expect_error "--spirv foreign" "not a SPIR-V module" "$VKBENCH" --pipeline-stats --spirv spirv
expect_error "--spirv without --pipeline-stats" "only applies with --pipeline-stats" "$VKBENCH" asteroid.oblg --spirv spirv
expect_error "--pipeline-stats with a scene" "takes no scene" "$VKBENCH" asteroid.oblg --pipeline-stats
say "PASS"
