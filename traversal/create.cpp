// createIntersector: the traversal for any registered strategy combination (the generic
// path, or an opt-in static instantiation), or a registered baseline (BaselineRegistry).
// See traversal/traversal.h and docs/traversal.md.
#include "traversal/traversal.h"

#include <chrono>

#include "core/error.h"
#include "core/scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace oblong {

void warnSkippedTriangles(const TraversalMesh& mesh, const std::string& what) {
  size_t skipped = 0, first = 0;
  for (size_t i = mesh.params.size(); i-- > 0;)
    if (!mesh.params[i].valid) ++skipped, first = i;
  if (skipped)
    eprint(
               "oblong: warning: {}: skipped {} of {} displaced triangles that cannot be displaced (zero area, "
               "degenerate uvs or vanishing normals; first: triangle {})\n",
               what, skipped, mesh.params.size(), first);
}

std::unique_ptr<Intersector> createIntersector(const TraversalConfig& cfg, std::vector<DisplacedTriangle> triangles,
                                               const Displacement& disp) {
  if (!disp.map) throw Error("traversal: a displaced mesh needs a displacement map");
  if (cfg.lodPerRay) return createPerRayLod(cfg, std::move(triangles), disp);
  if (!cfg.baseline.empty()) {
    const BaselineRegistry& reg = BaselineRegistry::instance();
    if (!reg.has(cfg.baseline))
      fail(cfg.where("strategies.baseline"), "unknown baseline '{}' (known: {})", cfg.baseline, reg.list());
    if (reg.traits(cfg.baseline).builtByScene)
      fail(cfg.where("strategies.baseline"), "the {} baseline is built by the scene (EmbreeScene), not an intersector",
           cfg.baseline);
    ParamSet bps(cfg.baselineParams, cfg.where("strategies.baseline"));
    return reg.create(cfg.baseline, bps, BaselineContext{cfg, &triangles, disp});
  }
  checkMarchingScale(cfg);
  // Invariant 4: the range query is built for what these triangles can ask.
  ParamSet rps(cfg.rangeParams, cfg.where("strategies.range"));
  auto rq = createRangeQuery(cfg.range, rps, RangeQueryContext{disp, QueryNeeds::forRects(disp, uvBoxes(triangles))});
  return assembleTraversal(cfg, std::move(triangles), disp, std::move(rq), rps.resolved());
}

void checkMarchingScale(const TraversalConfig& cfg) {
  if (!(cfg.marchingScale >= kMinMarchingScale) || !std::isfinite(cfg.marchingScale))
    fail("traversal", "marching scale must be a finite number of texels >= {} (smaller only multiplies the work), got {}",
         kMinMarchingScale, cfg.marchingScale);
  if (!(cfg.stackDepth >= 2 && cfg.stackDepth <= OBLONG_TRAV_STACK))
    fail("traversal", "stack depth must be 2 to {} entries, got {}", OBLONG_TRAV_STACK, cfg.stackDepth);
}

std::vector<Rect> uvBoxes(const std::vector<DisplacedTriangle>& triangles) {
  std::vector<Rect> boxes;
  boxes.reserve(triangles.size());
  for (const DisplacedTriangle& T : triangles)
    if (T.uvArea2 != 0.0f) boxes.push_back(T.uvBox);
  return boxes;
}

std::unique_ptr<Intersector> assembleTraversal(const TraversalConfig& cfg, std::vector<DisplacedTriangle> triangles,
                                               const Displacement& disp, std::unique_ptr<RangeQuery> rq,
                                               nlohmann::json rangeParams) {
  ParamSet ips(cfg.inverterParams, cfg.where("strategies.inverter"));
  auto inv = createInverter(cfg.inverter, ips);
  ParamSet sps(cfg.splitterParams, cfg.where("strategies.splitter"));
  auto split = createSplitter(cfg.splitter, sps);

  TraversalParts parts;
  parts.name = cfg.range + "+" + cfg.inverter + "+" + cfg.splitter;
  const RangeQuery& q = *rq;
  parts.mesh.build(std::move(triangles), disp, [&](const DisplacedTriangle& T) { return q.query(T.uvBox); });
  warnSkippedTriangles(parts.mesh, parts.name);
  parts.rq = std::move(rq);
  parts.inv = std::move(inv);
  parts.split = std::move(split);
  parts.rangeParams = std::move(rangeParams);
  parts.inverterParams = ips.resolved();
  parts.splitterParams = sps.resolved();
  parts.opt = TraversalOptions{cfg.marchingScale, cfg.inversionInTraversal, cfg.stackDepth};
  for (const StaticTraversal& st : staticTraversals())
    if (st.matches(parts)) return st.make(std::move(parts));
  return makeGenericTraversal(std::move(parts));
}

std::unique_ptr<Intersector> makeGenericTraversal(TraversalParts&& p) {
  return std::make_unique<Traversal<RangeQuery, Inverter, Splitter>>(std::move(p));
}

std::vector<StaticTraversal>& staticTraversals() {
  static std::vector<StaticTraversal> list;
  return list;
}

Intersector::Update Intersector::update(const SampleRange&) {
  fail(name(), "cannot be updated after an edit of its map: build it again");
}

Intersector::Update TraversalIntersectorBase::update(const SampleRange& changed) {
  using Clock = std::chrono::steady_clock;
  Update u;
  const auto t0 = Clock::now();
  rq_->update(changed);
  const auto t1 = Clock::now();
  const RangeQuery& q = *rq_;
  u.triangles = mesh_.update(changed, [&](const DisplacedTriangle& T) { return q.query(T.uvBox); });
  u.structureSeconds = std::chrono::duration<double>(t1 - t0).count();
  u.prismSeconds = std::chrono::duration<double>(Clock::now() - t1).count();
  return u;
}

nlohmann::json TraversalIntersectorBase::describe() const {
  nlohmann::json range = rq_->describe();
  range["params"] = params_[0];
  return {{"name", name_},
          {"path", path_},
          {"range", range},
          {"inverter", {{"name", std::string(inv_->name())}, {"params", params_[1]}}},
          {"splitter", {{"name", std::string(split_->name())}, {"params", params_[2]}}},
          {"marching_scale", opt_.marchingScale},
          {"inversion_in_traversal", opt_.inversionInTraversal},
          {"stack_depth", opt_.stackDepth}};
}

}  // namespace oblong
