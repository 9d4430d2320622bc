// rmip: rectangular min-max image pyramid (Thonat et al. 2023 §5; parameters and
// layout in rmip.h; design notes in docs/range_query.md).
//
// Build: separable. For each p, R_p[x] = minmax over pixels [x, x+2^p) of a row is
// doubled from R_{p-1} (wrap-indexed); the compressed entry for corner block
// [i s, i s + s) is R_p[i s] U R_p[last corner] because s <= 2^p leaves no gap. The same
// is then done down the columns of that horizontal layer for every q. O(entries) per
// layer plus O(N^2) per p and per (p,q) column pass.
#include "strategies/rmip.h"

#include "core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace oblong {

namespace {

template <typename F>
void parallelRows(int n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 16), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) f(i);
  });
}

inline Interval join(const Interval& a, const Interval& b) {
  return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
}

// Entries of one axis of layer p (block length 2^p) over n pixels with corner stride s.
int entries(int n, int p, int shift, bool wrap) {
  const int s = 1 << shift;
  return wrap ? (n + s - 1) / s : (n - (1 << p)) / s + 1;
}

}  // namespace

Rmip::Rmip(const Displacement& d, const QueryNeeds& needs, const Options& o) : RangeQueryImpl(d, needs) {
  const HeightMap& m = map();
  const int W = m.width(), H = m.height();
  f_ = o.resolution <= 0 ? 1 : std::max(1, (std::max(W, H) + o.resolution - 1) / o.resolution);
  rw_ = (W + f_ - 1) / f_;
  rh_ = (H + f_ - 1) / f_;
  c_ = o.compression;
  wrap_ = needs.wrap;

  // Largest pixel extent a sample extent e can map to (a partial last pixel adds one).
  auto pixExtent = [&](int e, int n) {
    e = std::max(e, 1);
    const int px = f_ == 1 ? e : (e - 1 + f_ - 1) / f_ + 2;
    return std::min(px, n);
  };
  P_ = log2floor(pixExtent(needs.maxExtentX, rw_));
  Q_ = log2floor(pixExtent(needs.maxExtentY, rh_));

  // Layer table and storage.
  layers_.resize(size_t(P_ + 1) * (Q_ + 1));
  size_t total = 0;
  for (int p = 0; p <= P_; ++p)
    for (int q = 0; q <= Q_; ++q) {
      Layer& L = layers_[size_t(p) * (Q_ + 1) + q];
      L.shiftX = std::max(p - c_, 0);
      L.shiftY = std::max(q - c_, 0);
      L.nx = entries(rw_, p, L.shiftX, wrap_);
      L.ny = entries(rh_, q, L.shiftY, wrap_);
      L.offset = uint32_t(total);
      total += size_t(L.nx) * L.ny;
    }
  if (total > size_t(UINT32_MAX)) fail(m.name(), "rmip: {} entries exceed the 32-bit layer offsets", total);
  data_.resize(total);

  // Base pixels: min/max over each f x f block of samples (clipped to the map).
  std::vector<Interval> rowR(size_t(rw_) * rh_), rowNext(rowR.size());
  parallelRows(rh_, [&](int j) {
    for (int i = 0; i < rw_; ++i) {
      Interval v;
      for (int y = j * f_; y < std::min((j + 1) * f_, H); ++y)
        for (int x = i * f_; x < std::min((i + 1) * f_, W); ++x) v.extend(m.atUnchecked(x, y));
      rowR[size_t(j) * rw_ + i] = v;
    }
  });

  std::vector<Interval> colR, colNext;
  for (int p = 0; p <= P_; ++p) {
    if (p > 0) {  // R_p from R_{p-1}, wrap-indexed (only 2^p <= rw_ is ever built)
      const int h = 1 << (p - 1);
      parallelRows(rh_, [&](int j) {
        const Interval* a = rowR.data() + size_t(j) * rw_;
        Interval* o = rowNext.data() + size_t(j) * rw_;
        for (int x = 0; x < rw_; ++x) o[x] = join(a[x], a[x + h < rw_ ? x + h : x + h - rw_]);
      });
      std::swap(rowR, rowNext);
    }
    // Horizontal compression: one entry per corner block, stored column-major
    // (entry i's column is contiguous) for the vertical passes.
    const int sx = std::max(p - c_, 0), nx = entries(rw_, p, sx, wrap_);
    const int lastCorner = wrap_ ? rw_ - 1 : rw_ - (1 << p);
    colR.resize(size_t(nx) * rh_);
    colNext.resize(colR.size());
    parallelRows(rh_, [&](int j) {
      const Interval* a = rowR.data() + size_t(j) * rw_;
      for (int i = 0; i < nx; ++i) {
        const int c0 = i << sx, c1 = std::min(c0 + (1 << sx) - 1, lastCorner);
        colR[size_t(i) * rh_ + j] = join(a[c0], a[c1]);
      }
    });
    for (int q = 0; q <= Q_; ++q) {
      if (q > 0) {
        const int h = 1 << (q - 1);
        parallelRows(nx, [&](int i) {
          const Interval* a = colR.data() + size_t(i) * rh_;
          Interval* o = colNext.data() + size_t(i) * rh_;
          for (int y = 0; y < rh_; ++y) o[y] = join(a[y], a[y + h < rh_ ? y + h : y + h - rh_]);
        });
        std::swap(colR, colNext);
      }
      const Layer& L = layers_[size_t(p) * (Q_ + 1) + q];
      const int lastY = wrap_ ? rh_ - 1 : rh_ - (1 << q);
      parallelRows(L.ny, [&](int jj) {
        const int c0 = jj << L.shiftY, c1 = std::min(c0 + (1 << L.shiftY) - 1, lastY);
        Interval* o = data_.data() + L.offset + size_t(jj) * L.nx;
        for (int i = 0; i < L.nx; ++i) o[i] = join(colR[size_t(i) * rh_ + c0], colR[size_t(i) * rh_ + c1]);
      });
    }
  }
}

void registerRmip(RangeQueryRegistry& r) {
  r.add("rmip", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    Rmip::Options o;
    o.resolution = ps.getInRange<int>("resolution", 0, 0, 1 << 24);
    o.compression = ps.getInRange<int>("compression", 1, 0, 1000);
    return std::make_unique<Rmip>(ctx.displacement, ctx.needs, o);
  });
}

}  // namespace oblong
