// Traversal<Rmip, {Newton, Cubic}, {Midpoint2D, Midpoint3D, Quadtree}>.
#include "render/traversal_dispatch.h"
#include "strategies/rmip.h"

namespace oblong {

std::unique_ptr<Intersector> makeRmipTraversal(TraversalParts&& p) { return makeForRange<Rmip>(std::move(p)); }

}  // namespace oblong
