// Inverter registry access (see inverter.h and docs/inversion.md). The strategies
// register themselves; "ceres" lives in oblong_ceres, so only programs linking that
// library (and so Ceres) know it.
#include "inversion/inverter.h"

#include "core/error.h"


namespace oblong {

std::unique_ptr<Inverter> createInverter(const std::string& name, ParamSet& params,
                                         const InverterContext& ctx) {
  auto& r = InverterRegistry::instance();
  if (name == "ceres" && !r.has("ceres"))
    fail(params.where(), "inverter 'ceres' is not linked into this program (link oblong_ceres)");
  return r.create(name, params, ctx);
}

std::unique_ptr<Inverter> createInverter(const std::string& name) {
  ParamSet ps;
  return createInverter(name, ps);
}

std::vector<std::string> inverterNames() { return InverterRegistry::instance().names(); }
const StrategyTraits& inverterTraits(const std::string& name) { return InverterRegistry::instance().traits(name); }

bool readDoublePrecision(ParamSet& ps, std::string_view strategy) {
  const std::string p = ps.get<std::string>("precision", "float");
  if (p != "float" && p != "double")
    fail(ps.where(), "{}: parameter 'precision' must be \"float\" or \"double\" (got \"{}\")", strategy, p);
  return p == "double";
}

}  // namespace oblong
