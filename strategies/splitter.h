// Splitter (docs/design.md §2; RMIP paper §4.3, Fig. 5): halves the bound of a piece of the
// ray's curve in texture space into a front and a back piece which together still
// contain the curve.
//
// A piece is a stretch of the ray's projection (along the displacement lines) that is
// monotone in both texture axes, between two curve points a (front, smaller t) and b:
// the rectangle spanned by a and b bounds it. Coordinates are the traversal's local
// sample coordinates (traversal/psi.h): texel centres at integers, grid cells [i,i+1]².
// Each point knows its ray parameter t exactly and its uv up to `pad` (per axis): the
// true projection of the ray point at t lies within uv ± pad.
//
// A splitter cuts the piece at one new curve point m, giving (a, m) and (m, b); the
// traversal pushes the back piece, then the front (front to back). It asks the ray's
// SplitContext for that point:
//   crossing(piece, axis, c) — where the curve crosses the grid-aligned line {axis = c}
//                              (closed form on ψ, paper Eq. 3-4; no inversion);
//   pointAt(t)               — the curve point at ray parameter t (point-wise inversion,
//                              §4.1).
//
// Strategies (one name everywhere: registry key, file, test tag, stats prefix):
//   midpoint2d  strategies/midpoint2d.h  split the longer side in the middle (§4.3, Fig. 5c)
//   midpoint3d  strategies/midpoint3d.h  invert the t-midpoint (Patterson, §4.3, Fig. 5b)
//   quadtree    strategies/quadtree.h    node-aligned splits of the min-max mipmap grid
//                                        (TFDM, Thonat et al. 2021), no inversion
//
// Concrete strategies are `final` classes deriving from SplitterImpl<Self>: split() is the
// virtual entry point; Self::splitFast<Ctx> is the inline template a static traversal
// instantiation calls with its concrete (final) context. A strategy registers itself in
// its .cpp: OBLONG_REGISTER_SPLITTER("name", factory, StrategyTraits{...}).
#pragma once

#include "core/kernels/curve_point.h"
#include "core/kernels/midpoint2d.h"
#include "core/math.h"
#include "core/registry.h"

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace oblong {

// A point of the ray's curve: ray parameter, local sample coordinates, error radius
// (core/kernels/curve_point.h, shared with the Vulkan shaders), zero when made here: t
// in double, uv in float, pad (float) covering uv's rounding.
struct CurvePoint : shared::CurvePoint {
  CurvePoint() : shared::CurvePoint{0.0, vec2(0.0f), vec2(0.0f)} {}
};

// A monotone piece of the curve from a (front) to b (back).
struct CurvePiece {
  CurvePoint a, b;
  // Bounding rectangle (padded endpoints), in double.
  dvec2 lo() const { return dvec2(shared::pieceLo(a, b)); }
  dvec2 hi() const { return dvec2(shared::pieceHi(a, b)); }
};

// What a splitter may ask about the current ray and triangle.
class SplitContext {
 public:
  // The curve point where the piece crosses {axis = c} (axis 0: X, 1: Y), strictly
  // between a and b. False when there is none or it is ambiguous.
  virtual bool crossing(const CurvePiece& piece, int axis, double c, CurvePoint& out) = 0;
  // The curve point at ray parameter t in (a.t, b.t). False when inversion failed.
  virtual bool pointAt(const CurvePiece& piece, double t, CurvePoint& out) = 0;
  // Absolute sample index of local (0, 0) (node alignment for quadtree).
  virtual ivec2 sampleOrigin() const = 0;

 protected:
  ~SplitContext() = default;
};

class Splitter {
 public:
  virtual ~Splitter() = default;
  virtual std::string_view name() const = 0;
  // Splits `piece` into front and back. False: this splitter could not split it (the
  // traversal then subdivides the piece's rectangle without the curve).
  virtual bool split(const CurvePiece& piece, SplitContext& ctx, CurvePiece& front, CurvePiece& back) const = 0;
};

template <typename Self>
class SplitterImpl : public Splitter {
 public:
  bool split(const CurvePiece& piece, SplitContext& ctx, CurvePiece& front, CurvePiece& back) const final {
    return static_cast<const Self*>(this)->splitFast(piece, ctx, front, back);
  }
};

// Helpers for strategies.
namespace split {
// Front and back pieces around the new point m.
inline void around(const CurvePiece& p, const CurvePoint& m, CurvePiece& front, CurvePiece& back) {
  front = {p.a, m};
  back = {m, p.b};
}
// The longer side of the piece's rectangle (0: X, 1: Y).
inline int longerAxis(const CurvePiece& p) {
  const dvec2 s = p.hi() - p.lo();
  return s.x >= s.y ? 0 : 1;
}
// True when c lies strictly between the endpoints' coordinates on `axis` (so the
// monotone curve crosses {axis = c} exactly once).
inline bool strictlyBetween(const CurvePiece& p, int axis, double c) {
  return shared::strictlyBetween(p.a, p.b, axis, c);
}
// Crossing of the line in the middle of the longer side, else of the other side
// (core/kernels/midpoint2d.h, as the Vulkan shader cuts).
template <typename Ctx>
inline bool middleCrossing(const CurvePiece& p, Ctx& ctx, CurvePoint& m) {
  for (int k = 0; k < 2; ++k) {
    int axis;
    double c;
    if (shared::midpointLine(p.a, p.b, k, axis, c) && ctx.crossing(p, axis, c, m)) return true;
  }
  return false;
}
}  // namespace split

struct SplitterContext {};
using SplitterRegistry = Registry<Splitter, SplitterContext>;
#define OBLONG_REGISTER_SPLITTER(name, ...) OBLONG_REGISTER(::oblong::SplitterRegistry, name, __VA_ARGS__)

// Creates a splitter by name; unknown names and unused parameters throw oblong::Error.
std::unique_ptr<Splitter> createSplitter(const std::string& name, ParamSet& params);
std::unique_ptr<Splitter> createSplitter(const std::string& name);
std::vector<std::string> splitterNames();
const StrategyTraits& splitterTraits(const std::string& name);

}  // namespace oblong
