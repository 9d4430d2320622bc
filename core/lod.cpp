#include "core/lod.h"

#include "core/error.h"
#include "core/memory.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace oblong {

int lodLevels(const HeightMap& m) {
  int k = 0;
  while (m.width() % (2 << k) == 0 && m.height() % (2 << k) == 0 && (m.width() >> (k + 1)) >= 2 &&
         (m.height() >> (k + 1)) >= 2)
    ++k;
  return k;
}

HeightMap downsampleLevel(const HeightMap& fine) {
  const int W = fine.width() / 2, H = fine.height() / 2;
  if (fine.width() % 2 || fine.height() % 2 || W < 2 || H < 2)
    fail(fine.name(), "{}x{} has no coarser level of detail (sizes must be even and at least 4)", fine.width(),
         fine.height());
  checkFits(fine.name(), "a level of detail", size_t(W) * size_t(H) * sizeof(float), "turn LoD off",
            fmt::format("{}x{} float texels", W, H));
  std::vector<float> out(size_t(W) * H);
  // Horizontal pass first into rows kept per coarse row: three fine rows per coarse row.
  // Each value is clamped to its inputs' range: float rounding of the weighted sum could
  // leave it by an ulp, and range queries at a level of detail rely on every level
  // staying within the level-0 samples of its support (docs/lod.md).
  struct Span {
    float v, lo, hi;
  };
  auto row = [&](int j, std::vector<Span>& r) {
    for (int i = 0; i < W; ++i) {
      const float p = fine.at(2 * i - 1, j), q = fine.at(2 * i, j), s = fine.at(2 * i + 1, j);
      r[i] = {0.25f * p + 0.5f * q + 0.25f * s, std::min({p, q, s}), std::max({p, q, s})};
    }
  };
  std::vector<Span> a(W), b(W), c(W);
  for (int j = 0; j < H; ++j) {
    row(2 * j - 1, a);
    row(2 * j, b);
    row(2 * j + 1, c);
    for (int i = 0; i < W; ++i)
      out[size_t(j) * W + i] = std::clamp(0.25f * a[i].v + 0.5f * b[i].v + 0.25f * c[i].v,
                                          std::min({a[i].lo, b[i].lo, c[i].lo}), std::max({a[i].hi, b[i].hi, c[i].hi}));
  }
  return HeightMap(W, H, std::move(out), fine.name());
}

HeightMap heightsAtLod(const HeightMap& level0, double lambda) {
  const int K = lodLevels(level0);
  if (!(lambda >= 0.0 && lambda <= K))
    fail(level0.name(), "level of detail {} is outside [0, {}] for a {}x{} map", lambda, K, level0.width(),
         level0.height());
  const int k = std::min(int(std::floor(lambda)), K);
  const float f = float(lambda - k);
  // Levels 1 .. k, each from the one before (level 0 is not copied).
  HeightMap coarse;
  for (int l = 0; l < k; ++l) coarse = downsampleLevel(l == 0 ? level0 : coarse);
  const HeightMap& level = k == 0 ? level0 : coarse;
  const std::string name = fmt::format("{}@lod{}", level0.name(), lambda);
  if (f == 0.0f) {
    std::vector<float> t = k == 0 ? level0.texels() : std::move(coarse).takeTexels();
    return HeightMap(level.width(), level.height(), std::move(t), name);
  }
  const HeightMap next = downsampleLevel(level);
  checkFits(level0.name(), "the heights at a level of detail", level.texels().size() * sizeof(float), "turn LoD off",
            fmt::format("{}x{} float texels", level.width(), level.height()));
  std::vector<float> out(level.texels().size());
  const int W = level.width(), H = level.height();
  // Displacement::lodHeight is the formula, shared with the per-ray blend (bit for bit).
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) out[size_t(j) * W + i] = Displacement::lodHeight(level, next, i, j, f);
  return HeightMap(W, H, std::move(out), name);
}

Displacement atLevel0(const Displacement& d) {
  Displacement r = d;
  if (d.level0) r.map = d.level0;
  r.level0.reset();
  r.next.reset();
  r.lod = 0.0f;
  r.sampleOffset = 0.5;
  return r;
}

Displacement atLod(const Displacement& d, float lambda) {
  if (!(lambda >= 0.0f) || !std::isfinite(lambda))
    fail(d.map->name(), "level of detail must be a finite number >= 0, got {}", lambda);
  Displacement r = atLevel0(d);
  const float l = std::min(lambda, float(lodLevels(*r.map)));
  if (l == 0.0f) return r;
  const int k = int(std::floor(l));
  r.level0 = r.map;
  r.map = std::make_shared<const HeightMap>(heightsAtLod(*r.level0, l));
  r.lod = l;
  r.sampleOffset = std::ldexp(0.5, -k);
  return r;
}

std::vector<std::shared_ptr<const HeightMap>> lodPyramid(const std::shared_ptr<const HeightMap>& level0) {
  std::vector<std::shared_ptr<const HeightMap>> levels{level0};
  for (int k = 0, K = lodLevels(*level0); k < K; ++k)
    levels.push_back(std::make_shared<const HeightMap>(downsampleLevel(*levels.back())));
  return levels;
}

Displacement lodBand(const Displacement& level0, const std::vector<std::shared_ptr<const HeightMap>>& levels, int k) {
  Displacement r = atLevel0(level0);
  r.level0 = levels[0];
  r.map = levels[size_t(k)];
  r.next = size_t(k) + 1 < levels.size() ? levels[size_t(k) + 1] : nullptr;
  r.lod = float(k);
  r.sampleOffset = std::ldexp(0.5, -k);
  return r;
}

Displacement lodNextLevel(const Displacement& band) {
  Displacement r = band;
  r.map = band.next;
  r.next.reset();
  r.lod = band.lod + 1.0f;
  r.sampleOffset = band.sampleOffset * 0.5;
  return r;
}

}  // namespace oblong
