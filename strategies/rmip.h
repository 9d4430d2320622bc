// rmip: rectangular min-max image pyramid (Thonat et al. 2023, §5, Eq. 5, Alg. 2;
// after Amir et al. 2007). Layer (p,q) holds, for every corner (x,y), the min and max
// over the 2^p x 2^q block at that corner; a range of extent (w,h) is the union of four
// such blocks with (p,q) = floor(log2(w,h)) at the range's four corners.
//
// Parameters (ParamSet):
//   resolution  int >= 0, default 0   RMIP resolution; 0 = the map's. Otherwise the
//                                     map is min/max-downsampled by f = max(1,
//                                     ceil(max(W,H)/resolution)) (paper Table 1
//                                     low/normal/high-res RMIP).
//   compression int in [0,1000], default 1
//                                     layer (p,q) keeps one corner entry per
//                                     2^max(p-c,0) x 2^max(q-c,0) block (entry = union
//                                     of the regions of its corners); memory ~ N^2
//                                     instead of N^2 (1+log N)^2; the covered range
//                                     grows by < 2^(p-c) on each side, a factor
//                                     < 1 + 2^(1-c) per axis whatever the anisotropy.
//                                     >= log2 N: uncompressed.
//                                     Default chosen with the benchmark, see
//                                     docs/range_query.md.
//
// Only layers up to the largest query extent in QueryNeeds are built; larger queries
// are covered by several top-layer blocks. Corners wrapping around the border are
// stored only when QueryNeeds::wrap (DESIGN invariant 4); otherwise crossing queries
// are split at the border.
#pragma once

#include "core/stats.h"
#include "strategies/range_query.h"

#include <bit>
#include <cstdint>

namespace oblong {

OBLONG_STAT_COUNTER("rmip/Queries", rmipQueries);
OBLONG_STAT_COUNTER("rmip/Lookups", rmipLookups);
OBLONG_STAT_COUNTER("rmip/BorderSplits", rmipBorderSplits);
OBLONG_STAT_COUNTER("rmip/BeyondBuiltLayers", rmipBeyondLayers);

class Rmip final : public RangeQueryImpl<Rmip> {
 public:
  struct Options {
    int resolution = 0;  // 0 = the map's
    int compression = 1;
  };
  struct Layer {
    uint32_t offset;  // into data_
    int nx, ny;       // entries per row / column
    int shiftX, shiftY;  // corner stride = 1 << shift
  };
  // What the constructor builds for a W x H map (the one copy of the layout formulas):
  // bytes() equals the built Rmip's bytes(); buildBytes() adds the scratch the build
  // holds at the same time (row and column passes, four float pairs per pixel).
  struct Layout {
    int f = 1, rw = 0, rh = 0, P = 0, Q = 0, c = 0;
    bool wrap = false;
    std::vector<Layer> layers;  // offsets filled while they fit in 32 bits
    size_t entries = 0;
    size_t bytes() const { return entries * sizeof(Interval) + layers.size() * sizeof(Layer); }
    size_t scratchBytes() const { return 4 * size_t(rw) * rh * sizeof(Interval); }
    size_t buildBytes() const { return bytes() + scratchBytes(); }
  };
  static Layout layout(int W, int H, const QueryNeeds& needs, const Options& o);
  // Throws the memory check's one-line oblong::Error when the build would not fit, with
  // the largest lower resolution and the other strategies that would.
  static void checkMemory(const HeightMap& m, const QueryNeeds& needs, const Options& o);

  Rmip(const Displacement& d, const QueryNeeds& needs, const Options& o);

  std::string_view name() const override { return "rmip"; }
  size_t bytes() const override { return data_.size() * sizeof(Interval) + layers_.size() * sizeof(Layer); }
  MemoryReport memory() const override {
    return {{"rmip/layers", data_.size() * sizeof(Interval)}, {"rmip/layer_table", layers_.size() * sizeof(Layer)}};
  }
  bool exact() const override { return f_ == 1 && P_ <= c_ && Q_ <= c_; }

  int downsample() const { return f_; }  // samples per RMIP pixel, per axis
  int resolutionX() const { return rw_; }
  int resolutionY() const { return rh_; }
  int layersX() const { return P_ + 1; }  // p = 0..P
  int layersY() const { return Q_ + 1; }
  bool storesWrap() const { return wrap_; }
  // Read-only view of the built pyramid, for copies of it (the Vulkan upload,
  // render/vulkan/rmip_layout.h): the layer table, (p, q) at index p * layersY() + q for
  // p < layersX(), q < layersY(), and the entries its offsets point into.
  const std::vector<Layer>& layerTable() const { return layers_; }
  const std::vector<Interval>& layerEntries() const { return data_; }

  Interval rawRangeFast(const SampleRange& r) const {
    OBLONG_STAT_INC(rmipQueries);
    int x0, x1, y0, y1;
    toPixels(r.x0, r.x1, map().width(), rw_, x0, x1);
    toPixels(r.y0, r.y1, map().height(), rh_, y0, y1);
    if (wrap_ || (x1 < rw_ && y1 < rh_)) return block(x0, x1, y0, y1);
    // No wrapping corners stored: split at the border into non-crossing pieces.
    OBLONG_STAT_INC(rmipBorderSplits);
    const int xa[2] = {x0, 0}, xb[2] = {std::min(x1, rw_ - 1), x1 - rw_};
    const int ya[2] = {y0, 0}, yb[2] = {std::min(y1, rh_ - 1), y1 - rh_};
    Interval out;
    for (int b = 0; b < (y1 < rh_ ? 1 : 2); ++b)
      for (int a = 0; a < (x1 < rw_ ? 1 : 2); ++a) out.extend(block(xa[a], xb[a], ya[b], yb[b]));
    return out;
  }

 protected:
  nlohmann::json describeLayout() const override;

 private:
  // Sample axis range -> RMIP pixel range: start in [0,n), end possibly >= n (crossing
  // the border), or the whole axis [0,n-1].
  void toPixels(int a0, int a1, int size, int n, int& s, int& e) const {
    wrapAxis(a0, a1, size, s, e);
    if (f_ == 1) return;
    e = e < size ? e / f_ : n + (e - size) / f_;  // the last pixel may be partial
    s /= f_;
    if (e - s + 1 >= n) s = 0, e = n - 1;
  }

  static int log2floor(int v) { return int(std::bit_width(unsigned(v))) - 1; }

  // Pixel block [x0,x1]x[y0,y1] (x0 in [0,rw), x1 < x0 + rw; crossing only if wrap_):
  // Eq. 5, with blocks of the top built layer tiled over ranges beyond it.
  Interval block(int x0, int x1, int y0, int y1) const {
    const int p = std::min(log2floor(x1 - x0 + 1), P_), q = std::min(log2floor(y1 - y0 + 1), Q_);
    const Layer& L = layers_[size_t(p) * (Q_ + 1) + q];
    const int lx = 1 << p, ly = 1 << q;
    const Interval* d = data_.data() + L.offset;
    Interval out;
    for (int cy = y0;; cy += ly) {
      const bool lastY = cy + ly - 1 >= y1;
      if (lastY) cy = y1 - ly + 1;
      const Interval* row = d + size_t((cy >= rh_ ? cy - rh_ : cy) >> L.shiftY) * L.nx;
      for (int cx = x0;; cx += lx) {
        const bool lastX = cx + lx - 1 >= x1;
        if (lastX) cx = x1 - lx + 1;
        OBLONG_STAT_INC(rmipLookups);
        out.extend(row[(cx >= rw_ ? cx - rw_ : cx) >> L.shiftX]);
        if (lastX) break;
      }
      if (lastY) break;
    }
#if OBLONG_STATS
    if (x1 - x0 + 1 >= 2 * lx || y1 - y0 + 1 >= 2 * ly) OBLONG_STAT_INC(rmipBeyondLayers);
#endif
    return out;
  }

  Options opt_;
  int f_ = 1, rw_ = 0, rh_ = 0, P_ = 0, Q_ = 0, c_ = 0;
  bool wrap_ = false;
  std::vector<Layer> layers_;  // (P+1) x (Q+1), index p * (Q+1) + q
  std::vector<Interval> data_;
};

}  // namespace oblong
