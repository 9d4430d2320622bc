// ceres: the correctness reference. Ceres Solver (Levenberg–Marquardt, dense QR) with
// automatic differentiation, in double precision, on the residual F(u,v,s) / L
// (inversion/inverter.h; L = longest edge, so the residual is dimensionless).
//
//   Initial guess:  (u, v, s) = (1/3, 1/3, 0), the same as newton. F can have other
//                   roots outside T which LM may reach from there (twisted normals); with
//                   multi_start (default on), a result that did not converge or lies
//                   outside T by more than 1e-9 is retried from T's vertices and edge
//                   midpoints (s = 0), and the first converged root inside T is
//                   returned (else the converged one nearest to T). Independent of the
//                   other inverters; iterations sums all starts.
//   Stopping rule:  Ceres' own: function_tolerance, parameter_tolerance,
//                   gradient_tolerance (parameters below).
//   Iteration cap:  max_iterations (Ceres iterations).
//   converged:      Ceres reports CONVERGENCE and the final |F| / L <= residual_tolerance
//                   (a local minimum of |F|² that is not a root is not converged).
//
// Parameters: function_tolerance (1e-16), parameter_tolerance (1e-14),
// gradient_tolerance (1e-20), max_iterations (100, per start), residual_tolerance
// (1e-10), multi_start (true).
//
// This header does not include Ceres; the solver lives in ceres.cpp, compiled into the
// library oblong_ceres, the only target that links Ceres (docs/design.md invariant 4). A program
// linking oblong_ceres knows "ceres" (it registers itself); others say it is not linked.
//
// Statistics: ceres/Inversions, ceres/Iterations, ceres/NotConverged.
#pragma once

#include "inversion/inverter.h"

namespace oblong {

struct CeresOptions {
  double functionTolerance = 1e-16;
  double parameterTolerance = 1e-14;
  double gradientTolerance = 1e-20;
  int maxIterations = 100;
  double residualTolerance = 1e-10;
  bool multiStart = true;
};

class CeresInverter final : public InverterImpl<CeresInverter> {
 public:
  explicit CeresInverter(const CeresOptions& o = {}) : o_(o) {}
  std::string_view name() const override { return "ceres"; }
  // Both entry points solve in double (the float one rounds the result).
  InversionResult invertFast(const vec3& X, const DisplacedTriangle& T) const;
  InversionResultD invertFastD(const dvec3& X, const DisplacedTriangle& T) const;

 private:
  CeresOptions o_;
};

}  // namespace oblong
