// Bounding prisms and the shell analysis (see prism.h for the reasoning).
#include "traversal/prism.h"

#include "core/kernels/microcells.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>

namespace oblong {

namespace {

constexpr double kUlpF = 1.0 / (1 << 24);  // unit roundoff of float

double det3(const dvec3& a, const dvec3& b, const dvec3& c) { return glm::dot(a, glm::cross(b, c)); }

double maxAbs(const dvec3& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }


// Lower bound on |det J(b, s)|, J = [e1 + s f1, e2 + s f2, N(b)], over b in T_delta and
// s in [s0, s1], and the cofactor bounds of J⁻¹'s rows. False when det J may vanish.
struct JBounds {
  double detAbsMin = 0, cofU = 0, cofV = 0, cofS = 0;
  dvec2 cofXY{0.0};  // for the sample-space rows X = sc.x + sU.x u + sV.x v (and Y)
};
bool jacobianBounds(const LocalFrame& F, double delta, double s0, double s1, JBounds& out) {
  const dvec2 bv[3] = {{-delta, -delta}, {1 + 2 * delta, -delta}, {-delta, 1 + 2 * delta}};
  double nMax = 0, dMin = std::numeric_limits<double>::infinity(), dMax = -dMin;
  for (const dvec2& b : bv) {
    const dvec3 N = F.N(b);
    nMax = std::max(nMax, glm::length(N));
    // det J at fixed b: A + B s + C s² (det is affine in N, N affine in b: extremes over
    // the triangle T_delta are at its vertices).
    const double A = det3(F.e1, F.e2, N);
    const double B = det3(F.f1, F.e2, N) + det3(F.e1, F.f2, N);
    const double C = det3(F.f1, F.f2, N);
    auto g = [&](double s) { return A + s * (B + s * C); };
    double lo = std::min(g(s0), g(s1)), hi = std::max(g(s0), g(s1));
    if (C != 0) {
      const double sv = -B / (2 * C);
      if (sv > s0 && sv < s1) lo = std::min(lo, g(sv)), hi = std::max(hi, g(sv));
    }
    dMin = std::min(dMin, lo);
    dMax = std::max(dMax, hi);
  }
  const double scale = glm::length(F.e1) * glm::length(F.e2) * std::max(nMax, 1e-300);
  double detAbs;
  if (dMin > 0) detAbs = dMin;
  else if (dMax < 0) detAbs = -dMax;
  else return false;
  // A Jacobian 1e-9 of the triangle's own scale is numerically folded.
  if (!(detAbs > 1e-9 * scale)) return false;
  auto len = [](const dvec3& v) { return glm::length(v); };
  const double c1 = std::max(len(F.e1 + s0 * F.f1), len(F.e1 + s1 * F.f1));
  const double c2 = std::max(len(F.e2 + s0 * F.f2), len(F.e2 + s1 * F.f2));
  out.detAbsMin = detAbs;
  out.cofU = c2 * nMax;
  out.cofV = c1 * nMax;
  out.cofS = c1 * c2;
  // ΔX = sU.x Δu + sV.x Δv = w · (c3 × (sV.x c1 − sU.x c2)) / det J; the vector is
  // affine in s, so its length is largest at an end of [s0, s1].
  for (int k = 0; k < 2; ++k) {
    auto g = [&](double s) { return len(F.sV[k] * (F.e1 + s * F.f1) - F.sU[k] * (F.e2 + s * F.f2)); };
    out.cofXY[k] = std::max(g(s0), g(s1)) * nMax;
  }
  return true;
}

}  // namespace

AABB BoxD::toFloatOutward() const {
  AABB r;
  for (int k = 0; k < 3; ++k) {
    float l = float(lo[k]), h = float(hi[k]);
    if (double(l) > lo[k]) l = std::nextafter(l, -kInfinity);
    if (double(h) < hi[k]) h = std::nextafter(h, kInfinity);
    r.lo[k] = l;
    r.hi[k] = h;
  }
  return r;
}

float cellRowDelta(const HeightMap& m, int j, int i0, int i1) {
  float best = 0;
  const int W = m.width(), H = m.height();
  const float* r0 = m.texels().data() + size_t(HeightMap::wrap(j, H)) * W;
  const float* r1 = m.texels().data() + size_t(HeightMap::wrap(j + 1, H)) * W;
  for (int i = i0; i < i1; ++i) {
    const int k = i + 1 < W ? i + 1 : 0;
    const float a = r0[i], b = r0[k], c = r1[i], d = r1[k];
    best = std::max(best, std::max({a, b, c, d}) - std::min({a, b, c, d}));
  }
  return best;
}

float maxCellDelta(const HeightMap& m) {
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, m.height(), 16), 0.0f,
      [&](const tbb::blocked_range<int>& r, float best) {
        for (int j = r.begin(); j != r.end(); ++j) best = std::max(best, cellRowDelta(m, j, 0, m.width()));
        return best;
      },
      [](float a, float b) { return std::max(a, b); });
}

PrismParams analyzeShell(const DisplacedTriangle& T, const Displacement& d, const Interval& heights,
                         float cellDelta) {
  PrismParams P;
  P.valid = T.uvArea2 != 0.0f && T.area > 0.0f && T.minNormalLength > 1e-6f && !heights.isEmpty();
  if (!P.valid) return P;
  const LocalFrame F = LocalFrame::make(T, d);
  const double m = T.minNormalLength;
  P.hmin = heights.lo, P.hmax = heights.hi;
  const double hmin = heights.lo, hmax = heights.hi;
  P.a = hmin < 0 ? hmin / m : hmin;
  P.b = hmax > 0 ? hmax / m : hmax;
  const double H = std::max(std::abs(hmin), std::abs(hmax));
  const double L = std::max({glm::length(F.e1), glm::length(F.e2), glm::length(F.e2 - F.e1)});

  // Float error of the micro-vertices (core/kernels/microcells.h computes them in float):
  // a grid point's barycentrics are McTri's float map at its integer offset (mcBaryMap:
  // the map's three coefficients rounded, the offsets' conversion, two products and two
  // sums, each at most one rounding of a term bounded by `sum`: 6 ulps of it, with the
  // double map's own error far below); an edge crossing rounds its parameter to float and
  // takes 1 - t (4 ulps). P = w·p0 + u·p1 + v·p2 rounds three products and two sums of
  // terms whose magnitudes add up to at most maxP (b inside T), and w = 1 − u − v twice: at
  // most 6 ulps of maxP per coordinate, √3·6 < 12 of them in length; N and normalize add a
  // few ulps of H.
  double maxP = 0;
  for (int k = 0; k < 3; ++k) maxP = std::max(maxP, maxAbs(dvec3(T.p[k])));
  dvec2 S[3];
  for (int k = 0; k < 3; ++k) S[k] = d.toSample(T.t[k]);
  shared::McTri scratch{};
  double sum = 0;
  shared::mcBaryMap(S, scratch, sum);
  const double db = 6 * kUlpF * sum + 4 * kUlpF;
  const double sumE = glm::length(F.e1) + glm::length(F.e2) + glm::length(F.e2 - F.e1);
  const double sumF = glm::length(F.f1) + glm::length(F.f2) + glm::length(F.f2 - F.f1);
  const double errN = 20 * kUlpF + sumF * db;
  P.vertexErr = 2.0 * (12 * kUlpF * maxP + sumE * db + H * (2 * errN / m + 6 * kUlpF) + kUlpF * (maxP + H) +
                       2 * kUlpF * (sumE + H * sumF / m));

  // Exact prism bounds (Embree).
  const Prism exact = Prism::exact(T, P.a, P.b);
  BoxD box = exact.bounds();
  box.pad(P.vertexErr);
  P.bounds = box.toFloatOutward();

  // Bulge / projection bounds. A micro-triangle lies in one cell and in T, so its
  // sample coordinates span at most rX = min(1, T's extent in X) and rY likewise (T
  // narrower than a cell: a coarse level of detail, or a dense mesh on a small map).
  const double eX = std::max({0.0, F.sU.x, F.sV.x}) - std::min({0.0, F.sU.x, F.sV.x});
  const double eY = std::max({0.0, F.sU.y, F.sV.y}) - std::min({0.0, F.sU.y, F.sV.y});
  const double rX = std::min(1.0, eX), rY = std::min(1.0, eY);
  // With ΔX ∈ [−rX, rX], ΔY ∈ [−rY, rY], N changes by at most max(|NX rX + NY rY|, |NX rX − NY rY|).
  const double fcell = std::max(glm::length(F.NX * rX + F.NY * rY), glm::length(F.NX * rX - F.NY * rY));
  const double dh = std::abs(double(d.scale)) * cellDelta;
  // σ = h/|N| varies within a micro-triangle by at most dsig.
  const double dsig = dh / m + H * fcell / (m * m);
  // The bulge of a micro-triangle point is Σλk (σk − σ̄) F (bk − b̄) = NX Cov(σ, X) +
  // NY Cov(σ, Y) (λ-weighted, X and Y the sample coordinates); a covariance of variables
  // with ranges Rσ and rX is at most Rσ rX / 4.
  const double w = dsig * (glm::length(F.NX) * rX + glm::length(F.NY) * rY) / 4 + 2 * P.vertexErr;
  const double sSpan = P.b - P.a;
  // Fixed point: the bounds hold on the domain T_dom × [a − ds', b + ds'] that they
  // themselves require.
  double delta = 0.0, ds = 0.0;
  JBounds jb;
  bool converged = false;
  for (int it = 0; it < 16 && !converged; ++it) {
    const double dom = delta * 1.1 + 1e-7, dsm = ds * 1.1 + 1e-7 * (L + std::abs(P.a) + std::abs(P.b));
    if (!jacobianBounds(F, dom, P.a - dsm, P.b + dsm, jb)) return P;  // ill-posed
    const double du = w * jb.cofU / jb.detAbsMin, dv = w * jb.cofV / jb.detAbsMin;
    const double nDelta = du + dv, nDs = w * jb.cofS / jb.detAbsMin;
    if (nDelta <= dom && nDs <= dsm) {
      converged = true;
      P.inflateB = dom;
      P.inflateS = dsm;
      // ε in samples: (X, Y) = sc + sU u + sV v.
      P.eps = w * jb.cofXY / jb.detAbsMin;
    }
    delta = std::max(delta, nDelta), ds = std::max(ds, nDs);
    if (delta > 0.25) return P;  // too loose to be useful: box-only
  }
  if (!converged) return P;
  // Inversion error bounds on a more generous domain: the traversal inverts points near
  // (not only inside) the inflated prism. Shrink the margin if that domain folds.
  for (double margin : {1.0, 0.25, 0.0}) {
    const double dom = P.inflateB + margin * 0.05;
    const double s0 = P.a - P.inflateS - margin * (0.1 * sSpan + 0.02 * L);
    const double s1 = P.b + P.inflateS + margin * (0.1 * sSpan + 0.02 * L);
    JBounds g;
    if (!jacobianBounds(F, dom, s0, s1, g)) continue;
    P.wellPosed = true;
    P.kb = dvec2(g.cofU, g.cofV) / g.detAbsMin;
    P.ks = g.cofS / g.detAbsMin;
    P.kxy = g.cofXY / g.detAbsMin;
    P.domainB = dom;
    P.domainS0 = s0;
    P.domainS1 = s1;
    return P;
  }
  return P;
}

Prism Prism::exact(const DisplacedTriangle& T, double a, double b) {
  Prism p;
  const dvec2 bv[3] = {{0, 0}, {1, 0}, {0, 1}};
  for (int k = 0; k < 3; ++k) {
    p.p_.q[k] = dvec3(T.p[k]);
    p.p_.n[k] = dvec3(T.n[k]);
    p.p_.bv[k] = bv[k];
  }
  p.p_.a = a, p.p_.b = b;
  return p;
}

Prism Prism::inflated(const LocalFrame& F, double a, double b, double delta) {
  Prism p;
  p.p_ = shared::prismInflated(F, a, b, delta);
  return p;
}

BoxD Prism::bounds() const {
  BoxD box;
  shared::prismBox(p_, box.lo, box.hi);
  return box;
}

}  // namespace oblong
