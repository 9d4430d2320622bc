#include "core/microgeometry.h"
#include "core/procedural.h"
#include "render/embree_scene.h"
#include "traversal/strategy_catalog.h"
#include "tests/fixtures/traversal_cases.h"

#include <catch2/catch.hpp>

#include <numbers>
#include <random>

using namespace oblong;

namespace {

double uvArea(const MicroTriangle& m) {
  const vec2 a = m.v[1].uv - m.v[0].uv, b = m.v[2].uv - m.v[0].uv;
  return 0.5 * std::abs(double(a.x) * b.y - double(a.y) * b.x);
}

DisplacedTriangle makeTriangle(vec2 t0, vec2 t1, vec2 t2) {
  DisplacedTriangle T;
  T.p[0] = vec3(0, 0, 0), T.p[1] = vec3(1.3f, 0.1f, 0), T.p[2] = vec3(0.2f, 1.1f, 0.3f);
  T.n[0] = glm::normalize(vec3(0.1f, -0.2f, 1.0f));
  T.n[1] = glm::normalize(vec3(-0.3f, 0.1f, 1.0f));
  T.n[2] = glm::normalize(vec3(0.2f, 0.3f, 1.0f));
  T.t[0] = t0, T.t[1] = t1, T.t[2] = t2;
  REQUIRE(T.prepare());
  return T;
}

}  // namespace

TEST_CASE("micro-triangles tile T's uv triangle and lie on Eq. 1", "[microgeometry][unit]") {
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(37, 23, 5));
  const Displacement d{map, 0.2f, -0.5f, vec2(2.0f, 3.0f)};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> U(-0.3f, 1.3f);
  for (int iter = 0; iter < 40; ++iter) {
    const DisplacedTriangle T = makeTriangle(vec2(U(rng), U(rng)), vec2(U(rng), U(rng)), vec2(U(rng), U(rng)));
    if (std::abs(T.uvArea2) < 1e-3f) continue;
    const auto tris = microTriangles(T, d);
    CAPTURE(iter, T.t[0].x, T.t[0].y, T.t[1].x, T.t[1].y, T.t[2].x, T.t[2].y);
    REQUIRE(!tris.empty());
    double area = 0;
    for (const auto& m : tris) {
      area += uvArea(m);
      for (const auto& v : m.v) {
        // Inside T (barycentrics within rounding) and on the displaced surface.
        const vec2 b = T.baryOfUV(v.uv);
        CHECK(b.x >= -1e-4f);
        CHECK(b.y >= -1e-4f);
        CHECK(b.x + b.y <= 1.0f + 1e-4f);
        const vec3 expect = T.P(b.x, b.y) + d.micro(v.uv) * glm::normalize(T.N(b.x, b.y));
        CHECK(glm::length(v.p - expect) < 2e-4f);
      }
    }
    CHECK(area == Approx(0.5 * std::abs(T.uvArea2)).epsilon(1e-4));
  }
}

TEST_CASE("cells wholly inside T are two flat triangles on the grid", "[microgeometry][unit]") {
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(16, 16, 2));
  const Displacement d{map, 0.1f, 0.0f, vec2(1.0f)};
  const DisplacedTriangle T = makeTriangle(vec2(0.0f), vec2(1.0f, 0.0f), vec2(0.0f, 1.0f));
  // Cell (3,3) .. (4,4) is deep inside: its two triangles have grid vertices only.
  const auto tris = microTriangles(T, d);
  int gridOnly = 0;
  for (const auto& m : tris) {
    bool all = true;
    for (const auto& v : m.v) {
      const dvec2 s = d.toSample(v.uv);
      all = all && std::abs(s.x - std::round(s.x)) < 1e-4 && std::abs(s.y - std::round(s.y)) < 1e-4;
    }
    gridOnly += all;
  }
  // 16x16 samples; the cells fully inside the half-square number about 15*14/2.
  CHECK(gridOnly >= 2 * (14 * 13) / 2);
}

// Through the pre-tessellation, the traversal (canonical, and the driver with TFDM's
// mipmap and quad-tree splits) and every exact baseline (tfdm, ...).
TEST_CASE("a cell's least corner per edge decides as all four corners do", "[microgeometry][unit]") {
  // MicroCells::interior tests one corner per edge (the computed σ·orient is monotone in
  // each coordinate): the same answer as testing the four corners, on every cell around
  // random triangles, with edges of every slope sign and of zero slope.
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(37, 23, 5));
  const Displacement d{map, 0.2f, -0.5f, vec2(2.0f, 3.0f)};
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> U(-0.3f, 1.3f);
  size_t cells = 0, inner = 0;
  for (int iter = 0; iter < 60; ++iter) {
    vec2 t[3] = {vec2(U(rng), U(rng)), vec2(U(rng), U(rng)), vec2(U(rng), U(rng))};
    if (iter % 3 == 1) t[1].y = t[0].y;  // a horizontal edge
    if (iter % 3 == 2) t[2].x = t[1].x;  // a vertical edge
    DisplacedTriangle T;
    T.p[0] = vec3(0, 0, 0), T.p[1] = vec3(1.3f, 0.1f, 0), T.p[2] = vec3(0.2f, 1.1f, 0.3f);
    for (int k = 0; k < 3; ++k) T.n[k] = vec3(0, 0, 1), T.t[k] = t[k];
    if (!T.prepare()) continue;
    const MicroCells mc(T, d);
    dvec2 S[3];
    for (int k = 0; k < 3; ++k) S[k] = d.toSample(t[k]);
    const auto orient = [](const dvec2& a, const dvec2& b, const dvec2& p) {
      return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    };
    const double side = orient(S[0], S[1], S[2]);
    const auto strictly = [&](const dvec2& p) {  // the definition: strictly inside every edge
      for (int e = 0; e < 3; ++e) {
        int A = e, B = (e + 1) % 3;
        if (t[B].x < t[A].x || (t[B].x == t[A].x && t[B].y < t[A].y)) std::swap(A, B);
        const double s = orient(S[A], S[B], S[3 - A - B]) > 0 ? 1.0 : -1.0;
        if (!(s * orient(S[A], S[B], p) > 0)) return false;
      }
      return true;
    };
    if (side == 0) continue;
    const dvec2 lo = glm::min(glm::min(S[0], S[1]), S[2]), hi = glm::max(glm::max(S[0], S[1]), S[2]);
    for (int j = int(std::floor(lo.y)) - 1; j <= int(std::floor(hi.y)) + 1; ++j)
      for (int i = int(std::floor(lo.x)) - 1; i <= int(std::floor(hi.x)) + 1; ++i) {
        const bool all = strictly(dvec2(i, j)) && strictly(dvec2(i + 1, j)) && strictly(dvec2(i, j + 1)) &&
                         strictly(dvec2(i + 1, j + 1));
        CHECK(mc.interior(i, j) == all);
        ++cells, inner += all;
      }
  }
  INFO(cells << " cells, " << inner << " interior");
  CHECK(inner > 100);
  CHECK(cells > 10 * inner / 9);
}

TEST_CASE("a closed displaced torus leaks no ray shot from inside", "[microgeometry][watertight][traversal]") {
  Scene s;
  SceneMesh torus;
  torus.mesh = torusMesh(1.0f, 0.4f, 24, 12);
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(61, 47, 9));  // odd sizes
  torus.displacement = Displacement{map, 0.15f, -0.5f, vec2(3.0f, 2.0f)};
  s.meshes.push_back(std::move(torus));
  AccelOptions tessellated = AccelOptions::withBaseline("tessellated"), canonical, driver;
  driver.traversal.range = "minmax_mipmap";
  driver.traversal.splitter = "quadtree";
  driver.traversal.inversionInTraversal = false;
  driver.traversal.marchingScale = 1.0f;
  std::vector<AccelOptions> all{tessellated, canonical, driver};
  for (const std::string& b : exactBaselines()) {
    AccelOptions o;
    o.traversal.baseline = b;
    all.push_back(o);
  }
  for (const AccelOptions& opts : all) {
    EmbreeScene accel(s, opts);
    INFO(accel.geometryName());
    if (opts.traversal.baseline == "tessellated") REQUIRE(accel.microTriangles() > 10000);
    // Origins on the tube's centre circle; the shell stays within 0.075 of radius 0.4.
    const int n = 20000, leaks = test::torusLeaks(accel, n);
    INFO(leaks << " of " << n << " rays leaked");
    CHECK(leaks == 0);
  }
}
