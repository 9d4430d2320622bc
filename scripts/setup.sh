#!/usr/bin/env bash
# Installs oblong's dependencies from Debian bookworm (run as root, or with sudo).
#   bash scripts/setup.sh            # everything: the tests, benchmarks, Vulkan path, Python
#                                    # module, fuzzers, Slurm backend (scripts/test.sh, CI)
#   bash scripts/setup.sh --minimal  # only what building `oblong` and a first render need
#                                    # (scripts/demo.sh)
# Idempotent: re-running only installs what is missing; the full set after --minimal adds
# the rest.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive

minimal=0
case "${1:-}" in
  --minimal) minimal=1 ;;
  "") ;;
  *) echo "scripts/setup.sh: unknown option '$1' (--minimal, or nothing for everything)" >&2; exit 1 ;;
esac

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

# The compiler, the build tools and every library CMake requires to build the `oblong`
# program (CMakeLists.txt's find_package calls before the tests'); glmark2-data holds the
# asteroid of the README's first render (scenes/asteroid.json); fonts-dejavu-core the
# font of the numbers on heat maps' and error images' colour bars (docs/render.md).
PKGS=(
  build-essential cmake ninja-build pkg-config
  libglm-dev libembree-dev libopenimageio-dev libceres-dev
  libfmt-dev libassimp-dev nlohmann-json3-dev libcli11-dev libtbb-dev
  glmark2-data fonts-dejavu-core
)

if [ "$minimal" = 0 ]; then
  # The tests (Catch2), the benchmarks (Google Benchmark), the experiments' plots and AOV
  # reading (matplotlib, numpy, oiiotool), the generated scene data (scripts/scene_data.sh:
  # the DEM in python-matplotlib-data), and clang with its sanitizer runtimes for the
  # fuzzers (scripts/fuzz.sh).
  PKGS+=(
    catch2 libbenchmark-dev openimageio-tools
    python3-matplotlib python-matplotlib-data python3-numpy
    clang libclang-rt-14-dev
  )

  # The Python module (python/, docs/python.md) for Debian's /usr/bin/python3: pybind11
  # and the interpreter's headers; pytest runs its tests (tests/python/).
  PKGS+=(pybind11-dev python3-dev python3-pytest)

  # Vulkan ray tracing path (render/vulkan/, docs/vulkan.md): headers, loader, glslc and
  # spirv-val from bookworm; Mesa's lavapipe (CPU Vulkan with VK_KHR_ray_tracing_pipeline,
  # Mesa >= 24.1) only from bookworm-backports, so the suite is added and the driver is
  # pinned to it below.
  # xz-utils: scripts/gpu_bundle.sh compresses the baked scenes.
  PKGS+=(libvulkan-dev glslc spirv-tools vulkan-tools xz-utils)

  # experiments/run_all --backend slurm and its test (tests/slurm_test.sh), which starts a
  # single-node Slurm of its own: the controller, the node daemon, the client commands
  # (sbatch, squeue, scancel, scontrol, sacct) and MUNGE for their authentication.
  PKGS+=(slurmctld slurmd slurm-client munge)
  BACKPORTS=/etc/apt/sources.list.d/bookworm-backports.list
  if [ ! -s "$BACKPORTS" ]; then
    echo "deb http://deb.debian.org/debian bookworm-backports main" | $SUDO tee "$BACKPORTS" >/dev/null
    $SUDO apt-get update -q
  fi
fi

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

[ "$minimal" = 1 ] && exit 0

# lavapipe from backports (the bookworm one is Mesa 22.3: no ray tracing). Re-run only
# when the installed driver did not come from backports.
if ! dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | grep -q 'bpo'; then
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends -t bookworm-backports mesa-vulkan-drivers
fi

# Scene data generated from the packages above (scenes/README.md); also a build step.
bash "$(dirname "$0")/scene_data.sh"
