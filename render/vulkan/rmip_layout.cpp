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
  auto toPixels = [&](int a0, int a1, int size, int n, int& s, int& e) {
    wrapAxis(a0, a1, size, s, e);
    if (f == 1) return;
    e = e < size ? e / f : n + (e - size) / f;
    s /= f;
    if (e - s + 1 >= n) s = 0, e = n - 1;
  };
  // traversal.glsl rmipEntry: decodes each entry (the CPU joins codes and decodes once;
  // the decode is monotone, so both give the same interval).
  auto entry = [&](size_t idx) {
    if (bits == 16) {
      const uint32_t w = words[idx];
      return Interval{q.decode(w & 0xffffu), q.decode(w >> 16)};
    }
    return Interval{std::bit_cast<float>(words[2 * idx]), std::bit_cast<float>(words[2 * idx + 1])};
  };
  auto block = [&](int x0, int x1, int y0, int y1) {
    const int p = std::clamp(log2floor(x1 - x0 + 1), p0, P), q = std::clamp(log2floor(y1 - y0 + 1), p0, Q);
    const glm::ivec4 L = layers[size_t(p) * (Q + 1) + q];
    const int lx = 1 << p, ly = 1 << q;
    Interval out;
    for (int cy = y0;; cy += ly) {
      const bool lastY = cy + ly - 1 >= y1;
      if (lastY) cy = std::max(y1 - ly + 1, y0);
      const size_t row = size_t((cy >= rh ? cy - rh : cy) >> L.w) * L.y;
      for (int cx = x0;; cx += lx) {
        const bool lastX = cx + lx - 1 >= x1;
        if (lastX) cx = std::max(x1 - lx + 1, x0);
        out.extend(entry(L.x + row + ((cx >= rw ? cx - rw : cx) >> L.z)));
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
