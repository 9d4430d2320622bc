// Inverter registry (see inverter.h and docs/inversion.md). Strategies are registered
// explicitly (a self-registering static object in a static library's .cpp would be
// dropped by the linker); "ceres" is added by registerCeresInverter() in oblong_ceres so
// that nothing else links Ceres.
#include "inversion/inverter.h"

#include "core/error.h"
#include "inversion/cubic.h"
#include "inversion/newton.h"

#include <mutex>

namespace oblong {

InverterRegistry& inverterRegistry() {
  static std::once_flag once;
  std::call_once(once, [] {
    auto& r = InverterRegistry::instance();
    registerNewton(r);
    registerCubic(r);
  });
  return InverterRegistry::instance();
}

std::unique_ptr<Inverter> createInverter(const std::string& name, ParamSet& params,
                                         const InverterContext& ctx) {
  auto& r = inverterRegistry();
  if (name == "ceres" && !r.has("ceres"))
    fail(params.where(),
         "inverter 'ceres' is not linked into this program (link oblong_ceres and call "
         "registerCeresInverter())");
  return r.create(name, params, ctx);
}

std::unique_ptr<Inverter> createInverter(const std::string& name) {
  ParamSet ps;
  return createInverter(name, ps);
}

std::vector<std::string> inverterNames() { return inverterRegistry().names(); }

bool readDoublePrecision(ParamSet& ps, std::string_view strategy) {
  const std::string p = ps.get<std::string>("precision", "float");
  if (p != "float" && p != "double")
    fail(ps.where(), "{}: parameter 'precision' must be \"float\" or \"double\" (got \"{}\")", strategy, p);
  return p == "double";
}

}  // namespace oblong
