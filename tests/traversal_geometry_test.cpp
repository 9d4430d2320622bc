// The traversal's geometry (docs/design.md invariants 2, 5): the allocation-free MicroCells
// against forEachMicroTriangle, the prism and the shell analysis against the
// micro-geometry, ψ's monotone split, and the float box over a snapped rectangle.
#include "core/microgeometry.h"
#include "core/procedural.h"
#include "core/stats.h"
#include "inversion/ceres.h"
#include "inversion/newton.h"
#include "traversal/intersector.h"
#include "traversal/prism.h"
#include "traversal/psi.h"
#include "traversal/texture_frame.h"
#include "traversal/traversal.h"
#include "strategies/quadtree.h"
#include "strategies/splitter.h"

#include "tests/fixtures/traversal_cases.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include <bit>
#include <chrono>
#include <cstring>
#include <numbers>
#include <random>
#include <set>

using namespace oblong;
using namespace oblong::test;

TEST_CASE("MicroCells gives forEachMicroTriangle's triangles bit for bit", "[traversal][microgeometry][unit]") {
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

TEST_CASE("micro-vertices at grid points lie within vertexErr of their exact Eq. 1 points",
          "[traversal][microgeometry][prism][unit]") {
  // vertexErr (traversal/prism.cpp) bounds a float micro-vertex's distance from the exact
  // point (double barycentrics of its sample point, P + h·N/|N| in double): every box and
  // the march's ε are padded by it. Besides the suites' scenarios, fine texels on a patch
  // of uv far from 0 (a 64² map tiled 2 000 times, T 0.004 wide in uv at 0.9): there the
  // grid points' uvs round to a sizeable fraction of a texel, which their barycentrics
  // must not inherit.
  std::vector<Scenario> cases = scenarios();
  for (const Scenario& s : stiffScenarios()) cases.push_back(s);
  {
    Mesh m = quadMesh(1.0f, 0.0f, 1);
    for (vec2& uv : m.uvs) uv = vec2(0.9f, 0.88f) + 0.004f * uv;
    auto map = std::make_shared<const HeightMap>(proceduralHeightMap(64, 64, 9));
    cases.push_back({"fine texels", trianglesOf(m), Displacement{map, 0.002f, -0.5f, vec2(2000.0f, 2000.0f)}});
  }
  for (const Scenario& s : cases) {
    const float delta = maxCellDelta(*s.disp.map);
    size_t points = 0;
    double worst = 0;  // the largest error over vertexErr
    for (size_t k = 0; k < s.tris.size(); ++k) {
      const DisplacedTriangle& T = s.tris[k];
      const LocalFrame F = LocalFrame::make(T, s.disp);
      Interval h;
      forEachMicroTriangle(T, s.disp, [&](const MicroTriangle& m) {
        for (const auto& v : m.v) h.extend(s.disp.micro(v.uv));
      });
      const PrismParams P = analyzeShell(T, s.disp, h, delta);
      if (!P.valid) continue;
      // The cells wholly inside T: their two triangles (v00, v10, v11), (v00, v11, v01)
      // are their corners, grid points computed inside T (MicroCells::cell).
      const MicroCells mc(T, s.disp);
      const CellRange r = cellsOverlapping(T, s.disp);
      MicroTriangle buf[MicroCells::kMaxPerCell];
      for (int j = r.y0; j <= r.y1; ++j)
        for (int i = r.x0; i <= r.x1; ++i) {
          if (!mc.interior(i, j) || mc.cell(i, j, buf) != 2) continue;
          const MicroVertex* corner[4] = {&buf[0].v[0], &buf[0].v[1], &buf[0].v[2], &buf[1].v[2]};
          const ivec2 at[4] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
          for (int q = 0; q < 4; ++q) {
            const dvec2 b = F.bary(dvec2(at[q] - F.origin));
            const double ht = double(s.disp.scale) * (double(s.disp.raw(at[q].x, at[q].y, 0.0f)) + double(s.disp.bias));
            const dvec3 exact = F.P(b) + ht * glm::normalize(F.N(b));
            const double err = glm::length(dvec3(corner[q]->p) - exact);
            worst = std::max(worst, err / P.vertexErr);
            ++points;
            INFO(s.name << " triangle " << k << " sample " << at[q].x << ", " << at[q].y << ": error " << err
                        << ", vertexErr " << P.vertexErr);
            CHECK(err <= P.vertexErr);
          }
        }
    }
    CHECK(points > 100);
    UNSCOPED_INFO(s.name << ": " << points << " grid points, largest error " << worst << " of vertexErr");
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

TEST_CASE("a made curve point's stored uv and pad hold the ray point's exact projection",
          "[traversal][claims][unit]") {
  // makePoint bounds a float claim's residual in float (from the ray's anchor in T's
  // frame, claimResidual) and stores the point's uv in float with a pad (float, rounded
  // up) that must cover both the claim's error and uv's rounding. Claims (b, s) off the
  // exact projection by 10^-12 to 10^-3 on every suite's triangles and the stiff ones,
  // from rays of any length (the anchor up to half the ray's length from the point); the
  // ray point X = O + t·D exact in long double, its projection (b*, s*) on T's frame by
  // Newton in long double; every accepted point's |uv* − uv| must be within its pad.
  std::vector<Scenario> cases = scenarios();
  for (const Scenario& s : stiffScenarios()) cases.push_back(s);
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  auto logU = [&](double lo, double hi) { return lo * std::pow(hi / lo, U(rng)); };
  using LD = long double;
  size_t allAccepted = 0, roundingDecides = 0;
  for (const Scenario& s : cases) {
    const Interval heights = s.disp.toHeight(s.disp.map->range());
    const float delta = maxCellDelta(*s.disp.map);
    size_t accepted = 0, claims = 0;
    double worst = 0;  // the largest |uv* − uv| over pad
    for (size_t k = 0; k < s.tris.size(); k += std::max<size_t>(1, s.tris.size() / 40)) {
      const DisplacedTriangle& T = s.tris[k];
      const PrismParams P = analyzeShell(T, s.disp, heights, delta);
      if (!P.valid || !P.wellPosed) continue;
      const LocalFrame F = LocalFrame::make(T, s.disp);
      const shared::ClaimBounds K{P.domainB, P.domainS0, P.domainS1, P.kb, P.ks, P.kxy};
      for (int q = 0; q < 60; ++q) {
        // A point of the prism, a ray through it.
        double u = U(rng), v = U(rng);
        if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
        const double s0 = P.a + (P.b - P.a) * U(rng);
        const dvec3 X0 = F.P(dvec2(u, v)) + s0 * F.N(dvec2(u, v));
        const dvec3 D = dvec3(randomDir(rng));
        const double t = logU(0.01, 100.0);
        const dvec3 O = X0 - t * D;
        LD X[3], G[3], J[3][3];
        for (int i = 0; i < 3; ++i) X[i] = LD(O[i]) + LD(t) * LD(D[i]);
        // Newton in long double on G(b, s) = X from (u, v, s0).
        LD bu = u, bv = v, bs = s0;
        for (int it = 0; it < 8; ++it) {
          for (int i = 0; i < 3; ++i) {
            const LD Ni = LD(F.n0[i]) + LD(F.f1[i]) * bu + LD(F.f2[i]) * bv;
            G[i] = LD(F.p0[i]) + LD(F.e1[i]) * bu + LD(F.e2[i]) * bv + bs * Ni - X[i];
            J[i][0] = LD(F.e1[i]) + bs * LD(F.f1[i]);
            J[i][1] = LD(F.e2[i]) + bs * LD(F.f2[i]);
            J[i][2] = Ni;
          }
          auto det3 = [](LD a[3][3]) {
            return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                   a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
          };
          const LD det = det3(J);
          LD dx[3];
          for (int c = 0; c < 3; ++c) {
            LD M[3][3];
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j) M[i][j] = j == c ? G[i] : J[i][j];
            dx[c] = det3(M) / det;
          }
          bu -= dx[0], bv -= dx[1], bs -= dx[2];
        }
        const LD exactX = LD(F.sc.x) + LD(F.sU.x) * bu + LD(F.sV.x) * bv;
        const LD exactY = LD(F.sc.y) + LD(F.sU.y) * bu + LD(F.sV.y) * bv;
        // A claim off by up to 10^-3 in b and s (relative to the prism's height).
        const double e = logU(1e-12, 1e-3);
        const vec2 b(float(double(bu) + e * (2.0 * U(rng) - 1.0)), float(double(bv) + e * (2.0 * U(rng) - 1.0)));
        const float sc = float(double(bs) + e * (2.0 * U(rng) - 1.0) * (P.b - P.a + 1e-3));
        const shared::ClaimAnchor A = shared::claimAnchor(F, O, D, t * (1.0 - 0.5 * U(rng) * U(rng)));
        shared::CurvePoint m;
        ++claims;
        if (!shared::makePoint(F, shared::frameF(F), K, A, t, b, sc, m)) continue;
        ++accepted;
        const double ex = double(std::abs(exactX - LD(m.uv.x))), ey = double(std::abs(exactY - LD(m.uv.y)));
        worst = std::max(worst, std::max(ex / double(m.pad.x), ey / double(m.pad.y)));
        INFO(s.name << " triangle " << k << ": uv (" << m.uv.x << ", " << m.uv.y << ") pad (" << m.pad.x << ", "
                    << m.pad.y << "), exact off by (" << ex << ", " << ey << "), claim error " << e);
        // Within the pad, and within the float rectangle the pieces take from it.
        CHECK(ex <= double(m.pad.x));
        CHECK(ey <= double(m.pad.y));
        const vec2 lo = shared::pieceLo(m, m), hi = shared::pieceHi(m, m);
        CHECK((LD(lo.x) <= exactX && exactX <= LD(hi.x)));
        CHECK((LD(lo.y) <= exactY && exactY <= LD(hi.y)));
        // Points whose error a pad from the computed residual alone (no term for the float
        // evaluation's error, nor for uv's rounding) would not cover.
        const shared::FrameF R = shared::frameF(F);
        const float dt = float(t - A.tA);
        const vec3 Xf = A.XA + dt * A.Df, Nf = R.n0 + R.f1 * b.x + R.f2 * b.y;
        const vec3 d = R.e1 * b.x + R.e2 * b.y + sc * Nf - Xf;
        const double rf = double(std::sqrt(glm::dot(d, d)));
        const dvec2 bare = P.kxy * (rf * OBLONG_TRAV_RESIDUAL_SAFETY) + OBLONG_TRAV_SNAP_ETA * (1.0 + glm::abs(dvec2(m.uv)));
        roundingDecides += ex > bare.x || ey > bare.y;
      }
    }
    CHECK(accepted >= claims / 4);  // the deep sphere has no well-posed triangle: no claims
    allAccepted += accepted;
    UNSCOPED_INFO(s.name << ": " << accepted << " of " << claims << " claims accepted, largest error " << worst
                         << " of the pad");
  }
  UNSCOPED_INFO(roundingDecides << " points need the rounding terms");
  CHECK(allAccepted > 5000);
  CHECK(roundingDecides > 0);
}

TEST_CASE("the ray's curve is monotone between the turning points", "[traversal][psi][unit]") {
  const Newton inv;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::uniform_real_distribution<float> W(-0.6f, 0.6f);
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(40, 40, 2));
  // Twisted normals (a quadratic ψ); and a sphere's triangles, whose central normals make
  // ψ nearly linear: their float rounding bends it into a hyperbola with a far branch
  // (every displacement line meets the centre), whose candidates the two-crossing rule
  // drops (setupCurve's farB).
  Scenario twisted{"twisted", {}, Displacement{map, 0.1f, -0.5f, vec2(1.0f)}};
  for (int k = 0; k < 20; ++k) {
    DisplacedTriangle T;
    T.p[0] = vec3(0, 0, 0), T.p[1] = vec3(1, 0, 0), T.p[2] = vec3(0.3f, 1, 0);
    for (int i = 0; i < 3; ++i) T.n[i] = glm::normalize(vec3(W(rng), W(rng), 1.0f));
    T.t[0] = vec2(0.1f, 0.1f), T.t[1] = vec2(0.9f, 0.15f), T.t[2] = vec2(0.3f, 0.9f);
    if (T.prepare()) twisted.tris.push_back(T);
  }
  Scenario sphere{"sphere", {}, Displacement{map, 0.02f, -0.5f, vec2(1.0f)}};
  for (int k = 0; k < 20; ++k) {
    const vec3 c = glm::normalize(vec3(W(rng), W(rng), W(rng)) + vec3(0.01f));
    const vec3 e = glm::normalize(glm::cross(c, vec3(0.3f, 0.5f, 0.8f))), f = glm::cross(c, e);
    DisplacedTriangle T;
    T.p[0] = glm::normalize(c - 0.05f * e), T.p[1] = glm::normalize(c + 0.05f * e);
    T.p[2] = glm::normalize(c + 0.05f * f);
    for (int i = 0; i < 3; ++i) T.n[i] = glm::normalize(T.p[i]);
    T.t[0] = vec2(0.1f, 0.1f), T.t[1] = vec2(0.9f, 0.15f), T.t[2] = vec2(0.3f, 0.9f);
    if (T.prepare()) sphere.tris.push_back(T);
  }
  for (const Scenario* sc : {&twisted, &sphere}) {
    const Scenario& s = *sc;
    REQUIRE(s.tris.size() >= 10);
    int splits = 0, checked = 0, dropped = 0;
    for (int iter = 0; iter < 400; ++iter) {
      const SurfacePoint sp = randomBasePoint(s, rng);
      const DisplacedTriangle& T = s.tris[sp.prim];
      const LocalFrame F = LocalFrame::make(T, s.disp);
      // A ray through the shell near the point, any direction (half of them grazing).
      vec3 dir = randomDir(rng);
      if (iter % 2) dir = glm::normalize(dir - 0.95f * glm::dot(dir, sp.n) * sp.n);
      const bool onSphere = sc == &sphere;  // its triangles are 0.1 across, the twisted ones 1
      const float len = onSphere ? 0.1f : 2.0f, lift = onSphere ? 0.002f : 0.02f;
      const dvec3 O = dvec3(sp.p + lift * sp.n - len * dir), D(dir);
      const Psi psi = Psi::make(F, O, D);
      const double h = onSphere ? 0.01 : 0.1;
      const Prism pr = Prism::exact(T, -h, h);
      Prism::Crossing a, b;
      const int crossings = pr.crossings(O, D, a, b);
      if (crossings < 2) continue;
      double ts[4], ss[4], all[4];
      dvec2 bs[4];
      const int n0 = monotoneSplits(F, psi, O, D, a.t, b.t, -1.0, all, bs, ss);
      const int n = monotoneSplits(F, psi, O, D, a.t, b.t, crossings == 2 ? 1.0 + pr.growth() : -1.0, ts, bs, ss);
      REQUIRE(n <= n0);
      dropped += n0 - n;
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
    INFO(s.name << ": " << splits << " splits, " << dropped << " far candidates dropped");
    CHECK(checked > 100);
    if (sc == &twisted) CHECK(splits > 0);  // some rays do turn
    else CHECK(dropped > 0);                // the far branch shows up, and goes
  }
}

namespace {

// T's shell analysis with its heights from its own micro-vertices.
PrismParams shellOf(const DisplacedTriangle& T, const Displacement& d, float delta) {
  Interval hT;
  for (const auto& m : microTriangles(T, d))
    for (const auto& v : m.v) hT.extend(d.micro(v.uv));
  return analyzeShell(T, d, hT, delta);
}

// A random range of T's cells (absolute), the heights over its cells' corners (exact), and
// its rectangle in local sample coordinates clipped to T's uv box, as the traversals pass
// it to their boxes.
struct CellRect {
  CellRange cells;
  Interval h;
  dvec2 lo, hi;
};
CellRect randomCellRect(std::mt19937& rng, const CellRange& cr, const Displacement& d, const DisplacedTriangle& T,
                        const LocalFrame& F) {
  std::uniform_int_distribution<int> X(cr.x0, cr.x1), Y(cr.y0, cr.y1);
  int x0 = X(rng), x1 = X(rng), y0 = Y(rng), y1 = Y(rng);
  if (x0 > x1) std::swap(x0, x1);
  if (y0 > y1) std::swap(y0, y1);
  CellRect r{CellRange{x0, y0, x1, y1}, Interval{}, dvec2(0.0), dvec2(0.0)};
  for (int j = y0; j <= y1 + 1; ++j)
    for (int i = x0; i <= x1 + 1; ++i) r.h.extend(d.sampleHeight(i, j));
  const dvec2 sb0 = d.toSample(T.uvBox.lo) - dvec2(F.origin), sb1 = d.toSample(T.uvBox.hi) - dvec2(F.origin);
  r.lo = glm::max(dvec2(x0, y0) - dvec2(F.origin), sb0);
  r.hi = glm::min(dvec2(x1 + 1, y1 + 1) - dvec2(F.origin), sb1);
  return r;
}

}  // namespace

TEST_CASE("the float box holds its cells' micro-vertices, and its slab test the rays through them",
          "[traversal][prism][unit]") {
  // boxOverRectF and clipBoxF (core/kernels/rect_bounds.h) as both traversals call them:
  // in T's texture frame relative to its anchor, with only the pad of the micro-vertices'
  // own float error (vertexErr) besides their own rounding; also far from the world's
  // origin, where the anchor and the rounded ray origin carry the float error.
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  int vertices = 0, rays = 0, parallel = 0;
  for (const Scenario& base : {coarseTorus(), sphere()})
    for (const vec3 shift : {vec3(0.0f), vec3(3000.0f, -2000.0f, 1000.0f)}) {
      const Scenario& s = base;
      const float delta = maxCellDelta(*s.disp.map);
      for (size_t k = 0; k < s.tris.size(); k += 7) {
        DisplacedTriangle T = s.tris[k];
        for (auto& p : T.p) p += shift;
        REQUIRE(T.prepare());
        const LocalFrame F = LocalFrame::make(T, s.disp);
        const CellRange cr = cellsOverlapping(T, s.disp);
        const TextureFrame X = TextureFrame::make(F, T, cr);
        const PrismParams P = shellOf(T, s.disp, delta);
        const float pad = shared::floatAbove(P.vertexErr, P.vertexErr);
        for (int q = 0; q < 12; ++q) {
          const CellRect r = randomCellRect(rng, cr, s.disp, T, F);
          const int x0 = r.cells.x0, x1 = r.cells.x1, y0 = r.cells.y0, y1 = r.cells.y1;
          vec3 blo, bhi;
          shared::boxOverRectF(X.box, vec2(r.lo), vec2(r.hi), r.h.lo, r.h.hi, pad, blo, bhi);
          forEachMicroTriangle(T, s.disp, CellRange{x0, y0, x1, y1}, [&](const MicroTriangle& m) {
            for (const auto& v : m.v) {
              const dvec3 pt = X.rot(dvec3(v.p)) - X.Pc;  // the vertex in the frame, relative to the anchor
              INFO(s.name << " shift " << shift.x << " triangle " << k << " cells " << x0 << ".." << x1 << " x " << y0
                          << ".." << y1);
              CHECK((pt.x >= blo.x && pt.y >= blo.y && pt.z >= blo.z && pt.x <= bhi.x && pt.y <= bhi.y &&
                     pt.z <= bhi.z));
              ++vertices;
              // A ray reaching the vertex at t = 1 from up to 50 units away (one in four
              // parallel to a slab): the slab test keeps t = 1.
              if ((vertices & 7) != 0) return;
              const dvec3 Pt = X.rot(dvec3(v.p));
              dvec3 Dt(U(rng), U(rng), U(rng));
              Dt *= 50.0 * (0.01 + std::abs(U(rng)));
              if ((vertices & 31) == 0) {
                Dt[vertices % 3] = 0.0;
                ++parallel;
              }
              const dvec3 Ot = Pt - Dt;
              double t0 = 0.0, t1 = 2.0;
              shared::clipBoxF(blo, bhi, shared::boxRayF(Ot, Dt, X.Pc), t0, t1);
              CHECK(t0 <= 1.0 + 1e-12);
              CHECK(t1 >= 1.0 - 1e-12);
              ++rays;
            }
          });
        }
      }
    }
  CHECK(vertices > 10000);
  CHECK(rays > 1000);
  CHECK(parallel > 10);
}

TEST_CASE("the float box and slab test cover their own rounding where the box is tight", "[traversal][prism][unit]") {
  // No pad from outside (pad 0): on random frames with a flat normal field (|N| = 1,
  // invM = 1) the box is tight at the rectangle's corners, so every float rounding of
  // boxOverRectF must be covered by its own pad; the corners' exact points (long double)
  // must lie in it, and rays through them from up to 1e3 away keep their t in clipBoxF.
  using LD = long double;
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  int corners = 0;
  for (int q = 0; q < 20000; ++q) {
    const double scale = std::pow(10.0, 3.0 * U(rng));  // texel size from 1e-3 to 1e3
    const dvec3 PX = scale * dvec3(U(rng), U(rng), U(rng)), PY = scale * dvec3(U(rng), U(rng), U(rng));
    const dvec3 N = glm::normalize(dvec3(U(rng), U(rng), U(rng)));
    const dvec2 xym(1.0 + 4096.0 * std::abs(U(rng)), 1.0 + 4096.0 * std::abs(U(rng)));
    const shared::BoxFrameF B = shared::boxFrameF(PX, PY, N, dvec3(0.0), dvec3(0.0), 1.0f, xym);
    const vec2 lo(float(xym.x * U(rng)), float(xym.y * U(rng)));
    const vec2 hi = glm::min(lo + vec2(float(1 + 64 * std::abs(U(rng))), float(1 + 64 * std::abs(U(rng)))), vec2(xym));
    if (!(lo.x <= hi.x && lo.y <= hi.y)) continue;
    const float h0 = float(scale * U(rng)), h1 = float(scale * U(rng));
    const float hlo = std::min(h0, h1), hhi = std::max(h0, h1);
    vec3 blo, bhi;
    shared::boxOverRectF(B, lo, hi, hlo, hhi, 0.0f, blo, bhi);
    for (int c = 0; c < 8; ++c) {
      const LD X = (c & 1) ? hi.x : lo.x, Y = (c & 2) ? hi.y : lo.y, H = (c & 4) ? hhi : hlo;
      LD p[3];
      for (int k = 0; k < 3; ++k) p[k] = LD(PX[k]) * X + LD(PY[k]) * Y + H * LD(N[k]);
      INFO("frame " << q << " corner " << c);
      for (int k = 0; k < 3; ++k) REQUIRE((p[k] >= LD(blo[k]) && p[k] <= LD(bhi[k])));
      // A ray reaching the corner at t = 1, from an anchor-relative origin up to 1e3 away
      // (the anchor itself up to 1e4 from the world's origin).
      const dvec3 anchor = 1e4 * dvec3(U(rng), U(rng), U(rng));
      const dvec3 Dt = 1e3 * std::abs(U(rng)) * dvec3(U(rng), U(rng), U(rng));
      dvec3 Ot;
      for (int k = 0; k < 3; ++k) Ot[k] = double(LD(anchor[k]) + p[k] - LD(Dt[k]));
      // The ray as rounded to double meets the corner at t* (per axis, the same up to the
      // double rounding of Ot, which is far below float's).
      double t0 = -1e30, t1 = 1e30;
      shared::clipBoxF(blo, bhi, shared::boxRayF(Ot, Dt, anchor), t0, t1);
      for (int k = 0; k < 3; ++k) {
        if (Dt[k] == 0.0) continue;
        const LD tk = (LD(anchor[k]) + p[k] - LD(Ot[k])) / LD(Dt[k]);
        INFO("axis " << k << " t " << double(tk) << " in [" << t0 << ", " << t1 << "]");
        REQUIRE((LD(t0) <= tk && tk <= LD(t1)));
      }
      ++corners;
    }
  }
  CHECK(corners > 100000);
}

TEST_CASE("a triangle's 1/|N| bound holds for every m its float rounds from", "[traversal][prism][unit]") {
  // minInterpolatedNormalLength rounds to nearest: the true minimum lies within half an
  // ulp of the float, and the boxes (boxFrameF's invM) multiply by invNormalLengthBound(m) instead of dividing.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> M(1e-6f, 1.0f);
  for (int q = 0; q < 100000; ++q) {
    const float mf = q == 0 ? 1.0f : M(rng);
    const long double halfUlp = (static_cast<long double>(std::nextafter(mf, 2.0f)) - mf) / 2;
    const long double mTrueMin = static_cast<long double>(mf) - halfUlp;
    const float inv = invNormalLengthBound(mf);
    INFO("m " << mf);
    REQUIRE(static_cast<long double>(inv) * mTrueMin >= 1.0L);
    // and it stays tight: within 2^-19 of 1/m
    REQUIRE(static_cast<double>(inv) * static_cast<double>(mf) <= 1.0 + 0x1p-19);
  }
}

namespace {

// The driver with hooks that the march reaches with no hit found: only the statistics
// and "no hit yet" are ever called; the others are instantiated with the march's stop.
struct MarchOnly : shared::RayPatchLoop<MarchOnly> {
  void rpStat(int) {}
  bool rpHitFound() { return false; }
  float rpHitT() { return 0.0f; }
  dvec2 rpHitUV() { return dvec2(0.0); }
  dvec2 rpToSample(const dvec2& uv) { return uv; }
  void rpInvert(const vec3&, vec2& b, float& h) {
    b = vec2(0.0f);
    h = 0.0f;
  }
};

}  // namespace

TEST_CASE("the march's walk reaches every cell within eps of its piece", "[traversal][unit]") {
  // Random monotone arcs of conics ψ = α·(w + γw² − c·(x − x0)²), w = y − y0 − s·(x − x0)
  // (x², xy, y² terms, a second branch at w ≈ −1/γ), anywhere up to 10^5 cells from the
  // origin, either axis major, either direction, with ε from 10^-3 to 2 cells and end
  // pads from 10^-12 to a quarter cell (plus the snap's allowance and uv's rounding to float, as makePoint's); every cell whose ε-dilated square holds a point of
  // the arc (2 000 points along it, in long double) must be among the walk's cells; a
  // quarter of the arcs are lines touching a dilated cell at a corner only.
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  auto logU = [&](double lo, double hi) { return lo * std::pow(hi / lo, U(rng)); };
  int pieces = 0, cellsChecked = 0, floatForm = 0, misses = 0;
  size_t walked = 0;
  std::string firstMiss;
  for (int q = 0; q < 4000; ++q) {
    long double x0 = (U(rng) - 0.5) * 2.0 * logU(1.0, 1e5), y0 = (U(rng) - 0.5) * 2.0 * logU(1.0, 1e5);
    const long double s = (U(rng) - 0.5) * 2.0 * logU(1e-3, 1.0);
    long double c = (U(rng) - 0.5) * 2.0 * logU(1e-6, 1e-1), g = (U(rng) - 0.5) * 2.0 * logU(1e-6, 1.0);
    const long double alpha = (U(rng) < 0.5 ? -1.0 : 1.0) * logU(1e-6, 1e6);
    const bool corner = q % 4 == 0;
    const double len = corner ? 4.0 + 4.0 * U(rng) : logU(1e-3, 8.0), eps = corner ? logU(1e-3, 0.1) : logU(1e-3, 2.0);
    const double pad = corner ? logU(1e-12, 1e-6) : logU(1e-12, 0.25);
    const bool swap = U(rng) < 0.5, back = U(rng) < 0.5;
    // The arc over x in [x0 + a0, x0 + a0 + len] (the branch through w = 0 at x0).
    long double a0 = (U(rng) - 0.5) * 4.0;
    // One piece in four is a line that touches a cell's dilated square only at a corner
    // (the middle point of the 2 000), far from its ends: the tightest case of the interval
    // test, where its rounding pad decides.
    if (corner) {
      const long double i = std::floor(x0), j = std::floor(y0);
      c = g = 0.0L;
      const bool upper = U(rng) < 0.5;  // the corner's cell lies above the line, or below
      x0 = (s > 0) == upper ? i + 1 + eps : i - eps;
      y0 = upper ? j - eps : j + 1 + eps;
      a0 = -len / 2;
    }
    auto wAt = [&](long double dx) {  // the root of γw² + w − c·dx² near 0
      const long double r = c * dx * dx;
      return std::abs(g * r) < 1e-12L ? r - g * r * r : (-1.0L + std::sqrt(1.0L + 4.0L * g * r)) / (2.0L * g);
    };
    auto point = [&](long double dx) { return std::pair<long double, long double>(x0 + dx, y0 + s * dx + wAt(dx)); };
    // Monotone and on the branch (1 + 4γc·dx² > 0) over the arc, else skipped.
    bool ok = true;
    long double prevY = point(a0).second;
    int sign = 0;
    for (int k = 1; k <= 64 && ok; ++k) {
      const long double dx = a0 + len * k / 64.0L;
      ok = 1.0L + 4.0L * g * c * dx * dx > 1e-6L;
      const long double y = point(dx).second;
      const int sg = y > prevY ? 1 : y < prevY ? -1 : 0;
      if (sg != 0 && sign != 0 && sg != sign) ok = false;
      if (sg != 0) sign = sg;
      prevY = y;
    }
    if (!ok) continue;
    // ψ in (X, Y) = swap ? (y, x) : (x, y), expanded about the origin, in double.
    // ψ = α(w + γw² − c·dx²), dx = x − x0, w = y − y0 − s·dx.
    const long double k0 = -y0 + s * x0;  // w = y − s·x + k0
    // w + γw² − c(x − x0)²: collect x², xy, y², x, y, 1.
    long double cxx = alpha * (g * s * s - c), cxy = alpha * (-2.0L * g * s), cyy = alpha * g;
    long double cx = alpha * (-s + 2.0L * g * (-s) * k0 + 2.0L * c * x0), cy = alpha * (1.0L + 2.0L * g * k0);
    long double c00 = alpha * (k0 + g * k0 * k0 - c * x0 * x0);
    MarchOnly m;
    m.g_psi = swap ? shared::Psi{double(c00), double(cy), double(cx), double(cyy), double(cxy), double(cxx)}
                   : shared::Psi{double(c00), double(cx), double(cy), double(cxx), double(cxy), double(cyy)};
    m.g_eps = dvec2(eps);
    m.g_cellLo = ivec2(-300000);
    m.g_cellHi = ivec2(300000);
    auto uv = [&](long double dx) {
      const auto [x, y] = point(dx);
      return swap ? dvec2(double(y), double(x)) : dvec2(double(x), double(y));
    };
    // End points stored as makePoint stores them: uv rounded to float, the pad at least
    // the snap's allowance (also above the rounding of the long double point to double)
    // plus uv's rounding, rounded up.
    auto end = [&](double t, long double dx) {
      const dvec2 p = uv(dx);
      const dvec2 pd = dvec2(pad) + OBLONG_TRAV_SNAP_ETA * (1.0 + glm::abs(p)) + OBLONG_U2M23 * glm::abs(p);
      return shared::CurvePoint{t, vec2(p), vec2(shared::floatAbove(pd.x, pd.x), shared::floatAbove(pd.y, pd.y))};
    };
    const shared::CurvePoint pa = end(0.0, back ? a0 + len : a0), pb = end(1.0, back ? a0 : a0 + len);
    m.startMarch(pa, pb);
    REQUIRE(m.g_gen == 2);
    floatForm += !m.g_mAny;
    std::set<std::pair<int, int>> cells;
    int ci = 0, cj = 0;
    while (cells.size() < 1000000 && m.nextCell(ci, cj)) cells.insert({ci, cj});
    REQUIRE(cells.size() < 1000000);
    walked += cells.size();
    ++pieces;
    for (int k = 0; k <= 2000; ++k) {
      const long double dx = a0 + len * k / 2000.0L;
      const auto [x, y] = point(dx);
      const long double X = swap ? y : x, Y = swap ? x : y;
      for (int i = int(std::floor(X - eps)); i <= int(std::floor(X + eps)); ++i)
        for (int j = int(std::floor(Y - eps)); j <= int(std::floor(Y + eps)); ++j) {
          if (!(i - eps <= X && X <= i + 1 + eps && j - eps <= Y && Y <= j + 1 + eps)) continue;
          ++cellsChecked;
          if (cells.count({i, j}) == 1 || !firstMiss.empty()) {
            misses += cells.count({i, j}) == 0;
            continue;
          }
          ++misses;
          firstMiss = fmt::format("piece {} point {} at ({}, {}), cell ({}, {}), eps {}, pad {}, alpha {}, swap {}, back {}",
                                  q, k, double(X), double(Y), i, j, eps, pad, double(alpha), swap, back);
        }
    }
  }
  INFO(firstMiss);
  CHECK(misses == 0);
  INFO(pieces << " pieces, " << floatForm << " with the float test, " << walked << " cells walked");
  CHECK(pieces > 2000);
  CHECK(floatForm == pieces);  // finite ψ and small rectangles: the float form held every time
  CHECK(cellsChecked > 1000000);
}

TEST_CASE("nearestF takes a quotient or root within 4 ulp to IEEE's, in integers", "[traversal][unit]") {
  // The GPU's divF and sqrtF correct its float `/` and sqrt with core/kernels/lang.h's
  // nearestF; here its code runs on the CPU from estimates 1 to 4 ulp off IEEE's result
  // (either side), over operands of every binade (subnormals too), quotients near powers of
  // two (where the ulp below is half the ulp above) and subnormal quotients.
  std::mt19937 rng(47);
  std::uniform_int_distribution<uint32_t> anyBits(1u, 0x7f7fffffu);
  std::uniform_int_distribution<int> small(-6, 6);
  const auto bits = [](float x) { return std::bit_cast<uint32_t>(x); };
  const auto fromBits = [](uint32_t b) { return std::bit_cast<float>(b); };
  int checked = 0, wrong = 0;
  std::string first;
  // r within 4 ulp of q (q > 0 finite) must come back as q.
  const auto check = [&](float A, float B, bool root) {
    const float q = root ? std::sqrt(A) : A / B;
    if (!(q > 0.0f) || std::isinf(q)) return;
    for (int k = -4; k <= 4; ++k) {
      const int64_t rb = int64_t(bits(q)) + k;
      if (rb <= 0 || rb >= 0x7f800000) continue;
      const float got = shared::nearestF(fromBits(uint32_t(rb)), A, B, root);
      ++checked;
      if (bits(got) != bits(q)) {
        if (++wrong == 1)
          first = fmt::format("{} of {:a} and {:a} from {:+d} ulp: {:a}, IEEE {:a}", root ? "root" : "quotient", A, B,
                              k, got, q);
      }
    }
  };
  for (int n = 0; n < 200000; ++n) {
    const float A = fromBits(anyBits(rng)), B = fromBits(anyBits(rng));
    check(A, B, false);
    check(A, 1.0f, true);
    // A quotient near a power of two, either side (A a few ulp from B·2^j: the quotients
    // fall between the neighbours below 2^j, whose spacing is half the one above), a
    // subnormal quotient, and a root near a power of two (A a few ulp from 4^j).
    const float Bn = fromBits(0x3f800000u | (anyBits(rng) & 0x7fffffu));
    const int j = small(rng) * 20;
    check(fromBits(uint32_t(int(bits(std::ldexp(Bn, j))) + small(rng))), Bn, false);
    check(fromBits(anyBits(rng) & 0x007fffffu | 1u), fromBits(0x3f800000u + (anyBits(rng) & 0x0fffffffu)), false);
    check(fromBits(uint32_t(int(bits(std::ldexp(1.0f, 2 * j))) + small(rng))), 1.0f, true);
  }
  INFO(first);
  CHECK(checked > 6000000);
  CHECK(wrong == 0);
}
