// Per-triangle conformance (docs/design.md invariant 1): every configuration of
// conformanceConfigs() (every registered strategy combination plus the shape variants,
// tests/fixtures/traversal_cases.h) against the brute-force Intersector, per base triangle, on
// every ray family, on the regular and the stiff scenarios. Same hit/miss, t within 1e-5
// relative (of max(|t|, 1e-3)); zero mismatches. The hidden tag [.large] runs many more
// rays per family; OBLONG_VERBOSE=1 prints per-configuration timings.
#include "core/microgeometry.h"
#include "core/procedural.h"
#include "core/stats.h"
#include "inversion/ceres.h"
#include "inversion/newton.h"
#include "traversal/intersector.h"
#include "traversal/prism.h"
#include "traversal/psi.h"
#include "traversal/traversal.h"
#include "strategies/quadtree.h"
#include "strategies/splitter.h"

#include "tests/fixtures/traversal_cases.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include <chrono>
#include <cstring>
#include <numbers>
#include <random>

using namespace oblong;
using namespace oblong::test;

namespace {

// Brute-force results per (ray, triangle) whose prism box the ray meets.
struct Reference {
  uint32_t ray, prim;
  bool hit;
  float t;
};
std::vector<Reference> reference(const Intersector& bf, const std::vector<RayCase>& rays) {
  std::vector<Reference> out;
  RayCounters c;
  for (uint32_t i = 0; i < rays.size(); ++i)
    for (uint32_t p = 0; p < bf.size(); ++p) {
      AABB b = bf.bounds(p);
      if (b.isEmpty()) continue;
      const vec3 e = 1e-4f * (b.extent() + vec3(1.0f));  // generous: this only filters
      b.lo -= e, b.hi += e;
      if (b.intersect(rays[i].r).isEmpty()) continue;
      TriangleHit h;
      const bool hit = bf.intersect(rays[i].r, p, h, c);
      out.push_back({i, p, hit, hit ? h.t : 0.0f});
    }
  return out;
}

bool sameT(float a, float b) { return std::abs(a - b) <= 1e-5f * std::max(std::abs(a), 1e-3f); }

struct Outcome {
  size_t pairs = 0, hits = 0, mismatches = 0;
  std::string first;
  RayCounters counters;
  double seconds = 0;
};

Outcome conformance(const Intersector& is, const std::vector<RayCase>& rays, const std::vector<Reference>& ref,
                    int stride) {
  Outcome o;
  const auto start = std::chrono::steady_clock::now();
  for (size_t k = 0; k < ref.size(); k += size_t(stride)) {
    const Reference& x = ref[k];
    const Ray& r = rays[x.ray].r;
    TriangleHit h;
    const bool hit = is.intersect(r, x.prim, h, o.counters);
    ++o.pairs;
    o.hits += x.hit;
    if (hit == x.hit && (!hit || sameT(h.t, x.t))) continue;
    if (o.mismatches++ == 0)
      o.first = fmt::format(
          "family '{}', ray {} o=({:.9g},{:.9g},{:.9g}) d=({:.9g},{:.9g},{:.9g}) t=[{:.9g},{:.9g}], triangle {}: "
          "bruteforce {} t={:.9g}, traversal {} t={:.9g}",
          kFamilies[rays[x.ray].family], x.ray, r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax, x.prim,
          x.hit ? "hit" : "miss", x.t, hit ? "hit" : "miss", h.t);
  }
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return o;
}

void runConformance(const std::vector<Scenario>& list, int count, bool verbose) {
  const auto configs = conformanceConfigs();
  for (const Scenario& s : list) {
    TraversalConfig bfc;
    bfc.baseline = "bruteforce";
    const auto bf = createIntersector(bfc, s.tris, s.disp);
    const auto rays = rayFamilies(s, *bf, count, 17);
    const auto ref = reference(*bf, rays);
    size_t hits = 0;
    for (const auto& x : ref) hits += x.hit;
    INFO(fmt::format("{}: {} rays, {} (ray, triangle) pairs, {} brute-force hits", s.name, rays.size(), ref.size(),
                     hits));
    REQUIRE(hits > ref.size() / 20);  // the families do hit the surface
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& [c, slow] : configs) {
      const auto is = createIntersector(c, s.tris, s.disp);
      const Outcome o = conformance(*is, rays, ref, slow ? kSlowStride : 1);
      if (verbose)
        fmt::print("  {:<14} {:<60} {:>7} pairs {:>6} hits {:>8.2f} us/pair  steps/pair {:.1f}  mismatches {}\n",
                   s.name, describe(c), o.pairs, o.hits, 1e6 * o.seconds / std::max<size_t>(o.pairs, 1),
                   double(o.counters.steps()) / std::max<size_t>(o.pairs, 1), o.mismatches);
      INFO(s.name << " / " << describe(c) << ": " << o.mismatches << " mismatches of " << o.pairs << "; first: "
                  << o.first);
      CHECK(o.mismatches == 0);
    }
    if (verbose)
      fmt::print("  {}: {:.2f} s for all configurations\n", s.name,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
}

}  // namespace

TEST_CASE("every strategy combination matches the brute force per triangle", "[traversal][conformance][bruteforce]") {
  runConformance(scenarios(), 60, false);
}

TEST_CASE("every strategy combination matches the brute force on stiff cases", "[traversal][conformance][bruteforce]") {
  runConformance(stiffScenarios(), 12, getenv("OBLONG_VERBOSE") != nullptr);
}

TEST_CASE("every strategy combination matches the brute force per triangle (large)", "[traversal][.large]") {
  runConformance(scenarios(), 3000, true);
  runConformance(stiffScenarios(), 600, true);
}

