// Bounding prisms and the shell analysis (see prism.h for the reasoning).
#include "traversal/prism.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>

namespace oblong {

namespace {

constexpr double kUlpF = 1.0 / (1 << 24);  // unit roundoff of float

double det3(const dvec3& a, const dvec3& b, const dvec3& c) { return glm::dot(a, glm::cross(b, c)); }

double maxAbs(const dvec3& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

bool lexLess(const dvec3& p, const dvec3& n, const dvec3& q, const dvec3& m) {
  for (int k = 0; k < 3; ++k)
    if (p[k] != q[k]) return p[k] < q[k];
  for (int k = 0; k < 3; ++k)
    if (n[k] != m[k]) return n[k] < m[k];
  return false;
}

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

  // Float error of the micro-vertices (core/microgeometry.cpp computes them in float):
  // rounding of uv, of T.uvToBary (float) and of (uv - t0) gives a barycentric error db;
  // P, N and normalize add a few ulps; edge crossings round their parameter to float.
  double maxP = 0, maxUV = 0, uvSpan = 0;
  for (int k = 0; k < 3; ++k) {
    maxP = std::max(maxP, maxAbs(dvec3(T.p[k])));
    maxUV = std::max({maxUV, std::abs(double(T.t[k].x)), std::abs(double(T.t[k].y))});
    uvSpan = std::max({uvSpan, std::abs(double(T.t[k].x - T.t[0].x)), std::abs(double(T.t[k].y - T.t[0].y))});
  }
  const glm::mat2& M = T.uvToBary;
  const double normM = std::max(std::abs(M[0][0]) + std::abs(M[1][0]), std::abs(M[0][1]) + std::abs(M[1][1]));
  const double db = normM * kUlpF * (2 * maxUV + 8 * uvSpan) + 4 * kUlpF;
  const double sumE = glm::length(F.e1) + glm::length(F.e2) + glm::length(F.e2 - F.e1);
  const double sumF = glm::length(F.f1) + glm::length(F.f2) + glm::length(F.f2 - F.f1);
  const double errN = 20 * kUlpF + sumF * db;
  P.vertexErr = 2.0 * (8 * kUlpF * 3 * maxP + sumE * db + H * (2 * errN / m + 6 * kUlpF) + kUlpF * (maxP + H) +
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
    p.q_[k] = dvec3(T.p[k]);
    p.n_[k] = dvec3(T.n[k]);
    p.bv_[k] = bv[k];
  }
  p.a_ = a, p.b_ = b;
  return p;
}

Prism Prism::inflated(const LocalFrame& F, double a, double b, double delta) {
  Prism p;
  const dvec2 bv[3] = {{-delta, -delta}, {1 + 2 * delta, -delta}, {-delta, 1 + 2 * delta}};
  for (int k = 0; k < 3; ++k) {
    p.q_[k] = F.P(bv[k]);
    p.n_[k] = F.N(bv[k]);
    p.bv_[k] = bv[k];
  }
  p.a_ = a, p.b_ = b;
  return p;
}

BoxD Prism::bounds() const {
  // G(b, s) is a convex combination of the six vertices (affine in b at fixed s, affine
  // in s at fixed b), so their box contains the prism.
  BoxD box;
  for (int k = 0; k < 3; ++k) {
    box.extend(vertex(k, false));
    box.extend(vertex(k, true));
  }
  return box;
}

int Prism::crossings(const dvec3& O, const dvec3& D, Crossing& first, Crossing& last) const {
  int count = 0;
  auto add = [&](double t, const dvec2& bary, double s) {
    if (!std::isfinite(t)) return;
    const Crossing c{t, bary, s};
    if (count == 0 || t < first.t) first = c;
    if (count == 0 || t > last.t) last = c;
    ++count;
  };
  constexpr double tol = 1e-9;
  const double sTol = tol * (std::abs(a_) + std::abs(b_) + 1e-3);
  // Caps: flat triangles q_k + s n_k (Möller–Trumbore in double).
  for (int cap = 0; cap < 2; ++cap) {
    const double s = cap ? b_ : a_;
    const dvec3 v0 = q_[0] + s * n_[0], v1 = q_[1] + s * n_[1], v2 = q_[2] + s * n_[2];
    const dvec3 e1 = v1 - v0, e2 = v2 - v0;
    const dvec3 pv = glm::cross(D, e2);
    const double det = glm::dot(e1, pv);
    if (det == 0.0) continue;
    const double inv = 1.0 / det;
    const dvec3 tv = O - v0;
    const double b1 = glm::dot(tv, pv) * inv;
    const dvec3 qv = glm::cross(tv, e1);
    const double b2 = glm::dot(D, qv) * inv;
    if (b1 < -tol || b2 < -tol || b1 + b2 > 1 + tol) continue;
    const double t = glm::dot(e2, qv) * inv;
    add(t, bv_[0] + b1 * (bv_[1] - bv_[0]) + b2 * (bv_[2] - bv_[0]), s);
  }
  // Walls: the ruled surfaces between the edge's displacement lines. The line at τ meets
  // the ray where det(O − Pτ, Nτ, D) = 0, a quadratic in τ. Canonical endpoint order.
  for (int e = 0; e < 3; ++e) {
    int A = e, B = (e + 1) % 3;
    if (lexLess(q_[B], n_[B], q_[A], n_[A])) std::swap(A, B);
    const dvec3 c = O - q_[A], ed = q_[B] - q_[A], g = n_[B] - n_[A];
    const double k0 = det3(c, n_[A], D);
    const double k1 = det3(c, g, D) - det3(ed, n_[A], D);
    const double k2 = -det3(ed, g, D);
    double tau[2], pad[2];
    const int nr = quadraticRoots(k2, k1, k0, tau, pad);
    for (int r = 0; r < nr; ++r) {
      const double ta = tau[r];
      if (ta < -tol - pad[r] || ta > 1 + tol + pad[r]) continue;
      const double tc = std::clamp(ta, 0.0, 1.0);
      const dvec3 Pt = q_[A] + tc * ed, Nt = n_[A] + tc * g;
      // Closest points of the ray and the displacement line at τ.
      const dvec3 Av = Pt - O;
      const double dd = glm::dot(D, D), nn = glm::dot(Nt, Nt), dn = glm::dot(D, Nt);
      const double den = dd * nn - dn * dn;
      if (!(den > 1e-24 * dd * nn)) continue;  // ray along the line: lies in the wall
      const double da = glm::dot(D, Av), na = glm::dot(Nt, Av);
      const double t = (nn * da - dn * na) / den;
      const double s = (dn * da - dd * na) / den;
      if (s < a_ - sTol || s > b_ + sTol) continue;
      add(t, bv_[A] + tc * (bv_[B] - bv_[A]), s);
    }
  }
  return count;
}

}  // namespace oblong
