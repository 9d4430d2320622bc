// minmax_mipmap: the min-max mipmap of TFDM (Thonat et al. 2021), after Greene et al.
// and Oh et al. (pyramidal displacement mapping). Level 0 is the samples; node (i,j) of
// level k covers samples [i 2^k, (i+1) 2^k - 1] x [j 2^k, (j+1) 2^k - 1], clipped to the
// map for sizes that are not powers of two. A range is bounded by the nodes of the
// smallest level at which it spans at most two nodes per axis (up to four neighbouring
// nodes); ranges crossing the border are split into non-crossing pieces.
//
// Parameters: bits  16 | 32, default 32: levels >= 1 as conservative 16-bit pairs
// (strategies/quantize.h) or float pairs. Level 0 is the map's own floats either way.
//
// Levels are built only up to the one where two nodes cover QueryNeeds' largest extent
// (docs/design.md invariant 4); larger ranges use all the top built level's nodes they touch.
// Level 0 is read from the map itself (no copy). node()/levels() are the interface of
// the mipmap-aligned quad-tree splitter (the RMIP driver with TFDM's nodes; TFDM itself is
// the `tfdm` baseline).
#pragma once

#include "core/stats.h"
#include "strategies/quantize.h"
#include "strategies/range_query.h"

#include <bit>

namespace oblong {

OBLONG_STAT_COUNTER("minmax_mipmap/Queries", mmQueries);
OBLONG_STAT_COUNTER("minmax_mipmap/Nodes", mmNodes);

class MinMaxMipmap final : public RangeQueryImpl<MinMaxMipmap> {
 public:
  // What the constructor builds for a W x H map (the one copy of the level formulas):
  // bytes() equals the built mipmap's bytes() and is its peak (no scratch).
  struct Layout {
    int K = 0;                   // top built level
    std::vector<size_t> offset;  // offset of level k >= 1 at [k-1]
    size_t entries = 0;
    int bits = 32;
    size_t bytes() const { return entries * (bits == 16 ? 4 : 8) + offset.size() * sizeof(size_t); }
  };
  static Layout layout(int W, int H, const QueryNeeds& needs, int bits = 32);
  static int levelSize(int n, int k) { return ((n - 1) >> k) + 1; }
  // Bytes of a full 16-bit min-max mipmap of a W x H map, every level down to 1x1 with
  // level 0 stored too (4 bytes per node): the RMIP paper's Table 1 reference.
  static size_t fullBytes16(int W, int H) {
    size_t b = 0;
    for (int k = 0;; ++k) {
      b += size_t(levelSize(W, k)) * size_t(levelSize(H, k)) * 4;
      if (levelSize(W, k) == 1 && levelSize(H, k) == 1) return b;
    }
  }

  MinMaxMipmap(const Displacement& d, const QueryNeeds& needs, int bits = 32, Interval quantRange = {});

  std::string_view name() const override { return "minmax_mipmap"; }
  size_t bytes() const override { return levelBytes() + offset_.size() * sizeof(size_t); }
  MemoryReport memory() const override {
    return {{"minmax_mipmap/levels", levelBytes()}, {"minmax_mipmap/level_table", offset_.size() * sizeof(size_t)}};
  }
  bool exact() const override { return false; }
  // Recomputes the nodes over the changed samples, level by level from their children.
  void update(const SampleRange& changed) override;
  std::span<const std::byte> storage() const override {
    return bits_ == 16 ? std::as_bytes(std::span(q16_)) : std::as_bytes(std::span(data_));
  }
  int bits() const { return bits_; }

  // Levels 0..levels()-1 (level 0 = samples). Level k is levelWidth(k) x levelHeight(k).
  int levels() const { return K_ + 1; }
  int levelWidth(int k) const { return levelSize(map().width(), k); }
  int levelHeight(int k) const { return levelSize(map().height(), k); }
  // Raw min/max of node (i,j) of level k (0 <= i < levelWidth(k), 0 <= j < levelHeight(k)).
  Interval node(int k, int i, int j) const {
    if (k == 0) {
      const float t = map().atUnchecked(i, j);
      return {t, t};
    }
    const size_t at = offset_[k - 1] + size_t(j) * levelWidth(k) + i;
    return bits_ == 16 ? q_.decodePair(q16_[at]) : data_[at];
  }

  Interval rawRangeFast(const SampleRange& r) const {
    OBLONG_STAT_INC(mmQueries);
    const AxisPieces px = splitAxis(r.x0, r.x1, map().width()), py = splitAxis(r.y0, r.y1, map().height());
    Interval out;
    for (int b = 0; b < py.count; ++b)
      for (int a = 0; a < px.count; ++a) out.extend(piece(px.lo[a], px.hi[a], py.lo[b], py.hi[b]));
    return out;
  }

 protected:
  nlohmann::json describeLayout() const override {
    nlohmann::json sizes = nlohmann::json::array();
    for (int k = 1; k <= K_; ++k) sizes.push_back({levelWidth(k), levelHeight(k)});
    const int full = int(std::bit_width(unsigned(std::max(map().width(), map().height()) - 1))) + 1;
    nlohmann::json j = {{"levels", K_ + 1}, {"full_mipmap_levels", full}, {"level_sizes", sizes},
                        {"stores_wrap", false}, {"bits", bits_}};
    if (bits_ == 16) j["quantization"] = {{"base", q_.base}, {"step", q_.step}};
    return j;
  }

 private:
  // Smallest level with x0>>k and x1>>k at most one apart: the highest bit where the
  // two differ, ignoring a difference of exactly one node.
  static int levelFor(int a0, int a1) {
    int k = 0;
    while ((a1 >> k) - (a0 >> k) > 1) ++k;
    return k;
  }
  Interval piece(int x0, int x1, int y0, int y1) const {
    const int k = std::min(std::max(levelFor(x0, x1), levelFor(y0, y1)), K_);
    Interval out;
    for (int j = y0 >> k; j <= y1 >> k; ++j)
      for (int i = x0 >> k; i <= x1 >> k; ++i) {
        OBLONG_STAT_INC(mmNodes);
        out.extend(node(k, i, j));
      }
    return out;
  }

  size_t levelBytes() const { return data_.size() * sizeof(Interval) + q16_.size() * sizeof(uint32_t); }
  void build();
  void buildNode(int k, int i, int j);  // node (i,j) of level k >= 1 from its children

  int K_ = 0;                   // top built level
  int bits_ = 32;
  Interval quantRange_;         // requested 16-bit range (empty: derived from the map)
  Quantizer16 q_;
  std::vector<size_t> offset_;  // offset of level k >= 1 in the entries at [k-1]
  std::vector<Interval> data_;  // bits 32
  std::vector<uint32_t> q16_;   // bits 16
};

}  // namespace oblong
