#include "inversion/cubic.h"

namespace oblong {

void registerCubic(InverterRegistry& r) {
  r.add("cubic", [](ParamSet& ps, const InverterContext&) -> std::unique_ptr<Inverter> {
    CubicOptions o;
    o.doublePrecision = readDoublePrecision(ps, "cubic");
    o.polish = ps.getInRange("polish", o.polish, 0, 4);
    return std::make_unique<Cubic>(o);
  });
}

}  // namespace oblong
