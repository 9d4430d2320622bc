// Traversal<SafetyZones, {Newton, Cubic}, {Midpoint2D, Midpoint3D, Quadtree}>.
#include "render/traversal_dispatch.h"
#include "strategies/safety_zones.h"

namespace oblong {

std::unique_ptr<Intersector> makeSafetyZonesTraversal(TraversalParts&& p) { return makeForRange<SafetyZones>(std::move(p)); }

}  // namespace oblong
