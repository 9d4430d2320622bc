// Traversal<MinMaxMipmap, {Newton, Cubic}, {Midpoint2D, Midpoint3D, Quadtree}>.
#include "render/traversal_dispatch.h"
#include "strategies/minmax_mipmap.h"

namespace oblong {

std::unique_ptr<Intersector> makeMinMaxMipmapTraversal(TraversalParts&& p) { return makeForRange<MinMaxMipmap>(std::move(p)); }

}  // namespace oblong
