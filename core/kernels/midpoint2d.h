// midpoint2d's cut (RMIP paper §4.3, Fig. 5c): the line that halves a curve piece's
// rectangle, written once for the CPU's splitters (strategies/splitter.h's
// split::middleCrossing, which midpoint2d, midpoint3d and quadtree use) and the Vulkan
// intersection shader's splitter hook (render/vulkan/shaders/traversal.glsl, rpSplit).
#ifndef OBLONG_KERNELS_MIDPOINT2D_H
#define OBLONG_KERNELS_MIDPOINT2D_H

#include "core/kernels/lang.h"
#include "core/kernels/ray_patch.h"

OBLONG_KERNELS_BEGIN

// The line {axis = c} of choice k (0: the middle of the rectangle's longer side, 1: of the
// other side), moved inside the endpoints' range where the pads put it outside; false
// when c is not strictly between the endpoints (the curve need not cross the line).
OBLONG_INLINE bool midpointLine(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b, int k, OBLONG_OUT(int) axis,
                                OBLONG_OUT(double) c) {
  dvec2 lo = dvec2(pieceLo(a, b)), hi = dvec2(pieceHi(a, b));
  OBLONG_PRECISE dvec2 ext = hi - lo;
  int first = ext.x >= ext.y ? 0 : 1;
  axis = k == 0 ? first : 1 - first;
  OBLONG_PRECISE double m = 0.5 * (lo[axis] + hi[axis]);
  if (!strictlyBetween(a, b, axis, m)) m = 0.5 * (double(a.uv[axis]) + double(b.uv[axis]));
  c = m;
  return strictlyBetween(a, b, axis, m);
}

OBLONG_KERNELS_END

#endif
