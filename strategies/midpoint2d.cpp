#include "strategies/midpoint2d.h"

namespace oblong {

void registerMidpoint2D(SplitterRegistry& r) {
  r.add("midpoint2d", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Midpoint2D>();
  });
}

}  // namespace oblong
