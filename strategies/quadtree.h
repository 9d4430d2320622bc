// quadtree: the texture-space quad-tree of TFDM (Thonat et al. 2021, §4; RMIP paper §6,
// Fig. 9b "the quad-tree nature of their texture-space traversal"). The piece is cut on
// the grid line, aligned to the min-max mipmap's nodes, of the coarsest level that
// separates its rectangle: the largest 2^k such that a multiple of 2^k (absolute sample
// index) lies strictly inside the rectangle's longer side; the curve's crossing with
// that line comes from ψ in closed form — no inversion. With minmax_mipmap, inversion
// during traversal off, and marching scale 1 this is the RMIP driver with TFDM's nodes: an
// ablation, not TFDM (which is the `tfdm` baseline, traversal/tfdm.cpp).
//
// Node alignment is in absolute sample indices; for map sizes that are not powers of two
// the wrapped nodes of minmax_mipmap start again at every period, so the alignment is
// exact only within the first period (the split stays valid, just not node-aligned).
//
// Fallback: no aligned line inside either side (a rectangle under one texel) or no
// crossing found: midpoint2d's rule, then inversion at the t-midpoint.
//
// Parameters: none. Statistics: quadtree/Splits, quadtree/Fallbacks.
#pragma once

#include "core/stats.h"
#include "strategies/splitter.h"

#include <cmath>

namespace oblong {

OBLONG_STAT_COUNTER("quadtree/Splits", quadtreeSplits);
OBLONG_STAT_COUNTER("quadtree/Fallbacks", quadtreeFallbacks);

class Quadtree final : public SplitterImpl<Quadtree> {
 public:
  std::string_view name() const override { return "quadtree"; }

  // The coarsest power-of-two-aligned integer strictly inside (x0, x1), or NaN.
  static double alignedSplit(double x0, double x1) {
    if (!(x1 - x0 > 0)) return std::nan("");
    for (int k = 30; k >= 0; --k) {
      const double s = std::ldexp(1.0, k);
      const double c = std::floor(x0 / s) * s + s;  // smallest multiple of 2^k above x0
      if (c < x1) return c;
    }
    return std::nan("");
  }

  template <typename Ctx>
  bool splitFast(const CurvePiece& p, Ctx& ctx, CurvePiece& front, CurvePiece& back) const {
    OBLONG_STAT_INC(quadtreeSplits);
    const ivec2 origin = ctx.sampleOrigin();
    const int first = split::longerAxis(p);
    CurvePoint m;
    for (int k = 0; k < 2; ++k) {
      const int axis = k == 0 ? first : 1 - first;
      // Strictly between the endpoints so that the monotone curve crosses it.
      const double x0 = double(std::min(p.a.uv[axis], p.b.uv[axis])) + origin[axis];
      const double x1 = double(std::max(p.a.uv[axis], p.b.uv[axis])) + origin[axis];
      const double c = alignedSplit(x0, x1);
      if (std::isfinite(c) && ctx.crossing(p, axis, c - origin[axis], m)) {
        split::around(p, m, front, back);
        return true;
      }
    }
    OBLONG_STAT_INC(quadtreeFallbacks);
    if (!split::middleCrossing(p, ctx, m) && !ctx.pointAt(p, 0.5 * (p.a.t + p.b.t), m)) return false;
    split::around(p, m, front, back);
    return true;
  }
};


}  // namespace oblong
