#include "strategies/midpoint3d.h"

namespace oblong {

void registerMidpoint3D(SplitterRegistry& r) {
  r.add("midpoint3d", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Midpoint3D>();
  });
}

}  // namespace oblong
