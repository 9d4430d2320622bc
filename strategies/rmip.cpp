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
#include "core/memory.h"
#include "strategies/minmax_mipmap.h"

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

Rmip::Layout Rmip::layout(int W, int H, const QueryNeeds& needs, const Options& o) {
  Layout L;
  L.f = o.resolution <= 0 ? 1 : std::max(1, (std::max(W, H) + o.resolution - 1) / o.resolution);
  L.rw = (W + L.f - 1) / L.f;
  L.rh = (H + L.f - 1) / L.f;
  L.c = o.compression;
  L.wrap = needs.wrap;

  // Largest pixel extent a sample extent e can map to (a partial last pixel adds one).
  auto pixExtent = [&](int e, int n) {
    e = std::max(e, 1);
    const int px = L.f == 1 ? e : (e - 1 + L.f - 1) / L.f + 2;
    return std::min(px, n);
  };
  L.P = log2floor(pixExtent(needs.maxExtentX, L.rw));
  L.Q = log2floor(pixExtent(needs.maxExtentY, L.rh));

  L.layers.resize(size_t(L.P + 1) * (L.Q + 1));
  for (int p = 0; p <= L.P; ++p)
    for (int q = 0; q <= L.Q; ++q) {
      Layer& e = L.layers[size_t(p) * (L.Q + 1) + q];
      e.shiftX = std::max(p - L.c, 0);
      e.shiftY = std::max(q - L.c, 0);
      e.nx = entries(L.rw, p, e.shiftX, L.wrap);
      e.ny = entries(L.rh, q, e.shiftY, L.wrap);
      e.offset = uint32_t(L.entries);
      L.entries += size_t(e.nx) * e.ny;
    }
  return L;
}

void Rmip::checkMemory(const HeightMap& m, const QueryNeeds& needs, const Options& o) {
  const int W = m.width(), H = m.height();
  const Layout L = layout(W, H, needs, o);
  if (fitsInMemory(L.buildBytes())) return;
  // Alternatives that fit, each with what it would need: the largest lower resolution
  // (halving the pixels per axis), compression 0, the min-max mipmap.
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
  if (o.compression > 0) {
    Options c0 = o;
    c0.compression = 0;
    const size_t b = layout(W, H, needs, c0).buildBytes();
    if (fitsInMemory(b)) alt.push_back(fmt::format("\"compression\": 0 ({})", humanBytes(b)));
  }
  std::string hint;
  for (size_t i = 0; i < alt.size(); ++i) hint += (i ? " or " : "try ") + alt[i];
  if (!alt.empty()) hint += " in \"strategies\": {\"range\": {...}}";
  const size_t mm = MinMaxMipmap::layout(W, H, needs).bytes();
  if (fitsInMemory(mm)) hint += fmt::format("{}--range minmax_mipmap ({})", alt.empty() ? "try " : ", or ", humanBytes(mm));
  if (hint.empty()) hint = "no range query fits: free memory or use a smaller map";
  checkFits(m.name(), "rmip", L.buildBytes(), hint,
            fmt::format("{} of layers for {}x{} pixels{}, {} more while building", humanBytes(L.bytes()), L.rw, L.rh,
                        L.f == 1 ? "" : fmt::format(" at {} samples per pixel", L.f), humanBytes(L.scratchBytes())));
}

Rmip::Rmip(const Displacement& d, const QueryNeeds& needs, const Options& o) : RangeQueryImpl(d, needs), opt_(o) {
  const HeightMap& m = map();
  const int W = m.width(), H = m.height();
  checkMemory(m, needs, o);
  Layout lay = layout(W, H, needs, o);
  f_ = lay.f, rw_ = lay.rw, rh_ = lay.rh, c_ = lay.c, P_ = lay.P, Q_ = lay.Q;
  wrap_ = lay.wrap;
  const size_t total = lay.entries;
  if (total > size_t(UINT32_MAX)) fail(m.name(), "rmip: {} entries exceed the 32-bit layer offsets", total);
  layers_ = std::move(lay.layers);
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

nlohmann::json Rmip::describeLayout() const {
  // Bytes of each built layer (p rows, q columns) and of the corners that wrap around
  // the border (the same layout without them).
  nlohmann::json bytes = nlohmann::json::array();
  for (int p = 0; p <= P_; ++p) {
    nlohmann::json row = nlohmann::json::array();
    for (int q = 0; q <= Q_; ++q) {
      const Layer& l = layers_[size_t(p) * (Q_ + 1) + q];
      row.push_back(size_t(l.nx) * size_t(l.ny) * sizeof(Interval));
    }
    bytes.push_back(std::move(row));
  }
  QueryNeeds inside = needs_;
  inside.wrap = false;
  const size_t noWrap = layout(map().width(), map().height(), inside, opt_).entries * sizeof(Interval);
  const int fullP = int(std::bit_width(unsigned(rw_))) - 1, fullQ = int(std::bit_width(unsigned(rh_))) - 1;
  return {{"pixels", {rw_, rh_}},
          {"downsample", f_},
          {"compression", c_},
          {"layers", {P_ + 1, Q_ + 1}},
          {"full_pyramid_layers", {fullP + 1, fullQ + 1}},
          {"layer_bytes", bytes},
          {"stores_wrap", wrap_},
          {"wrap_bytes", wrap_ ? data_.size() * sizeof(Interval) - noWrap : 0}};
}

OBLONG_REGISTER_RANGE_QUERY("rmip", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    Rmip::Options o;
    o.resolution = ps.getInRange<int>("resolution", 0, 0, 1 << 24);
    o.compression = ps.getInRange<int>("compression", 1, 0, 1000);
    return std::make_unique<Rmip>(ctx.displacement, ctx.needs, o);
  },
  StrategyTraits{false, "rectangular min-max image pyramid, exact bounds over any rectangle (Thonat et al. 2023, Sec. 5)"});

}  // namespace oblong
