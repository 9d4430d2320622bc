#include "inversion/newton.h"

#include "core/error.h"

namespace oblong {

OBLONG_REGISTER_INVERTER("newton", [](ParamSet& ps, const InverterContext&) -> std::unique_ptr<Inverter> {
    NewtonOptions o;
    o.doublePrecision = readDoublePrecision(ps, "newton");
    o.tolerance = ps.getInRange("tolerance", o.doublePrecision ? 1e-10 : double(OBLONG_NEWTON_TOLERANCE), 0.0, 1.0);
    o.toleranceD = o.doublePrecision ? o.tolerance : std::min(o.tolerance, 1e-10);
    o.maxIterations = ps.getInRange("max_iterations", o.maxIterations, 1, 1000);
    const std::string fb = ps.get<std::string>("fallback", "cubic");
    if (fb != "cubic" && fb != "none")
      fail(ps.where(), "newton: parameter 'fallback' must be \"cubic\" or \"none\" (got \"{}\")", fb);
    o.fallback = fb == "cubic";
    return std::make_unique<Newton>(o);
  },
  StrategyTraits{.summary = "Newton on the 3x3 system, float or double, cubic fallback (RMIP Sec. 4.1)",
                 .vulkanKernel = "core/kernels/invert.h"});

}  // namespace oblong
