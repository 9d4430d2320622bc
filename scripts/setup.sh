#!/usr/bin/env bash
# Installs every dependency of oblong from Debian bookworm (run as root).
# Idempotent: re-running only installs what is missing.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

PKGS=(
  build-essential cmake ninja-build pkg-config
  libglm-dev libembree-dev libopenimageio-dev openimageio-tools libceres-dev
  catch2 libfmt-dev libassimp-dev nlohmann-json3-dev libcli11-dev libtbb-dev
  libbenchmark-dev
  glmark2-data python3-matplotlib python-matplotlib-data python3-numpy
  clang libclang-rt-14-dev
)

# Vulkan ray tracing path (render/vulkan/, issue 7): headers, loader, glslc and
# spirv-val from bookworm; Mesa's lavapipe (CPU Vulkan with VK_KHR_ray_tracing_pipeline,
# Mesa >= 24.1) only from bookworm-backports, so the suite is added and the driver is
# pinned to it below.
PKGS+=(libvulkan-dev glslc spirv-tools vulkan-tools)
BACKPORTS=/etc/apt/sources.list.d/bookworm-backports.list
if [ ! -s "$BACKPORTS" ]; then
  echo "deb http://deb.debian.org/debian bookworm-backports main" | $SUDO tee "$BACKPORTS" >/dev/null
  $SUDO apt-get update -q
fi

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# lavapipe from backports (the bookworm one is Mesa 22.3: no ray tracing). Re-run only
# when the installed driver did not come from backports.
if ! dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | grep -q 'bpo'; then
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends -t bookworm-backports mesa-vulkan-drivers
fi

# Debian's OpenImageIO CMake config lists /usr/include/opencv4 as an include
# directory; CMake's generate step fails when it does not exist.
$SUDO mkdir -p /usr/include/opencv4

# Scene data converted at set-up time (scenes/README.md): the Jacksboro fault DEM from
# python-matplotlib-data -> scenes/data/jacksboro_fault_dem.png (git-ignored) for
# scenes/terrain.json. Debian's /usr/bin/python3 has numpy; a `python3` found earlier
# on PATH may be another interpreter without it.
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
DEM="$(dpkg -L python-matplotlib-data | grep '/jacksboro_fault_dem\.npz$' | head -n 1)"
TERRAIN="$ROOT/scenes/data/jacksboro_fault_dem.png"
if [ -z "$DEM" ]; then
  echo "setup.sh: jacksboro_fault_dem.npz not found in python-matplotlib-data" >&2
  exit 1
fi
if [ ! -s "$TERRAIN" ] || [ "$TERRAIN" -ot "$ROOT/scenes/tools/make_terrain.py" ] || [ "$TERRAIN" -ot "$DEM" ]; then
  /usr/bin/python3 "$ROOT/scenes/tools/make_terrain.py" "$DEM" "$TERRAIN"
fi
