// RMIP layers for the GPU: a copy of the built Rmip's entries and layer table (the CPU
// traversal's own range query, so there is one build), and the query kernel
// (core/kernels/rmip_query.h) over them as the shader reads them (checked against Rmip by
// tests/vulkan_test.cpp).
#include "render/vulkan/rmip_layout.h"

#include "core/error.h"
#include "core/kernels/rmip_query.h"
#include "strategies/rmip.h"

#include <algorithm>
#include <bit>
#include <cstdint>

namespace oblong::vk {

namespace {

// The shader's storage (traversal.glsl rmipLayer / rmipJoin) for the query kernel: each
// entry decoded (the CPU joins codes and decodes once; the decode is monotone, so both
// give the same interval).
struct LayoutAccess {
  const RmipLayout* L;
};
shared::RmipLayerRef rmipLayer(const LayoutAccess& a, int index) {
  const glm::ivec4& l = a.L->layers[size_t(index)];
  return {uint32_t(l.x), l.y, l.z, l.w};
}
void rmipJoin(const LayoutAccess& a, uint32_t idx, Interval& acc) {
  const RmipLayout& L = *a.L;
  if (L.bits == 16) {
    const uint32_t w = L.words[idx];
    acc.extend(Interval{L.q.decode(w & 0xffffu), L.q.decode(w >> 16)});
  } else {
    acc.extend(Interval{std::bit_cast<float>(L.words[2 * size_t(idx)]), std::bit_cast<float>(L.words[2 * size_t(idx) + 1])});
  }
}

}  // namespace

RmipLayout RmipLayout::of(const Rmip& rmip) {
  RmipLayout L;
  L.f = rmip.downsample();
  L.rw = rmip.resolutionX();
  L.rh = rmip.resolutionY();
  L.P = rmip.layersX() - 1;
  L.Q = rmip.layersY() - 1;
  L.wrap = rmip.storesWrap();
  L.p0 = rmip.firstLayer();
  L.bits = rmip.bits();
  L.q = rmip.quantizer();
  const std::vector<Rmip::Layer>& table = rmip.layerTable();
  if (table.size() != size_t(L.P + 1) * size_t(L.Q + 1))
    fail("--device vulkan", "internal: rmip layer table has {} layers, expected {}x{}", table.size(), L.P + 1, L.Q + 1);
  if (rmip.wordCount() > size_t(INT32_MAX))
    fail("--device vulkan", "rmip: {} words exceed the 32-bit offsets of the GPU layout", rmip.wordCount());
  L.layers.reserve(table.size());
  for (const Rmip::Layer& l : table) L.layers.emplace_back(int(l.offset), l.nx, l.shiftX, l.shiftY);
  L.words = rmip.words();
  return L;
}

Interval RmipLayout::rawRange(const HeightMap& m, const SampleRange& r) const {
  const shared::RmipGeom g{f, m.width(), m.height(), rw, rh, P, Q, p0, wrap};
  Interval out;
  shared::rmipRange(LayoutAccess{this}, g, r.x0, r.y0, r.x1, r.y1, out);
  return out;
}

}  // namespace oblong::vk
