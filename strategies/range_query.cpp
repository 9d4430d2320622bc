// RangeQuery registry access, brute-force oracle and QueryNeeds (see range_query.h and
// docs/range_query.md). The strategies register themselves (core/registry.h).
#include "strategies/range_query.h"

#include "core/error.h"
#include "core/lod.h"
#include "strategies/quantize.h"

#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <new>

namespace oblong {

std::unique_ptr<RangeQuery> createRangeQuery(const std::string& name, ParamSet& params,
                                             const RangeQueryContext& ctx) {
  if (!ctx.displacement.map) fail(params.where(), "range query '{}' needs a displacement map", name);
  return RangeQueryRegistry::instance().create(name, params, ctx);
}

std::vector<std::string> rangeQueryNames() { return RangeQueryRegistry::instance().names(); }
const StrategyTraits& rangeQueryTraits(const std::string& name) { return RangeQueryRegistry::instance().traits(name); }

nlohmann::json RangeQuery::describe() const {
  nlohmann::json j = {{"name", std::string(name())},
                      {"exact", exact()},
                      {"bytes", bytes()},
                      {"needs", {{"max_extent", {needs_.maxExtentX, needs_.maxExtentY}}, {"wrap", needs_.wrap}}}};
  const nlohmann::json layout = describeLayout();
  if (!layout.empty()) j["layout"] = layout;
  return j;
}

Interval bruteForceRange(const HeightMap& m, const SampleRange& r) {
  const AxisPieces px = splitAxis(r.x0, r.x1, m.width()), py = splitAxis(r.y0, r.y1, m.height());
  Interval out;
  for (int a = 0; a < py.count; ++a)
    for (int j = py.lo[a]; j <= py.hi[a]; ++j)
      for (int b = 0; b < px.count; ++b)
        for (int i = px.lo[b]; i <= px.hi[b]; ++i) out.extend(m.atUnchecked(i, j));
  return out;
}

void* allocateLarge(size_t bytes) {
  constexpr size_t kHuge = size_t(2) << 20;
  if (bytes < 2 * kHuge) {  // on a cache line: rmip's 4 x 4 tiles are one line each
    if (void* p = std::aligned_alloc(64, std::max<size_t>((bytes + 63) / 64 * 64, 64))) return p;
    throw std::bad_alloc();
  }
  const size_t rounded = (bytes + kHuge - 1) / kHuge * kHuge;
  void* p = std::aligned_alloc(kHuge, rounded);
  if (!p) throw std::bad_alloc();
  madvise(p, rounded, MADV_HUGEPAGE);  // advice only: no error if the kernel declines
  return p;
}
void deallocateLarge(void* p, size_t) { std::free(p); }

bool keepsQuantizer(const HeightMap& m, const SampleRange& changed, const Quantizer16& q, Interval& requested) {
  const Interval edited = bruteForceRange(m, changed);
  if (!requested.isEmpty()) {
    if (q.covers(edited)) return true;
    requested = {};
    return false;
  }
  const Quantizer16 unit = Quantizer16::over({0.0f, 1.0f});
  if (q.base == unit.base && q.step == unit.step && edited.lo >= 0.0f && edited.hi <= 1.0f) return true;
  const Quantizer16 fresh = Quantizer16::over(Quantizer16::rangeFor(m.range()));
  return fresh.base == q.base && fresh.step == q.step;
}

SampleRange RangeQuery::snapAtLod(const Rect& uv, float lod) const {
  if (!(lod >= 0.0f) || !std::isfinite(lod))
    fail(std::string(name()), "level of detail must be a finite number >= 0, got {}", lod);
  if (disp_.level0)
    fail(std::string(name()), "built on {} (already at level of detail {}): level of detail {} asked of it",
         map().name(), disp_.lod, lod);
  const float l = std::min(lod, float(lodLevels(map())));
  const int k = int(std::floor(l)), top = l > float(k) ? k + 1 : k;
  const double step = std::ldexp(1.0, top), support = step - 1.0;
  const dvec2 a = disp_.toSample(uv.lo), b = disp_.toSample(uv.hi);
  // The same margin as snap, in level-0 samples; clamped in double so that no tiling
  // overflows int (an extent beyond the map means "whole axis" to every strategy).
  constexpr double eps = 1e-5, lim = 1e9;
  auto lo = [&](double v) { return int(std::clamp(std::floor((v - eps) / step) * step - support, -lim, lim)); };
  auto hi = [&](double v) { return int(std::clamp(std::ceil((v + eps) / step) * step + support, -lim, lim)); };
  return {lo(a.x), lo(a.y), hi(b.x), hi(b.y)};
}

QueryNeeds QueryNeeds::forRects(const Displacement& d, const std::vector<Rect>& uvBoxes) {
  QueryNeeds n;
  const int W = d.map->width(), H = d.map->height();
  // Same snap as RangeQuery::snap; clamped in double first so huge tilings cannot
  // overflow int (an extent beyond W+1 means "whole axis" to every strategy anyway).
  constexpr double eps = 1e-5, lim = 1e9;
  auto lo = [&](double v) { return int(std::clamp(std::floor(v - eps), -lim, lim)); };
  auto hi = [&](double v) { return int(std::clamp(std::ceil(v + eps), -lim, lim)); };
  for (const Rect& r : uvBoxes) {
    if (r.isEmpty()) continue;
    const dvec2 a = d.toSample(r.lo), b = d.toSample(r.hi);
    const int x0 = lo(a.x), y0 = lo(a.y), x1 = hi(b.x), y1 = hi(b.y);
    n.maxExtentX = std::max(n.maxExtentX, int(std::min<int64_t>(int64_t(x1) - x0 + 1, W + 1)));
    n.maxExtentY = std::max(n.maxExtentY, int(std::min<int64_t>(int64_t(y1) - y0 + 1, H + 1)));
    if (x0 < 0 || y0 < 0 || x1 > W - 1 || y1 > H - 1) n.wrap = true;
  }
  return n;
}

}  // namespace oblong
