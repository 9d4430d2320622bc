#!/usr/bin/env bash
# Collects what a GPU machine needs to measure the Vulkan path, and nothing it cannot
# run: oblong_vkbench (Vulkan loader and C/C++ runtime only), its SPIR-V, the Vulkan
# loader as a fallback, baked scenes (oblong bake) up to a size budget, the CPU's hit
# checksums and Mrays/s for the same rays on this machine, and run.sh, which runs the
# whole measurement in at most 8 minutes and writes into one folder given as its
# argument. docs/vulkan.md ("On a GPU") says how to use it.
#
#   scripts/gpu_bundle.sh [BUNDLE_DIR (default build/gpu_bundle)] [BUILD_DIR (default build)]
#   BUNDLE_DIR/run.sh RESULTS_DIR                                     (on the GPU machine)
#
# Environment: OBLONG_BUNDLE_MIB (size budget, default 60), OBLONG_PARITY_SIZE (the
# camera rays whose hits the GPU must reproduce, default 320x240).
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
# The loader, for machines without one (run.sh uses it only when none is found).
loader="$(ldd "$VK" | awk '/libvulkan.so.1/ {print $3}')"
[ -n "$loader" ] && cp -L "$loader" "$BUNDLE/lib/libvulkan.so.1"
# This machine's glibc (~3 MiB), for a GPU machine whose glibc is older than the one
# oblong_vkbench was linked against (run.sh starts it through this ld.so only then).
mkdir -p "$BUNDLE/lib/glibc"
for l in ld-linux-x86-64.so.2 libc.so.6 libm.so.6 libpthread.so.0 libdl.so.2 librt.so.1; do
  cp -L "/lib/x86_64-linux-gnu/$l" "$BUNDLE/lib/glibc/"
done
budget=$(( BUDGET_MIB * 1024 * 1024 ))
used() { du -sb "$BUNDLE" | cut -f1; }

# In order of priority; a scene that would exceed the budget (or whose data is not set
# up) is left out with a line saying so.
ref="$BUNDLE/cpu_reference.tsv"
printf 'scene\trays\thits\tchecksum\tcpu_mrays_per_second\tcpu_threads\n' >"$ref"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for s in asteroid terrain quad_tiled paper/alien_sphere paper/terracotta_roof paper/desert_tire paper/diving_helmet \
         paper/creature; do
  name="$(basename "$s")"
  out="$BUNDLE/scenes/$name.oblg"
  if ! "$OBLONG" bake "$ROOT/scenes/$s.json" -o "$out" >"$tmp/bake.txt" 2>&1; then
    say "$name: left out: $(tail -1 "$tmp/bake.txt")"
    rm -f "$out"
    continue
  fi
  if [ "$(used)" -gt "$budget" ]; then
    say "$name: left out: $(( $(stat -c %s "$out") >> 20 )) MiB would take the bundle past $BUDGET_MIB MiB"
    rm -f "$out"
    continue
  fi
  # The CPU's answer for the parity rays (the camera's at $PARITY), and its speed here.
  "$VK" "$out" --size "$PARITY" --rays-out "$tmp/rays.bin" --no-trace
  "$OBLONG" trace "$ROOT/scenes/$s.json" --rays "$tmp/rays.bin" -o "$tmp/hits.csv" --stats "$tmp/stats.json" >/dev/null
  sum="$("$VK" --checksum "$tmp/hits.csv")"
  read -r rays hits mrays threads < <(python3 -c 'import json,sys; j=json.load(open(sys.argv[1]))
print(j["rays"]["count"], j["rays"]["hits"], j["mrays_per_second"], j.get("run", {}).get("threads", ""))' "$tmp/stats.json")
  printf '%s\t%s\t%s\t%s\t%.3f\t%s\n' "$name" "$rays" "$hits" "$sum" "$mrays" "$threads" >>"$ref"
  say "$name: $(( $(stat -c %s "$out") >> 20 )) MiB, CPU: $rays rays, $hits hits, checksum $sum, $mrays Mrays/s"
done
echo "$PARITY" >"$BUNDLE/parity_size.txt"
git -C "$ROOT" describe --always --dirty >"$BUNDLE/version.txt" 2>/dev/null || true

cat >"$BUNDLE/run.sh" <<'RUN'
#!/usr/bin/env bash
# The GPU measurement (written by scripts/gpu_bundle.sh; docs/vulkan.md "On a GPU"):
# per baked scene, the parity rays (hit checksum against the CPU's, cpu_reference.tsv),
# then primary rays (1024^2, then 2048^2 when time allows) and the path integrator,
# each timed per pass by timestamp queries. Everything lands in RESULTS_DIR; the whole
# run stays under OBLONG_RUN_SECONDS (default 450: 7.5 minutes).
#   run.sh RESULTS_DIR
set -u
HERE="$(cd "$(dirname "$0")" && pwd)"
OUT="${1:?usage: run.sh RESULTS_DIR}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
exec > >(tee "$OUT/run.log") 2>&1
T0=$(date +%s)
END=$(( T0 + ${OBLONG_RUN_SECONDS:-450} ))
left() { echo $(( END - $(date +%s) )); }
VK=("$HERE/bin/oblong_vkbench")
CAP="${OBLONG_RUN_CAP:-120}"  # seconds for one oblong_vkbench run at most
PARITY="$(cat "$HERE/parity_size.txt")"

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
field() { sed -n "s/.*\"$2\": \"\{0,1\}\([^\",]*\)\"\{0,1\},\{0,1\}$/\1/p" "$1" | head -1; }

summary="$OUT/summary.txt"
: >"$summary"
scenes=$(ls "$HERE"/scenes/*.oblg)
for f in $scenes; do  # parity first: the checksums are the point
  s="$(basename "$f" .oblg)"
  if ! run "${s}_parity" "$f" --size "$PARITY" --repeat 1; then
    echo "$s parity $PARITY: not measured (see run.log)" | tee -a "$summary"
    continue
  fi
  got="$(field "$OUT/${s}_parity.json" hit_checksum)"
  want="$(awk -v s="$s" '$1 == s {print $4}' "$HERE/cpu_reference.tsv")"
  [ "$got" = "$want" ] && verdict=SAME || verdict=DIFFERENT
  echo "$s parity $PARITY: GPU checksum $got, CPU $want: $verdict" | tee -a "$summary"
done
for f in $scenes; do
  s="$(basename "$f" .oblg)"
  t=$(date +%s)
  run "${s}_primary_1024" "$f" --size 1024x1024 --repeat 5 || continue
  # 2048^2 (the papers' primary-ray setting) when 1024^2 was quick enough.
  if [ $(( $(date +%s) - t )) -lt 20 ]; then run "${s}_primary_2048" "$f" --size 2048x2048 --repeat 5; fi
done
for f in $scenes; do
  s="$(basename "$f" .oblg)"
  run "${s}_path_1024" "$f" --size 1024x1024 --integrator path --repeat 3
done
for j in "$OUT"/*_primary_*.json "$OUT"/*_path_*.json; do
  [ -f "$j" ] || continue
  echo "$(basename "$j" .json): $(field "$j" rays_per_repeat) rays, GPU $(field "$j" gpu_seconds_median) s," \
       "$(field "$j" gpu_median) Mrays/s (GPU), $(field "$j" wall_median) Mrays/s (wall), checksum $(field "$j" hit_checksum)" |
    tee -a "$summary"
done
echo "run.sh: done in $(( $(date +%s) - T0 )) s; results in $OUT"
RUN
chmod +x "$BUNDLE/run.sh"
size=$(used)
say "$BUNDLE: $(( size >> 20 )) MiB ($size bytes): $(ls "$BUNDLE/scenes" | tr '\n' ' ')"
[ "$size" -le "$budget" ] || { echo "gpu_bundle: the bundle exceeds $BUDGET_MIB MiB" >&2; exit 1; }
