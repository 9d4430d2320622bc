// The traversal's interfaces and baselines: splitter names and parameters, quadtree's
// aligned split, intersector names, bounds, memory and statistics, fixedstep's sanity, and
// the float traversal against a double-precision run (docs/design.md invariant 5).
#include "core/microgeometry.h"
#include "core/procedural.h"
#include "core/stats.h"
#include "inversion/ceres.h"
#include "inversion/newton.h"
#include "render/embree_scene.h"
#include "traversal/intersector.h"
#include "traversal/prism.h"
#include "traversal/psi.h"
#include "traversal/traversal.h"
#include "strategies/quadtree.h"
#include "strategies/splitter.h"

#include "tests/test_util.h"
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

TraversalConfig config(const std::string& range, const std::string& inv, const std::string& split) {
  TraversalConfig c;
  c.range = range, c.inverter = inv, c.splitter = split;
  return c;
}

}  // namespace

TEST_CASE("the named splitters are registered and validate their parameters",
          "[traversal][midpoint2d][midpoint3d][quadtree][unit]") {
  const auto names = splitterNames();
  REQUIRE(!names.empty());
  for (const std::string& n : names) CHECK(createSplitter(n)->name() == n);
  CHECK_THROWS_WITH(createSplitter("bisect"), Catch::Contains("unknown strategy 'bisect'"));
  ParamSet ps(nlohmann::json{{"depth", 3}}, "test: strategies.splitter");
  CHECK_THROWS_WITH(createSplitter("midpoint2d", ps), Catch::Contains("unknown parameter 'depth'"));
  // Unknown names of every kind fail when the intersector is built.
  const Scenario s = tiledQuad();
  CHECK_THROWS_WITH(createIntersector(config("rmip", "newton", "bisect"), s.tris, s.disp),
                    Catch::Contains("bisect"));
  TraversalConfig bad = config("rmip", "newton", "midpoint2d");
  bad.marchingScale = 0;
  CHECK_THROWS_WITH(createIntersector(bad, s.tris, s.disp), Catch::Contains("marching scale"));
  bad = config("rmip", "newton", "midpoint2d");
  bad.baseline = "tessellated";  // registered (render/embree_scene.cpp), but built by the scene
  CHECK_THROWS_WITH(createIntersector(bad, s.tris, s.disp), Catch::Contains("not an intersector"));
  // Baseline parameters are checked like strategy parameters.
  TraversalConfig b;
  b.baseline = "nope";
  CHECK_THROWS_WITH(createIntersector(b, s.tris, s.disp),
                    Catch::Contains("strategies.baseline") && Catch::Contains("'nope'") && Catch::Contains("tfdm"));
  b.baseline = "tfdm";
  b.baselineParams = {{"boxes", "diagonal"}};
  CHECK_THROWS_WITH(createIntersector(b, s.tris, s.disp), Catch::Contains("boxes") && Catch::Contains("diagonal"));
  b.baselineParams = {{"bogus", 1}};
  CHECK_THROWS_WITH(createIntersector(b, s.tris, s.disp), Catch::Contains("strategies.baseline") && Catch::Contains("bogus"));
  b.baselineParams = {{"bits", 8}};
  CHECK_THROWS_WITH(createIntersector(b, s.tris, s.disp), Catch::Contains("parameter 'bits' = 8 is not 16 or 32"));
  b.baselineParams = {{"boxes", "world"}, {"bits", 32}};
  CHECK_NOTHROW(createIntersector(b, s.tris, s.disp));
  b.baseline = "fixedstep";  // its step from a scene file's strategies.baseline
  b.baselineParams = {{"step", -1}};
  CHECK_THROWS_WITH(createIntersector(b, s.tris, s.disp), Catch::Contains("fixed step must be >= 0"));
  b.baselineParams = {{"step", "far"}};
  CHECK_THROWS_WITH(createIntersector(b, s.tris, s.disp), Catch::Contains("strategies.baseline") && Catch::Contains("step"));
}

TEST_CASE("quadtree splits on the coarsest node-aligned grid line", "[traversal][quadtree][unit]") {
  CHECK(Quadtree::alignedSplit(3.2, 9.7) == 8.0);
  CHECK(Quadtree::alignedSplit(-5.0, 3.0) == 0.0);
  CHECK(Quadtree::alignedSplit(17.5, 18.5) == 18.0);
  CHECK(std::isnan(Quadtree::alignedSplit(4.2, 4.8)));
}

TEST_CASE("intersectors report names, bounds and memory", "[traversal][unit]") {
  const Scenario s = torus();
  const auto is = createIntersector(config("safety_zones", "cubic", "quadtree"), s.tris, s.disp);
  CHECK(is->name() == "safety_zones+cubic+quadtree");
  CHECK(is->size() == s.tris.size());
  const MemoryReport m = is->memory();
  CHECK(totalBytes(m) > 0);
  bool tri = false;
  for (const auto& item : m) tri = tri || item.name == "traversal/triangles";
  CHECK(tri);
  TraversalConfig c;
  c.baseline = "bruteforce";
  CHECK(createIntersector(c, s.tris, s.disp)->name() == "bruteforce");
  c.baseline = "fixedstep";
  CHECK(createIntersector(c, s.tris, s.disp)->name() == "fixedstep");
  // Statistics carry the traversal/ prefix.
  Stats::reset();
  RayCounters rc;
  TriangleHit h;
  const Ray r{vec3(0, 2, 1.4f), glm::normalize(vec3(0, -1, 0)), 0, kInfinity};
  for (uint32_t p = 0; p < is->size(); ++p) is->intersect(r, p, h, rc);
#if OBLONG_STATS
  const auto snap = Stats::snapshot();
  CHECK(snap.at("traversal/Prisms") == rc.prisms);
  CHECK(snap.at("traversal/Boxes") == rc.boxes);
#endif
}

TEST_CASE("fixedstep approximates the surface", "[traversal][fixedstep][unit]") {
  const Scenario s = tiledQuad();
  TraversalConfig c;
  c.baseline = "bruteforce";
  const auto bf = createIntersector(c, s.tris, s.disp);
  c.baseline = "fixedstep";
  c.fixedStep = 0.002f;
  const auto fs = createIntersector(c, s.tris, s.disp);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> U(-0.9f, 0.9f);
  int agree = 0, n = 0;
  for (int i = 0; i < 200; ++i) {
    const Ray r{vec3(U(rng), 1.0f, U(rng)), glm::normalize(vec3(0.3f * U(rng), -1.0f, 0.3f * U(rng))), 0, kInfinity};
    TriangleHit a, b;
    const bool ha = closest(*bf, r, a), hb = closest(*fs, r, b);
    ++n;
    if (ha == hb && (!ha || std::abs(a.t - b.t) < 0.01f)) ++agree;
  }
  CHECK(agree >= n * 9 / 10);
}

TEST_CASE("tfdm: 16-bit codes take half the bytes of the float mipmap and give the same hits", "[traversal][tfdm][unit]") {
  // A power-of-two map (every level stored) and the torus' odd one (level 0 stored, the
  // levels above folded or answered by the float range query).
  const Scenario pow2{"quad, 64x64 map",
                      trianglesOf(quadMesh(1.0f, 0.0f, 3)),
                      Displacement{std::make_shared<const HeightMap>(proceduralHeightMap(64, 64, 5)), 0.1f, -0.5f, vec2(2.0f, 3.0f)}};
  for (const Scenario& s : {pow2, torus()}) {
    INFO(s.name);
    TraversalConfig c;
    c.baseline = "bruteforce";
    const auto bf = createIntersector(c, s.tris, s.disp);
    c.baseline = "tfdm";
    c.baselineParams = {{"bits", 32}};
    const auto f32 = createIntersector(c, s.tris, s.disp);
    c.baselineParams = nlohmann::json::object();  // the default: 16
    const auto f16 = createIntersector(c, s.tris, s.disp);
    CHECK(f16->describe().at("bits") == 16);
    CHECK(f32->describe().at("bits") == 32);
    auto mipmapBytes = [](const Intersector& is) {
      for (const MemoryItem& m : is.memory())
        if (m.name == "tfdm/mipmap") return m.bytes;
      return size_t(0);
    };
    CHECK(mipmapBytes(*f32) > 0);
    CHECK(mipmapBytes(*f16) * 2 == mipmapBytes(*f32));
    // The closest hit over the triangles whose (own) prism box the ray meets, as Embree
    // would call them, with the work counters.
    auto trace = [](const Intersector& is, const Ray& r, TriangleHit& best, RayCounters& c) {
      uint32_t prim;
      return closest(is, r, best, prim, c);
    };
    size_t hits = 0;
    RayCounters c16, c32;
    for (const RayCase& rc : rayFamilies(s, *bf, 40, 31)) {
      TriangleHit a, b;
      const bool ha = trace(*f16, rc.r, a, c16), hb = trace(*f32, rc.r, b, c32);
      REQUIRE(ha == hb);
      if (!ha) continue;
      ++hits;
      CHECK(std::memcmp(&a.t, &b.t, sizeof(float)) == 0);
      CHECK(std::memcmp(&a.uv, &b.uv, sizeof(vec2)) == 0);
      CHECK(std::memcmp(&a.ng, &b.ng, sizeof(vec3)) == 0);
    }
    CHECK(hits > 40);
    // Looser nodes, the same traversal: the work changes by a little.
    CHECK(c16.boxes + c16.cellsMarched >= c32.boxes + c32.cellsMarched);
    CHECK(c16.boxes + c16.cellsMarched <= 2 * (c32.boxes + c32.cellsMarched));
  }
}

namespace {

// Möller–Trumbore in double; the barycentric margin tells how far inside the hit lies.
bool hitDouble(const dvec3& o, const dvec3& d, const dvec3& a, const dvec3& b, const dvec3& c, double& t,
               double& margin) {
  const dvec3 e1 = b - a, e2 = c - a, pv = glm::cross(d, e2);
  const double det = glm::dot(e1, pv);
  if (det == 0.0) return false;
  const dvec3 tv = o - a, qv = glm::cross(tv, e1);
  const double u = glm::dot(tv, pv) / det, v = glm::dot(d, qv) / det;
  t = glm::dot(e2, qv) / det;
  margin = std::min({u, v, 1 - u - v});
  return margin >= 0 && t > 0;
}

// The micro-vertex of Eq. 1 at sample (i, j), in double throughout.
dvec3 microVertexDouble(const DisplacedTriangle& T, const Displacement& d, int i, int j) {
  const double W = double(d.map->width()) * d.tiling.x, H = double(d.map->height()) * d.tiling.y;
  const dvec2 uv((i + 0.5) / W, (j + 0.5) / H);
  const dvec2 t0(T.t[0]), t1(T.t[1]), t2(T.t[2]);
  const dvec2 e1 = t1 - t0, e2 = t2 - t0, r = uv - t0;
  const double det = e1.x * e2.y - e1.y * e2.x;
  const double bu = (r.x * e2.y - r.y * e2.x) / det, bv = (e1.x * r.y - e1.y * r.x) / det;
  const dvec3 P = dvec3(T.p[0]) * (1 - bu - bv) + dvec3(T.p[1]) * bu + dvec3(T.p[2]) * bv;
  const dvec3 N = dvec3(T.n[0]) * (1 - bu - bv) + dvec3(T.n[1]) * bu + dvec3(T.n[2]) * bv;
  const double h = double(d.scale) * (double(d.map->at(i, j)) + double(d.bias));
  return P + h * glm::normalize(N);
}

}  // namespace

// docs/design.md invariant 5: the float bounds (padded, see docs/traversal.md) are checked
// against a double-precision run. The micro-geometry of the cells wholly inside a
// triangle is rebuilt in double and intersected in double; every hit found there with a
// clear margin (not within float noise of a micro-edge) must be found by the float
// traversal at the same t, unless it finds a hit in front of it. Also: every double
// micro-vertex lies inside the float prism AABB handed to Embree.
TEST_CASE("float traversal loses no hit of a double-precision run", "[traversal][precision][minmax_mipmap][unit]") {
  for (const Scenario& s : {torus(), twisted(), rotatedUVs()}) {
    INFO(s.name);
    std::vector<std::unique_ptr<Intersector>> configs;
    configs.push_back(createIntersector(config("rmip", "newton", "midpoint2d"), s.tris, s.disp));
    TraversalConfig driver = config("minmax_mipmap", "newton", "quadtree");
    driver.inversionInTraversal = false;
    driver.marchingScale = 1.0f;
    configs.push_back(createIntersector(driver, s.tris, s.disp));
    for (const std::string& b : exactBaselines()) {
      TraversalConfig c;
      c.baseline = b;
      configs.push_back(createIntersector(c, s.tris, s.disp));
    }
    // The double micro-triangles of interior cells, and the AABB check.
    struct Tri {
      dvec3 a, b, c;
    };
    std::vector<Tri> tris;
    int outside = 0;
    for (uint32_t p = 0; p < s.tris.size(); ++p) {
      const DisplacedTriangle& T = s.tris[p];
      const MicroCells mc(T, s.disp);
      const CellRange cr = cellsOverlapping(T, s.disp);
      const AABB box = configs[0]->bounds(p);
      for (int j = cr.y0; j <= cr.y1; ++j)
        for (int i = cr.x0; i <= cr.x1; ++i) {
          if (!mc.interior(i, j)) continue;
          const dvec3 v00 = microVertexDouble(T, s.disp, i, j), v10 = microVertexDouble(T, s.disp, i + 1, j);
          const dvec3 v11 = microVertexDouble(T, s.disp, i + 1, j + 1), v01 = microVertexDouble(T, s.disp, i, j + 1);
          for (const dvec3& v : {v00, v10, v11, v01})
            for (int k = 0; k < 3; ++k) outside += v[k] < double(box.lo[k]) || v[k] > double(box.hi[k]);
          tris.push_back({v00, v10, v11});
          tris.push_back({v00, v11, v01});
        }
    }
    CHECK(outside == 0);
    REQUIRE(tris.size() > 1000);
    std::mt19937 rng(41);
    AABB all;
    for (uint32_t p = 0; p < s.tris.size(); ++p) all.extend(configs[0]->bounds(p));
    const vec3 c = 0.5f * (all.lo + all.hi);
    const float diag = glm::length(all.extent());
    int robust = 0, lost = 0;
    for (int k = 0; k < 300; ++k) {
      const vec3 o = c + 1.5f * diag * randomDir(rng);
      const vec3 target = randomBasePoint(s, rng).p;
      const Ray r{o, glm::normalize(target - o), 0.0f, kInfinity};
      double best = std::numeric_limits<double>::infinity(), bestMargin = 0;
      for (const Tri& t : tris) {
        double th, m;
        if (hitDouble(dvec3(r.o), dvec3(r.d), t.a, t.b, t.c, th, m) && th < best) best = th, bestMargin = m;
      }
      if (!(best < 1e30) || bestMargin < 1e-3) continue;  // no hit, or within float noise of an edge
      ++robust;
      for (const auto& is : configs) {
        TriangleHit h;
        const bool found = closest(*is, r, h);
        // A hit in front is allowed (cells crossing T's edges are not in the double set).
        if (!found || h.t > best * (1 + 1e-4)) ++lost;
      }
    }
    INFO(robust << " robust double hits");
    CHECK(robust > 50);
    CHECK(lost == 0);
  }
}

TEST_CASE("a scene updated after map edits traces as one built on the edited map", "[traversal][update]") {
  // The default scene's torus (tiled map: wrapping queries) and the asteroid, each with
  // the default rmip and rmip 32-bit: brushes anywhere, crossing the border, some leaving
  // the map's range (everything re-encoded, every prism recomputed). Per triangle: the same
  // bounds, hits and work as a fresh build; per scene (the BVH refitted, not rebuilt, so
  // prisms may be visited in another order): the same hits.
  for (const char* which : {"default", "asteroid"})
    for (const char* params : {"{}", R"({"bits":32})", R"({"layout":"corners","compression":0})"}) {
      Scene scene = std::string(which) == "default" ? defaultScene() : loadScene(shippedScene("asteroid.json"));
      const auto src = scene.meshes[0].displacement->map;
      auto map = std::make_shared<HeightMap>(src->width(), src->height(), src->texels(), src->name());
      scene.meshes[0].displacement->map = map;
      scene.range.params = nlohmann::json::parse(params);
      const AccelOptions opts{traversalConfigOf(scene)};
      EmbreeScene updated(scene, opts);
      const Mesh& mesh = scene.meshes[0].mesh;
      auto triangles = [&] {
        std::vector<DisplacedTriangle> t(mesh.triangles.size());
        for (size_t i = 0; i < t.size(); ++i) t[i] = mesh.triangle(i);
        return t;
      };
      const auto isect = createIntersector(opts.traversal, triangles(), *scene.meshes[0].displacement);
      const int W = map->width(), H = map->height();
      const Interval range = map->range();
      std::mt19937 rng(17);
      size_t rebuilt = 0;
      for (int stroke = 0; stroke < 4; ++stroke) {
        std::uniform_int_distribution<int> x(-W / 4, W), y(-H / 4, H), side(1, std::max(2, W / 8));
        const int x0 = x(rng), y0 = y(rng), w = side(rng), h = side(rng);
        const float lo = stroke == 3 ? range.lo - 0.3f * range.width() : range.lo;
        std::uniform_real_distribution<float> v(lo, range.hi);
        for (int j = y0; j < y0 + h; ++j)
          for (int i = x0; i < x0 + w; ++i) map->set(i, j, v(rng));
        const SampleRange changed{x0, y0, x0 + w - 1, y0 + h - 1};
        const EmbreeScene::UpdateTimes t = updated.update(0, changed);
        rebuilt += t.triangles;
        const Intersector::Update u = isect->update(changed);
        CHECK(u.triangles.size() == t.triangles);
        const EmbreeScene fresh(scene, opts);
        const auto freshIsect = createIntersector(opts.traversal, triangles(), *scene.meshes[0].displacement);
        {
          const auto* ta = dynamic_cast<const TraversalIntersectorBase*>(isect.get());
          const auto* tb = dynamic_cast<const TraversalIntersectorBase*>(freshIsect.get());
          REQUIRE((ta && tb));
          const auto sa = ta->rangeQuery().storage(), sb = tb->rangeQuery().storage();
          INFO(which << " " << params << " stroke " << stroke << " [" << changed.x0 << "," << changed.x1 << "]x[" << changed.y0 << "," << changed.y1 << "] needs " << ta->rangeQuery().needs().maxExtentX << " " << ta->rangeQuery().needs().maxExtentY << " " << ta->rangeQuery().needs().wrap);
          REQUIRE(sa.size() == sb.size());
          REQUIRE(std::equal(sa.begin(), sa.end(), sb.begin()));
          REQUIRE(ta->mesh().cellDelta == tb->mesh().cellDelta);
          REQUIRE(ta->mesh().lastDelta == tb->mesh().lastDelta);
        }
        for (uint32_t i = 0; i < isect->size(); ++i) {
          const AABB a = isect->bounds(i), b = freshIsect->bounds(i);
          INFO(which << " " << params << " stroke " << stroke << " triangle " << i);
          REQUIRE((a.lo == b.lo && a.hi == b.hi));
        }
        // Rays aimed at random points of the mesh from around the camera.
        int hits = 0, rays = 0;
        std::uniform_int_distribution<size_t> tri(0, mesh.triangles.size() - 1);
        std::uniform_real_distribution<float> u01(0.0f, 1.0f);
        for (int k = 0; k < 700; ++k) {
          const glm::uvec3& T = mesh.triangles[tri(rng)];
          float a = u01(rng), b = u01(rng);
          if (a + b > 1) a = 1 - a, b = 1 - b;
          const vec3 p = mesh.positions[T.x] * (1 - a - b) + mesh.positions[T.y] * a + mesh.positions[T.z] * b;
          const vec3 o = scene.camera.from + vec3(u01(rng) - 0.5f, u01(rng) - 0.5f, u01(rng) - 0.5f) * 0.5f;
          Ray r;
          r.o = o, r.d = p - o, r.tmin = 0.0f, r.tmax = kInfinity;
          const Hit ha = updated.intersect(r), hb = fresh.intersect(r);
          INFO(which << " " << params << " stroke " << stroke << " ray " << k);
          REQUIRE(ha.mesh == hb.mesh);
          REQUIRE(ha.prim == hb.prim);
          REQUIRE(ha.t == hb.t);
          REQUIRE(ha.uv == hb.uv);
          hits += ha.valid(), ++rays;
          // The triangle aimed at, and the one hit: same hit, same work.
          for (uint32_t prim : {uint32_t(&T - mesh.triangles.data()), uint32_t(std::max(ha.prim, 0))}) {
            TriangleHit ta, tb;
            RayCounters ca, cb;
            const bool a1 = isect->intersect(r, prim, ta, ca), b1 = freshIsect->intersect(r, prim, tb, cb);
            REQUIRE(a1 == b1);
            REQUIRE(ta.t == tb.t);
            REQUIRE(ca.steps() == cb.steps());
            REQUIRE(ca.rangeQueries == cb.rangeQueries);
          }
        }
        CHECK(hits > rays / 5);
      }
      CHECK(rebuilt > 0);  // the last stroke leaves the map's range: every prism at least
    }
}

TEST_CASE("a 4320x2161 float relief on a sphere: rmip within 1.5x a 16-bit mipmap, hits as tfdm's", "[traversal][scale]") {
  // The size of the real relief maps users bring (a 4k-class equirectangular EXR, not a
  // power of two, wrapping in u): the default rmip's bytes against a full 16-bit mipmap
  // (the RMIP paper's Table 1 accounting), and its hits against the exact tfdm baseline.
  const auto dir = test::scratchDir("scale_relief");
  const int W = 4320, H = 2161;
  std::vector<float> v(size_t(W) * H);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const double x = 2 * std::numbers::pi * i / W, y = std::numbers::pi * j / H;
      v[size_t(j) * W + i] = float(1200.0 * std::sin(7 * x) * std::sin(3 * y) + 300.0 * std::sin(61 * x + 43 * y) +
                                   40.0 * std::cos(397 * x - 211 * y) + 9.0 * ((i * 2654435761u + j) % 97) / 97.0);
    }
  const std::string map = (dir / "relief.exr").string();
  test::writeGray(map, W, H, v, OIIO::TypeDesc::FLOAT);
  const nlohmann::json doc = {
      {"camera", {{"from", {0.0, 0.4, 3.2}}, {"to", {0, 0, 0}}, {"up", {0, 1, 0}}, {"fov", 40}}},
      {"meshes",
       {{{"shape", {{"type", "sphere"}, {"radius", 1}, {"segments", {96, 48}}}},
         {"displacement", {{"map", map}, {"scale", 0.00004}, {"bias", 0.0}}}}}}};
  Scene scene = parseScene(doc, (dir / "relief.json").string());
  const AccelOptions opts{traversalConfigOf(scene)};
  const EmbreeScene rmip(scene, opts);
  const nlohmann::json d = rmip.describe().at(0).at("range");
  INFO(d.dump());
  CHECK(d.at("layout").at("ratio_to_mipmap16").get<double>() <= 1.5);
  CHECK(d.at("bytes").get<size_t>() < size_t(W) * H * 5);
  AccelOptions tfdmOpts = opts;
  tfdmOpts.traversal.baseline = "tfdm";
  const EmbreeScene tfdm(scene, tfdmOpts);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int hits = 0;
  for (int k = 0; k < 3000; ++k) {
    // Camera-like rays and grazing rays skimming the relief.
    Ray r;
    if (k % 3) {
      r.o = scene.camera.from, r.d = vec3(u(rng), u(rng), 0.0f) * 1.1f - scene.camera.from;
    } else {
      const vec3 p = glm::normalize(vec3(u(rng), u(rng), u(rng)));
      const vec3 t = glm::normalize(glm::cross(p, vec3(0.3f, 1.0f, 0.2f)));
      r.o = p * 1.03f - t * 2.0f, r.d = t + p * (0.01f * u(rng));
    }
    const Hit a = rmip.intersect(r), b = tfdm.intersect(r);
    INFO("ray " << k);
    REQUIRE(a.mesh == b.mesh);
    REQUIRE(a.prim == b.prim);
    REQUIRE(a.t == Approx(b.t).epsilon(1e-5));
    hits += a.valid();
  }
  CHECK(hits > 1000);
  std::filesystem::remove_all(dir);
}

TEST_CASE("curve points between known ones are claimed: the inverter is the fallback", "[traversal][claims][unit]") {
  // Every point the canonical traversal needs between two known curve points (a clipped
  // end of a piece, an end of the ray inside the prism) and the marching stop's point
  // are claimed and validated by their residual (curvePointAt on a pending point).
  // Without the claims these rays invert 0.45-1.05 times per prism traversed, with them
  // 0.014-0.092 (the coarse torus's big curved triangles the most); the bound fails if
  // the claims stop validating, which exactness would not show (the inverter answers).
  for (const Scenario& s : scenarios()) {
    INFO(s.name);
    TraversalConfig bfc;
    bfc.baseline = "bruteforce";
    const auto bf = createIntersector(bfc, s.tris, s.disp);
    const auto canonical = createIntersector(TraversalConfig{}, s.tris, s.disp);
    RayCounters c;
    size_t traversed = 0;
    for (const RayCase& rc : rayFamilies(s, *bf, 40, 17))
      for (uint32_t p = 0; p < s.tris.size(); ++p) {
        RayCounters one;
        TriangleHit h;
        canonical->intersect(rc.r, p, h, one);
        traversed += one.boxes + one.cellsMarched + one.inversions > 0;
        c += one;
      }
    const double perPrism = double(c.inversions) / double(traversed);
    INFO(traversed << " prisms traversed, " << c.inversions << " inversions");
    CHECK(traversed > 200);
    CHECK(perPrism < 0.15);
  }
}

TEST_CASE("rays from 1e6 and 1e7 away hit as rays from nearby", "[traversal][far][unit]") {
  // The plane of size 2 under a 32x32 map (heights 0..0.3); rays from far away, steep
  // enough to cross the shell inside the plane, each also started near the plane on
  // the same float line: same hit (t within float rounding of the near ray's).
  Scene s;
  s.path = "<far rays>";
  SceneMesh q;
  q.mesh = quadMesh(1.0f, 0.0f, 1);
  q.displacement = Displacement{std::make_shared<const HeightMap>(proceduralHeightMap(32, 32, 4)), 0.3f, 0.0f, vec2(1.0f)};
  s.meshes.push_back(std::move(q));
  AccelOptions bf, tess;
  bf.traversal.baseline = "bruteforce";
  tess.traversal.baseline = "tessellated";
  const EmbreeScene canonical(s, AccelOptions{}), brute(s, bf), tessellated(s, tess);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> U(-0.1f, 0.1f);
  for (const double far : {1e6, 1e7}) {
    size_t missed[3] = {0, 0, 0}, off[3] = {0, 0, 0};
    std::string first;
    for (int i = 0; i < 300; ++i) {
      vec3 w;
      do w = randomDir(rng);
      while (w.y < 0.5f);
      const dvec3 target(U(rng), 0.15, U(rng));
      const Ray r{vec3(target + far * dvec3(w)), vec3(target - dvec3(vec3(target + far * dvec3(w)))), 0.0f, kInfinity};
      // The same float line started at t = 1 - 2/far (about 2 units before the target).
      const double s0 = 1.0 - 2.0 / far;
      const Ray nearRay{vec3(dvec3(r.o) + s0 * dvec3(r.d)), r.d, 0.0f, kInfinity};
      const Hit ref = brute.intersect(nearRay);
      REQUIRE(ref.valid());
      const EmbreeScene* scenes[3] = {&canonical, &brute, &tessellated};
      for (int k = 0; k < 3; ++k) {
        const Hit h = scenes[k]->intersect(r);
        // The near ray's line differs from the far one by the rounding of its origin
        // (ulp 2^-22 at 2 units): t agrees to that over |d| = far, and to float t.
        const double expect = s0 + double(ref.t);
        if (!h.valid()) ++missed[k];
        else if (std::abs(double(h.t) - expect) > 1e-6 * expect) ++off[k];
        else continue;
        if (first.empty())
          first = fmt::format("ray {} ({}): {} t={}, expected {}", i, k, h.valid() ? "hit" : "miss", h.t, expect);
      }
    }
    INFO("from " << far << ": missed (canonical, bruteforce, tessellated) " << missed[0] << ", " << missed[1] << ", "
                 << missed[2] << "; t off " << off[0] << ", " << off[1] << ", " << off[2] << " of 300; " << first);
    CHECK(missed[0] + missed[1] + missed[2] == 0);
    CHECK(off[0] + off[1] + off[2] == 0);
  }
}
