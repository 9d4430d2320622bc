#include "inversion/ceres.h"

#include "core/stats.h"

#include <ceres/ceres.h>

#include <mutex>

namespace oblong {

OBLONG_STAT_COUNTER("ceres/Inversions", ceresInversions);
OBLONG_STAT_COUNTER("ceres/Iterations", ceresIterations);
OBLONG_STAT_COUNTER("ceres/NotConverged", ceresNotConverged);

namespace {

// F(u,v,s) / L in the frame of p0: e1 u + e2 v + s (n0 + u f1 + v f2) - W.
struct Residual {
  double e1[3], e2[3], n0[3], f1[3], f2[3], w[3], iL;
  template <typename J>
  bool operator()(const J* const x, J* r) const {
    const J& u = x[0];
    const J& v = x[1];
    const J& s = x[2];
    for (int k = 0; k < 3; ++k) {
      const J N = n0[k] + u * f1[k] + v * f2[k];
      r[k] = (e1[k] * u + e2[k] * v + s * N - w[k]) * iL;
    }
    return true;
  }
};

}  // namespace

InversionResultD CeresInverter::invertFastD(const dvec3& X, const DisplacedTriangle& T) const {
  const inv::Frame<double> F = inv::frameOf<double>(T);
  const dvec3 W = X - F.p0;
  Residual base;
  for (int k = 0; k < 3; ++k) {
    base.e1[k] = F.e1[k], base.e2[k] = F.e2[k], base.n0[k] = F.n0[k];
    base.f1[k] = F.f1[k], base.f2[k] = F.f2[k], base.w[k] = W[k];
  }
  base.iL = 1.0 / F.L;
  ceres::Solver::Options opt;
  opt.linear_solver_type = ceres::DENSE_QR;
  opt.minimizer_progress_to_stdout = false;
  opt.logging_type = ceres::SILENT;
  opt.function_tolerance = o_.functionTolerance;
  opt.parameter_tolerance = o_.parameterTolerance;
  opt.gradient_tolerance = o_.gradientTolerance;
  opt.max_num_iterations = o_.maxIterations;
  opt.num_threads = 1;

  // Starts: the centroid, then (only if that gives no converged root inside T) the
  // vertices and edge midpoints of T, all on the base surface (s = 0).
  static constexpr double kStarts[7][2] = {{1.0 / 3, 1.0 / 3}, {0, 0}, {1, 0}, {0, 1},
                                           {0.5, 0}, {0.5, 0.5}, {0, 0.5}};
  InversionResultD best;
  bool have = false;
  int iters = 0;
  for (int k = 0; k < (o_.multiStart ? 7 : 1); ++k) {
    double x[3] = {kStarts[k][0], kStarts[k][1], 0.0};
    ceres::Problem problem;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Residual, 3, 3>(new Residual(base)), nullptr, x);
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    const double resid = std::sqrt(2.0 * summary.final_cost);
    const bool conv = summary.termination_type == ceres::CONVERGENCE && resid <= o_.residualTolerance;
    iters += int(summary.iterations.size()) - 1;  // iteration 0 is the initial state
    const InversionResultD r = inv::finish(F, T, x[0], x[1], x[2], conv, 0);
    const bool better = !have || (r.converged && !best.converged) ||
                        (r.converged == best.converged && r.outside() < best.outside());
    if (better) best = r, have = true;
    if (best.converged && best.outside() <= 1e-9) break;
  }
  best.iterations = iters;
  OBLONG_STAT_INC(ceresInversions);
  OBLONG_STAT_ADD(ceresIterations, iters);
  if (!best.converged) OBLONG_STAT_INC(ceresNotConverged);
  return best;
}

InversionResult CeresInverter::invertFast(const vec3& X, const DisplacedTriangle& T) const {
  const InversionResultD d = invertFastD(dvec3(X), T);
  return {vec2(d.bary), vec2(d.uv), float(d.h), d.converged, d.iterations};
}

OBLONG_REGISTER_INVERTER("ceres", [](ParamSet& ps, const InverterContext&) -> std::unique_ptr<Inverter> {
    CeresOptions o;
    o.functionTolerance = ps.getInRange("function_tolerance", o.functionTolerance, 0.0, 1.0);
    o.parameterTolerance = ps.getInRange("parameter_tolerance", o.parameterTolerance, 0.0, 1.0);
    o.gradientTolerance = ps.getInRange("gradient_tolerance", o.gradientTolerance, 0.0, 1.0);
    o.maxIterations = ps.getInRange("max_iterations", o.maxIterations, 1, 10000);
    o.residualTolerance = ps.getInRange("residual_tolerance", o.residualTolerance, 0.0, 1.0);
    o.multiStart = ps.get<bool>("multi_start", o.multiStart);
    return std::make_unique<CeresInverter>(o);
  },
  StrategyTraits{true, "Ceres autodiff in double with multi-start: the correctness reference (slow)"});

}  // namespace oblong
