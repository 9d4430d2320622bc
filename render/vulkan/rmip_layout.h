// The RMIP layers (strategies/rmip.h) laid out for the GPU: the built Rmip's own entries
// and layer table (Rmip::layerEntries(), Rmip::layerTable()) in the shader's formats, so the
// shader's query reads exactly the CPU's data and returns the CPU's interval bit for bit.
// RmipLayout::rawRange is the shader's lookup (the kernel core/kernels/rmip_query.h over
// these buffers, decoded per entry as traversal.glsl reads them) on the host, checked
// against Rmip's own query by tests/vulkan_test.cpp.
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "strategies/quantize.h"
#include "strategies/range_query.h"

#include <vector>

namespace oblong {
class Rmip;
}

namespace oblong::vk {

struct RmipLayout {
  int f = 1, rw = 0, rh = 0, P = 0, Q = 0, p0 = 0;  // downsample, pixels, top and first layer
  bool wrap = false;
  int bits = 16;                    // 16: one word of codes per entry; 32: lo, hi float bits
  Quantizer16 q;                    // bits 16
  std::vector<uint32_t> words;      // Rmip::words()
  std::vector<glm::ivec4> layers;   // (offset, nx, shiftX, shiftY), index p * (Q + 1) + q

  // A copy of the built Rmip's pyramid (the CPU traversal's own range query).
  static RmipLayout of(const Rmip& rmip);
  // The shader's query (render/vulkan/shaders/traversal.glsl rmipRawRange) on the host.
  Interval rawRange(const HeightMap& m, const SampleRange& r) const;
  size_t bytes() const { return words.size() * sizeof(uint32_t) + layers.size() * sizeof(glm::ivec4); }
};

}  // namespace oblong::vk
