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
// Roots (polyRoots in core/kernels/invert_scalar.h): the largest real root by Cardano / the trigonometric form,
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
// The kernel (core/kernels/invert.h: polyRoots, cubicRoot, cubicSolve) for T.
template <typename S>
inline InversionResultT<S> cubicSolve(const glm::vec<3, S>& X, const DisplacedTriangle& T, int polish,
                                      int* degreeOut = nullptr) {
  int degree;
  const auto r = shared::cubicSolve(frameOf<S>(T), X, polish, degree);
  if (degreeOut) *degreeOut = degree;
  return toResult<S>(r, T);
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
