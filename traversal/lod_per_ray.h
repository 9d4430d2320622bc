// A level of detail per ray (docs/lod.md, "A λ per ray"): the intersector of
// createPerRayLod (traversal.h) and the range queries of its bands, declared here so that
// the Vulkan records (render/vulkan/records.cpp) can take each level's structures.
#pragma once

#include "core/error.h"
#include "traversal/traversal.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace oblong {

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
  const RangeQuery& fine() const { return *fine_; }
  const RangeQuery* coarse() const { return coarse_.get(); }  // null on the last level

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
    const size_t k = size_t(std::min(std::floor(l), float(bands_.size() - 1)));
    return bands_[k]->intersect(r, prim, hit, c);
  }
  size_t levels() const { return bands_.size(); }
  const Intersector& band(size_t k) const { return *bands_[k]; }  // level k's traversal
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

}  // namespace oblong
