// RMIP layers for the GPU: a copy of the built Rmip's entries and layer table (the CPU
// traversal's own range query, so there is one build), and the query of Rmip::rawRange
// as the shader runs it (checked against Rmip by tests/vulkan_test.cpp).
#include "render/vulkan/rmip_layout.h"

#include "core/error.h"
#include "strategies/rmip.h"

#include <algorithm>
#include <bit>
#include <cstdint>

namespace oblong::vk {

namespace {

int log2floor(int v) { return int(std::bit_width(unsigned(v))) - 1; }

}  // namespace

RmipLayout RmipLayout::of(const Rmip& rmip) {
  RmipLayout L;
  L.f = rmip.downsample();
  L.rw = rmip.resolutionX();
  L.rh = rmip.resolutionY();
  L.P = rmip.layersX() - 1;
  L.Q = rmip.layersY() - 1;
  L.wrap = rmip.storesWrap();
  const std::vector<Rmip::Layer>& table = rmip.layerTable();
  if (table.size() != size_t(L.P + 1) * size_t(L.Q + 1))
    fail("--device vulkan", "internal: rmip layer table has {} layers, expected {}x{}", table.size(), L.P + 1, L.Q + 1);
  const std::vector<Interval>& entries = rmip.layerEntries();
  if (entries.size() > size_t(INT32_MAX))
    fail("--device vulkan", "rmip: {} entries exceed the 32-bit layer offsets of the GPU layout", entries.size());
  L.layers.reserve(table.size());
  for (const Rmip::Layer& l : table) L.layers.emplace_back(int(l.offset), l.nx, l.shiftX, l.shiftY);
  L.data.reserve(entries.size());
  for (const Interval& e : entries) L.data.emplace_back(e.lo, e.hi);
  return L;
}

Interval RmipLayout::rawRange(const HeightMap& m, const SampleRange& r) const {
  auto toPixels = [&](int a0, int a1, int size, int n, int& s, int& e) {
    wrapAxis(a0, a1, size, s, e);
    if (f == 1) return;
    e = e < size ? e / f : n + (e - size) / f;
    s /= f;
    if (e - s + 1 >= n) s = 0, e = n - 1;
  };
  auto block = [&](int x0, int x1, int y0, int y1) {
    const int p = std::min(log2floor(x1 - x0 + 1), P), q = std::min(log2floor(y1 - y0 + 1), Q);
    const glm::ivec4 L = layers[size_t(p) * (Q + 1) + q];
    const int lx = 1 << p, ly = 1 << q;
    Interval out;
    for (int cy = y0;; cy += ly) {
      const bool lastY = cy + ly - 1 >= y1;
      if (lastY) cy = y1 - ly + 1;
      const size_t row = size_t((cy >= rh ? cy - rh : cy) >> L.w) * L.y;
      for (int cx = x0;; cx += lx) {
        const bool lastX = cx + lx - 1 >= x1;
        if (lastX) cx = x1 - lx + 1;
        const glm::vec2 v = data[L.x + row + ((cx >= rw ? cx - rw : cx) >> L.z)];
        out.extend(Interval{v.x, v.y});
        if (lastX) break;
      }
      if (lastY) break;
    }
    return out;
  };
  int x0, x1, y0, y1;
  toPixels(r.x0, r.x1, m.width(), rw, x0, x1);
  toPixels(r.y0, r.y1, m.height(), rh, y0, y1);
  if (wrap || (x1 < rw && y1 < rh)) return block(x0, x1, y0, y1);
  const int xa[2] = {x0, 0}, xb[2] = {std::min(x1, rw - 1), x1 - rw};
  const int ya[2] = {y0, 0}, yb[2] = {std::min(y1, rh - 1), y1 - rh};
  Interval out;
  for (int b = 0; b < (y1 < rh ? 1 : 2); ++b)
    for (int a = 0; a < (x1 < rw ? 1 : 2); ++a) out.extend(block(xa[a], xb[a], ya[b], yb[b]));
  return out;
}

}  // namespace oblong::vk
