// The canonical traversal's work does not depend on how a mesh is turned (its boxes are in
// each triangle's texture frame, docs/traversal.md), and it does not explode with tiling.
// Step counts are deterministic: they are asserted, never times.
#include "core/procedural.h"
#include "tests/fixtures/traversal_cases.h"
#include "traversal/intersector.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include <random>

using namespace oblong;

namespace {

struct Found {
  TriangleHit h;
  uint32_t prim = ~0u;
};

// Closest hit over all triangles (world-box filtered, in index order) and the summed work.
bool traceAll(const Intersector& is, const Ray& r, Found& best, RayCounters& c) {
  return test::closest(is, r, best.h, best.prim, c);
}

test::Scenario rotated(const test::Scenario& s, const glm::mat3& R) {
  test::Scenario out{s.name, {}, s.disp};
  for (DisplacedTriangle T : s.tris) {
    for (int k = 0; k < 3; ++k) T.p[k] = R * T.p[k], T.n[k] = R * T.n[k];
    T.prepare();
    out.tris.push_back(T);
  }
  return out;
}

bool sameT(float a, float b) { return std::abs(a - b) <= 1e-5f * std::max({std::abs(a), std::abs(b), 1e-3f}); }

}  // namespace

TEST_CASE("orientation: a scene turned with its rays gives the same hits and the same canonical steps",
          "[conformance][orientation]") {
  // Two turns: one that takes the scenes' axis-aligned faces (the tiled quad's plane, the
  // tori's rims) off the axes, and one about a tilted axis.
  const glm::mat3 turns[] = {glm::mat3(glm::rotate(glm::mat4(1.0f), glm::radians(54.7356f), glm::normalize(vec3(1, 0, -1)))),
                             glm::mat3(glm::rotate(glm::mat4(1.0f), 1.1f, glm::normalize(vec3(0.3f, 1.0f, 2.0f))))};
  TraversalConfig oracle;
  oracle.baseline = "bruteforce";
  std::vector<test::Scenario> all = test::scenarios();
  // Shallow, fine relief on a flat mesh: where boxes in the world's axes, smeared by a
  // turn, would prune least (the heights are a small part of each box).
  all.push_back({"shallow quad", test::trianglesOf(planeMesh(vec2(2.0f), ivec2(2))),
                 Displacement{std::make_shared<const HeightMap>(proceduralHeightMap(64, 64, 3)), 0.01f, -0.5f, vec2(8.0f)}});
  for (const test::Scenario& s : all) {
    const auto bf = createIntersector(oracle, s.tris, s.disp);
    const std::vector<test::RayCase> cases = test::rayFamilies(s, *bf, 24, 41);
    const auto can = createIntersector(TraversalConfig{}, s.tris, s.disp);
    RayCounters c0;
    std::vector<Found> h0(cases.size());
    std::vector<bool> f0(cases.size());
    for (size_t i = 0; i < cases.size(); ++i) f0[i] = traceAll(*can, cases[i].r, h0[i], c0);
    for (const glm::mat3& R : turns) {
      const test::Scenario t = rotated(s, R);
      const auto canR = createIntersector(TraversalConfig{}, t.tris, t.disp);
      const auto bfR = createIntersector(oracle, t.tris, t.disp);
      RayCounters c1, cb;
      int agree = 0, exact = 0, outside = 0;
      for (size_t i = 0; i < cases.size(); ++i) {
        Ray r = cases[i].r;
        r.o = R * r.o, r.d = R * r.d;
        Found h, hb;
        const bool f = traceAll(*canR, r, h, c1), fb = traceAll(*bfR, r, hb, cb);
        exact += f == fb && (!f || (sameT(h.h.t, hb.h.t) && h.prim == hb.prim));
        // Rays from outside the shell (camera, grazing, along ±N): those that start on or
        // in the surface (spawned, shadow, inside) meet a micro-geometry that rounding of
        // the turned base mesh moves by ulps, at t near 0.
        if (cases[i].family > 2) continue;
        ++outside;
        agree += f == f0[i] && (!f || (sameT(h.h.t, h0[i].h.t) && h.prim == h0[i].prim));
      }
      const double ratio = double(c1.steps()) / double(std::max<int64_t>(1, c0.steps()));
      fmt::print("orientation, {}: {} rays, {} agree with the oracle; of {} from outside, {} agree with the unturned "
                 "scene; steps {} -> {} (x{:.3f})\n",
                 s.name, cases.size(), exact, outside, agree, c0.steps(), c1.steps(), ratio);
      CHECK(exact == int(cases.size()));  // exact on the turned scene
      // The turned micro-geometry is the unturned one up to float rounding of its base
      // mesh: a ray through a silhouette or an edge, or grazing the shallow relief, may
      // change its hit (at most 3 of 90 here).
      CHECK(agree >= outside * 95 / 100);
      CHECK(ratio <= 1.1);
      CHECK(ratio >= 1 / 1.1);
    }
  }
}

TEST_CASE("tiling: on a plane tiled 1e3 and 1e4 times canonical takes no more steps than tfdm", "[traversal][tiling]") {
  // A 64^2 uniform-noise map on a plane of size 2: at tiling 1e4 a texel is 3e-6, a few
  // float ulps of the plane's coordinates, and the traversal's rounding margin ε spans
  // many texels. The horizontal ray hits at its entry into the shell, the vertical one
  // at its first micro-triangle.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<float> texels(64 * 64);
  for (float& v : texels) v = U(rng);
  const auto map = std::make_shared<const HeightMap>(64, 64, std::move(texels));
  const std::vector<DisplacedTriangle> tris = test::trianglesOf(planeMesh(vec2(2.0f), ivec2(1)));
  const Ray rays[] = {{vec3(-1.5f, 0.005f, 0.1f), vec3(1, 0, 0), 0.0f, 100.0f},
                      {vec3(0.1f, 1.0f, 0.2f), vec3(0, -1, 0), 0.0f, 100.0f}};
  TraversalConfig tf;
  tf.baseline = "tfdm";
  for (float tiling : {1e3f, 1e4f}) {
    const Displacement d{map, 0.01f, 0.0f, vec2(tiling)};
    const auto can = createIntersector(TraversalConfig{}, tris, d);
    const auto tfdm = createIntersector(tf, tris, d);
    for (const Ray& r : rays) {
      RayCounters cc, ct;
      Found hc, ht;
      const bool fc = traceAll(*can, r, hc, cc), ft = traceAll(*tfdm, r, ht, ct);
      fmt::print("tiling {}: ray d=({}, {}, {}): canonical {} steps ({} boxes, {} cells, {} micro-triangles), "
                 "tfdm {} steps ({} boxes, {} cells, {} micro-triangles)\n",
                 tiling, r.d.x, r.d.y, r.d.z, cc.steps(), cc.boxes, cc.cellsMarched, cc.microTriangles, ct.steps(),
                 ct.boxes, ct.cellsMarched, ct.microTriangles);
      REQUIRE(fc);
      REQUIRE(ft);
      CHECK(hc.h.t == ht.h.t);
      CHECK(cc.steps() <= ct.steps());
    }
    // Exactness where ε spans texels (the wide-ε leaves, RayPatch::leaf), against tfdm (exact,
    // and affordable here where the brute force is not): rays from above at 5-85 degrees
    // and grazing rays at 0.5-6 degrees, same hit or miss and the same t, bit for bit.
    std::mt19937 rr(11);
    int n = 0, same = 0, hits = 0;
    for (int i = 0; i < 150; ++i) {
      const bool grazing = i % 3 == 0;
      const float a = (grazing ? 0.5f + 5.5f * U(rr) : 5.0f + 80.0f * U(rr)) * 3.14159265f / 180.0f;
      const float phi = 6.2831853f * U(rr);
      const vec3 target(1.8f * U(rr) - 0.9f, 0.01f * U(rr), 1.8f * U(rr) - 0.9f);
      const vec3 dir(std::cos(a) * std::cos(phi), -std::sin(a), std::cos(a) * std::sin(phi));
      const Ray r{target - 0.5f * dir, dir, 0.0f, 100.0f};
      RayCounters cc, ct;
      Found hc, ht;
      const bool fc = traceAll(*can, r, hc, cc), ft = traceAll(*tfdm, r, ht, ct);
      ++n;
      hits += fc;
      same += fc == ft && (!fc || hc.h.t == ht.h.t);
    }
    fmt::print("tiling {}: {} rays, {} hits, {} with the same hit or miss and t as tfdm\n", tiling, n, hits, same);
    CHECK(same == n);
    CHECK(hits > n / 2);
  }
}
