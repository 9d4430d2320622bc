// minmax_mipmap: TFDM's min-max mipmap (Thonat et al. 2021; Oh et al.). Interface and
// parameters in minmax_mipmap.h; design notes in docs/range_query.md.
#include "strategies/minmax_mipmap.h"

#include "core/memory.h"
#include "strategies/rmip.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace oblong {

MinMaxMipmap::Layout MinMaxMipmap::layout(int W, int H, const QueryNeeds& needs) {
  Layout L;
  // Two nodes of level k cover any range of extent <= 2^k + 1; ranges wider than the
  // map are clamped to it, so the 1x1 top level is never exceeded.
  const int e = std::max(std::min(needs.maxExtentX, W), std::min(needs.maxExtentY, H));
  const int top = int(std::bit_width(unsigned(std::max(W, H) - 1)));
  L.K = std::min(e <= 2 ? 0 : int(std::bit_width(unsigned(e - 2))), top);
  for (int k = 1; k <= L.K; ++k) {
    L.offset.push_back(L.entries);
    L.entries += size_t(levelSize(W, k)) * levelSize(H, k);
  }
  return L;
}

MinMaxMipmap::MinMaxMipmap(const Displacement& d, const QueryNeeds& needs) : RangeQueryImpl(d, needs) {
  const int W = map().width(), H = map().height();
  Layout L = layout(W, H, needs);
  if (!fitsInMemory(L.bytes())) {
    // A low-resolution, uncompressed rmip is the one smaller structure.
    std::string hint = "free memory or use a smaller map";
    for (int f = 2; f < 2 * std::max(W, H); f *= 2) {
      const int res = (std::max(W, H) + f - 1) / f;
      const size_t b = Rmip::layout(W, H, needs, {res, 0}).buildBytes();
      if (b < L.bytes() && fitsInMemory(b)) {
        hint = fmt::format("try --range rmip with \"resolution\": {}, \"compression\": 0 in \"strategies\": "
                           "{{\"range\": {{...}}}} ({})", res, humanBytes(b));
        break;
      }
    }
    checkFits(map().name(), "minmax_mipmap", L.bytes(), hint, fmt::format("levels 1..{} over {}x{} texels", L.K, W, H));
  }
  K_ = L.K;
  offset_ = std::move(L.offset);
  data_.resize(L.entries);
  for (int k = 1; k <= K_; ++k) {
    const int w = levelWidth(k), h = levelHeight(k), cw = levelWidth(k - 1), ch = levelHeight(k - 1);
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      for (int j = rows.begin(); j != rows.end(); ++j)
        for (int i = 0; i < w; ++i) {
          Interval v;  // children clipped at the border of odd-sized levels
          for (int y = 2 * j; y <= std::min(2 * j + 1, ch - 1); ++y)
            for (int x = 2 * i; x <= std::min(2 * i + 1, cw - 1); ++x) v.extend(node(k - 1, x, y));
          data_[offset_[k - 1] + size_t(j) * w + i] = v;
        }
    });
  }
}

OBLONG_REGISTER_RANGE_QUERY("minmax_mipmap", [](ParamSet&, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    return std::make_unique<MinMaxMipmap>(ctx.displacement, ctx.needs);
  },
  StrategyTraits{false, "min-max mipmap, bounds from aligned power-of-two nodes (TFDM, Thonat et al. 2021)"});

}  // namespace oblong
