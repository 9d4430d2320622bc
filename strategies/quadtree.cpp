#include "strategies/quadtree.h"

namespace oblong {

OBLONG_REGISTER_SPLITTER("quadtree", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Quadtree>();
  },
  StrategyTraits{false, "split on the coarsest node-aligned grid line, no inversion (TFDM's quad-tree nodes, inside the RMIP driver)"});

}  // namespace oblong
