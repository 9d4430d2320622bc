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
  glmark2-data python3-matplotlib python3-numpy
  clang libclang-rt-14-dev
)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Debian's OpenImageIO CMake config lists /usr/include/opencv4 as an include
# directory; CMake's generate step fails when it does not exist.
$SUDO mkdir -p /usr/include/opencv4
