#include "strategies/midpoint3d.h"

namespace oblong {

OBLONG_REGISTER_SPLITTER("midpoint3d", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Midpoint3D>();
  },
  StrategyTraits{false, "invert the midpoint of the ray interval (RMIP Sec. 4.3, Fig. 5b)"});

}  // namespace oblong
