// rmip: rectangular min-max image pyramid (Thonat et al. 2023, §5, Eq. 5, Alg. 2;
// after Amir et al. 2007). Layer (p,q) bounds every 2^p x 2^q block of pixels by its
// corner; a range of extent (w,h) is the union of the blocks with (p,q) = floor(log2(w,h))
// at its four corners: four lookups.
//
// Two layouts (docs/range_query.md; experiments/range_query/README.md measures them):
//   "pairs"   (default) layers p, q >= 1 only; entry (i,j) of layer (p,q) holds the
//             min/max over the pixels [i 2^p, i 2^p + 2^(p+1) - 2] x [j 2^q, ...]: the
//             union of every 2^p x 2^q block whose corner falls in [i 2^p, (i+1) 2^p)
//             (corner stride = block size). About N^2 entries in all, the paper's
//             "order of a classical mipmap" (§5). A range narrower than 2 pixels uses
//             layer 1 (snapped ranges are at least 2 samples wide).
//   "corners" every layer p, q >= 0, entries at corner strides 2^max(p-c,0) for a
//             `compression` c: (c+2)^2 N^2 entries, exact when c >= the top layer.
// Storage `bits`: 16 (default) codes each pair in one 32-bit word, rounded outward
// (strategies/quantize.h); 32 stores float pairs.
//
// Parameters (ParamSet):
//   layout      "pairs" | "corners", default "pairs"
//   bits        16 | 32, default 16
//   resolution  int >= 0, default 0   RMIP resolution; 0 = the map's. Otherwise the map
//                                     is min/max-downsampled by f = max(1,
//                                     ceil(max(W,H)/resolution)) (paper Table 1).
//   compression int in [0,1000], default 1, layout "corners" only.
//
// Only layers up to the largest query extent in QueryNeeds are built; larger queries are
// covered by several top-layer blocks. Entries whose blocks wrap round the border are
// filled with the wrapped pixels only when QueryNeeds::wrap (docs/design.md invariant 4);
// otherwise crossing queries are split at the border.
#pragma once

#include "core/stats.h"
#include "core/kernels/rmip_query.h"
#include "strategies/quantize.h"
#include "strategies/range_query.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>

namespace oblong {

OBLONG_STAT_COUNTER("rmip/Queries", rmipQueries);
OBLONG_STAT_COUNTER("rmip/Lookups", rmipLookups);
OBLONG_STAT_COUNTER("rmip/BorderSplits", rmipBorderSplits);
OBLONG_STAT_COUNTER("rmip/BeyondBuiltLayers", rmipBeyondLayers);

class Rmip final : public RangeQueryImpl<Rmip> {
 public:
  enum class Scheme { Pairs, Corners };
  struct Options {
    int resolution = 0;  // 0 = the map's
    int compression = 1;  // Corners only
    Scheme layout = Scheme::Pairs;
    int bits = 16;          // 16 or 32
    Interval quantRange{};  // 16-bit codes' range; empty: Quantizer16::rangeFor(map range)
  };
  struct Layer {
    uint32_t offset;  // into the entries, in entries (stored in 4 x 4 tiles: rmipRowBase)
    int nx, ny;       // entries per row / column (0: layer not stored)
    int shiftX, shiftY;  // corner x is looked up at entry x >> shiftX
  };
  // What the constructor builds for a W x H map (the one copy of the layout formulas):
  // bytes() equals the built Rmip's bytes(); buildBytes() adds the scratch the build
  // holds at the same time.
  struct Layout {
    int f = 1, rw = 0, rh = 0, P = 0, Q = 0, c = 0, p0 = 0;
    bool wrap = false;
    int bits = 16;
    Scheme scheme = Scheme::Pairs;
    std::vector<Layer> layers;  // (P+1) x (Q+1), index p * (Q+1) + q; rows p < p0 empty
    size_t entries = 0;
    size_t entryBytes() const { return bits == 16 ? 4 : 8; }
    size_t bytes() const { return entries * entryBytes() + layers.size() * sizeof(Layer); }
    size_t scratchBytes() const;
    size_t buildBytes() const { return bytes() + scratchBytes(); }
  };
  static Layout layout(int W, int H, const QueryNeeds& needs, const Options& o);
  // Throws the memory check's one-line oblong::Error when the build would not fit, with
  // the alternatives that would.
  static void checkMemory(const HeightMap& m, const QueryNeeds& needs, const Options& o);

  Rmip(const Displacement& d, const QueryNeeds& needs, const Options& o);

  std::string_view name() const override { return "rmip"; }
  size_t bytes() const override { return entryBytes() + layers_.size() * sizeof(Layer); }
  MemoryReport memory() const override {
    return {{"rmip/layers", entryBytes()}, {"rmip/layer_table", layers_.size() * sizeof(Layer)}};
  }
  bool exact() const override {
    return scheme_ == Scheme::Corners && bits_ == 32 && f_ == 1 && P_ <= c_ && Q_ <= c_;
  }
  // Refreshes the entries whose pixels overlap the changed samples (the map was edited
  // there): the result equals a full build with the same options and 16-bit range, bit for
  // bit. "pairs" updates only those entries; "corners" rebuilds. An edit leaving the 16-bit
  // range re-encodes everything over the new range.
  void update(const SampleRange& changed) override;

  std::span<const std::byte> storage() const override {
    return bits_ == 16 ? std::as_bytes(std::span(q16_.data(), q16_.size())) : std::as_bytes(std::span(f32_.data(), f32_.size()));
  }

  int downsample() const { return f_; }  // samples per RMIP pixel, per axis
  int resolutionX() const { return rw_; }
  int resolutionY() const { return rh_; }
  int layersX() const { return P_ + 1; }  // p = 0..P (p < firstLayer() not stored)
  int layersY() const { return Q_ + 1; }
  int firstLayer() const { return p0_; }
  int bits() const { return bits_; }
  Scheme scheme() const { return scheme_; }
  bool storesWrap() const { return wrap_; }
  const Quantizer16& quantizer() const { return q_; }
  // Read-only view of the built pyramid, for copies of it (the Vulkan upload,
  // render/vulkan/rmip_layout.h) and bit-for-bit comparisons: the layer table, (p, q) at
  // index p * layersY() + q, and the entries its offsets point into, as 32-bit words
  // (bits 16: one word per entry; bits 32: the float bits of lo, then hi): storage()'s
  // bytes, copied out (the float pairs are not read through another type).
  const std::vector<Layer>& layerTable() const { return layers_; }
  std::vector<uint32_t> words() const {
    const std::span<const std::byte> b = storage();
    std::vector<uint32_t> w(b.size() / sizeof(uint32_t));
    if (!w.empty()) std::memcpy(w.data(), b.data(), w.size() * sizeof(uint32_t));
    return w;
  }
  size_t wordCount() const { return storage().size() / sizeof(uint32_t); }

  Interval rawRangeFast(const SampleRange& r) const {
    return bits_ == 16 ? q_.decodePair(rangeT(q16_.data(), r)) : rangeT(f32_.data(), r);
  }

 protected:
  nlohmann::json describeLayout() const override;

 private:
  size_t entryBytes() const { return q16_.size() * sizeof(uint32_t) + f32_.size() * sizeof(Interval); }
  void build();
  void buildCorners();
  template <typename T, typename Enc>
  void buildPairs(T* data, const Enc& enc);
  template <typename T, typename Enc>
  void updatePairs(T* data, const Enc& enc, const SampleRange& changed);

  static Interval joinT(const Interval& a, const Interval& b) {
    return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
  }
  static uint32_t joinT(uint32_t a, uint32_t b) { return join16(a, b); }
  template <typename T>
  static T emptyT() {
    if constexpr (std::is_same_v<T, uint32_t>) return kEmpty16;
    else return Interval{};
  }

  // The storage as the kernel (core/kernels/rmip_query.h) reads it: entries of type T
  // (16-bit code pairs or float pairs) and the layer table.
  template <typename T>
  struct Access {
    const T* d;
    const Layer* layers;
  };
  template <typename T>
  friend shared::RmipLayerRef rmipLayer(const Access<T>& a, int index) {
    const Layer& L = a.layers[index];
    return {L.offset, L.nx, L.shiftX, L.shiftY};
  }
  template <typename T>
  friend void rmipJoin(const Access<T>& a, uint32_t entry, T& acc) {
    OBLONG_STAT_INC(rmipLookups);
    acc = joinT(acc, a.d[entry]);
  }

  template <typename T>
  T rangeT(const T* d, const SampleRange& r) const {
    OBLONG_STAT_INC(rmipQueries);
    const shared::RmipGeom g{f_, map().width(), map().height(), rw_, rh_, P_, Q_, p0_, wrap_};
    T out = emptyT<T>();
    [[maybe_unused]] const int flags = shared::rmipRange(Access<T>{d, layers_.data()}, g, r.x0, r.y0, r.x1, r.y1, out);
#if OBLONG_STATS
    if (flags & OBLONG_RMIP_BORDER_SPLIT) OBLONG_STAT_INC(rmipBorderSplits);
    OBLONG_STAT_ADD(rmipBeyondLayers, flags / OBLONG_RMIP_BEYOND);
#endif
    return out;
  }

  Options opt_;
  Scheme scheme_ = Scheme::Pairs;
  int f_ = 1, rw_ = 0, rh_ = 0, P_ = 0, Q_ = 0, c_ = 0, p0_ = 0, bits_ = 16;
  bool wrap_ = false;
  Quantizer16 q_;
  std::vector<Layer> layers_;  // (P+1) x (Q+1), index p * (Q+1) + q
  UninitVector<uint32_t> q16_;  // bits 16
  UninitVector<Interval> f32_;  // bits 32
};

}  // namespace oblong
