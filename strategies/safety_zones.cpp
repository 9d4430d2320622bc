// safety_zones: dilation/erosion maps for several box sizes (Kolb & Rezk-Salama §3.2,
// §3.4). Interface and parameters in safety_zones.h; notes in docs/range_query.md.
//
// Each map is a separable sliding-window min/max (van Herk / Gil-Werman: O(1) per
// sample whatever the box size) along rows, then along columns, with wrap addressing.
#include "strategies/safety_zones.h"

#include "core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace oblong {

namespace {

inline Interval join(const Interval& a, const Interval& b) {
  return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
}

// out[i] = minmax of in[i-d .. i+d] (wrapping) over a period-n signal. g/h: scratch.
void slide(const Interval* in, int n, int d, Interval* out, std::vector<Interval>& g,
           std::vector<Interval>& h) {
  const int L = 2 * d + 1;
  if (L >= n) {
    Interval all;
    for (int i = 0; i < n; ++i) all.extend(in[i]);
    std::fill(out, out + n, all);
    return;
  }
  const int m = n + 2 * d;  // extended signal ext[k] = in[wrap(k - d)], d < n here
  auto ext = [&](int k) {
    const int i = k - d;
    return in[i < 0 ? i + n : (i >= n ? i - n : i)];
  };
  g.resize(m);
  h.resize(m);
  for (int k = 0; k < m; ++k) g[k] = k % L == 0 ? ext(k) : join(g[k - 1], ext(k));
  for (int k = m - 1; k >= 0; --k) h[k] = (k % L == L - 1 || k == m - 1) ? ext(k) : join(h[k + 1], ext(k));
  for (int i = 0; i < n; ++i) out[i] = join(h[i], g[i + L - 1]);
}

}  // namespace

SafetyZones::SafetyZones(const Displacement& disp, const QueryNeeds& needs, std::vector<int> deltas)
    : RangeQueryImpl(disp, needs), global_(map().range()) {
  const int W = map().width(), H = map().height(), big = std::max(W, H);
  if (deltas.empty()) {
    // Half-width a box centred on the range needs for the largest extent (clamped to the map).
    const int e = std::max(std::min(needs.maxExtentX, W), std::min(needs.maxExtentY, H));
    const int needMax = e / 2;  // ceil((e-1)/2)
    for (int d = 1; 2 * d + 1 < big; d *= 2) {
      deltas.push_back(d);
      if (d >= needMax) break;
    }
  }
  std::sort(deltas.begin(), deltas.end());
  deltas.erase(std::unique(deltas.begin(), deltas.end()), deltas.end());
  deltas_ = std::move(deltas);

  const size_t plane = size_t(W) * H;
  data_.resize(deltas_.size() * plane);
  std::vector<Interval> tmp(plane);
  for (size_t k = 0; k < deltas_.size(); ++k) {
    const int d = deltas_[k];
    Interval* dst = data_.data() + k * plane;
    tbb::parallel_for(tbb::blocked_range<int>(0, H), [&](const tbb::blocked_range<int>& r) {
      std::vector<Interval> row(W), g, h;
      for (int j = r.begin(); j != r.end(); ++j) {
        for (int i = 0; i < W; ++i) {
          const float t = map().atUnchecked(i, j);
          row[i] = {t, t};
        }
        slide(row.data(), W, d, tmp.data() + size_t(j) * W, g, h);
      }
    });
    tbb::parallel_for(tbb::blocked_range<int>(0, W), [&](const tbb::blocked_range<int>& r) {
      std::vector<Interval> col(H), res(H), g, h;
      for (int i = r.begin(); i != r.end(); ++i) {
        for (int j = 0; j < H; ++j) col[j] = tmp[size_t(j) * W + i];
        slide(col.data(), H, d, res.data(), g, h);
        for (int j = 0; j < H; ++j) dst[size_t(j) * W + i] = res[j];
      }
    });
  }
}

void registerSafetyZones(RangeQueryRegistry& r) {
  r.add("safety_zones", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    auto deltas = ps.get<std::vector<int>>("deltas", {});
    for (int d : deltas)
      if (d < 0 || d > (1 << 24)) fail(ps.where(), "parameter 'deltas' has a bad value {}", d);
    if (ps.has("deltas") && deltas.empty()) fail(ps.where(), "parameter 'deltas' is an empty list");
    return std::make_unique<SafetyZones>(ctx.displacement, ctx.needs, std::move(deltas));
  });
}

}  // namespace oblong
