// Splitter registry (see splitter.h). Strategies are registered explicitly: a static
// self-registering object in a static library's .cpp would be dropped by the linker.
#include "strategies/splitter.h"

#include "strategies/midpoint2d.h"
#include "strategies/midpoint3d.h"
#include "strategies/quadtree.h"

#include <mutex>

namespace oblong {

SplitterRegistry& splitterRegistry() {
  static std::once_flag once;
  std::call_once(once, [] {
    auto& r = SplitterRegistry::instance();
    registerMidpoint2D(r);
    registerMidpoint3D(r);
    registerQuadtree(r);
  });
  return SplitterRegistry::instance();
}

std::unique_ptr<Splitter> createSplitter(const std::string& name, ParamSet& params) {
  return splitterRegistry().create(name, params, {});
}

std::unique_ptr<Splitter> createSplitter(const std::string& name) {
  ParamSet ps;
  return createSplitter(name, ps);
}

std::vector<std::string> splitterNames() { return splitterRegistry().names(); }

}  // namespace oblong
