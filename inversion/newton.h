// newton: Newton's method on the 3x3 system F(u,v,s) = P(u,v) + s·N(u,v) − X = 0
// (inversion/inverter.h), h = s·|N(u,v)|. RMIP's choice (paper §4.1, Fig. 4).
//
//   Initial guess:  the centroid of T on the base surface, (u, v, s) = (1/3, 1/3, 0).
//                   The first step therefore projects X onto the base plane along
//                   N(1/3,1/3); for parallel normals F is linear and that step is exact.
//   Step:           J = [P_u + s N_u, P_v + s N_v, N(u,v)], solved by Cramer's rule in the
//                   frame of p0 (X − p0 first, which keeps float accurate far from 0).
//   Stopping rule:  after a step (du, dv, ds) with max(|du|,|dv|) <= tolerance and
//                   |ds| <= tolerance · (L + |s|), L = longest edge of T: converged.
//                   Quadratic convergence makes the returned point's error ~tolerance².
//   Iteration cap:  max_iterations steps; hitting it (or a singular Jacobian, or a
//                   non-finite step) returns the last iterate with converged = false.
//                   tolerance = 0 gives a fixed number of steps (converged is then true
//                   only if a step was exactly zero; use it for fixed-cost experiments).
//   Fallback:       Newton from the centroid can converge to another root of F, outside
//                   T, although X is inside T's prism (strongly twisted normals; see
//                   docs/inversion.md — RMIP's "the prism lies in the convergence region"
//                   does not hold in general). With fallback = "cubic" (default), a result
//                   outside T by more than 1e-5 (float) / 1e-9 (double) barycentric units,
//                   not finite, or not converged (unless tolerance = 0: fixed step count)
//                   is replaced by the cubic inverter's (same precision, one polish
//                   step), which picks the root inside T.
//                   Points outside the prism legitimately invert outside T and pay for
//                   the cubic as well. iterations then counts Newton's steps plus one.
//
// Parameters:
//   precision       "float" (default) | "double": arithmetic of invert(); invertD() is
//                   always double.
//   tolerance       step tolerance of invert() (default 1e-5 with float arithmetic,
//                   1e-10 with double); invertD() uses it when precision is double and
//                   min(tolerance, 1e-10) when it is float
//   max_iterations  iteration cap (default 10)
//   fallback        "cubic" (default) | "none"
//
// Statistics: newton/Inversions, newton/Iterations, newton/NotConverged (after the
// fallback), newton/Fallbacks.
#pragma once

#include "core/stats.h"
#include "inversion/inverter.h"
#include "core/kernels/constants.h"

namespace oblong {

OBLONG_STAT_COUNTER("newton/Inversions", newtonInversions);
OBLONG_STAT_COUNTER("newton/Iterations", newtonIterations);
OBLONG_STAT_COUNTER("newton/NotConverged", newtonNotConverged);
OBLONG_STAT_COUNTER("newton/Fallbacks", newtonFallbacks);

struct NewtonOptions {
  bool doublePrecision = false;  // arithmetic of invert()
  double tolerance = OBLONG_NEWTON_TOLERANCE;
  double toleranceD = OBLONG_NEWTON_TOLERANCE_D;  // used by invertD()
  int maxIterations = OBLONG_NEWTON_MAX_ITERATIONS;
  bool fallback = true;  // to cubic when the result is unconverged or outside T
};


class Newton final : public InverterImpl<Newton> {
 public:
  explicit Newton(const NewtonOptions& o = {}) : o_(o) {}
  std::string_view name() const override { return "newton"; }
  const NewtonOptions& options() const { return o_; }

  InversionResult invertFast(const vec3& X, const DisplacedTriangle& T) const {
    InversionResult r;
    if (o_.doublePrecision) {
      const InversionResultD d = solve<double>(dvec3(X), T, o_.tolerance);
      r = {vec2(d.bary), vec2(d.uv), float(d.h), d.converged, d.iterations};
    } else {
      r = solve<float>(X, T, float(o_.tolerance));
    }
    OBLONG_STAT_INC(newtonInversions);
    OBLONG_STAT_ADD(newtonIterations, r.iterations);
    if (!r.converged) OBLONG_STAT_INC(newtonNotConverged);
    return r;
  }
  InversionResultD invertFastD(const dvec3& X, const DisplacedTriangle& T) const {
    const InversionResultD r = solve<double>(X, T, o_.toleranceD);
    OBLONG_STAT_INC(newtonInversions);
    OBLONG_STAT_ADD(newtonIterations, r.iterations);
    if (!r.converged) OBLONG_STAT_INC(newtonNotConverged);
    return r;
  }

 private:
  // The kernel (core/kernels/invert.h), which the Vulkan shaders run as well.
  template <typename S>
  InversionResultT<S> solve(const glm::vec<3, S>& X, const DisplacedTriangle& T, S tol) const {
    bool fellBack;
    const auto r = shared::newtonSolve(inv::frameOf<S>(T), X, tol, o_.maxIterations, o_.fallback,
                                       OBLONG_NEWTON_FALLBACK_POLISH, fellBack);
    if (fellBack) OBLONG_STAT_INC(newtonFallbacks);
    return inv::toResult<S>(r, T);
  }
  NewtonOptions o_;
};


}  // namespace oblong
