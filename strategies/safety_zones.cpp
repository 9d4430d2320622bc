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

// out[i] = minmax of in[i .. i+2d] for i in [0, n - 2d) (no wrap: the caller extends).
void slideLinear(const Interval* in, int n, int d, Interval* out, std::vector<Interval>& g,
                 std::vector<Interval>& h) {
  const int L = 2 * d + 1;
  g.resize(n);
  h.resize(n);
  for (int k = 0; k < n; ++k) g[k] = k % L == 0 ? in[k] : join(g[k - 1], in[k]);
  for (int k = n - 1; k >= 0; --k) h[k] = (k % L == L - 1 || k == n - 1) ? in[k] : join(h[k + 1], in[k]);
  for (int i = 0; i + L - 1 < n; ++i) out[i] = join(h[i], g[i + L - 1]);
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

SafetyZones::SafetyZones(const Displacement& disp, const QueryNeeds& needs, std::vector<int> deltas, int bits,
                         Interval quantRange)
    : RangeQueryImpl(disp, needs), bits_(bits), quantRange_(quantRange) {
  if (bits != 16 && bits != 32) fail(map().name(), "safety_zones: bits must be 16 or 32, not {}", bits);
  const int W = map().width(), H = map().height();
  deltas_ = resolveDeltas(W, H, needs, std::move(deltas));
  if (const size_t need = buildBytes(W, H, deltas_.size(), bits_); !fitsInMemory(need)) {
    // Fewer (the smallest) deltas, then the structures that need less per texel.
    std::vector<std::string> alt;
    for (size_t n = deltas_.size() - 1; n > 0; --n)
      if (fitsInMemory(buildBytes(W, H, n, bits_))) {
        std::string ds;
        for (size_t k = 0; k < n; ++k) ds += fmt::format("{}{}", k ? ", " : "", deltas_[k]);
        alt.push_back(fmt::format("\"deltas\": [{}] in \"strategies\": {{\"range\": {{...}}}} ({})", ds,
                                  humanBytes(buildBytes(W, H, n, bits_))));
        break;
      }
    const size_t mm = MinMaxMipmap::layout(W, H, needs, bits_).bytes();
    if (fitsInMemory(mm)) alt.push_back(fmt::format("--range minmax_mipmap ({})", humanBytes(mm)));
    std::string hint;
    for (size_t i = 0; i < alt.size(); ++i) hint += (i ? " or " : "try ") + alt[i];
    if (hint.empty()) hint = "free memory or use a smaller map";
    checkFits(map().name(), "safety_zones", need, hint,
              fmt::format("{} min/max maps of {}x{} texels, one more while building", deltas_.size(), W, H));
  }
  build();
}

void SafetyZones::build() {
  const int W = map().width(), H = map().height();
  global_ = map().range();
  const size_t plane = size_t(W) * H;
  data_.clear(), q16_.clear();
  if (bits_ == 16) {
    q_ = Quantizer16::over(quantRange_.isEmpty() ? Quantizer16::rangeFor(global_) : quantRange_);
    q16_.resize(deltas_.size() * plane);
  } else {
    data_.resize(deltas_.size() * plane);
  }
  std::vector<Interval> tmp(deltas_.empty() ? 0 : plane);  // buildBytes counts it only with deltas
  for (size_t k = 0; k < deltas_.size(); ++k) {
    const int d = deltas_[k];
    const size_t dst = k * plane;
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
        for (int j = 0; j < H; ++j) store(dst + size_t(j) * W + i, res[j]);
      }
    });
  }
}

void SafetyZones::buildWindow(size_t k, int c0, int w, int r0, int h) {
  // Zone (i, j) = minmax over samples [i-d, i+d] x [j-d, j+d]: rows [r0-d, r0+h+d) of
  // horizontal results over columns [c0, c0+w), each from samples [c0-d, c0+w+d).
  const HeightMap& m = map();
  const int d = deltas_[k], W = m.width(), H = m.height();
  const int rows = h + 2 * d, span = w + 2 * d;
  std::vector<Interval> hor(size_t(rows) * w), line(size_t(std::max(span, rows))), out(size_t(std::max(w, h))), g, gg;
  for (int r = 0; r < rows; ++r) {
    const int y = HeightMap::wrap(r0 - d + r, H);
    for (int x = 0; x < span; ++x) {
      const float t = m.atUnchecked(HeightMap::wrap(c0 - d + x, W), y);
      line[size_t(x)] = {t, t};
    }
    slideLinear(line.data(), span, d, hor.data() + size_t(r) * w, g, gg);
  }
  const size_t base = k * size_t(W) * H;
  for (int c = 0; c < w; ++c) {
    for (int r = 0; r < rows; ++r) line[size_t(r)] = hor[size_t(r) * w + c];
    slideLinear(line.data(), rows, d, out.data(), g, gg);
    const int x = HeightMap::wrap(c0 + c, W);
    for (int j = 0; j < h; ++j) store(base + size_t(HeightMap::wrap(r0 + j, H)) * W + x, out[size_t(j)]);
  }
}

void SafetyZones::update(const SampleRange& changed) {
  const HeightMap& m = map();
  const int W = m.width(), H = m.height();
  global_ = m.range();
  if (bits_ == 16 && !keepsQuantizer(m, changed, q_, quantRange_)) {
    build();
    return;
  }
  int x0, x1, y0, y1;
  wrapAxis(changed.x0, changed.x1, W, x0, x1);
  wrapAxis(changed.y0, changed.y1, H, y0, y1);
  for (size_t k = 0; k < deltas_.size(); ++k) {
    const int d = deltas_[k];
    // The zones within d of the change, the whole axis once that window covers it.
    const int w = std::min(x1 - x0 + 1 + 2 * d, W), h = std::min(y1 - y0 + 1 + 2 * d, H);
    buildWindow(k, w == W ? 0 : x0 - d, w, h == H ? 0 : y0 - d, h);
  }
}

OBLONG_REGISTER_RANGE_QUERY("safety_zones", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    auto deltas = ps.get<std::vector<int>>("deltas", {});
    for (int d : deltas)
      if (d < 0 || d > (1 << 24)) fail(ps.where(), "parameter 'deltas' has a bad value {}", d);
    if (ps.has("deltas") && deltas.empty()) fail(ps.where(), "parameter 'deltas' is an empty list");
    const int bits = ps.get<int>("bits", 32);
    if (bits != 16 && bits != 32) fail(ps.where(), "parameter 'bits' = {} is not 16 or 32", bits);
    return std::make_unique<SafetyZones>(ctx.displacement, ctx.needs, std::move(deltas), bits);
  },
  StrategyTraits{false, "dilation and erosion maps for a few box radii (Kolb & Rezk-Salama, safety zones, Sec. 3.2)"});

}  // namespace oblong
