// midpoint2d: RMIP's bound subdivision (Thonat et al. 2023, §4.3, Fig. 5c). The longer
// side of the piece's rectangle is split in the middle and the ray's curve is cut where
// it crosses that line, found in closed form on the implicit form ψ (§4.2, Eq. 3): no
// inversion. Each split halves the rectangle's longer side, which bounds the number of
// traversal steps.
//
// Fallback: when the crossing cannot be found (ambiguous roots, a ray along the
// displacement direction), the piece is cut at its t-midpoint by inversion (midpoint3d's
// rule); when that fails too, the traversal subdivides the rectangle without the curve.
//
// Parameters: none. Statistics: midpoint2d/Splits, midpoint2d/Fallbacks.
#pragma once

#include "core/stats.h"
#include "strategies/splitter.h"

namespace oblong {

OBLONG_STAT_COUNTER("midpoint2d/Splits", midpoint2dSplits);
OBLONG_STAT_COUNTER("midpoint2d/Fallbacks", midpoint2dFallbacks);

class Midpoint2D final : public SplitterImpl<Midpoint2D> {
 public:
  std::string_view name() const override { return "midpoint2d"; }

  template <typename Ctx>
  bool splitFast(const CurvePiece& p, Ctx& ctx, CurvePiece& front, CurvePiece& back) const {
    OBLONG_STAT_INC(midpoint2dSplits);
    CurvePoint m;
    if (!split::middleCrossing(p, ctx, m)) {
      OBLONG_STAT_INC(midpoint2dFallbacks);
      if (!ctx.pointAt(p, 0.5 * (p.a.t + p.b.t), m)) return false;
    }
    split::around(p, m, front, back);
    return true;
  }
};


}  // namespace oblong
