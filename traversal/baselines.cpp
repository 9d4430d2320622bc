// Two baselines that share the traversal's micro-geometry: "bruteforce", the oracle
// (every micro-triangle, no pruning), and "fixedstep", PDM-style constant-step marching
// (Hoetzlein 2025, §4.2; approximate). See docs/traversal.md; "tfdm" is in tfdm.cpp.
#include "traversal/traversal.h"

#include "core/error.h"
#include "core/lod.h"
#include "core/scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace oblong {

OBLONG_STAT_COUNTER("bruteforce/Prisms", bfPrisms);
OBLONG_STAT_COUNTER("bruteforce/MicroTriangles", bfMicroTris);
OBLONG_STAT_COUNTER("fixedstep/Prisms", fsPrisms);
OBLONG_STAT_COUNTER("fixedstep/Steps", fsSteps);
OBLONG_STAT_COUNTER("fixedstep/Hits", fsHits);

namespace {

// The samples under T's uv box, snapped outward; exactHeights: the heights over them by
// brute force (baselines: no RangeQuery is built for them).
SampleRange samplesOf(const DisplacedTriangle& T, const Displacement& d) {
  const dvec2 a = d.toSample(T.uvBox.lo), b = d.toSample(T.uvBox.hi);
  constexpr double eps = 1e-5, lim = 1e9;
  return {int(std::clamp(std::floor(a.x - eps), -lim, lim)), int(std::clamp(std::floor(a.y - eps), -lim, lim)),
          int(std::clamp(std::ceil(b.x + eps), -lim, lim)), int(std::clamp(std::ceil(b.y + eps), -lim, lim))};
}
Interval exactHeights(const DisplacedTriangle& T, const Displacement& d) {
  const Interval h = d.toHeight(bruteForceRange(*d.map, samplesOf(T, d)));
  if (!d.next) return h;
  // Blended per ray toward level k + 1 (docs/lod.md): its samples under T bound the rest.
  const Displacement n = lodNextLevel(d);
  const Interval g = n.toHeight(bruteForceRange(*n.map, samplesOf(T, n)));
  return {std::min(h.lo, g.lo), std::max(h.hi, g.hi)};
}

// Do the inclusive index ranges [a0,a1] and [c0,c1] meet modulo n?
bool meetsWrapped(int64_t a0, int64_t a1, int64_t c0, int64_t c1, int n) {
  const int64_t la = a1 - a0 + 1, lc = c1 - c0 + 1;
  if (la <= 0 || lc <= 0) return false;
  if (la >= n || lc >= n) return true;
  const int64_t s = ((c0 - a0) % n + n) % n;  // start of c, relative to a0
  return s < la || s + lc > n;
}

// The oracle: every micro-triangle of the triangle, in cell order, no pruning at all
// (not even the prism's box), computed on the fly (nothing cached).
class BruteForce final : public Intersector {
 public:
  explicit BruteForce(TraversalMesh mesh) : mesh_(std::move(mesh)) {}
  std::string name() const override { return "bruteforce"; }
  size_t size() const override { return mesh_.tris.size(); }
  AABB bounds(uint32_t prim) const override { return mesh_.bounds(prim); }
  MemoryReport memory() const override { return {{"bruteforce/triangles", mesh_.bytes()}}; }

  bool intersect(const Ray& r, uint32_t prim, TriangleHit& hit, RayCounters& c) const override {
    if (!mesh_.params[prim].valid) return false;
    const DisplacedTriangle& T = mesh_.tris[prim];
    const CellRange& cr = mesh_.cells[prim];
    const MicroCells mc(T, mesh_.disp, mesh_.disp.blendOf(r.lod));
    const WatertightRay wr(r);
    ClosestHit best;
    MicroTriangle buf[MicroCells::kMaxPerCell];
    int64_t tested = 0;
    for (int j = cr.y0; j <= cr.y1; ++j)
      for (int i = cr.x0; i <= cr.x1; ++i) {
        const int n = mc.cell(i, j, buf);
        tested += n;
        for (int k = 0; k < n; ++k) best.test(wr, buf[k], r.tmin, r.tmax);
      }
    c.prisms += 1;
    c.microTriangles += tested;
    c.cellsMarched += int64_t(cr.x1 - cr.x0 + 1) * (cr.y1 - cr.y0 + 1);
    OBLONG_STAT_INC(bfPrisms);
    OBLONG_STAT_ADD(bfMicroTris, tested);
    if (best.found) best.fill(hit);
    return best.found;
  }

 private:
  TraversalMesh mesh_;
};

// PDM-style fixed-step marching (Hoetzlein 2025, §4.2): the ray is sampled at a constant
// world-space step dt inside the exact prism; each sample is projected to the base
// triangle (point-wise inversion) and its height compared with the micro-geometry's
// height there; a sign change of (ray height − surface height) is refined by secant
// steps. Approximate by design (it can step over thin features and grazing hits): it is
// the "error against run time" baseline, excluded from exactness tests.
class FixedStep final : public Intersector {
 public:
  FixedStep(TraversalMesh mesh, float step, std::unique_ptr<Inverter> inv)
      : mesh_(std::move(mesh)), step_(step), inv_(std::move(inv)) {}
  std::string name() const override { return "fixedstep"; }
  size_t size() const override { return mesh_.tris.size(); }
  AABB bounds(uint32_t prim) const override { return mesh_.bounds(prim); }
  MemoryReport memory() const override { return {{"fixedstep/triangles", mesh_.bytes()}}; }

  // No range-query structure: a prism's heights are brute-force over its triangle's
  // samples, so only triangles whose samples meet the edit are scanned again (the
  // others keep their heights; all prisms are redone if the largest cell delta moved).
  Update update(const SampleRange& changed) override {
    const auto t0 = std::chrono::steady_clock::now();
    const Displacement& d = mesh_.disp;
    const int W = d.map->width(), H = d.map->height();
    Update u;
    u.triangles = mesh_.update(changed, [&](const DisplacedTriangle& T) {
      const SampleRange r = samplesOf(T, d);
      if (meetsWrapped(r.x0, r.x1, changed.x0, changed.x1, W) && meetsWrapped(r.y0, r.y1, changed.y0, changed.y1, H))
        return exactHeights(T, d);
      return mesh_.lastHeights[size_t(&T - mesh_.tris.data())];
    });
    u.prismSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return u;
  }

  bool intersect(const Ray& r, uint32_t prim, TriangleHit& hit, RayCounters& c) const override {
    const PrismParams& P = mesh_.params[prim];
    if (!P.valid) return false;
    const DisplacedTriangle& T = mesh_.tris[prim];
    const Displacement& d = mesh_.disp;
    c.prisms += 1;
    OBLONG_STAT_INC(fsPrisms);
    const dvec3 O(r.o), D(r.d);
    Prism::Crossing first, last;
    if (Prism::exact(T, P.a, P.b).crossings(O, D, first, last) < 2) return false;
    const double tIn = std::max(first.t, double(r.tmin)), tOut = std::min(last.t, double(r.tmax));
    if (!(tIn <= tOut)) return false;
    const LocalFrame F = LocalFrame::make(T, d);
    // Default step: one texel's world size (the shorter texel side) along the ray.
    double dt = step_;
    if (!(dt > 0)) dt = std::min(glm::length(F.PX), glm::length(F.PY));
    dt /= glm::length(D);
    // f(t) = height of the ray point above the micro-geometry at its projection.
    auto f = [&](double t, vec2& uv) -> double {
      ++c.inversions;
      const InversionResult q = inv_->invert(vec3(O + t * D), T);
      if (!std::isfinite(q.h) || !q.insideT(1e-4f)) return std::nan("");
      uv = q.uv;
      return double(q.h) - double(d.micro(q.uv));
    };
    vec2 uv0, uv1;
    double t0 = tIn, f0 = f(t0, uv0);
    int64_t steps = 0;
    while (t0 < tOut) {
      const double t1 = std::min(t0 + dt, tOut);
      const double f1 = f(t1, uv1);
      ++steps;
      if (std::isfinite(f0) && std::isfinite(f1) && (f0 == 0 || (f0 < 0) != (f1 < 0))) {
        // Secant refinement inside [t0, t1].
        double a = t0, fa = f0, b = t1, fb = f1, t = t1;
        vec2 uv = uv1;
        for (int it = 0; it < 6 && fb != fa; ++it) {
          t = std::clamp(b - fb * (b - a) / (fb - fa), std::min(a, b), std::max(a, b));
          vec2 uvt;
          const double ft = f(t, uvt);
          if (!std::isfinite(ft)) break;
          uv = uvt;
          if ((ft < 0) == (fa < 0)) a = t, fa = ft;
          else b = t, fb = ft;
        }
        c.cellsMarched += steps;
        OBLONG_STAT_ADD(fsSteps, steps);
        OBLONG_STAT_INC(fsHits);
        hit.t = float(t);
        hit.uv = uv;
        hit.ng = normalAt(T, uv, F);
        return true;
      }
      t0 = t1, f0 = f1, uv0 = uv1;
    }
    c.cellsMarched += steps;
    OBLONG_STAT_ADD(fsSteps, steps);
    return false;
  }

 private:
  // Normal of the micro-geometry around uv by finite differences over one texel
  // (S_u × S_v, the orientation of the micro-triangles).
  vec3 normalAt(const DisplacedTriangle& T, const vec2& uv, const LocalFrame& F) const {
    const Displacement& d = mesh_.disp;
    auto S = [&](const vec2& q) {
      const vec2 b = T.baryOfUV(q);
      return T.P(b.x, b.y) + d.micro(q) * glm::normalize(T.N(b.x, b.y));
    };
    const vec2 du(float(0.5 / F.perUV.x), 0.0f), dv(0.0f, float(0.5 / F.perUV.y));
    const vec3 n = glm::cross(S(uv + du) - S(uv - du), S(uv + dv) - S(uv - dv));
    const float len = glm::length(n);
    return len > 0 ? n / len : T.faceNormal;
  }

  TraversalMesh mesh_;
  float step_;
  std::unique_ptr<Inverter> inv_;
};

std::unique_ptr<Intersector> makeBruteForce(ParamSet&, const BaselineContext& ctx) {
  TraversalMesh mesh;
  const Displacement& disp = ctx.disp;
  mesh.build(std::move(*ctx.triangles), disp, [&](const DisplacedTriangle& T) { return exactHeights(T, disp); });
  warnSkippedTriangles(mesh, "bruteforce");
  return std::make_unique<BruteForce>(std::move(mesh));
}

std::unique_ptr<Intersector> makeFixedStep(ParamSet& params, const BaselineContext& ctx) {
  const TraversalConfig& cfg = ctx.config;
  const Displacement& disp = ctx.disp;
  // Errors name where the step came from: the scene's baseline parameters or --step.
  const std::string stepFrom = params.has("step") ? params.where() + ".step" : std::string("--step");
  const float step = params.get<float>("step", cfg.fixedStep);
  if (!(step >= 0) || !std::isfinite(step)) fail(stepFrom, "fixed step must be >= 0 (0: one texel), got {}", step);
  ParamSet ips(cfg.inverterParams, cfg.where("strategies.inverter"));
  auto inv = createInverter(cfg.inverter, ips);
  TraversalMesh mesh;
  mesh.build(std::move(*ctx.triangles), disp, [&](const DisplacedTriangle& T) { return exactHeights(T, disp); });
  warnSkippedTriangles(mesh, "fixedstep");
  if (step > 0) {  // bounded work: no step far below the smallest texel
    double texel = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < mesh.tris.size(); ++i)
      if (mesh.params[i].valid) {
        const LocalFrame F = LocalFrame::make(mesh.tris[i], disp);
        texel = std::min({texel, double(glm::length(F.PX)), double(glm::length(F.PY))});
      }
    if (std::isfinite(texel) && double(step) < kMinFixedStepTexels * texel)
      fail(stepFrom, "{} is below {} of the smallest texel's world size ({:g}): at least {:g}", step,
           kMinFixedStepTexels, texel, kMinFixedStepTexels * texel);
  }
  return std::make_unique<FixedStep>(std::move(mesh), step, std::move(inv));
}

}  // namespace

OBLONG_REGISTER_BASELINE("bruteforce", makeBruteForce,
                         StrategyTraits{.summary = "every micro-triangle of the triangle, no pruning: the oracle",
                                        .perRayLod = true});
OBLONG_REGISTER_BASELINE("fixedstep", makeFixedStep,
                         StrategyTraits{.summary = "PDM-style constant-step marching with secant refinement "
                                                   "(Hoetzlein 2025, Sec. 4.2; approximate)",
                                        .approximate = true});

}  // namespace oblong
