// cubic: the analytic inverse (Jeschke et al. 2007 style). X = P(u,v) + s·N(u,v) means X
// lies on the offset triangle q_i(s) = p_i + s·n_i with barycentrics (u,v), so
//
//     det(q1 − q0, q2 − q0, X − q0) = 0
//
// is a cubic in s. With σ = s / L (L = longest edge; all lengths divided by L, so the
// coefficients are dimensionless), e1 = p1−p0, e2 = p2−p0, f1 = n1−n0, f2 = n2−n0,
// W = X − p0:
//     a0 = det(e1, e2, W)
//     a1 = det(f1, e2, W) + det(e1, f2, W) − det(e1, e2, n0)
//     a2 = det(f1, f2, W) − det(f1, e2, n0) − det(e1, f2, n0)
//     a3 = −det(f1, f2, n0)
// a3 = 0 when the normals are coplanar (e.g. two equal), a3 = a2 = 0 when they are
// parallel (flat shading): the polynomial is then quadratic or linear. A leading
// coefficient is dropped when the root it carries lies beyond 1/eps triangle sizes
// (|a2/a3|, |a1/a3|^½, |a0/a3|^⅓ all > 1/eps; eps = 1e-12 in double, 1e-6 in float):
// rounding noise on a3 (coplanar normals) then cannot create spurious roots.
//
// Roots (polyRoots below): the largest real root by Cardano / the trigonometric form,
// the other two from the deflated quadratic, all polished by two Newton steps on the
// polynomial; stable quadratic formula (a double root split by rounding is accepted);
// linear.
// Choice: for each root, the barycentrics of X in the offset triangle (X − q0 = u·(q1−q0)
// + v·(q2−q0), by cross products); the root whose barycentrics are inside T, or nearest
// to inside, wins; among roots inside T (a prism folded over itself), the smallest |s|.
// Then `polish` Newton steps on F(u,v,s) (inverter.h) and h = s·|N(u,v)|.
//
// converged = false only when no real root gives a non-degenerate offset triangle (all
// coefficients zero, or only complex roots). iterations = polish steps taken.
//
// Parameters:
//   precision  "float" (default) | "double": arithmetic of invert(); invertD() is double
//   polish     Newton steps on F after the root is chosen (default 1, 0..4)
//
// Statistics: cubic/Inversions, cubic/LowerDegree (quadratic or linear), cubic/NotConverged,
// cubic/OutsideT (the best root is outside T).
#pragma once

#include "core/stats.h"
#include "inversion/inverter.h"

namespace oblong {

OBLONG_STAT_COUNTER("cubic/Inversions", cubicInversions);
OBLONG_STAT_COUNTER("cubic/LowerDegree", cubicLowerDegree);
OBLONG_STAT_COUNTER("cubic/NotConverged", cubicNotConverged);
OBLONG_STAT_COUNTER("cubic/OutsideT", cubicOutsideT);

struct CubicOptions {
  bool doublePrecision = false;  // arithmetic of invert()
  int polish = 1;
};

namespace inv {

// Two Newton steps on a3 x³ + a2 x² + a1 x + a0 from x, each kept only if it reduces |f|
// (near a double root f' vanishes and a step could throw x far away).
template <typename S>
inline S polishPolyRoot(S a0, S a1, S a2, S a3, S x) {
  S f = ((a3 * x + a2) * x + a1) * x + a0;
  for (int k = 0; k < 2; ++k) {
    const S df = (S(3) * a3 * x + S(2) * a2) * x + a1;
    if (!(std::abs(df) > S(0))) break;
    const S nx = x - f / df;
    const S nf = ((a3 * nx + a2) * nx + a1) * nx + a0;
    if (!(std::abs(nf) < std::abs(f))) break;
    x = nx, f = nf;
  }
  return x;
}

// Real roots of c2 x² + c1 x + c0 (c2 != 0), stable formula; a slightly negative
// discriminant (a double root split by rounding) counts as zero.
template <typename S>
inline int quadRoots(S c0, S c1, S c2, S eps, S x[2]) {
  S D = c1 * c1 - S(4) * c2 * c0;
  if (D < S(0) && D > -S(16) * eps * (c1 * c1 + std::abs(S(4) * c2 * c0))) D = S(0);
  if (!(D >= S(0))) return 0;
  const S q = S(-0.5) * (c1 + std::copysign(std::sqrt(D), c1));
  if (q == S(0)) {  // c1 = 0 and D = 0: double root at 0
    x[0] = S(0);
    return 1;
  }
  x[0] = q / c2;
  x[1] = c0 / q;
  return 2;
}

// Real roots of a3 x³ + a2 x² + a1 x + a0 (with the degree-dropping rule above). Returns
// the number of roots written to x (at most 3); `degree` receives the degree used.
// Cubic: the largest-magnitude real root r by Cardano or the trigonometric form (the
// large root is accurate even when |a2/a3| is huge and the small ones are not), then the
// other two from the deflated quadratic: if r is the largest root (|r|³|a3| >= |a0|),
// (a3 r) x² − (a1 + a0/r) x − a0, built from the low-order coefficients so that small
// roots keep their accuracy; else synthetic division from the top. Every root is
// polished by two Newton steps on the full polynomial and kept if it is one.
template <typename S>
inline int polyRoots(S a0, S a1, S a2, S a3, S x[3], int& degree) {
  const S eps = sizeof(S) == 4 ? S(1e-6) : S(1e-12);
  const S M = std::max({std::abs(a0), std::abs(a1), std::abs(a2), std::abs(a3)});
  degree = 0;
  if (!(M > S(0)) || !std::isfinite(M)) return 0;
  // A leading coefficient is dropped when the root it adds is beyond 1/eps: all of
  // |a_{k-1}/a_k|, |a_{k-2}/a_k|^(1/2), ... exceed 1/eps.
  const S big = S(1) / eps;
  const bool cubic = std::abs(a2) < big * std::abs(a3) || std::abs(a1) < big * big * std::abs(a3) ||
                     std::abs(a0) < big * big * big * std::abs(a3);
  const bool quadratic = std::abs(a1) < big * std::abs(a2) || std::abs(a0) < big * big * std::abs(a2);
  int n = 0;
  if (cubic) {
    degree = 3;
    const S A = a2 / a3, B = a1 / a3, C = a0 / a3;
    const S A3 = A / S(3);
    const S p = B - A * A3, q = S(2) * A3 * A3 * A3 - A3 * B + C;
    const S D = q * q / S(4) + p * p * p / S(27);
    S r;
    if (D > S(0)) {
      const S w = -q / S(2) - std::copysign(std::sqrt(D), q);
      const S t = std::cbrt(w);
      r = (t != S(0) ? t - p / (S(3) * t) : S(0)) - A3;
    } else if (p == S(0)) {
      r = -A3;
    } else {
      const S rr = std::sqrt(-p / S(3));
      const S c = std::clamp(S(3) * q / (S(2) * p) * std::sqrt(S(-3) / p), S(-1), S(1));
      const S phi = std::acos(c) / S(3);
      constexpr S k2pi3 = S(2.0943951023931954923);
      r = S(0);
      for (int k = 0; k < 3; ++k) {
        const S t = S(2) * rr * std::cos(phi - S(k) * k2pi3) - A3;
        if (std::abs(t) > std::abs(r)) r = t;
      }
    }
    if (!std::isfinite(r)) return 0;
    r = polishPolyRoot(a0, a1, a2, a3, r);
    x[n++] = r;
    S y[2];
    int m;
    const S b2 = a2 + a3 * r;  // synthetic division from the top: a3 x² + b2 x + b1
    if (r != S(0) && std::abs(r) * r * r * std::abs(a3) >= std::abs(a0)) {
      // r is the largest root: deflate from the bottom (keeps small roots accurate).
      m = quadRoots(-a0, -(a1 + a0 / r), a3 * r, eps, y);
    } else {
      m = quadRoots(a1 + r * b2, b2, a3, eps, y);
    }
    for (int i = 0; i < m; ++i) x[n++] = polishPolyRoot(a0, a1, a2, a3, y[i]);
  } else if (quadratic) {
    degree = 2;
    S y[2];
    const int m = quadRoots(a0, a1, a2, eps, y);
    for (int i = 0; i < m; ++i) x[n++] = polishPolyRoot(a0, a1, a2, a3, y[i]);
  } else if (std::abs(a1) > eps * M) {
    degree = 1;
    x[n++] = polishPolyRoot(a0, a1, a2, a3, -a0 / a1);
  }
  // Keep finite candidates that are roots: |f| <= tol · Σ|a_k||x|^k (tol 1e-6, float
  // 1e-2) rejects the real parts of complex pairs that the near-double rule let through.
  const S tol = sizeof(S) == 4 ? S(1e-2) : S(1e-6);
  int kept = 0;
  for (int i = 0; i < n; ++i) {
    const S xi = x[i], ax = std::abs(xi);
    const S f = ((a3 * xi + a2) * xi + a1) * xi + a0;
    const S scale = ((std::abs(a3) * ax + std::abs(a2)) * ax + std::abs(a1)) * ax + std::abs(a0);
    if (std::isfinite(xi) && std::abs(f) <= tol * scale) x[kept++] = xi;
  }
  return kept;
}

// The cubic in s/L of the point W = X − p0 (the header's a0..a3), with the edges and W
// scaled by 1/L (e1, e2, w) as its roots' barycentrics need them.
template <typename S>
struct CubicOf {
  glm::vec<3, S> e1, e2, w;
  S a0, a1, a2, a3;
  CubicOf(const Frame<S>& F, const glm::vec<3, S>& W) {
    const S iL = S(1) / F.L;
    e1 = F.e1 * iL, e2 = F.e2 * iL, w = W * iL;
    a0 = det3(e1, e2, w);
    a1 = det3(F.f1, e2, w) + det3(e1, F.f2, w) - det3(e1, e2, F.n0);
    a2 = det3(F.f1, F.f2, w) - det3(F.f1, e2, F.n0) - det3(e1, F.f2, F.n0);
    a3 = -det3(F.f1, F.f2, F.n0);
  }
};

template <typename S>
inline InversionResultT<S> cubicSolve(const glm::vec<3, S>& X, const DisplacedTriangle& T, int polish,
                                      int* degreeOut = nullptr) {
  using V = glm::vec<3, S>;
  const Frame<S> F(T);
  const V W = X - V(T.p[0]);
  const CubicOf<S> C(F, W);
  const V &e1 = C.e1, &e2 = C.e2, &w = C.w;
  const S a0 = C.a0, a1 = C.a1, a2 = C.a2, a3 = C.a3;
  S roots[3];
  int degree;
  const int n = polyRoots(a0, a1, a2, a3, roots, degree);
  if (degreeOut) *degreeOut = degree;

  const S tieEps = sizeof(S) == 4 ? S(1e-5) : S(1e-10);
  bool found = false;
  S bu = 0, bv = 0, bs = 0, bOut = 0;
  for (int i = 0; i < n; ++i) {
    const S sg = roots[i];
    const V A = e1 + sg * F.f1, B = e2 + sg * F.f2, R = w - sg * F.n0;
    const V nS = glm::cross(A, B);
    const S d = glm::dot(nS, nS);
    if (!(d > S(0))) continue;
    const S u = glm::dot(glm::cross(R, B), nS) / d, v = glm::dot(glm::cross(A, R), nS) / d;
    if (!std::isfinite(u) || !std::isfinite(v)) continue;
    const S out = std::max({S(0), -u, -v, u + v - S(1)});
    const bool better = !found || out < bOut - tieEps ||
                        (out <= bOut + tieEps && std::abs(sg) < std::abs(bs));
    if (better) found = true, bu = u, bv = v, bs = sg, bOut = out;
  }
  if (!found) return finish(F, T, S(1) / S(3), S(1) / S(3), S(0), false, 0);
  S u = bu, v = bv, s = bs * F.L;
  int it = 0;
  for (; it < polish; ++it) {
    S du, dv, ds;
    if (!newtonStep(F, W, u, v, s, du, dv, ds)) break;
  }
  return finish(F, T, u, v, s, true, it);
}

}  // namespace inv

class Cubic final : public InverterImpl<Cubic> {
 public:
  explicit Cubic(const CubicOptions& o = {}) : o_(o) {}
  std::string_view name() const override { return "cubic"; }
  const CubicOptions& options() const { return o_; }

  InversionResult invertFast(const vec3& X, const DisplacedTriangle& T) const {
    int degree;
    InversionResult r;
    if (o_.doublePrecision) {
      const InversionResultD d = inv::cubicSolve<double>(dvec3(X), T, o_.polish, &degree);
      r = {vec2(d.bary), vec2(d.uv), float(d.h), d.converged, d.iterations};
    } else {
      r = inv::cubicSolve<float>(X, T, o_.polish, &degree);
    }
    count(r.converged, degree, r.outside() > 0.0f);
    return r;
  }
  InversionResultD invertFastD(const dvec3& X, const DisplacedTriangle& T) const {
    int degree;
    const InversionResultD r = inv::cubicSolve<double>(X, T, o_.polish, &degree);
    count(r.converged, degree, r.outside() > 0.0);
    return r;
  }

 private:
  static void count(bool converged, int degree, bool outside) {
    OBLONG_STAT_INC(cubicInversions);
    if (degree < 3) OBLONG_STAT_INC(cubicLowerDegree);
    if (!converged) OBLONG_STAT_INC(cubicNotConverged);
    if (converged && outside) OBLONG_STAT_INC(cubicOutsideT);
  }
  CubicOptions o_;
};


}  // namespace oblong
