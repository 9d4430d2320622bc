// minmax_mipmap: TFDM's min-max mipmap (Thonat et al. 2021; Oh et al.). Interface and
// parameters in minmax_mipmap.h; design notes in docs/range_query.md.
#include "strategies/minmax_mipmap.h"

#include "core/memory.h"
#include "strategies/rmip.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace oblong {

MinMaxMipmap::Layout MinMaxMipmap::layout(int W, int H, const QueryNeeds& needs, int bits) {
  Layout L;
  L.bits = bits;
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

MinMaxMipmap::MinMaxMipmap(const Displacement& d, const QueryNeeds& needs, int bits, Interval quantRange)
    : RangeQueryImpl(d, needs), bits_(bits), quantRange_(quantRange) {
  if (bits != 16 && bits != 32) fail(map().name(), "minmax_mipmap: bits must be 16 or 32, not {}", bits);
  build();
}

void MinMaxMipmap::buildNode(int k, int i, int j) {
  const int w = levelWidth(k), cw = levelWidth(k - 1), ch = levelHeight(k - 1);
  const size_t at = offset_[k - 1] + size_t(j) * w + i;
  if (bits_ == 16 && k > 1) {  // codes from codes: the same as encoding the children's union
    uint32_t v = kEmpty16;
    for (int y = 2 * j; y <= std::min(2 * j + 1, ch - 1); ++y)
      for (int x = 2 * i; x <= std::min(2 * i + 1, cw - 1); ++x) v = join16(v, q16_[offset_[k - 2] + size_t(y) * cw + x]);
    q16_[at] = v;
    return;
  }
  Interval v;  // children clipped at the border of odd-sized levels
  for (int y = 2 * j; y <= std::min(2 * j + 1, ch - 1); ++y)
    for (int x = 2 * i; x <= std::min(2 * i + 1, cw - 1); ++x) v.extend(node(k - 1, x, y));
  if (bits_ == 16) q16_[at] = q_.encode(v);
  else data_[at] = v;
}

void MinMaxMipmap::build() {
  const int W = map().width(), H = map().height();
  Layout L = layout(W, H, needs_, bits_);
  if (!fitsInMemory(L.bytes())) {
    // A low-resolution rmip is the one smaller structure.
    std::string hint = "free memory or use a smaller map";
    for (int f = 2; f < 2 * std::max(W, H); f *= 2) {
      const int res = (std::max(W, H) + f - 1) / f;
      const size_t b = Rmip::layout(W, H, needs_, {res}).buildBytes();
      if (b < L.bytes() && fitsInMemory(b)) {
        hint = fmt::format("try --range rmip with \"resolution\": {} in \"strategies\": "
                           "{{\"range\": {{...}}}} ({})", res, humanBytes(b));
        break;
      }
    }
    checkFits(map().name(), "minmax_mipmap", L.bytes(), hint, fmt::format("levels 1..{} over {}x{} texels", L.K, W, H));
  }
  K_ = L.K;
  offset_ = std::move(L.offset);
  data_.clear(), q16_.clear();
  if (bits_ == 16) {
    q_ = Quantizer16::over(quantRange_.isEmpty() ? Quantizer16::rangeFor(map().range()) : quantRange_);
    q16_.resize(L.entries);
  } else {
    data_.resize(L.entries);
  }
  for (int k = 1; k <= K_; ++k) {
    const int w = levelWidth(k), h = levelHeight(k);
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      for (int j = rows.begin(); j != rows.end(); ++j)
        for (int i = 0; i < w; ++i) buildNode(k, i, j);
    });
  }
}

void MinMaxMipmap::update(const SampleRange& changed) {
  if (bits_ == 16 && !keepsQuantizer(map(), changed, q_, quantRange_)) {
    build();
    return;
  }
  const AxisPieces px = splitAxis(changed.x0, changed.x1, map().width());
  const AxisPieces py = splitAxis(changed.y0, changed.y1, map().height());
  for (int k = 1; k <= K_; ++k)
    for (int b = 0; b < py.count; ++b)
      for (int a = 0; a < px.count; ++a)
        for (int j = py.lo[b] >> k; j <= py.hi[b] >> k; ++j)
          for (int i = px.lo[a] >> k; i <= px.hi[a] >> k; ++i) buildNode(k, i, j);
}

OBLONG_REGISTER_RANGE_QUERY("minmax_mipmap", [](ParamSet& ps, const RangeQueryContext& ctx) -> std::unique_ptr<RangeQuery> {
    const int bits = ps.get<int>("bits", 32);
    if (bits != 16 && bits != 32) fail(ps.where(), "parameter 'bits' = {} is not 16 or 32", bits);
    return std::make_unique<MinMaxMipmap>(ctx.displacement, ctx.needs, bits);
  },
  StrategyTraits{false, "min-max mipmap, bounds from aligned power-of-two nodes (TFDM, Thonat et al. 2021)"});

}  // namespace oblong
