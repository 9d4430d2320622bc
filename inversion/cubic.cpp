#include "inversion/cubic.h"

namespace oblong {

OBLONG_REGISTER_INVERTER("cubic", [](ParamSet& ps, const InverterContext&) -> std::unique_ptr<Inverter> {
    CubicOptions o;
    o.doublePrecision = readDoublePrecision(ps, "cubic");
    o.polish = ps.getInRange("polish", o.polish, 0, 4);
    return std::make_unique<Cubic>(o);
  },
  StrategyTraits{false, "analytic: X on the offset triangle gives a cubic in s"});

}  // namespace oblong
