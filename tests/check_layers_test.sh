#!/usr/bin/env bash
# scripts/check_layers.py on small trees of its own: a clean tree passes; a Vulkan file
# that includes Embree's backend (render/embree_scene.h, by root or relative path) fails,
# naming the file and the line, as does an include of a higher layer.
#   tests/check_layers_test.sh SOURCE_DIR
set -euo pipefail
src="${1:?usage: check_layers_test.sh SOURCE_DIR}"
check="$src/scripts/check_layers.py"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# A tree with one file per layer that the cases below include.
tree() {
  local root="$tmp/$1"
  mkdir -p "$root/core" "$root/render/vulkan" "$root/apps"
  echo '#pragma once' >"$root/core/math.h"
  printf '#pragma once\n#include "core/math.h"\n' >"$root/render/accel_options.h"
  printf '#pragma once\n#include "render/accel_options.h"\n' >"$root/render/embree_scene.h"
  printf '#include "render/embree_scene.h"\n' >"$root/apps/oblong.cpp"
  printf '#pragma once\n#include "render/accel_options.h"\n' >"$root/render/vulkan/commands.h"
  echo "$root"
}

# expect RC ROOT [PATTERN]: check_layers exits RC on ROOT and, given, prints PATTERN.
expect() {
  local rc=0 out
  out="$(python3 "$check" --root "$2" 2>&1)" || rc=$?
  if [[ "$rc" != "$1" ]]; then
    echo "check_layers_test: $2: exit $rc, expected $1:"; echo "$out"; exit 1
  fi
  if [[ $# -ge 3 ]] && ! grep -qE -- "$3" <<<"$out"; then
    echo "check_layers_test: $2: no line matching '$3':"; echo "$out"; exit 1
  fi
}

expect 0 "$(tree clean)"

root="$(tree vulkan_root)"
printf '#pragma once\n\n#include "render/embree_scene.h"\n' >"$root/render/vulkan/vulkan_scene.h"
expect 1 "$root" '^render/vulkan/vulkan_scene.h:3: includes render/embree_scene.h, which render/vulkan/ may not'

root="$(tree vulkan_relative)"
printf '#include "../embree_scene.h"\n' >"$root/render/vulkan/records.cpp"
expect 1 "$root" '^render/vulkan/records.cpp:1: includes render/embree_scene.h'

root="$(tree upward)"
printf '#include "apps/oblong.cpp"\n' >"$root/render/image.cpp"
expect 1 "$root" '^render/image.cpp:1: includes apps/oblong.cpp \(apps/, rank 5\), a layer above render/'

echo "check_layers_test: 4 trees as expected"
