// RMIP layers for the GPU: the build of strategies/rmip.cpp (Rmip::Rmip), kept in step
// with it by tests/vulkan_test.cpp ("rmip layout equals Rmip"), and the query of
// Rmip::rawRange as the shader runs it.
#include "render/vulkan/rmip_layout.h"

#include "core/error.h"
#include "strategies/rmip.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>

namespace oblong::vk {

namespace {

Interval join(const Interval& a, const Interval& b) { return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)}; }

int entries(int n, int p, int shift, bool wrap) {
  const int s = 1 << shift;
  return wrap ? (n + s - 1) / s : (n - (1 << p)) / s + 1;
}

int log2floor(int v) { return int(std::bit_width(unsigned(v))) - 1; }

template <typename F>
void parallelRows(int n, F&& f) {
  tbb::parallel_for(0, n, [&](int i) { f(i); });
}

}  // namespace

RmipLayout RmipLayout::build(const HeightMap& m, const QueryNeeds& needs, int resolution, int compression) {
  Rmip::Options opts;
  opts.resolution = resolution;
  opts.compression = compression;
  Rmip::checkMemory(m, needs, opts);  // the same layers and scratch as the CPU build
  RmipLayout L;
  const int W = m.width(), H = m.height();
  const int f = resolution <= 0 ? 1 : std::max(1, (std::max(W, H) + resolution - 1) / resolution);
  L.f = f;
  L.rw = (W + f - 1) / f;
  L.rh = (H + f - 1) / f;
  L.wrap = needs.wrap;
  const int c = compression, rw = L.rw, rh = L.rh;
  auto pixExtent = [&](int e, int n) {
    e = std::max(e, 1);
    const int px = f == 1 ? e : (e - 1 + f - 1) / f + 2;
    return std::min(px, n);
  };
  L.P = log2floor(pixExtent(needs.maxExtentX, rw));
  L.Q = log2floor(pixExtent(needs.maxExtentY, rh));
  const int P = L.P, Q = L.Q;
  L.layers.resize(size_t(P + 1) * (Q + 1));
  size_t total = 0;
  for (int p = 0; p <= P; ++p)
    for (int q = 0; q <= Q; ++q) {
      glm::ivec4& e = L.layers[size_t(p) * (Q + 1) + q];
      const int sx = std::max(p - c, 0), sy = std::max(q - c, 0);
      e = glm::ivec4(int(total), entries(rw, p, sx, L.wrap), sx, sy);
      total += size_t(e.y) * entries(rh, q, sy, L.wrap);
    }
  if (total > size_t(INT32_MAX)) fail(m.name(), "vulkan: rmip: {} entries exceed the 32-bit layer offsets", total);
  std::vector<Interval> out(total);

  std::vector<Interval> rowR(size_t(rw) * rh), rowNext(rowR.size());
  parallelRows(rh, [&](int j) {
    for (int i = 0; i < rw; ++i) {
      Interval v;
      for (int y = j * f; y < std::min((j + 1) * f, H); ++y)
        for (int x = i * f; x < std::min((i + 1) * f, W); ++x) v.extend(m.atUnchecked(x, y));
      rowR[size_t(j) * rw + i] = v;
    }
  });
  std::vector<Interval> colR, colNext;
  for (int p = 0; p <= P; ++p) {
    if (p > 0) {
      const int h = 1 << (p - 1);
      parallelRows(rh, [&](int j) {
        const Interval* a = rowR.data() + size_t(j) * rw;
        Interval* o = rowNext.data() + size_t(j) * rw;
        for (int x = 0; x < rw; ++x) o[x] = join(a[x], a[x + h < rw ? x + h : x + h - rw]);
      });
      std::swap(rowR, rowNext);
    }
    const int sx = std::max(p - c, 0), nx = entries(rw, p, sx, L.wrap);
    const int lastCorner = L.wrap ? rw - 1 : rw - (1 << p);
    colR.resize(size_t(nx) * rh);
    colNext.resize(colR.size());
    parallelRows(rh, [&](int j) {
      const Interval* a = rowR.data() + size_t(j) * rw;
      for (int i = 0; i < nx; ++i) {
        const int c0 = i << sx, c1 = std::min(c0 + (1 << sx) - 1, lastCorner);
        colR[size_t(i) * rh + j] = join(a[c0], a[c1]);
      }
    });
    for (int q = 0; q <= Q; ++q) {
      if (q > 0) {
        const int h = 1 << (q - 1);
        parallelRows(nx, [&](int i) {
          const Interval* a = colR.data() + size_t(i) * rh;
          Interval* o = colNext.data() + size_t(i) * rh;
          for (int y = 0; y < rh; ++y) o[y] = join(a[y], a[y + h < rh ? y + h : y + h - rh]);
        });
        std::swap(colR, colNext);
      }
      const glm::ivec4 e = L.layers[size_t(p) * (Q + 1) + q];
      const int ny = entries(rh, q, e.w, L.wrap);
      const int lastY = L.wrap ? rh - 1 : rh - (1 << q);
      parallelRows(ny, [&](int jj) {
        const int c0 = jj << e.w, c1 = std::min(c0 + (1 << e.w) - 1, lastY);
        Interval* o = out.data() + e.x + size_t(jj) * e.y;
        for (int i = 0; i < e.y; ++i) o[i] = join(colR[size_t(i) * rh + c0], colR[size_t(i) * rh + c1]);
      });
    }
  }
  L.data.resize(total);
  for (size_t i = 0; i < total; ++i) L.data[i] = glm::vec2(out[i].lo, out[i].hi);
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
