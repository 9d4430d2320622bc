// docs/extending.md's examples, compiled from the page itself (scripts/doc_examples.py
// extracts its ```cpp blocks into this program, oblong_docs_tests, and nowhere else) and
// run: registered by name, the range query's update against a fresh build, and the
// traversal of the three example strategies and the example baseline against the brute
// force, per (ray, triangle) pair, on a few hundred rays (as tests/traversal_conformance_test.cpp
// does for every registered combination).
#include "core/procedural.h"
#include "inversion/inverter.h"
#include "strategies/range_query.h"
#include "strategies/splitter.h"
#include "traversal/intersector.h"
#include "traversal/strategy_catalog.h"

#include "tests/fixtures/traversal_cases.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <memory>
#include <random>

using namespace oblong;
using namespace oblong::test;

namespace {

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

bool sameT(float a, float b) { return std::abs(a - b) <= 1e-5f * std::max(std::abs(a), 1e-3f); }

// Mismatches of `is` against the brute force on every (ray, triangle) pair whose prism
// box the ray meets; `pairs` and `hits` count what was compared.
size_t mismatches(const Intersector& is, const Intersector& bf, const std::vector<RayCase>& rays, size_t& pairs,
                  size_t& hits) {
  size_t bad = 0;
  RayCounters c;
  for (const RayCase& rc : rays)
    for (uint32_t p = 0; p < bf.size(); ++p) {
      AABB b = bf.bounds(p);
      if (b.isEmpty()) continue;
      const vec3 e = 1e-4f * (b.extent() + vec3(1.0f));
      b.lo -= e, b.hi += e;
      if (b.intersect(rc.r).isEmpty()) continue;
      TriangleHit hb, hi;
      const bool xb = bf.intersect(rc.r, p, hb, c), xi = is.intersect(rc.r, p, hi, c);
      ++pairs;
      hits += xb;
      bad += xb != xi || (xb && !sameT(hb.t, hi.t));
    }
  return bad;
}

}  // namespace

TEST_CASE("docs/extending.md: the examples are registered and selectable by name", "[docs]") {
  CHECK(contains(rangeQueryNames(), "whole_map"));
  CHECK(contains(inverterNames(), "fixed_newton"));
  CHECK(contains(splitterNames(), "one_third"));
  CHECK(contains(baselineNames(), "oracle_copy"));
  CHECK(strategyChoices(StrategyKind::Range).find("whole_map") != std::string::npos);
  // Unknown parameters are errors; known ones are read within their range.
  ParamSet bad(nlohmann::json{{"step", 3}}, "test");
  CHECK_THROWS(createInverter("fixed_newton", bad));
  ParamSet outOfRange(nlohmann::json{{"steps", 0}}, "test");
  CHECK_THROWS(createInverter("fixed_newton", outOfRange));
}

TEST_CASE("docs/extending.md: the example range query is conservative and updates to a fresh build", "[docs]") {
  auto map = std::make_shared<HeightMap>(proceduralHeightMap(37, 29, 5));
  const Displacement disp{map, 0.2f, -0.5f, vec2(3.0f, 2.0f)};
  ParamSet ps(nlohmann::json::object(), "test");
  auto q = createRangeQuery("whole_map", ps, RangeQueryContext{disp, QueryNeeds::all(*map)});
  REQUIRE(q->name() == "whole_map");
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> at(-40, 80), len(0, 50);
  for (int k = 0; k < 200; ++k) {
    const int x0 = at(rng), y0 = at(rng);
    const SampleRange r{x0, y0, x0 + len(rng), y0 + len(rng)};
    CHECK(q->rawRange(r).contains(bruteForceRange(*map, r)));
  }
  // A brush stroke that raises the maximum, then one that lowers it again.
  for (float v : {3.0f, 0.1f}) {
    for (int j = 10; j < 14; ++j)
      for (int i = 30; i < 40; ++i) map->set(i, j, v);  // crosses the border (width 37)
    q->update(SampleRange{30, 10, 39, 13});
    ParamSet fresh(nlohmann::json::object(), "test");
    const auto f = createRangeQuery("whole_map", fresh, RangeQueryContext{disp, QueryNeeds::all(*map)});
    const auto a = q->storage(), b = f->storage();
    REQUIRE(a.size() == b.size());
    CHECK(std::memcmp(a.data(), b.data(), a.size()) == 0);
  }
}

TEST_CASE("docs/extending.md: the example strategies and baseline give the brute force's hits", "[docs]") {
  TraversalConfig examples;
  examples.range = "whole_map", examples.inverter = "fixed_newton", examples.splitter = "one_third";
  TraversalConfig copy;
  copy.baseline = "oracle_copy";
  TraversalConfig bfc;
  bfc.baseline = "bruteforce";
  for (const Scenario& s : {tiledQuad(), torus()}) {
    const auto bf = createIntersector(bfc, s.tris, s.disp);
    const auto rays = rayFamilies(s, *bf, 6, 11);
    for (const TraversalConfig& c : {examples, copy}) {
      const auto is = createIntersector(c, s.tris, s.disp);
      size_t pairs = 0, hits = 0;
      const size_t bad = mismatches(*is, *bf, rays, pairs, hits);
      INFO(s.name << " / " << is->name() << ": " << bad << " mismatches of " << pairs << " pairs, " << hits
                  << " brute-force hits");
      CHECK(bad == 0);
      CHECK(hits > 20);
    }
  }
}
