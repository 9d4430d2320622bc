// rmip: rectangular min-max image pyramid (Thonat et al. 2023 §5; parameters and
// layouts in rmip.h; design notes and measurements in docs/range_query.md).
//
// "pairs" build: per axis, entry i of level p covers pixels [i 2^p, i 2^p + 2^(p+1) - 2],
// which is exactly the union of entries 2i, 2i+1, 2i+2 of level p-1 (level 0 = pixels).
// Near a wrapping border the recursion takes whichever level p-1 entries cover the
// wrapped pixels (PairAxis::sources), a superset only where the size is not a multiple of
// 2^p. A 2D entry is the min/max over the product of its two axes' pixel sets, so it can
// be computed in any order of x and y steps with the same result bit for bit: the build
// goes pixels -> (1,1) -> (1,q) -> (p,q), and update() recomputes only the entries whose
// pixel sets meet the edit, reading the stored neighbours.
//
// "corners" build: separable. For each p, R_p[x] = minmax over pixels [x, x+2^p) of a row
// is doubled from R_{p-1} (wrap-indexed); the compressed entry for corner block
// [i s, i s + s) is R_p[i s] U R_p[last corner] because s <= 2^p leaves no gap. The same
// is then done down the columns for every q.
#include "strategies/rmip.h"

#include "core/error.h"
#include "core/memory.h"
#include "strategies/minmax_mipmap.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace oblong {

namespace {

template <typename F>
void parallelRows(int n, F&& f, int grain = 16) {
  tbb::parallel_for(tbb::blocked_range<int>(0, n, grain), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) f(i);
  });
}

// Entries of one axis of a "corners" layer p (block length 2^p) over n pixels, stride 2^shift.
int cornerEntries(int n, int p, int shift, bool wrap) {
  const int s = 1 << shift;
  return wrap ? (n + s - 1) / s : (n - (1 << p)) / s + 1;
}

// One axis of the "pairs" layout: entries per level and each entry's sources at the
// level below (level 0 = pixels).
struct PairAxis {
  int n = 0, top = 0;
  bool wrap = false;
  std::vector<int> count;  // count[p]: entries of level p (count[0] = n pixels)

  PairAxis(int n_, int top_, bool wrap_) : n(n_), top(top_), wrap(wrap_), count(size_t(top_) + 1) {
    for (int p = 0; p <= top; ++p) count[size_t(p)] = int((int64_t(n) + (int64_t(1) << p) - 1) >> p);
  }
  // First entry of level p whose sources are not simply 2i, 2i+1, 2i+2.
  int interiorEnd(int p) const { return std::clamp((count[size_t(p - 1)] - 2) / 2, 0, count[size_t(p)]); }
  // Sources of entry i of level p >= 1 at level p-1: at most 6, no repeats.
  int sources(int p, int i, int out[6]) const {
    const int prev = count[size_t(p - 1)], h = 1 << (p - 1);
    int m = 0;
    auto push = [&](int k) {
      for (int t = 0; t < m; ++t)
        if (out[t] == k) return;
      out[m++] = k;
    };
    for (int k = 2 * i; k <= 2 * i + 2; ++k) {
      if (k < prev) {
        push(k);
      } else if (wrap) {
        // Pixels from k*h on, wrapped: start s in [0,n); entry s/h covers [s/h*h, +2h-2],
        // the rest of [s, s+2h-2] lies in the next entry, or past the border in entry 0.
        const int s = int((int64_t(k) * h) % n), e = s / h;
        push(e);
        if (s % h) push(e + 1 < prev ? e + 1 : 0);
      }
    }
    return m;
  }
  // Entries of level p whose pixel sets meet the dirty pixels (dirty[0]); all levels.
  std::vector<std::vector<int>> dirtyLists(const std::vector<char>& pixels) const {
    std::vector<std::vector<int>> lists(size_t(top) + 1);
    std::vector<char> cur = pixels, next;
    for (int p = 1; p <= top; ++p) {
      next.assign(size_t(count[size_t(p)]), 0);
      int src[6];
      for (int i = 0; i < count[size_t(p)]; ++i) {
        const int m = sources(p, i, src);
        for (int t = 0; t < m; ++t)
          if (cur[size_t(src[t])]) {
            next[size_t(i)] = 1;
            lists[size_t(p)].push_back(i);
            break;
          }
      }
      cur.swap(next);
    }
    return lists;
  }
};

// Pixels of one sample axis touched by the inclusive, possibly wrapping range [a0, a1].
std::vector<char> dirtyPixels(int a0, int a1, int size, int f, int n) {
  std::vector<char> d(size_t(n), 0);
  if (int64_t(a1) - a0 + 1 >= size) {
    std::fill(d.begin(), d.end(), 1);
    return d;
  }
  for (int64_t s = a0; s <= a1; ++s) d[size_t(HeightMap::wrap(int(s % size), size) / f)] = 1;
  return d;
}

}  // namespace

size_t Rmip::Layout::scratchBytes() const {
  // The tiling pass (tileLayers) copies one layer at a time.
  size_t largest = 0;
  for (const Layer& l : layers) largest = std::max(largest, size_t(shared::rmipLayerEntries(l.nx, l.ny)));
  if (scheme == Scheme::Pairs) return std::max(size_t(rh) * ((size_t(rw) + 1) / 2), largest) * entryBytes();
  // Corners: row and column passes in float pairs, plus the float entries before encoding.
  return 4 * size_t(rw) * rh * sizeof(Interval) + (bits == 16 ? entries * sizeof(Interval) : 0) +
         largest * sizeof(Interval);
}

Rmip::Layout Rmip::layout(int W, int H, const QueryNeeds& needs, const Options& o) {
  Layout L;
  L.f = o.resolution <= 0 ? 1 : std::max(1, (std::max(W, H) + o.resolution - 1) / o.resolution);
  L.rw = (W + L.f - 1) / L.f;
  L.rh = (H + L.f - 1) / L.f;
  L.scheme = o.layout;
  L.bits = o.bits;
  L.c = o.layout == Scheme::Corners ? o.compression : 0;
  L.p0 = o.layout == Scheme::Pairs ? 1 : 0;
  L.wrap = needs.wrap;

  // Largest pixel extent a sample extent e can map to (a partial last pixel adds one).
  auto pixExtent = [&](int e, int n) {
    e = std::max(e, 1);
    const int px = L.f == 1 ? e : (e - 1 + L.f - 1) / L.f + 2;
    return std::min(px, n);
  };
  L.P = std::max(shared::findMSB(pixExtent(needs.maxExtentX, L.rw)), L.p0);
  L.Q = std::max(shared::findMSB(pixExtent(needs.maxExtentY, L.rh)), L.p0);

  L.layers.assign(size_t(L.P + 1) * (L.Q + 1), Layer{0, 0, 0, 0, 0});
  for (int p = L.p0; p <= L.P; ++p)
    for (int q = L.p0; q <= L.Q; ++q) {
      Layer& e = L.layers[size_t(p) * (L.Q + 1) + q];
      if (L.scheme == Scheme::Pairs) {
        e.shiftX = p, e.shiftY = q;
        e.nx = int((int64_t(L.rw) + (int64_t(1) << p) - 1) >> p);
        e.ny = int((int64_t(L.rh) + (int64_t(1) << q) - 1) >> q);
      } else {
        e.shiftX = std::max(p - L.c, 0);
        e.shiftY = std::max(q - L.c, 0);
        e.nx = cornerEntries(L.rw, p, e.shiftX, L.wrap);
        e.ny = cornerEntries(L.rh, q, e.shiftY, L.wrap);
      }
      e.offset = uint32_t(L.entries);
      L.entries += (size_t(e.nx) + 3) / 4 * ((size_t(e.ny) + 3) / 4) * 16;  // whole 4 x 4 tiles
    }
  return L;
}

void Rmip::checkMemory(const HeightMap& m, const QueryNeeds& needs, const Options& o) {
  const int W = m.width(), H = m.height();
  const Layout L = layout(W, H, needs, o);
  if (fitsInMemory(L.buildBytes())) return;
  // Alternatives that fit, each with what it would need: the largest lower resolution
  // (halving the pixels per axis), the default layout, the min-max mipmap.
  std::vector<std::string> alt;
  for (int f = L.f * 2; f < 2 * std::max(W, H); f *= 2) {
    Options lower = o;
    lower.resolution = (std::max(W, H) + f - 1) / f;
    const size_t b = layout(W, H, needs, lower).buildBytes();
    if (fitsInMemory(b)) {
      alt.push_back(fmt::format("\"resolution\": {} ({})", lower.resolution, humanBytes(b)));
      break;
    }
  }
  if (o.layout != Scheme::Pairs || o.bits != 16) {
    Options def = o;
    def.layout = Scheme::Pairs, def.bits = 16;
    const size_t b = layout(W, H, needs, def).buildBytes();
    if (fitsInMemory(b)) alt.push_back(fmt::format("\"layout\": \"pairs\", \"bits\": 16 ({})", humanBytes(b)));
  }
  std::string hint;
  for (size_t i = 0; i < alt.size(); ++i) hint += (i ? " or " : "try ") + alt[i];
  if (!alt.empty()) hint += " in \"strategies\": {\"range\": {...}}";
  const size_t mm = MinMaxMipmap::layout(W, H, needs).bytes();  // what --range minmax_mipmap builds
  if (fitsInMemory(mm)) hint += fmt::format("{}--range minmax_mipmap ({})", alt.empty() ? "try " : ", or ", humanBytes(mm));
  if (hint.empty()) hint = "no range query fits: free memory or use a smaller map";
  checkFits(m.name(), "rmip", L.buildBytes(), hint,
            fmt::format("{} of layers for {}x{} pixels{}, {} more while building", humanBytes(L.bytes()), L.rw, L.rh,
                        L.f == 1 ? "" : fmt::format(" at {} samples per pixel", L.f), humanBytes(L.scratchBytes())));
}

Rmip::Rmip(const Displacement& d, const QueryNeeds& needs, const Options& o) : RangeQueryImpl(d, needs), opt_(o) {
  if (o.bits != 16 && o.bits != 32) fail(map().name(), "rmip: bits must be 16 or 32, not {}", o.bits);
  build();
}

namespace {

// The pixel values a build reads: f x f blocks of samples (clipped to the map), as T.
template <typename T, typename Enc>
void pixelRow(const HeightMap& m, int f, int rw, int j, const Enc& enc, T* out) {
  const int W = m.width(), H = m.height();
  for (int i = 0; i < rw; ++i) {
    Interval v;
    for (int y = j * f; y < std::min((j + 1) * f, H); ++y)
      for (int x = i * f; x < std::min((i + 1) * f, W); ++x) v.extend(m.atUnchecked(x, y));
    out[i] = enc(v);
  }
}

template <typename T, typename Join>
T joinSources(const T* base, ptrdiff_t stride, const int* src, int m, T empty, const Join& join) {
  T v = empty;
  for (int t = 0; t < m; ++t) v = join(v, base[src[t] * stride]);
  return v;
}

shared::RmipLayerRef layerRef(const Rmip::Layer& L) { return {L.offset, L.nx, L.shiftX, L.shiftY}; }

// The builders fill each layer row by row (entry (i, j) at offset + j nx + i); the query
// reads it in 4 x 4 tiles (core/kernels/rmip_query.h). Moves every layer to the tiled
// order in place, the padding entries empty.
template <typename T>
void tileLayers(T* data, const std::vector<Rmip::Layer>& layers, T empty) {
  std::vector<T> rows;
  for (const Rmip::Layer& L : layers) {
    if (L.nx == 0 || L.ny == 0) continue;
    rows.assign(data + L.offset, data + L.offset + size_t(L.nx) * L.ny);
    const shared::RmipLayerRef ref = layerRef(L);
    const int tilesY = (L.ny + 3) / 4;
    parallelRows(tilesY, [&](int ty) {
      for (int j = 4 * ty; j < 4 * ty + 4; ++j) {
        const uint32_t base = shared::rmipRowBase(ref, j);
        for (int i = 0; i < 4 * ((L.nx + 3) / 4); ++i)
          data[base + shared::rmipColumn(i)] = i < L.nx && j < L.ny ? rows[size_t(j) * L.nx + i] : empty;
      }
    }, 64);
  }
}

}  // namespace

void Rmip::build() {
  const HeightMap& m = map();
  const int W = m.width(), H = m.height();
  checkMemory(m, needs_, opt_);
  Layout lay = layout(W, H, needs_, opt_);
  f_ = lay.f, rw_ = lay.rw, rh_ = lay.rh, c_ = lay.c, P_ = lay.P, Q_ = lay.Q, p0_ = lay.p0;
  scheme_ = lay.scheme, bits_ = lay.bits, wrap_ = lay.wrap;
  const size_t total = lay.entries;
  if (total > size_t(UINT32_MAX)) fail(m.name(), "rmip: {} entries exceed the 32-bit layer offsets", total);
  layers_ = std::move(lay.layers);
  q16_.clear(), f32_.clear();
  if (bits_ == 16) {
    q_ = Quantizer16::over(opt_.quantRange.isEmpty() ? Quantizer16::rangeFor(m.range()) : opt_.quantRange);
  }

  if (scheme_ == Scheme::Pairs) {
    if (bits_ == 16) {
      q16_.resize(total);
      buildPairs(q16_.data(), [this](const Interval& v) { return v.lo == v.hi ? q_.encodeSample(v.lo) : q_.encode(v); });
    } else {
      f32_.resize(total);
      buildPairs(f32_.data(), [](const Interval& v) { return v; });
    }
    return;
  }
  buildCorners();
}

template <typename T, typename Enc>
void Rmip::buildPairs(T* data, const Enc& enc) {
  const HeightMap& m = map();
  const PairAxis X(rw_, P_, wrap_), Y(rh_, Q_, wrap_);
  const T empty = emptyT<T>();
  auto join = [](const T& a, const T& b) { return joinT(a, b); };
  auto layer = [&](int p, int q) -> const Layer& { return layers_[size_t(p) * (Q_ + 1) + q]; };

  // Pixels -> level 1 across each row: H1[y][i] = pixels 2i..2i+2 of row y.
  const int n1 = X.count[1], e1 = X.interiorEnd(1);
  UninitVector<T> h1(size_t(rh_) * n1);
  tbb::parallel_for(tbb::blocked_range<int>(0, rh_, 8), [&](const tbb::blocked_range<int>& rows) {
    std::vector<T> px(static_cast<size_t>(rw_));
    int src[6];
    for (int y = rows.begin(); y != rows.end(); ++y) {
      if (f_ == 1) {
        for (int x = 0; x < rw_; ++x) {
          const float t = m.atUnchecked(x, y);
          px[size_t(x)] = enc(Interval{t, t});
        }
      } else {
        pixelRow(m, f_, rw_, y, enc, px.data());
      }
      T* o = h1.data() + size_t(y) * n1;
      for (int i = 0; i < e1; ++i) o[i] = join(join(px[2 * i], px[2 * i + 1]), px[2 * i + 2]);
      for (int i = e1; i < n1; ++i) o[i] = joinSources(px.data(), 1, src, X.sources(1, i, src), empty, join);
    }
  });

  // (1,1) from H1 down the columns, then (1,q) from (1,q-1): whole rows at a time.
  for (int q = 1; q <= Q_; ++q) {
    const Layer& L = layer(1, q);
    const T* from = q == 1 ? h1.data() : data + layer(1, q - 1).offset;
    T* to = data + L.offset;
    parallelRows(L.ny, [&](int j) {
      int src[6];
      const int k = Y.sources(q, j, src);
      T* o = to + size_t(j) * L.nx;
      const T* r0 = from + size_t(src[0]) * L.nx;
      if (k == 3) {  // the interior: rows 2j, 2j+1, 2j+2 in one pass
        const T *r1 = from + size_t(src[1]) * L.nx, *r2 = from + size_t(src[2]) * L.nx;
        for (int i = 0; i < L.nx; ++i) o[i] = join(join(r0[i], r1[i]), r2[i]);
        return;
      }
      std::copy(r0, r0 + L.nx, o);
      for (int t = 1; t < k; ++t) {
        const T* r = from + size_t(src[t]) * L.nx;
        for (int i = 0; i < L.nx; ++i) o[i] = join(o[i], r[i]);
      }
    }, 4);
  }
  UninitVector<T>().swap(h1);

  // (p,q) from (p-1,q) along the rows.
  for (int p = 2; p <= P_; ++p) {
    const int ep = X.interiorEnd(p);
    for (int q = 1; q <= Q_; ++q) {
      const Layer& L = layer(p, q);
      const Layer& F = layer(p - 1, q);
      parallelRows(L.ny, [&](int j) {
        int src[6];
        const T* a = data + F.offset + size_t(j) * F.nx;
        T* o = data + L.offset + size_t(j) * L.nx;
        for (int i = 0; i < ep; ++i) o[i] = join(join(a[2 * i], a[2 * i + 1]), a[2 * i + 2]);
        for (int i = ep; i < L.nx; ++i) o[i] = joinSources(a, 1, src, X.sources(p, i, src), empty, join);
      }, 8);
    }
  }
  tileLayers(data, layers_, empty);
}

void Rmip::buildCorners() {
  const HeightMap& m = map();
  UninitVector<Interval> data(layers_.empty() ? 0 : size_t(layers_.back().offset) +
                                                      shared::rmipLayerEntries(layers_.back().nx, layers_.back().ny));

  // Base pixels: min/max over each f x f block of samples (clipped to the map).
  std::vector<Interval> rowR(size_t(rw_) * rh_), rowNext(rowR.size());
  parallelRows(rh_, [&](int j) { pixelRow(m, f_, rw_, j, [](const Interval& v) { return v; }, rowR.data() + size_t(j) * rw_); });

  std::vector<Interval> colR, colNext;
  for (int p = 0; p <= P_; ++p) {
    if (p > 0) {  // R_p from R_{p-1}, wrap-indexed (only 2^p <= rw_ is ever built)
      const int h = 1 << (p - 1);
      parallelRows(rh_, [&](int j) {
        const Interval* a = rowR.data() + size_t(j) * rw_;
        Interval* o = rowNext.data() + size_t(j) * rw_;
        for (int x = 0; x < rw_; ++x) o[x] = joinT(a[x], a[x + h < rw_ ? x + h : x + h - rw_]);
      });
      std::swap(rowR, rowNext);
    }
    // Horizontal compression: one entry per corner block, stored column-major
    // (entry i's column is contiguous) for the vertical passes.
    const int sx = std::max(p - c_, 0), nx = cornerEntries(rw_, p, sx, wrap_);
    const int lastCorner = wrap_ ? rw_ - 1 : rw_ - (1 << p);
    colR.resize(size_t(nx) * rh_);
    colNext.resize(colR.size());
    parallelRows(rh_, [&](int j) {
      const Interval* a = rowR.data() + size_t(j) * rw_;
      for (int i = 0; i < nx; ++i) {
        const int c0 = i << sx, c1 = std::min(c0 + (1 << sx) - 1, lastCorner);
        colR[size_t(i) * rh_ + j] = joinT(a[c0], a[c1]);
      }
    });
    for (int q = 0; q <= Q_; ++q) {
      if (q > 0) {
        const int h = 1 << (q - 1);
        parallelRows(nx, [&](int i) {
          const Interval* a = colR.data() + size_t(i) * rh_;
          Interval* o = colNext.data() + size_t(i) * rh_;
          for (int y = 0; y < rh_; ++y) o[y] = joinT(a[y], a[y + h < rh_ ? y + h : y + h - rh_]);
        });
        std::swap(colR, colNext);
      }
      const Layer& L = layers_[size_t(p) * (Q_ + 1) + q];
      const int lastY = wrap_ ? rh_ - 1 : rh_ - (1 << q);
      parallelRows(L.ny, [&](int jj) {
        const int c0 = jj << L.shiftY, c1 = std::min(c0 + (1 << L.shiftY) - 1, lastY);
        Interval* o = data.data() + L.offset + size_t(jj) * L.nx;
        for (int i = 0; i < L.nx; ++i) o[i] = joinT(colR[size_t(i) * rh_ + c0], colR[size_t(i) * rh_ + c1]);
      });
    }
  }
  tileLayers(data.data(), layers_, Interval{});
  if (bits_ == 32) {
    f32_ = std::move(data);
    return;
  }
  q16_.resize(data.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, data.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) q16_[i] = q_.encode(data[i]);
  });
}

void Rmip::update(const SampleRange& changed) {
  const HeightMap& m = map();
  if (scheme_ == Scheme::Corners) {
    build();
    return;
  }
  if (bits_ == 16) {
    if (!keepsQuantizer(m, changed, q_, opt_.quantRange)) {
      build();
      return;
    }
    updatePairs(q16_.data(), [this](const Interval& v) { return v.lo == v.hi ? q_.encodeSample(v.lo) : q_.encode(v); },
                changed);
  } else {
    updatePairs(f32_.data(), [](const Interval& v) { return v; }, changed);
  }
}

template <typename T, typename Enc>
void Rmip::updatePairs(T* data, const Enc& enc, const SampleRange& changed) {
  const HeightMap& m = map();
  const PairAxis X(rw_, P_, wrap_), Y(rh_, Q_, wrap_);
  const auto dx = X.dirtyLists(dirtyPixels(changed.x0, changed.x1, m.width(), f_, rw_));
  const auto dy = Y.dirtyLists(dirtyPixels(changed.y0, changed.y1, m.height(), f_, rh_));
  const T empty = emptyT<T>();
  auto join = [](const T& a, const T& b) { return joinT(a, b); };
  auto layer = [&](int p, int q) -> const Layer& { return layers_[size_t(p) * (Q_ + 1) + q]; };
  auto at = [&](const Layer& L, int i, int j) -> T& {  // the entries are tiled
    return data[shared::rmipRowBase(layerRef(L), j) + shared::rmipColumn(i)];
  };
  auto pix = [&](int i, int j) -> T {
    Interval v;
    for (int y = j * f_; y < std::min((j + 1) * f_, m.height()); ++y)
      for (int x = i * f_; x < std::min((i + 1) * f_, m.width()); ++x) v.extend(m.atUnchecked(x, y));
    return enc(v);
  };
  int sx[6], sy[6];
  // (1,1) from pixels.
  {
    const Layer& L = layer(1, 1);
    for (int j : dy[1]) {
      const int ky = Y.sources(1, j, sy);
      for (int i : dx[1]) {
        const int kx = X.sources(1, i, sx);
        T v = empty;
        for (int b = 0; b < ky; ++b)
          for (int a = 0; a < kx; ++a) v = join(v, pix(sx[a], sy[b]));
        at(L, i, j) = v;
      }
    }
  }
  for (int q = 2; q <= Q_; ++q) {
    const Layer& L = layer(1, q);
    const Layer& F = layer(1, q - 1);
    for (int j : dy[size_t(q)]) {
      const int ky = Y.sources(q, j, sy);
      for (int i : dx[1]) {
        T v = empty;
        for (int t = 0; t < ky; ++t) v = join(v, at(F, i, sy[t]));
        at(L, i, j) = v;
      }
    }
  }
  for (int p = 2; p <= P_; ++p)
    for (int q = 1; q <= Q_; ++q) {
      const Layer& L = layer(p, q);
      const Layer& F = layer(p - 1, q);
      for (int j : dy[size_t(q)])
        for (int i : dx[size_t(p)]) {
          const int kx = X.sources(p, i, sx);
          T v = empty;
          for (int t = 0; t < kx; ++t) v = join(v, at(F, sx[t], j));
          at(L, i, j) = v;
        }
    }
}

nlohmann::json Rmip::describeLayout() const {
  // Bytes of each built layer (p rows, q columns) and of the wrapping corners ("corners"
  // layout: the same layout without them; "pairs" stores the same entries either way).
  nlohmann::json bytes = nlohmann::json::array();
  const size_t eb = bits_ == 16 ? 4 : 8;
  for (int p = 0; p <= P_; ++p) {
    nlohmann::json row = nlohmann::json::array();
    for (int q = 0; q <= Q_; ++q) {
      const Layer& l = layers_[size_t(p) * (Q_ + 1) + q];
      row.push_back(size_t(shared::rmipLayerEntries(l.nx, l.ny)) * eb);
    }
    bytes.push_back(std::move(row));
  }
  QueryNeeds inside = needs_;
  inside.wrap = false;
  const size_t noWrap = layout(map().width(), map().height(), inside, opt_).entries * eb;
  const int fullP = int(std::bit_width(unsigned(rw_))) - 1, fullQ = int(std::bit_width(unsigned(rh_))) - 1;
  nlohmann::json j = {{"layout", scheme_ == Scheme::Pairs ? "pairs" : "corners"},
                      {"bits", bits_},
                      {"pixels", {rw_, rh_}},
                      {"downsample", f_},
                      {"layers", {P_ + 1, Q_ + 1}},
                      {"first_layer", p0_},
                      {"full_pyramid_layers", {fullP + 1, fullQ + 1}},
                      {"layer_bytes", bytes},
                      {"stores_wrap", wrap_},
                      {"wrap_bytes", wrap_ ? entryBytes() - noWrap : 0}};
  if (scheme_ == Scheme::Corners) j["compression"] = c_;
  if (bits_ == 16) j["quantization"] = {{"base", q_.base}, {"step", q_.step}};
  // Against a 16-bit min-max mipmap of the same map with every level stored, level 0
  // included (the RMIP paper's Table 1 accounting: 21 MB at 2048^2), and per map texel.
  const size_t mip16 = MinMaxMipmap::fullBytes16(map().width(), map().height());
  j["mipmap16_bytes"] = mip16;
  j["ratio_to_mipmap16"] = std::round(100.0 * double(this->bytes()) / double(mip16)) / 100.0;
  j["bytes_per_texel"] = std::round(100.0 * double(this->bytes()) / (double(map().width()) * map().height())) / 100.0;
  return j;
}

OBLONG_REGISTER_RANGE_QUERY("rmip", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    Rmip::Options o;
    o.resolution = ps.getInRange<int>("resolution", 0, 0, 1 << 24);
    const std::string layout = ps.get<std::string>("layout", "pairs");
    if (layout == "pairs") {
      o.layout = Rmip::Scheme::Pairs;
      if (ps.has("compression"))
        fail(ps.where(), "parameter 'compression' applies to \"layout\": \"corners\" only (the layout is \"pairs\")");
    } else if (layout == "corners") {
      o.layout = Rmip::Scheme::Corners;
      o.compression = ps.getInRange<int>("compression", 1, 0, 1000);
    } else {
      fail(ps.where(), "parameter 'layout' = \"{}\" is not one of \"pairs\", \"corners\"", layout);
    }
    o.bits = ps.get<int>("bits", 16);
    if (o.bits != 16 && o.bits != 32) fail(ps.where(), "parameter 'bits' = {} is not 16 or 32", o.bits);
    return std::make_unique<Rmip>(ctx.displacement, ctx.needs, o);
  },
  StrategyTraits{.summary = "rectangular min-max image pyramid, bounds over any rectangle in four lookups (Thonat et al. 2023, Sec. 5)",
                 .vulkanKernel = "core/kernels/rmip_query.h"});

}  // namespace oblong
