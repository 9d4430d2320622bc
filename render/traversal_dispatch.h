// Static instantiations of Traversal<RQ, Inv, Split> for one range query: included by
// traversal_<range>.cpp, one file per range query so the 18 combinations compile in
// parallel.
#pragma once

#include "inversion/cubic.h"
#include "inversion/newton.h"
#include "render/traversal.h"
#include "strategies/midpoint2d.h"
#include "strategies/midpoint3d.h"
#include "strategies/quadtree.h"

namespace oblong {

template <typename RQ, typename Inv>
std::unique_ptr<Intersector> makeForSplitter(TraversalParts&& p) {
  const Splitter* s = p.split.get();
  if (dynamic_cast<const Midpoint2D*>(s)) return makeTraversal<RQ, Inv, Midpoint2D>(std::move(p));
  if (dynamic_cast<const Midpoint3D*>(s)) return makeTraversal<RQ, Inv, Midpoint3D>(std::move(p));
  if (dynamic_cast<const Quadtree*>(s)) return makeTraversal<RQ, Inv, Quadtree>(std::move(p));
  return nullptr;  // parts untouched: the caller takes the generic path
}

template <typename RQ>
std::unique_ptr<Intersector> makeForRange(TraversalParts&& p) {
  const Inverter* inv = p.inv.get();
  if (dynamic_cast<const Newton*>(inv)) return makeForSplitter<RQ, Newton>(std::move(p));
  if (dynamic_cast<const Cubic*>(inv)) return makeForSplitter<RQ, Cubic>(std::move(p));
  return nullptr;
}

}  // namespace oblong
