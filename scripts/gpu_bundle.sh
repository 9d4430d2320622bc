#!/usr/bin/env bash
# Collects what a GPU machine needs to measure the Vulkan path, and nothing it cannot
# run: oblong_vkbench (Vulkan loader and C/C++ runtime only), its SPIR-V, the Vulkan
# loader as a fallback, baked scenes (oblong bake) up to a size budget, the CPU's hit
# checksums and Mrays/s for the same rays on this machine, and run.sh, which runs the
# whole measurement in at most 8 minutes and writes into one folder given as its
# argument. docs/vulkan.md ("On a GPU") says how to use it.
#
#   scripts/gpu_bundle.sh [BUNDLE_DIR (default build/gpu_bundle)] [BUILD_DIR (default build)]
#   BUNDLE_DIR/run.sh [--quick] RESULTS_DIR                           (on the GPU machine)
#
# Environment: OBLONG_BUNDLE_MIB (size budget, default 60), OBLONG_PARITY_SIZE (the
# camera rays whose hits the GPU must reproduce, default 320x240), OBLONG_BUNDLE_SCENES
# (scene files under scenes/ without .json, in order of priority; NAME@L bakes and
# traces it at the fixed level of detail L, a map 2^L times smaller per side, for a
# machine whose transfer limit the full map exceeds), OBLONG_BUNDLE_XZ (1, the default:
# each scene's two baked files in one NAME.tar.xz, one xz stream whose dictionary spans
# both, since the two methods' prism records are mostly the same bytes; run.sh unpacks
# them with xz and tar, else python3; 0: uncompressed), OBLONG_BUNDLE_GLIBC (1, the
# default: this machine's glibc, ~3 MiB, for a GPU machine with an older one; 0: not),
# OBLONG_BUNDLE_BASELINE (a commit whose shaders run.sh compiles into pipelines beside the
# build's, for the driver's statistics before and after: default 5cac6cc, whose
# shaders are those of experiments/GPU.md's H200 run; empty: none).
set -euo pipefail

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUNDLE="${1:-$ROOT/build/gpu_bundle}"
BUILD="$(cd "${2:-$ROOT/build}" && pwd)"
BUDGET_MIB="${OBLONG_BUNDLE_MIB:-60}"
PARITY="${OBLONG_PARITY_SIZE:-320x240}"
OBLONG="$BUILD/oblong"
VK="$BUILD/oblong_vkbench"
say() { echo "gpu_bundle: $*"; }
[ -x "$OBLONG" ] && [ -x "$VK" ] || { echo "gpu_bundle: build oblong and oblong_vkbench first (ninja -C $BUILD oblong oblong_vkbench)" >&2; exit 1; }

rm -rf "$BUNDLE"
mkdir -p "$BUNDLE"/{bin,lib,shaders,scenes}
cp "$VK" "$BUNDLE/bin/"
cp "$BUILD"/vulkan_shaders/*.spv "$BUNDLE/shaders/"
# The baseline commit's shaders, compiled as the build compiles its own (CMakeLists.txt:
# glslc -O, the default stack of 32 entries), for run.sh's pipeline statistics.
BASELINE="${OBLONG_BUNDLE_BASELINE-5cac6cc}"
if [ -n "$BASELINE" ]; then
  base="$(mktemp -d)"
  if git -C "$ROOT" archive "$BASELINE" render/vulkan/shaders core/kernels 2>"$base/err.txt" | tar -x -C "$base" 2>>"$base/err.txt" &&
     [ -f "$base/render/vulkan/shaders/prism.rint" ]; then
    mkdir -p "$BUNDLE/shaders_baseline"
    for st in trace.rgen trace.rmiss prism.rint tfdm.rint prism.rchit triangle.rchit; do
      glslc --target-env=vulkan1.2 -DOBLONG_TRAV_STACK_GPU=32 -I "$base" -O \
        -o "$BUNDLE/shaders_baseline/$st.spv" "$base/render/vulkan/shaders/$st" 2>>"$base/err.txt" ||
        { say "baseline $BASELINE: left out: glslc $st: $(tail -1 "$base/err.txt")"; rm -rf "$BUNDLE/shaders_baseline"; break; }
    done
    [ -d "$BUNDLE/shaders_baseline" ] && git -C "$ROOT" rev-parse --short "$BASELINE" >"$BUNDLE/shaders_baseline/commit.txt"
  else
    say "baseline $BASELINE: left out: $(tail -1 "$base/err.txt")"
  fi
  rm -rf "$base"
fi
# The loader, for machines without one (run.sh uses it only when none is found).
loader="$(ldd "$VK" | awk '/libvulkan.so.1/ {print $3}')"
[ -n "$loader" ] && cp -L "$loader" "$BUNDLE/lib/libvulkan.so.1"
# This machine's glibc (~3 MiB), for a GPU machine whose glibc is older than the one
# oblong_vkbench was linked against (run.sh starts it through this ld.so only then).
if [ "${OBLONG_BUNDLE_GLIBC:-1}" = 1 ]; then
  mkdir -p "$BUNDLE/lib/glibc"
  for l in ld-linux-x86-64.so.2 libc.so.6 libm.so.6 libpthread.so.0 libdl.so.2 librt.so.1; do
    cp -L "/lib/x86_64-linux-gnu/$l" "$BUNDLE/lib/glibc/"
  done
fi
budget=$(( BUDGET_MIB * 1024 * 1024 ))
used() { du -sb "$BUNDLE" | cut -f1; }

# In order of priority, each scene with both methods (the canonical traversal and the
# tfdm baseline, which the GPU table compares); a scene whose pair would exceed the budget
# (or whose data is not set up) is left out with a line saying so.
ref="$BUNDLE/cpu_reference.tsv"
printf 'file\tscene\tmethod\trays\thits\tchecksum\tcpu_mrays_per_second\tcpu_threads\n' >"$ref"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
SCENES="${OBLONG_BUNDLE_SCENES:-asteroid quad_tiled paper/terracotta_roof@2 paper/alien_sphere@2 paper/diving_helmet@3 paper/desert_tire@3 paper/creature@3}"
# method M: the flags and the baked file's name of method M for the current scene.
method() {
  flags=("${lod[@]}"); file="$name"
  if [ "$1" = tfdm ]; then flags+=(--baseline tfdm); file="$name-tfdm"; fi
}
for entry in $SCENES; do
  s="${entry%@*}"
  lod=(); name="$(basename "$s")"
  if [ "$entry" != "$s" ]; then lod=(--lod "${entry#*@}"); name="$name-lod${entry#*@}"; fi
  ok=1
  for m in canonical tfdm; do
    method "$m"
    if ! "$OBLONG" bake "$ROOT/scenes/$s.json" "${flags[@]}" -o "$BUNDLE/scenes/$file.oblg" >"$tmp/bake.txt" 2>&1; then
      say "$name: left out: $m: $(tail -1 "$tmp/bake.txt")"
      ok=0
      break
    fi
  done
  # The CPU's answer for the parity rays (the camera's at $PARITY), and its speed here.
  for m in canonical tfdm; do
    [ "$ok" = 1 ] || break
    method "$m"
    "$VK" "$BUNDLE/scenes/$file.oblg" --size "$PARITY" --rays-out "$tmp/rays.bin" --no-trace
    "$OBLONG" trace "$ROOT/scenes/$s.json" "${flags[@]}" --rays "$tmp/rays.bin" -o "$tmp/hits.csv" --stats "$tmp/stats.json" >/dev/null
    sum="$("$VK" --checksum "$tmp/hits.csv")"
    read -r rays hits mrays threads < <(python3 -c 'import json,sys; j=json.load(open(sys.argv[1]))
print(j["rays"]["count"], j["rays"]["hits"], j["mrays_per_second"], j.get("run", {}).get("threads", ""))' "$tmp/stats.json")
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%.3f\t%s\n' "$file" "$name" "$m" "$rays" "$hits" "$sum" "$mrays" "$threads" >>"$tmp/ref.tsv"
    say "$file: $(( $(stat -c %s "$BUNDLE/scenes/$file.oblg") >> 20 )) MiB, CPU: $rays rays, $hits hits, checksum $sum, $mrays Mrays/s"
  done
  # One stream for both files, single-threaded (xz's threads would cut it into blocks)
  # with a dictionary larger than the first file, so that the second's records are
  # coded as matches into the first's.
  if [ "$ok" = 1 ] && [ "${OBLONG_BUNDLE_XZ:-1}" = 1 ]; then
    dict=$(( ($(stat -c %s "$BUNDLE/scenes/$name.oblg") >> 20) + 8 ))
    tar -C "$BUNDLE/scenes" -cf - "$name.oblg" "$name-tfdm.oblg" |
      xz -T1 --lzma2=preset=6,dict=${dict}MiB >"$BUNDLE/scenes/$name.tar.xz"
    rm -f "$BUNDLE/scenes/$name.oblg" "$BUNDLE/scenes/$name-tfdm.oblg"
  fi
  if [ "$ok" = 1 ] && [ "$(used)" -gt "$budget" ]; then
    say "$name: left out: $(( $(du -cb "$BUNDLE/scenes/$name".oblg "$BUNDLE/scenes/$name-tfdm".oblg "$BUNDLE/scenes/$name".tar.xz 2>/dev/null | tail -1 | cut -f1) >> 20 )) MiB (both methods) would take the bundle past $BUDGET_MIB MiB"
    ok=0
  fi
  if [ "$ok" = 0 ]; then
    rm -f "$BUNDLE/scenes/$name".oblg "$BUNDLE/scenes/$name-tfdm".oblg "$BUNDLE/scenes/$name".tar.xz
    : >"$tmp/ref.tsv"
    continue
  fi
  cat "$tmp/ref.tsv" >>"$ref"
  : >"$tmp/ref.tsv"
done
echo "$PARITY" >"$BUNDLE/parity_size.txt"
git -C "$ROOT" describe --always --dirty >"$BUNDLE/version.txt" 2>/dev/null || true

cat >"$BUNDLE/run.sh" <<'RUN'
#!/usr/bin/env bash
# The GPU measurement (written by scripts/gpu_bundle.sh; docs/vulkan.md "On a GPU"): per
# baked scene and method (NAME.oblg: the canonical traversal; NAME-tfdm.oblg: the tfdm
# baseline), the parity rays (hit checksum against the CPU's, cpu_reference.tsv), then
# primary rays at 1024^2, the path integrator at 1024^2, and primary rays at 2048^2 while
# time is left, each timed per pass by timestamp queries, repeated (the median is
# reported). Writes RESULTS_DIR:
# one JSON per run, run.log, summary.txt and table.md (the paper's Table 1 layout: ms per
# frame, Mrays/s, bytes, speed-up over tfdm), pipelines.json and pipelines.txt (the
# driver's statistics of both pipelines: registers, binary size, ..., where the driver
# reports them) and pipelines_baseline.* (the same for the bundled baseline commit's
# shaders). The whole run stays under
# OBLONG_RUN_SECONDS (default 450: 7.5 minutes); --quick: parity and primary rays only
# (3 repeats), under 120 s. Exit status 1 when a parity checksum differs or was not
# measured.
#   run.sh [--quick] RESULTS_DIR
set -u
QUICK=0
if [ "${1:-}" = "--quick" ]; then QUICK=1; shift; fi
HERE="$(cd "$(dirname "$0")" && pwd)"
OUT="${1:?usage: run.sh [--quick] RESULTS_DIR}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
exec > >(tee "$OUT/run.log") 2>&1
T0=$(date +%s)
if [ "$QUICK" = 1 ]; then LIMIT=${OBLONG_RUN_SECONDS:-120}; else LIMIT=${OBLONG_RUN_SECONDS:-450}; fi
END=$(( T0 + LIMIT ))
left() { echo $(( END - $(date +%s) )); }
VK=("$HERE/bin/oblong_vkbench")
CAP="${OBLONG_RUN_CAP:-120}"  # seconds for one oblong_vkbench run at most
PARITY="$(cat "$HERE/parity_size.txt")"
SIZE="${OBLONG_RUN_SIZE:-1024}"  # primary and path images: SIZE x SIZE

# The Vulkan loader: the system's, else the bundled one.
if ldd "${VK[0]}" | grep -q "libvulkan.so.1 => not found"; then export LD_LIBRARY_PATH="$HERE/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"; fi
# An older glibc than the build machine's: start it through the bundled one.
if ! "${VK[@]}" --help >/dev/null 2>"$OUT/start_error.txt"; then
  echo "run.sh: oblong_vkbench does not start: $(head -1 "$OUT/start_error.txt"); using the bundled glibc"
  VK=("$HERE/lib/glibc/ld-linux-x86-64.so.2" --library-path "$HERE/lib/glibc:${LD_LIBRARY_PATH:-$HERE/lib}" "$HERE/bin/oblong_vkbench")
  "${VK[@]}" --help >/dev/null || echo "run.sh: it does not start with the bundled glibc either"
fi
# A container's NVIDIA driver keeps its ICD manifest outside the loader's search path.
if [ -z "${VK_ICD_FILENAMES:-}${VK_DRIVER_FILES:-}" ] && [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] &&
   ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json /usr/local/share/vulkan/icd.d/*.json >/dev/null 2>&1; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json VK_ICD_FILENAMES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  echo "run.sh: using the driver's ICD manifest $VK_DRIVER_FILES"
fi
# NVIDIA's ICD manifest, when the driver is installed without one (CUDA-only images).
if [ -z "${VK_ICD_FILENAMES:-}${VK_DRIVER_FILES:-}" ] &&
   ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json /usr/local/share/vulkan/icd.d/*.json >/dev/null 2>&1; then
  glx="$( (ldconfig -p 2>/dev/null | awk '/libGLX_nvidia.so.0/ {print $NF; exit}'; ls /usr/lib/x86_64-linux-gnu/libGLX_nvidia.so.0 /usr/lib64/libGLX_nvidia.so.0 2>/dev/null) | head -1)"
  if [ -n "$glx" ]; then
    printf '{"file_format_version": "1.0.0", "ICD": {"library_path": "%s", "api_version": "1.3.0"}}\n' "$glx" >"$OUT/nvidia_icd.json"
    export VK_ICD_FILENAMES="$OUT/nvidia_icd.json" VK_DRIVER_FILES="$OUT/nvidia_icd.json"
    echo "run.sh: no Vulkan ICD manifest installed; using $OUT/nvidia_icd.json -> $glx"
  fi
fi
{
  date -u; uname -a; cat "$HERE/version.txt" 2>/dev/null
  nvidia-smi 2>&1 | head -20
  ldd "${VK[@]: -1}"
  echo "started as: ${VK[*]}"
} >"$OUT/environment.txt" 2>&1
cp "$HERE/cpu_reference.tsv" "$OUT/"
# Compressed scenes (OBLONG_BUNDLE_XZ: NAME.tar.xz, both methods) are unpacked into a
# folder beside the results.
SCENES_DIR="$HERE/scenes"
if ls "$HERE"/scenes/*.tar.xz >/dev/null 2>&1; then
  SCENES_DIR="$OUT/.scenes"
  mkdir -p "$SCENES_DIR"
  for z in "$HERE"/scenes/*.tar.xz; do
    if command -v xz >/dev/null && command -v tar >/dev/null; then xz -dc "$z" | tar -x -C "$SCENES_DIR"
    else python3 -c 'import sys, tarfile; tarfile.open(sys.argv[1], "r:xz").extractall(sys.argv[2])' "$z" "$SCENES_DIR"; fi
  done
  echo "run.sh: unpacked $(ls "$SCENES_DIR" | wc -l) scenes in $(( $(date +%s) - T0 )) s"
fi

# run NAME ARGS...: one oblong_vkbench run, limited to the time left.
run() {
  local name="$1"; shift
  local budget; budget=$(left)
  if [ "$budget" -lt 10 ]; then echo "run.sh: $name: skipped (time is up)"; return 1; fi
  [ "$budget" -gt "$CAP" ] && budget=$CAP
  local t=$(date +%s)
  timeout "$budget" "${VK[@]}" "$@" --out "$OUT/$name.json"
  local rc=$?
  echo "run.sh: $name: exit $rc, $(( $(date +%s) - t )) s"
  return $rc
}
# field FILE KEY: the first value of "KEY" in a JSON written by oblong_vkbench (one key a line).
field() { sed -n "s|.*\"$2\": \"\{0,1\}\([^\",]*\)\"\{0,1\},\{0,1\}$|\1|p" "$1" 2>/dev/null | head -1; }

summary="$OUT/summary.txt"
: >"$summary"
files=$(ls "$SCENES_DIR"/*.oblg)
status=0
for f in $files; do  # parity first: the checksums are the point
  s="$(basename "$f" .oblg)"
  if ! run "${s}_parity" "$f" --size "$PARITY" --repeat 1; then
    echo "$s parity $PARITY: not measured (see run.log)" | tee -a "$summary"
    status=1
    continue
  fi
  got="$(field "$OUT/${s}_parity.json" hit_checksum)"
  want="$(awk -v s="$s" '$1 == s {print $6}' "$HERE/cpu_reference.tsv")"
  [ "$got" = "$want" ] && verdict=SAME || { verdict=DIFFERENT; status=1; }
  echo "$s parity $PARITY: GPU checksum $got, CPU $want: $verdict" | tee -a "$summary"
done
# The driver's statistics of both pipelines (VK_KHR_pipeline_executable_properties), this
# build's shaders and the baseline commit's: seconds each, before any timing.
stats() { local name="$1"; shift; run "$name" --pipeline-stats "$@" | tee "$OUT/$name.txt"; }
stats pipelines
if [ -d "$HERE/shaders_baseline" ]; then
  stats pipelines_baseline --spirv "$HERE/shaders_baseline"
  echo "baseline commit: $(cat "$HERE/shaders_baseline/commit.txt" 2>/dev/null)" >>"$OUT/pipelines_baseline.txt"
fi
reps=5; [ "$QUICK" = 1 ] && reps=3
for f in $files; do
  s="$(basename "$f" .oblg)"
  run "${s}_primary_$SIZE" "$f" --size "${SIZE}x$SIZE" --repeat $reps
done
if [ "$QUICK" = 0 ]; then
  for f in $files; do
    s="$(basename "$f" .oblg)"
    run "${s}_path_$SIZE" "$f" --size "${SIZE}x$SIZE" --integrator path --repeat 3
  done
  # 2048^2 (the papers' primary-ray setting) with the time that is left, last: a table
  # with every scene's primary and path rows comes first.
  if [ "$SIZE" = 1024 ]; then
    for f in $files; do
      s="$(basename "$f" .oblg)"
      run "${s}_primary_2048" "$f" --size 2048x2048 --repeat 3
    done
  fi
fi
for j in "$OUT"/*_primary_*.json "$OUT"/*_path_*.json; do
  [ -f "$j" ] || continue
  echo "$(basename "$j" .json): $(field "$j" rays_per_repeat) rays, GPU $(field "$j" gpu_seconds_median) s," \
       "$(field "$j" gpu_median) Mrays/s (GPU), $(field "$j" wall_median) Mrays/s (wall), checksum $(field "$j" hit_checksum)" |
    tee -a "$summary"
done

# table.md: per scene, the canonical traversal and tfdm side by side.
ms() { local v; v="$(field "$1" gpu_seconds_median)"; [ -n "$v" ] && awk -v v="$v" 'BEGIN {printf "%.2f", v * 1000}' || echo "–"; }
mr() { local v; v="$(field "$1" gpu_median)"; [ -n "$v" ] && awk -v v="$v" 'BEGIN {printf "%.3g", v}' || echo "–"; }
mib() { [ -n "$1" ] && awk -v v="$1" 'BEGIN {printf "%.1f", v / 1048576}' || echo "–"; }
ratio() { [ -n "$1" ] && [ -n "$2" ] && [ "$1" != "–" ] && [ "$2" != "–" ] && awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2f", b / a}' || echo "–"; }
{
  any="$(ls "$OUT"/*_parity.json 2>/dev/null | head -1)"
  echo "GPU: $(field "$any" name), driver $(field "$any" driver)"
  echo "Times: GPU timestamps, median of the repeats; ${SIZE}x${SIZE} camera rays (primary) or paths (path, up to 5 vertices)."
  echo
  echo "| scene | method | primary ms | primary Mrays/s | path ms | path Mrays/s | structure MiB | total MiB | speed-up over tfdm (primary / path) | parity |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  for f in $files; do
    s="$(basename "$f" .oblg)"
    case "$s" in *-tfdm) continue ;; esac
    for m in "$s" "$s-tfdm"; do
      p="$OUT/${m}_primary_$SIZE.json"; q="$OUT/${m}_path_$SIZE.json"; par="$OUT/${m}_parity.json"
      [ -f "$par" ] || [ -f "$p" ] || continue
      src="$p"; [ -f "$src" ] || src="$par"
      struct="$(field "$src" vulkan/rmip_layers)"; [ -n "$struct" ] || struct="$(field "$src" vulkan/tfdm_mipmap)"
      v=$(grep -m1 -F "$m parity" "$summary" | awk '{print $NF}')
      if [ "$m" = "$s" ]; then
        rp="$(ratio "$(ms "$p")" "$(ms "$OUT/${s}-tfdm_primary_$SIZE.json")") / $(ratio "$(ms "$q")" "$(ms "$OUT/${s}-tfdm_path_$SIZE.json")")"
        echo "| $s | canonical | $(ms "$p") | $(mr "$p") | $(ms "$q") | $(mr "$q") | $(mib "$struct") | $(mib "$(field "$src" memory_total)") | $rp | $v |"
      else
        echo "| $s | tfdm | $(ms "$p") | $(mr "$p") | $(ms "$q") | $(mr "$q") | $(mib "$struct") | $(mib "$(field "$src" memory_total)") | 1 | $v |"
      fi
    done
  done
  echo
  echo "Pipelines (the driver's statistics, pipelines.txt; the baseline commit's shaders: pipelines_baseline.txt):"
  echo
  for t in "$OUT"/pipelines.txt "$OUT"/pipelines_baseline.txt; do
    [ -f "$t" ] && sed 's/^/    /' "$t"
  done
} >"$OUT/table.md"
cat "$OUT/table.md"
rm -rf "$OUT/.scenes"
echo "run.sh: done in $(( $(date +%s) - T0 )) s; results in $OUT"
exit $status
RUN
chmod +x "$BUNDLE/run.sh"
size=$(used)
say "$BUNDLE: $(( size >> 20 )) MiB ($size bytes): $(ls "$BUNDLE/scenes" | tr '\n' ' ')"
[ "$size" -le "$budget" ] || { echo "gpu_bundle: the bundle exceeds $BUDGET_MIB MiB" >&2; exit 1; }
