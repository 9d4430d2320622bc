// safety_zones: dilation (max) and erosion (min) maps of the displacement map for a
// few box half-widths delta (Kolb & Rezk-Salama, "Efficient empty space skipping for
// per-pixel displacement mapping", §3.2 "Safety zones based on filtered displacement
// maps"; §3.4 uses several box sizes). Entry (i,j) of the maps for
// delta d is the min/max over samples [i-d, i+d] x [j-d, j+d] (wrap addressing). A
// range is answered at its centre sample with the smallest delta whose box covers it;
// when none does, with the whole map's min/max.
//
// Parameters (ParamSet):
//   deltas  list of ints >= 0, default [1, 2, 4, ...] up to the smallest delta whose
//           box covers QueryNeeds' largest extent (boxes covering the whole map are
//           not stored: the global min/max answers them).
#pragma once

#include "core/stats.h"
#include "strategies/range_query.h"

namespace oblong {

OBLONG_STAT_COUNTER("safety_zones/Queries", szQueries);
OBLONG_STAT_COUNTER("safety_zones/GlobalFallbacks", szGlobal);

class SafetyZones final : public RangeQueryImpl<SafetyZones> {
 public:
  // The deltas the constructor builds (empty: the default set for `needs`), sorted,
  // without repeats; the one copy of that rule.
  static std::vector<int> resolveDeltas(int W, int H, const QueryNeeds& needs, std::vector<int> deltas);
  // bytes(): equals the built structure's bytes() for resolved deltas; buildBytes() adds
  // the W x H scratch plane of the row pass.
  static size_t bytes(int W, int H, size_t deltas) {
    return deltas * size_t(W) * H * sizeof(Interval) + deltas * sizeof(int);
  }
  static size_t buildBytes(int W, int H, size_t deltas) {
    return bytes(W, H, deltas) + (deltas ? size_t(W) * H * sizeof(Interval) : 0);
  }

  // Empty deltas: the default set for `needs`.
  SafetyZones(const Displacement& d, const QueryNeeds& needs, std::vector<int> deltas);

  std::string_view name() const override { return "safety_zones"; }
  size_t bytes() const override { return data_.size() * sizeof(Interval) + deltas_.size() * sizeof(int); }
  MemoryReport memory() const override {
    return {{"safety_zones/zones", data_.size() * sizeof(Interval)},
            {"safety_zones/deltas", deltas_.size() * sizeof(int)}};
  }
  bool exact() const override { return false; }
  const std::vector<int>& deltas() const { return deltas_; }

  Interval rawRangeFast(const SampleRange& r) const {
    OBLONG_STAT_INC(szQueries);
    const int W = map().width(), H = map().height();
    int x0, x1, y0, y1;
    wrapAxis(r.x0, r.x1, W, x0, x1);
    wrapAxis(r.y0, r.y1, H, y0, y1);
    const int cx = (x0 + x1) >> 1, cy = (y0 + y1) >> 1;  // non-negative: plain halving
    const int need = std::max(x1 - cx, y1 - cy);          // box [c-d, c+d] covers the range
    for (size_t k = 0; k < deltas_.size(); ++k)
      if (deltas_[k] >= need)
        return data_[k * size_t(W) * H + size_t(cy >= H ? cy - H : cy) * W + (cx >= W ? cx - W : cx)];
    OBLONG_STAT_INC(szGlobal);
    return global_;
  }

 protected:
  nlohmann::json describeLayout() const override {
    return {{"deltas", deltas_}, {"zone_bytes", size_t(map().width()) * map().height() * sizeof(Interval)},
            {"stores_wrap", false}};
  }

 private:
  std::vector<int> deltas_;      // ascending
  std::vector<Interval> data_;   // one W x H (erosion, dilation) map per delta
  Interval global_;
};

}  // namespace oblong
