// The RMIP layers (strategies/rmip.h) laid out for the GPU: one flat array of (min, max)
// entries and a layer table, exactly as Rmip stores them (same build, same compressed
// corner blocks), so that the shader's query returns the CPU's interval bit for bit.
// Rmip keeps its storage private, so the layout is rebuilt here with the same algorithm
// (strategies/rmip.cpp) and checked against Rmip::rawRange by tests/vulkan_test.cpp.
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "strategies/range_query.h"

#include <vector>

namespace oblong::vk {

struct RmipLayout {
  int f = 1, rw = 0, rh = 0, P = 0, Q = 0;  // downsample, pixels, top layer indices
  bool wrap = false;
  std::vector<glm::vec2> data;      // (lo, hi) raw texels
  std::vector<glm::ivec4> layers;   // (offset, nx, shiftX, shiftY), index p * (Q + 1) + q

  // resolution / compression: Rmip::Options (the scene's rmip parameters).
  static RmipLayout build(const HeightMap& m, const QueryNeeds& needs, int resolution, int compression);
  // The shader's query (render/vulkan/shaders/traversal.glsl rmipRawRange) on the host.
  Interval rawRange(const HeightMap& m, const SampleRange& r) const;
  size_t bytes() const { return data.size() * sizeof(glm::vec2) + layers.size() * sizeof(glm::ivec4); }
};

}  // namespace oblong::vk
