// Traversal<RangeQuery, Inverter, Splitter>: the same algorithm through the virtual
// interfaces, for strategies without a static instantiation (ceres, new ones).
#include "render/traversal.h"

namespace oblong {

std::unique_ptr<Intersector> makeGenericTraversal(TraversalParts&& p) {
  return makeTraversal<RangeQuery, Inverter, Splitter>(std::move(p));
}

}  // namespace oblong
