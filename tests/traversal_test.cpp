// The traversal (issue 4; DESIGN invariants 1, 2, 5): every strategy combination against
// the brute-force Intersector, per base triangle, on every ray family; the prism and the
// shell analysis against the micro-geometry; ψ's monotone split; the splitters; the
// allocation-free MicroCells against forEachMicroTriangle.
//
// Conformance: same hit/miss, t within 1e-5 relative (of max(|t|, 1e-3)). Zero
// mismatches. fixedstep is approximate by design and only checked for sanity. The hidden
// tag [.large] runs many more rays per family.
#include "core/microgeometry.h"
#include "core/procedural.h"
#include "core/stats.h"
#include "inversion/ceres.h"
#include "inversion/newton.h"
#include "render/embree_scene.h"
#include "render/intersector.h"
#include "render/prism.h"
#include "render/psi.h"
#include "render/rect_bounds.h"
#include "render/traversal.h"
#include "strategies/quadtree.h"
#include "strategies/splitter.h"

#include "tests/traversal_cases.h"

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

TEST_CASE("every strategy combination matches the brute force per triangle", "[traversal][conformance]") {
  runConformance(scenarios(), 60, false);
}

TEST_CASE("every strategy combination matches the brute force on stiff cases", "[traversal][conformance]") {
  runConformance(stiffScenarios(), 12, getenv("OBLONG_VERBOSE") != nullptr);
}

TEST_CASE("every strategy combination matches the brute force per triangle (large)", "[traversal][.large]") {
  runConformance(scenarios(), 3000, true);
  runConformance(stiffScenarios(), 600, true);
}

TEST_CASE("the named splitters are registered and validate their parameters",
          "[traversal][midpoint2d][midpoint3d][quadtree]") {
  const auto names = splitterNames();
  for (const std::string n : {"midpoint2d", "midpoint3d", "quadtree"}) {
    CHECK(std::find(names.begin(), names.end(), n) != names.end());
    CHECK(createSplitter(n)->name() == n);
  }
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
  bad.baseline = "tessellated";
  CHECK_THROWS_WITH(createIntersector(bad, s.tris, s.disp), Catch::Contains("unknown baseline"));
}

TEST_CASE("quadtree splits on the coarsest node-aligned grid line", "[traversal][quadtree]") {
  CHECK(Quadtree::alignedSplit(3.2, 9.7) == 8.0);
  CHECK(Quadtree::alignedSplit(-5.0, 3.0) == 0.0);
  CHECK(Quadtree::alignedSplit(17.5, 18.5) == 18.0);
  CHECK(std::isnan(Quadtree::alignedSplit(4.2, 4.8)));
}

TEST_CASE("intersectors report names, bounds and memory", "[traversal]") {
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

TEST_CASE("MicroCells gives forEachMicroTriangle's triangles bit for bit", "[traversal][microgeometry]") {
  for (const Scenario& s : {torus(), tiledQuad()}) {
    for (size_t k = 0; k < s.tris.size(); k += 7) {
      const DisplacedTriangle& T = s.tris[k];
      std::vector<MicroTriangle> a, b;
      forEachMicroTriangle(T, s.disp, [&](const MicroTriangle& m) { a.push_back(m); });
      const MicroCells mc(T, s.disp);
      const CellRange r = cellsOverlapping(T, s.disp);
      MicroTriangle buf[MicroCells::kMaxPerCell];
      for (int j = r.y0; j <= r.y1; ++j)
        for (int i = r.x0; i <= r.x1; ++i) {
          const int n = mc.cell(i, j, buf);
          b.insert(b.end(), buf, buf + n);
        }
      REQUIRE(a.size() == b.size());
      CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(MicroTriangle)) == 0);
    }
  }
}

TEST_CASE("prisms contain the micro-geometry and the shell analysis bounds bulge and projection",
          "[traversal][prism]") {
  const Newton newtonD;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (const Scenario& s : scenarios()) {
    TraversalConfig bfc;
    bfc.baseline = "bruteforce";
    const auto bf = createIntersector(bfc, s.tris, s.disp);
    const float delta = maxCellDelta(*s.disp.map);
    size_t wellPosed = 0, outsideExact = 0, points = 0;
    double maxEps = 0;
    for (size_t k = 0; k < s.tris.size(); ++k) {
      const DisplacedTriangle& T = s.tris[k];
      const AABB box = bf->bounds(uint32_t(k));
      const auto micro = microTriangles(T, s.disp);
      // Heights as the traversal's prism gets them (exact over T's snapped uv box).
      Interval h;
      for (const auto& m : micro)
        for (const auto& v : m.v) h.extend(s.disp.micro(v.uv));
      for (const auto& m : micro)
        for (const auto& v : m.v) REQUIRE(box.contains(v.p));
      const PrismParams P = analyzeShell(T, s.disp, h, delta);
      REQUIRE(P.valid);
      if (!P.wellPosed) continue;
      ++wellPosed;
      const LocalFrame F = LocalFrame::make(T, s.disp);
      maxEps = std::max({maxEps, P.eps.x, P.eps.y});
      // Points of micro-triangles (vertices and random interior points): their preimage
      // lies in T_δ × [a − Δs, b + Δs] and within ε of their cell.
      for (size_t i = 0; i < micro.size(); i += 3) {
        const MicroTriangle& m = micro[i];
        const dvec2 s0 = s.disp.toSample(m.v[0].uv), s1 = s.disp.toSample(m.v[1].uv), s2 = s.disp.toSample(m.v[2].uv);
        const dvec2 cell = glm::floor((s0 + s1 + s2) / 3.0);
        for (int q = 0; q < 4; ++q) {
          double l1 = U(rng), l2 = U(rng);
          if (l1 + l2 > 1) l1 = 1 - l1, l2 = 1 - l2;
          if (q == 0) l1 = l2 = 0;
          const dvec3 X = (1 - l1 - l2) * dvec3(m.v[0].p) + l1 * dvec3(m.v[1].p) + l2 * dvec3(m.v[2].p);
          const InversionResultD r = newtonD.invertD(X, T);
          REQUIRE(r.converged);
          const double sv = r.h / glm::length(F.N(r.bary));
          const double dT = P.inflateB + 1e-9, dS = P.inflateS + 1e-9 * (1 + std::abs(sv));
          ++points;
          if (r.outside() > 1e-7 || sv < P.a - 1e-7 || sv > P.b + 1e-7) ++outsideExact;
          INFO(s.name << " triangle " << k << " point " << X.x << "," << X.y << "," << X.z);
          CHECK(r.outside() <= dT);
          CHECK(sv >= P.a - dS);
          CHECK(sv <= P.b + dS);
          const dvec2 loc = F.local(r.bary) + dvec2(F.origin);
          CHECK(loc.x >= cell.x - P.eps.x - 1e-6);
          CHECK(loc.x <= cell.x + 1 + P.eps.x + 1e-6);
          CHECK(loc.y >= cell.y - P.eps.y - 1e-6);
          CHECK(loc.y <= cell.y + 1 + P.eps.y + 1e-6);
        }
      }
    }
    INFO(s.name);
    CHECK(wellPosed == s.tris.size());
    UNSCOPED_INFO(fmt::format("{}: {} of {} micro-triangle points lie outside the exact prism; max eps {:.3g} texels",
                              s.name, outsideExact, points, maxEps));
  }
}

TEST_CASE("the ray's curve is monotone between the turning points", "[traversal][psi]") {
  const Newton inv;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  // Twisted normals (a quadratic ψ); the sphere's central normals make ψ linear (the
  // projection of a line through the centre onto a flat triangle is a line), so it is
  // not used here.
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(40, 40, 2));
  Scenario s{"twisted", {}, Displacement{map, 0.1f, -0.5f, vec2(1.0f)}};
  for (int k = 0; k < 20; ++k) {
    std::uniform_real_distribution<float> W(-0.6f, 0.6f);
    DisplacedTriangle T;
    T.p[0] = vec3(0, 0, 0), T.p[1] = vec3(1, 0, 0), T.p[2] = vec3(0.3f, 1, 0);
    for (int i = 0; i < 3; ++i) T.n[i] = glm::normalize(vec3(W(rng), W(rng), 1.0f));
    T.t[0] = vec2(0.1f, 0.1f), T.t[1] = vec2(0.9f, 0.15f), T.t[2] = vec2(0.3f, 0.9f);
    if (T.prepare()) s.tris.push_back(T);
  }
  int splits = 0, checked = 0;
  for (int iter = 0; iter < 400; ++iter) {
    const SurfacePoint sp = randomBasePoint(s, rng);
    const DisplacedTriangle& T = s.tris[sp.prim];
    const LocalFrame F = LocalFrame::make(T, s.disp);
    // A ray through the shell near the point, any direction (half of them grazing).
    vec3 dir = randomDir(rng);
    if (iter % 2) dir = glm::normalize(dir - 0.95f * glm::dot(dir, sp.n) * sp.n);
    const dvec3 O = dvec3(sp.p + 0.02f * sp.n - 2.0f * dir), D(dir);
    const Psi psi = Psi::make(F, O, D);
    const Prism pr = Prism::exact(T, -0.1, 0.1);
    Prism::Crossing a, b;
    if (pr.crossings(O, D, a, b) < 2) continue;
    double ts[4];
    const int n = monotoneSplits(F, psi, O, D, a.t, b.t, ts);
    splits += n;
    double cuts[6] = {a.t};
    int nc = 1;
    for (int k = 0; k < n; ++k) cuts[nc++] = ts[k];
    cuts[nc++] = b.t;
    for (int k = 0; k + 1 < nc; ++k) {
      // Sample the projection densely: both coordinates monotone on each piece, and ψ ≈ 0.
      dvec2 prev(0.0);
      int sx = 0, sy = 0;
      for (int q = 0; q <= 64; ++q) {
        const double t = cuts[k] + (cuts[k + 1] - cuts[k]) * q / 64.0;
        const InversionResultD r = inv.invertFastD(O + t * D, T);
        const dvec2 p = F.local(r.bary);
        CHECK(std::abs(psi.eval(p)) <= 1e-8 * (1 + glm::length(O)));
        if (q > 0) {
          const dvec2 d = p - prev;
          const double tol = 1e-9 * (1 + glm::length(p));
          if (std::abs(d.x) > tol) {
            const int sgn = d.x > 0 ? 1 : -1;
            CHECK((sx == 0 || sx == sgn));
            sx = sgn;
          }
          if (std::abs(d.y) > tol) {
            const int sgn = d.y > 0 ? 1 : -1;
            CHECK((sy == 0 || sy == sgn));
            sy = sgn;
          }
        }
        prev = p;
      }
      ++checked;
    }
  }
  CHECK(checked > 100);
  CHECK(splits > 0);  // some rays do turn
}

TEST_CASE("the box over a snapped rectangle holds its cells' micro-triangles", "[traversal][prism]") {
  std::mt19937 rng(7);
  for (const Scenario& s : {coarseTorus(), sphere()}) {
    const float delta = maxCellDelta(*s.disp.map);
    for (size_t k = 0; k < s.tris.size(); k += 5) {
      const DisplacedTriangle& T = s.tris[k];
      const LocalFrame F = LocalFrame::make(T, s.disp);
      const CellRange cr = cellsOverlapping(T, s.disp);
      const auto micro = microTriangles(T, s.disp);
      Interval hT;
      for (const auto& m : micro)
        for (const auto& v : m.v) hT.extend(s.disp.micro(v.uv));
      const PrismParams P = analyzeShell(T, s.disp, hT, delta);
      for (int q = 0; q < 20; ++q) {
        std::uniform_int_distribution<int> X(cr.x0, cr.x1), Y(cr.y0, cr.y1);
        int x0 = X(rng), x1 = X(rng), y0 = Y(rng), y1 = Y(rng);
        if (x0 > x1) std::swap(x0, x1);
        if (y0 > y1) std::swap(y0, y1);
        // Heights over the cells' corners (exact).
        Interval h;
        for (int j = y0; j <= y1 + 1; ++j)
          for (int i = x0; i <= x1 + 1; ++i) h.extend(s.disp.sampleHeight(i, j));
        const dvec2 sb0 = s.disp.toSample(T.uvBox.lo) - dvec2(F.origin), sb1 = s.disp.toSample(T.uvBox.hi) - dvec2(F.origin);
        const dvec2 lo = glm::max(dvec2(x0, y0) - dvec2(F.origin), sb0);
        const dvec2 hi = glm::min(dvec2(x1 + 1, y1 + 1) - dvec2(F.origin), sb1);
        const BoxD box = boxOverRect(F, T.minNormalLength, lo, hi, h.lo, h.hi, P.vertexErr);
        forEachMicroTriangle(T, s.disp, CellRange{x0, y0, x1, y1}, [&](const MicroTriangle& m) {
          for (const auto& v : m.v) {
            const dvec3 p(v.p);
            INFO(s.name << " triangle " << k << " cells " << x0 << ".." << x1 << " x " << y0 << ".." << y1);
            CHECK((p.x >= box.lo.x && p.y >= box.lo.y && p.z >= box.lo.z && p.x <= box.hi.x && p.y <= box.hi.y &&
                   p.z <= box.hi.z));
          }
        });
      }
    }
  }
}

TEST_CASE("fixedstep approximates the surface", "[traversal][fixedstep]") {
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

// DESIGN invariant 5: the float bounds (padded, see docs/traversal.md) are checked
// against a double-precision run. The micro-geometry of the cells wholly inside a
// triangle is rebuilt in double and intersected in double; every hit found there with a
// clear margin (not within float noise of a micro-edge) must be found by the float
// traversal at the same t, unless it finds a hit in front of it. Also: every double
// micro-vertex lies inside the float prism AABB handed to Embree.
TEST_CASE("float traversal loses no hit of a double-precision run", "[traversal][precision]") {
  for (const Scenario& s : {torus(), twisted(), rotatedUVs()}) {
    INFO(s.name);
    std::vector<std::unique_ptr<Intersector>> configs;
    configs.push_back(createIntersector(config("rmip", "newton", "midpoint2d"), s.tris, s.disp));
    TraversalConfig tfdm = config("minmax_mipmap", "newton", "quadtree");
    tfdm.inversionInTraversal = false;
    tfdm.marchingScale = 1.0f;
    configs.push_back(createIntersector(tfdm, s.tris, s.disp));
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
