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
#include "core/error.h"
#include "core/lod.h"
#include "render/traversal/traversal.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace oblong {

namespace {

// Range queries for a band: level k's structure over the sample range, and level
// k + 1's over the coarse samples around it (level k's sample i sits at level k + 1's
// i / 2, between samples ⌊i/2⌋ and ⌈i/2⌉).
class LodBandQuery final : public RangeQuery {
 public:
  LodBandQuery(const Displacement& band, std::shared_ptr<const RangeQuery> fine,
               std::shared_ptr<const RangeQuery> coarse)
      : RangeQuery(band, fine->needs()), fine_(std::move(fine)), coarse_(std::move(coarse)) {}

  std::string_view name() const override { return fine_->name(); }
  Interval query(const Rect& uv, float lod) const override {
    if (lod != 0.0f) fail(std::string(name()), "a per-ray level-of-detail structure answers lod 0 only, got {}", lod);
    return disp_.toHeight(rawRange(snap(uv)));
  }
  Interval rawRange(const SampleRange& r) const override {
    const Interval a = fine_->rawRange(r);
    if (!coarse_) return a;
    const Interval b = coarse_->rawRange({r.x0 >> 1, r.y0 >> 1, (r.x1 + 1) >> 1, (r.y1 + 1) >> 1});
    return {std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
  }
  // Each level's structure is counted once: by the band whose own level it is.
  size_t bytes() const override { return fine_->bytes(); }
  MemoryReport memory() const override { return fine_->memory(); }
  bool exact() const override { return !coarse_ && fine_->exact(); }
  void update(const SampleRange&) override {
    fail(std::string(name()), "a per-ray level of detail cannot follow an edit of the map: build it again");
  }
  std::span<const std::byte> storage() const override { return fine_->storage(); }

 private:
  std::shared_ptr<const RangeQuery> fine_, coarse_;
};

class PerRayLod final : public Intersector {
 public:
  explicit PerRayLod(std::vector<std::unique_ptr<Intersector>> bands) : bands_(std::move(bands)) {}
  std::string name() const override { return bands_[0]->name(); }
  size_t size() const override { return bands_[0]->size(); }
  AABB bounds(uint32_t prim) const override {
    AABB b;
    for (const auto& band : bands_) {
      const AABB a = band->bounds(prim);
      if (a.isEmpty()) continue;
      b.lo = glm::min(b.lo, a.lo);
      b.hi = glm::max(b.hi, a.hi);
    }
    return b;
  }
  bool intersect(const Ray& r, uint32_t prim, TriangleHit& hit, RayCounters& c) const override {
    // λ clamped to [0, last level] (NaN: 0), as the whole-scene surface clamps it.
    const float l = r.lod > 0.0f ? r.lod : 0.0f;
    const size_t k = std::min(size_t(std::floor(l)), bands_.size() - 1);
    return bands_[k]->intersect(r, prim, hit, c);
  }
  MemoryReport memory() const override {
    MemoryReport out;
    for (const auto& band : bands_)
      for (const MemoryItem& m : band->memory()) {
        auto it = std::find_if(out.begin(), out.end(), [&](const MemoryItem& x) { return x.name == m.name; });
        if (it == out.end()) out.push_back(m);
        else it->bytes += m.bytes;
      }
    return out;
  }
  nlohmann::json describe() const override {
    nlohmann::json j = bands_[0]->describe();
    j["lod"] = {{"per_ray", true}, {"levels", bands_.size()}};
    return j;
  }

 private:
  std::vector<std::unique_ptr<Intersector>> bands_;  // level k at index k
};

}  // namespace

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
