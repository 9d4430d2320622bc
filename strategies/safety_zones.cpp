// safety_zones: dilation/erosion maps for several box sizes (Kolb & Rezk-Salama §3.2,
// §3.4). Interface and parameters in safety_zones.h; notes in docs/range_query.md.
//
// Each map is a separable sliding-window min/max (van Herk / Gil-Werman: O(1) per
// sample whatever the box size) along rows, then along columns, with wrap addressing.
#include "strategies/safety_zones.h"

#include "core/error.h"
#include "core/memory.h"
#include "strategies/minmax_mipmap.h"

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

std::vector<int> SafetyZones::resolveDeltas(int W, int H, const QueryNeeds& needs, std::vector<int> deltas) {
  const int big = std::max(W, H);
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
  return deltas;
}

SafetyZones::SafetyZones(const Displacement& disp, const QueryNeeds& needs, std::vector<int> deltas)
    : RangeQueryImpl(disp, needs), global_(map().range()) {
  const int W = map().width(), H = map().height();
  deltas_ = resolveDeltas(W, H, needs, std::move(deltas));
  if (const size_t need = buildBytes(W, H, deltas_.size()); !fitsInMemory(need)) {
    // Fewer (the smallest) deltas, then the structures that need less per texel.
    std::vector<std::string> alt;
    for (size_t n = deltas_.size() - 1; n > 0; --n)
      if (fitsInMemory(buildBytes(W, H, n))) {
        std::string ds;
        for (size_t k = 0; k < n; ++k) ds += fmt::format("{}{}", k ? ", " : "", deltas_[k]);
        alt.push_back(fmt::format("\"deltas\": [{}] in \"strategies\": {{\"range\": {{...}}}} ({})", ds,
                                  humanBytes(buildBytes(W, H, n))));
        break;
      }
    const size_t mm = MinMaxMipmap::layout(W, H, needs).bytes();
    if (fitsInMemory(mm)) alt.push_back(fmt::format("--range minmax_mipmap ({})", humanBytes(mm)));
    std::string hint;
    for (size_t i = 0; i < alt.size(); ++i) hint += (i ? " or " : "try ") + alt[i];
    if (hint.empty()) hint = "free memory or use a smaller map";
    checkFits(map().name(), "safety_zones", need, hint,
              fmt::format("{} min/max maps of {}x{} texels, one more while building", deltas_.size(), W, H));
  }

  const size_t plane = size_t(W) * H;
  data_.resize(deltas_.size() * plane);
  std::vector<Interval> tmp(deltas_.empty() ? 0 : plane);  // buildBytes counts it only with deltas
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

OBLONG_REGISTER_RANGE_QUERY("safety_zones", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    auto deltas = ps.get<std::vector<int>>("deltas", {});
    for (int d : deltas)
      if (d < 0 || d > (1 << 24)) fail(ps.where(), "parameter 'deltas' has a bad value {}", d);
    if (ps.has("deltas") && deltas.empty()) fail(ps.where(), "parameter 'deltas' is an empty list");
    return std::make_unique<SafetyZones>(ctx.displacement, ctx.needs, std::move(deltas));
  },
  StrategyTraits{false, "dilation and erosion maps for a few box radii (Kolb & Rezk-Salama, safety zones, Sec. 3.2)"});

}  // namespace oblong
