// A level of detail per ray (docs/lod.md, "A λ per ray"; RMIP §2 and Alg. 2's λ).
//
// The surface at λ = k + f is level k's grid with heights blended toward level k + 1
// (core/lod.h). For a λ that changes from ray to ray, one intersector per level k is
// built on level k's grid with Displacement::next = level k + 1; each ray reads the
// heights of its own f on the fly (Displacement::raw), bit for bit those of the
// whole-scene surface at its λ. What an intersector precomputes must hold for every
// f in [0, 1]: the blended heights are convex combinations of level k's samples and of
// level k + 1's micro-geometry at them, so
//   - range queries answer the hull of level k's and level k + 1's ranges (LodBandQuery;
//     one structure per level, shared by the two bands that read it),
//   - prisms take those heights and the larger cell delta (TraversalMesh::build),
//   - the oracle's heights likewise (baselines.cpp, exactHeights).
// Embree gets one box per triangle, the union of its prisms over the levels.
#include "traversal/lod_per_ray.h"

#include "core/error.h"
#include "core/lod.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace oblong {

std::unique_ptr<Intersector> createPerRayLod(const TraversalConfig& cfg, std::vector<DisplacedTriangle> triangles,
                                             const Displacement& disp) {
  TraversalConfig one = cfg;
  one.lodPerRay = false;
  const std::string where = cfg.where("strategies.lod");
  if (!cfg.baseline.empty()) {
    const BaselineRegistry& reg = BaselineRegistry::instance();
    if (reg.has(cfg.baseline) && !reg.traits(cfg.baseline).perRayLod)
      fail(where, "the {} baseline has one surface for every ray: a level of detail per ray needs the traversal or "
                  "bruteforce (or a fixed level of detail)", cfg.baseline);
  }
  const Displacement level0 = atLevel0(disp);
  const auto levels = lodPyramid(level0.map);
  const int K = int(levels.size()) - 1;
  std::vector<std::unique_ptr<Intersector>> bands;
  if (!cfg.baseline.empty()) {
    for (int k = 0; k <= K; ++k) bands.push_back(createIntersector(one, triangles, lodBand(level0, levels, k)));
    return std::make_unique<PerRayLod>(std::move(bands));
  }
  checkMarchingScale(cfg);
  // One range structure per level, built for what both bands that read it can ask.
  const std::vector<Rect> boxes = uvBoxes(triangles);
  std::vector<Displacement> plain(size_t(K) + 1);
  std::vector<QueryNeeds> needs(size_t(K) + 1);
  for (int k = 0; k <= K; ++k) {
    plain[size_t(k)] = lodBand(level0, levels, k);
    plain[size_t(k)].next.reset();
    needs[size_t(k)] = QueryNeeds::forRects(plain[size_t(k)], boxes);
    if (k > 0) {  // band k - 1 asks for its ranges halved, one sample wider
      const QueryNeeds& f = needs[size_t(k) - 1];
      QueryNeeds& n = needs[size_t(k)];
      n.maxExtentX = std::min(levels[size_t(k)]->width() + 1, std::max(n.maxExtentX, f.maxExtentX / 2 + 2));
      n.maxExtentY = std::min(levels[size_t(k)]->height() + 1, std::max(n.maxExtentY, f.maxExtentY / 2 + 2));
      n.wrap = n.wrap || f.wrap;
    }
  }
  std::vector<std::shared_ptr<const RangeQuery>> structures;
  nlohmann::json rangeParams;
  for (int k = 0; k <= K; ++k) {
    ParamSet rps(cfg.rangeParams, cfg.where("strategies.range"));
    structures.push_back(createRangeQuery(cfg.range, rps, RangeQueryContext{plain[size_t(k)], needs[size_t(k)]}));
    if (k == 0) rangeParams = rps.resolved();
  }
  for (int k = 0; k <= K; ++k) {
    const Displacement band = lodBand(level0, levels, k);
    auto rq = std::make_unique<LodBandQuery>(band, structures[size_t(k)], k < K ? structures[size_t(k) + 1] : nullptr);
    bands.push_back(assembleTraversal(one, triangles, band, std::move(rq), rangeParams));
  }
  return std::make_unique<PerRayLod>(std::move(bands));
}

}  // namespace oblong
