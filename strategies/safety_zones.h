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
//   bits    16 | 32, default 32: zones as conservative 16-bit pairs (strategies/quantize.h)
//           or float pairs.
#pragma once

#include "core/stats.h"
#include "strategies/quantize.h"
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
  static size_t bytes(int W, int H, size_t deltas, int bits = 32) {
    return deltas * size_t(W) * H * (bits == 16 ? 4 : 8) + deltas * sizeof(int);
  }
  static size_t buildBytes(int W, int H, size_t deltas, int bits = 32) {
    return bytes(W, H, deltas, bits) + (deltas ? size_t(W) * H * sizeof(Interval) : 0);
  }

  // Empty deltas: the default set for `needs`.
  SafetyZones(const Displacement& d, const QueryNeeds& needs, std::vector<int> deltas, int bits = 32,
              Interval quantRange = {});

  std::string_view name() const override { return "safety_zones"; }
  size_t bytes() const override { return zoneBytes() + deltas_.size() * sizeof(int); }
  MemoryReport memory() const override {
    return {{"safety_zones/zones", zoneBytes()}, {"safety_zones/deltas", deltas_.size() * sizeof(int)}};
  }
  bool exact() const override { return false; }
  // Recomputes the zones within delta of the changed samples (a whole plane when that
  // window covers the map) and the global range.
  void update(const SampleRange& changed) override;
  std::span<const std::byte> storage() const override {
    return bits_ == 16 ? std::as_bytes(std::span(q16_)) : std::as_bytes(std::span(data_));
  }
  int bits() const { return bits_; }
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
      if (deltas_[k] >= need) {
        const size_t at = k * size_t(W) * H + size_t(cy >= H ? cy - H : cy) * W + (cx >= W ? cx - W : cx);
        return bits_ == 16 ? q_.decodePair(q16_[at]) : data_[at];
      }
    OBLONG_STAT_INC(szGlobal);
    return global_;
  }

 protected:
  nlohmann::json describeLayout() const override {
    nlohmann::json j = {{"deltas", deltas_}, {"bits", bits_},
                        {"zone_bytes", size_t(map().width()) * map().height() * (bits_ == 16 ? 4 : 8)},
                        {"stores_wrap", false}};
    if (bits_ == 16) j["quantization"] = {{"base", q_.base}, {"step", q_.step}};
    return j;
  }

 private:
  size_t zoneBytes() const { return data_.size() * sizeof(Interval) + q16_.size() * sizeof(uint32_t); }
  void build();
  // Zones of delta k over columns [c0, c0+w) x rows [r0, r0+h) (wrapped), stored.
  void buildWindow(size_t k, int c0, int w, int r0, int h);
  void store(size_t at, const Interval& v) {
    if (bits_ == 16) q16_[at] = q_.encode(v);
    else data_[at] = v;
  }

  std::vector<int> deltas_;      // ascending
  int bits_ = 32;
  Interval quantRange_;          // requested 16-bit range (empty: derived from the map)
  Quantizer16 q_;
  std::vector<Interval> data_;   // bits 32: one W x H (erosion, dilation) map per delta
  std::vector<uint32_t> q16_;    // bits 16
  Interval global_;
};

}  // namespace oblong
