#include "strategies/midpoint2d.h"

namespace oblong {

OBLONG_REGISTER_SPLITTER("midpoint2d", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Midpoint2D>();
  },
  StrategyTraits{.summary = "split the longer side of the rectangle in the middle (RMIP Sec. 4.3, Fig. 5c)",
                 .vulkanKernel = "core/kernels/midpoint2d.h"});

}  // namespace oblong
