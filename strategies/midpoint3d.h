// midpoint3d: Patterson et al.'s subdivision (Patterson, Hoggar, Logie 1991; RMIP paper
// §4.3, Fig. 5b): the ray interval [a.t, b.t] is cut at its midpoint in 3D, whose
// projection to texture space is found by point-wise inversion (§4.1). With range
// arithmetic bounds the projected midpoint can lie anywhere along the curve, so the
// traversal can be unbalanced; RMIP's ablation baseline for midpoint2d.
//
// Fallback: when inversion fails, the piece is cut where the curve crosses the middle of
// the rectangle's longer side (midpoint2d's rule).
//
// Parameters: none. Statistics: midpoint3d/Splits, midpoint3d/Fallbacks.
#pragma once

#include "core/stats.h"
#include "strategies/splitter.h"

namespace oblong {

OBLONG_STAT_COUNTER("midpoint3d/Splits", midpoint3dSplits);
OBLONG_STAT_COUNTER("midpoint3d/Fallbacks", midpoint3dFallbacks);

class Midpoint3D final : public SplitterImpl<Midpoint3D> {
 public:
  std::string_view name() const override { return "midpoint3d"; }

  template <typename Ctx>
  bool splitFast(const CurvePiece& p, Ctx& ctx, CurvePiece& front, CurvePiece& back) const {
    OBLONG_STAT_INC(midpoint3dSplits);
    CurvePoint m;
    if (!ctx.pointAt(p, 0.5 * (p.a.t + p.b.t), m)) {
      OBLONG_STAT_INC(midpoint3dFallbacks);
      if (!split::middleCrossing(p, ctx, m)) return false;
    }
    split::around(p, m, front, back);
    return true;
  }
};


}  // namespace oblong
