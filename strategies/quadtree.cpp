#include "strategies/quadtree.h"

namespace oblong {

void registerQuadtree(SplitterRegistry& r) {
  r.add("quadtree", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Quadtree>();
  });
}

}  // namespace oblong
