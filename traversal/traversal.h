// The traversal driver (RMIP paper Alg. 1; docs/design.md §2): Traversal<RQ, Inv, Split>, an
// Intersector over any registered strategy combination. createIntersector
// (traversal/intersector.h) builds Traversal<RangeQuery, Inverter, Splitter>, which calls
// the strategies through their virtual interfaces (one indirect call per range query,
// inversion and split); an opt-in static instantiation on concrete types is one line
// (OBLONG_STATIC_TRAVERSAL below) and is kept only where a benchmark shows it faster.
// Per ray and triangle the work is RayPatch's (traversal/ray_patch.h, where the
// algorithm is described); the per-triangle constants are TraversalMesh's
// (traversal_mesh.h); createIntersector and describe() are in create.cpp; the
// baselines (bruteforce, fixedstep in baselines.cpp, tfdm in tfdm.cpp) register
// themselves in BaselineRegistry (traversal/intersector.h).
#pragma once

#include "core/registry.h"
#include "traversal/intersector.h"
#include "traversal/ray_patch.h"
#include "traversal/traversal_mesh.h"

#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace oblong {

// What createIntersector hands to a traversal instantiation: the built strategies, their
// resolved parameters and the per-triangle constants.
struct TraversalParts {
  std::string name;
  TraversalMesh mesh;
  std::unique_ptr<RangeQuery> rq;
  std::unique_ptr<Inverter> inv;
  std::unique_ptr<Splitter> split;
  nlohmann::json rangeParams, inverterParams, splitterParams;  // ParamSet::resolved()
  TraversalOptions opt;
};

// Shared part of the traversal intersectors.
class TraversalIntersectorBase : public Intersector {
 public:
  TraversalIntersectorBase(TraversalParts&& p, std::string path)
      : name_(std::move(p.name)),
        path_(std::move(path)),
        mesh_(std::move(p.mesh)),
        rq_(std::move(p.rq)),
        inv_(std::move(p.inv)),
        split_(std::move(p.split)),
        params_{std::move(p.rangeParams), std::move(p.inverterParams), std::move(p.splitterParams)},
        opt_(p.opt) {}
  std::string name() const override { return name_; }
  size_t size() const override { return mesh_.tris.size(); }
  AABB bounds(uint32_t prim) const override { return mesh_.bounds(prim); }
  MemoryReport memory() const override {
    MemoryReport r = rq_->memory();
    r.push_back({"traversal/triangles", mesh_.bytes()});
    return r;
  }
  nlohmann::json describe() const override;
  // The range query's update, then the prisms of the triangles the edit reaches.
  Update update(const SampleRange& changed) override;
  // "generic" (virtual calls into the strategies) or "static" (an opt-in instantiation
  // on the concrete strategy types).
  const std::string& path() const { return path_; }
  const TraversalMesh& mesh() const { return mesh_; }
  const RangeQuery& rangeQuery() const { return *rq_; }

 protected:
  std::string name_, path_;
  TraversalMesh mesh_;
  std::unique_ptr<RangeQuery> rq_;
  std::unique_ptr<Inverter> inv_;
  std::unique_ptr<Splitter> split_;
  nlohmann::json params_[3];  // range, inverter, splitter
  TraversalOptions opt_;
};

template <typename RQ, typename Inv, typename Split>
class Traversal final : public TraversalIntersectorBase {
 public:
  static constexpr bool kGeneric =
      std::is_same_v<RQ, RangeQuery> && std::is_same_v<Inv, Inverter> && std::is_same_v<Split, Splitter>;
  explicit Traversal(TraversalParts&& p) : TraversalIntersectorBase(std::move(p), kGeneric ? "generic" : "static") {}

  bool intersect(const Ray& r, uint32_t prim, TriangleHit& hit, RayCounters& c) const override {
    if (!mesh_.params[prim].valid) return false;
    RayCounters local;
    local.prisms = 1;
    const RayConstants& rc = rayConstants(r);
    if (mesh_.missesPrism(prim, r, rc)) {
      flushCounters(local, false, c);
      return false;
    }
    const RQ& rq = static_cast<const RQ&>(*rq_);
    const Inv& inv = static_cast<const Inv&>(*inv_);
    const Split& split = static_cast<const Split&>(*split_);
    RayPatch<RQ, Inv, Split> patch(mesh_, prim, rq, inv, split, opt_, r, rc);
    const bool found = patch.run(local);
    if (found) patch.hit().fill(hit);
    flushCounters(local, found, c);
    return found;
  }
};

// The generic path: Traversal<RangeQuery, Inverter, Splitter> (create.cpp).
std::unique_ptr<Intersector> makeGenericTraversal(TraversalParts&& p);

// The steps of createIntersector (create.cpp), shared with the per-ray level of detail
// (lod_per_ray.cpp): the marching-scale check, the triangles' uv boxes (what the range
// query is built for), and the traversal over a built range query.
void checkMarchingScale(const TraversalConfig& cfg);
std::vector<Rect> uvBoxes(const std::vector<DisplacedTriangle>& triangles);
std::unique_ptr<Intersector> assembleTraversal(const TraversalConfig& cfg, std::vector<DisplacedTriangle> triangles,
                                               const Displacement& disp, std::unique_ptr<RangeQuery> rq,
                                               nlohmann::json rangeParams);
// One intersector per level of the map, each on level k's grid blending toward level
// k + 1 with the ray's fraction; a ray at λ goes to level ⌊λ⌋ (docs/lod.md).
std::unique_ptr<Intersector> createPerRayLod(const TraversalConfig& cfg, std::vector<DisplacedTriangle> triangles,
                                             const Displacement& disp);

// Opt-in static instantiations. The generic path is the default: instantiations on the
// concrete strategy types measured no faster (0.2-0.3% fewer instructions, the same
// speed within noise; docs/traversal.md, "Generic path"), so none is registered. One that a benchmark shows to be faster is one line in a .cpp
// linked into the program:
//     OBLONG_STATIC_TRAVERSAL(Rmip, Newton, Midpoint2D);
// createIntersector then uses it for exactly that combination (`path()` says which ran).
struct StaticTraversal {
  bool (*matches)(const TraversalParts&);
  std::unique_ptr<Intersector> (*make)(TraversalParts&&);
};
std::vector<StaticTraversal>& staticTraversals();

template <typename RQ, typename Inv, typename Split>
StaticTraversal staticTraversal() {
  return {[](const TraversalParts& p) {
            return dynamic_cast<const RQ*>(p.rq.get()) && dynamic_cast<const Inv*>(p.inv.get()) &&
                   dynamic_cast<const Split*>(p.split.get());
          },
          [](TraversalParts&& p) -> std::unique_ptr<Intersector> {
            return std::make_unique<Traversal<RQ, Inv, Split>>(std::move(p));
          }};
}
struct StaticTraversalRegistration {
  explicit StaticTraversalRegistration(StaticTraversal t) { staticTraversals().push_back(t); }
};
#define OBLONG_STATIC_TRAVERSAL(RQ, Inv, Split)                                                          \
  static const ::oblong::StaticTraversalRegistration OBLONG_REGISTRY_CAT(oblongStaticTraversal_, __LINE__) { \
    ::oblong::staticTraversal<RQ, Inv, Split>()                                                         \
  }

}  // namespace oblong
