// RayPatch, the driver of the RMIP traversal (Thonat et al. 2023, Alg. 1; docs/design.md
// §2), written once for the CPU and the Vulkan shaders in the subset of core/kernels/lang.h.
// This header holds its stateless parts (the per-ray margins, the stack entry); the driver
// itself, its state and its loop, is core/kernels/ray_patch_body.h. Per ray and displaced
// triangle (docs/traversal.md has the reasoning):
//   1. Clip the ray to the triangle's inflated prism; its crossings give [tIn, tOut] and
//      the uv of its ends; a ray starting (or ending) inside gets its end's uv from a point
//      claimed between the crossings (curvePointAt), else by inversion.
//   2. Split [tIn, tOut] where the curve may turn (ψ's turning points): monotone pieces.
//      Their ends (the crossings' claims, the ends inside, the turning points) are made
//      when their piece is first popped, at pieceEnd's one call site of the claim and of
//      the inverter, where every curve point is made (a split's, a clipped end's, the
//      march's stop).
//   3. A fixed-size stack of pieces, front to back. A piece whose rectangle is at most
//      `marchingScale` texels is marched; otherwise its rectangle, dilated by ε and snapped
//      outward to whole cells, is bounded (range query + interval arithmetic), the ray is
//      clipped to that box, the piece is optionally tightened by re-projecting the clipped
//      ends (Fig. 5a, "inversion during traversal"), and the splitter cuts it in two.
//   4. Texel marching (§4.4): the cells within ε of the monotone piece, column by column
//      along its major axis, front to back, by a walk whose every cell is decided by an
//      interval test of ψ over the cell dilated by ε.
//   5. Every hit updates the closest hit; pieces starting beyond it are skipped.
// Wherever the curve machinery cannot vouch for a piece (ill-posed triangle, failed
// inversion, failed split), that part falls back to projection-free box subdivision of
// whole cell ranges: slower, never wrong.
//
// The body is included where the state lives: in C++ inside RayPatchLoop below (its
// variables are members), in GLSL at global scope (render/vulkan/shaders/traversal.glsl).
// What differs between the devices is reached through hooks, which each side defines and
// the body calls as OBLONG_HOOK(name)(...) (C++: the derived class's member; GLSL: a
// function of that name declared before the body):
//   vec2  rpRangeRaw(int sx0, int sy0, int sx1, int sy1)  the range query's raw (min, max)
//   vec2  rpToHeight(vec2 raw)                 Displacement::toHeight
//   float rpRaw(int I, int J)                  a texel at the ray's level of detail
//   int   rpCellMicro(int I, int J)            tests cell (I, J)'s micro-triangles; how many
//   void  rpInvert(vec3 X, out vec2 bary, out float h)   the inverter
//   int   rpSplit(CurvePoint a, CurvePoint b, inout int line, out CurvePoint m, out double t)
//         the splitter: 1: m splits the piece; 2: invert at t for it; 3: claim m, a pending
//         crossing (OBLONG_RP_PENDING_CROSSING) of its cut number `line` (from 0), for
//         it; where that claim is refused, pieceEnd asks again with line + 1; 0: no split
//   bool  rpHitFound(); float rpHitT(); dvec2 rpHitUV()  the closest hit and its uv
//   dvec2 rpToSample(dvec2 uv)                 Displacement::toSample
//   void  rpBoxOverRect(vec2 lo, vec2 hi, vec2 h, out vec3 blo, out vec3 bhi)  the box over
//         local rectangle [lo, hi] at heights h in T's float box frame, padded by
//         g_texPadF (rect_bounds.h's boxOverRectF)
//   void  rpInflatedBox(out dvec3 lo, out dvec3 hi)   the inflated prism's box, padded
//   PrismShape rpPrism()                       the inflated prism (prism.h)
//   void  rpStat(int what)                     a statistics event (OBLONG_RP_STAT_*)
#ifndef OBLONG_KERNELS_RAY_PATCH_H
#define OBLONG_KERNELS_RAY_PATCH_H

#include "core/kernels/constants.h"
#include "core/kernels/curve_point.h"
#include "core/kernels/lang.h"
#include "core/kernels/patch_math.h"
#include "core/kernels/rect_bounds.h"
#include "core/kernels/prism.h"

// The statistics events the body reports (C++: core/stats.h counters; GLSL: none).
#define OBLONG_RP_STAT_ILL_POSED 0
#define OBLONG_RP_STAT_GRAZE 1
#define OBLONG_RP_STAT_TURNING 2
#define OBLONG_RP_STAT_BOX_ONLY_PIECE 3
#define OBLONG_RP_STAT_BOX_ONLY_PRISM 4
#define OBLONG_RP_STAT_OVERFLOW 5
#define OBLONG_RP_STAT_MARCH_STOP 6
#define OBLONG_RP_STAT_WIDE_LEAF 7
#define OBLONG_RP_STAT_LEAF 8
#define OBLONG_RP_STAT_BAD_INVERSION 9

// A curve point to be made at pieceEnd's one call site of the claim and the inverter (an
// end setupCurve leaves pending, a clipped end, a split's point, the march's stop): its t
// is known, and pad.x (negative, which a made point's pad never is) says how to make it.
#define OBLONG_RP_PENDING_CLAIM (-1.0)   // claimed from uv (on the chord between two points), else inverted
#define OBLONG_RP_PENDING_INVERT (-2.0)  // inverted
#define OBLONG_RP_PENDING_TURN (-3.0)    // a turning point: claimed at its prism coordinates, else inverted
#define OBLONG_RP_PENDING_CROSSING (-5.0)  // claimed at known prism coordinates (uv: b, pad.y: s)
#define OBLONG_RP_PENDING_HIT (-6.0)     // claimed from uv at the closest hit, whatever its pad
// A stack entry that is a box: a.pad.x holds this, a.uv and b.uv its local cells' corners
// (clo, chi: integers within T's cells, exact in float), a.t and b.t its ray interval.
#define OBLONG_RP_BOX_ENTRY (-4.0)

OBLONG_KERNELS_BEGIN

// A stack entry: a piece of the curve (a, b), or a box of local cells with its ray
// interval in the same fields (OBLONG_RP_BOX_ENTRY): 48 bytes, the stack's whole state.
struct RpEntry {
  CurvePoint a, b;
};

// The rounding of the ray's own arithmetic (RayMargins): the error of a ray point for
// vertex magnitude maxP, origin magnitude maxO and heights [a, b].
OBLONG_INLINE double rayError(double maxP, double maxO, double a, double b) {
  OBLONG_PRECISE double r = OBLONG_TRAV_RAY_ERR * (maxP + maxO + abs(a) + abs(b));
  return r;
}

// What the ray's rounding adds to the inflated prism's margins: in barycentrics (kb: their
// error per unit residual) and in height (ks).
OBLONG_INLINE double rayExtraB(OBLONG_IN(dvec2) kb, double rayErr) {
  OBLONG_PRECISE double r = (kb.x + kb.y) * double(OBLONG_TRAV_RAY_ERR_FACTOR) * rayErr;
  return r;
}
OBLONG_INLINE double rayExtraS(double ks, double rayErr) {
  OBLONG_PRECISE double r = ks * double(OBLONG_TRAV_RAY_ERR_FACTOR) * rayErr;
  return r;
}

// The margins of a ray whose origin has max-norm maxO (traversal/traversal_mesh.h's
// RayMargins) for a triangle of vertex magnitude maxP, heights [a, b], vertex rounding
// vertexErr, inflation (inflateS, inflateB) and claim slopes (kb, ks): the watertight
// test's rounding, the boxes' pad and the inflated prism's heights [lo, hi] and bulge
// delta (Prism::inflated's arguments).
struct RayMargin {
  double rayErr, boxPad, lo, hi, delta;
};
OBLONG_INLINE RayMargin rayMargin(double maxP, double maxO, double a, double b, double vertexErr, double inflateS,
                                  double inflateB, OBLONG_IN(dvec2) kb, double ks) {
  RayMargin m;
  m.rayErr = rayError(maxP, maxO, a, b);
  OBLONG_PRECISE double pad = vertexErr + m.rayErr;
  m.boxPad = pad;
  double extraB = rayExtraB(kb, m.rayErr), extraS = rayExtraS(ks, m.rayErr);
  OBLONG_PRECISE double lo = a - inflateS - extraS, hi = b + inflateS + extraS, delta = inflateB + extraB;
  m.lo = lo;
  m.hi = hi;
  m.delta = delta;
  return m;
}

// A world pad in the texture frame: the rotation maps a box padded by p per world
// coordinate into one padded by √3 p (1.75 > √3) per texture axis, plus the rotation's
// own rounding of points of max-norm up to mag.
OBLONG_INLINE double texFramePad(double worldPad, double mag) {
  OBLONG_PRECISE double r = 1.75 * worldPad + OBLONG_TRAV_OBB_ROUND * (mag + 1.0);
  return r;
}
// The pad of the exact prism's box in its texture frame (TraversalMesh::texPrismBox) for
// a world pad meant for origins up to max-norm maxO, the prism's own vertices having
// max-norm texMag in that frame.
OBLONG_INLINE double texBoxPad(double worldPad, double maxO, double texMag) {
  return texFramePad(worldPad, max(maxO, texMag));
}
// The boxes' pad for boxes built in the texture frame on the fly (the pieces' boxes, tfdm's
// nodes): the world pad rotated with points of max-norm up to maxO + maxP + |a| + |b|.
OBLONG_INLINE double texPiecePad(double boxPad, double maxO, double maxP, double a, double b) {
  OBLONG_PRECISE double mag = maxO + maxP + (abs(a) + abs(b));
  return texFramePad(boxPad, mag);
}

// The rectangle of a piece: its padded endpoints' box, in float (a made point's pad
// covers the rounding of uv ± pad too: makePoint).
OBLONG_INLINE vec2 pieceLo(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b) {
  OBLONG_PRECISE vec2 r = min(a.uv - a.pad, b.uv - b.pad);
  return r;
}
OBLONG_INLINE vec2 pieceHi(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b) {
  OBLONG_PRECISE vec2 r = max(a.uv + a.pad, b.uv + b.pad);
  return r;
}

// c strictly between the endpoints' coordinates on `axis`: the monotone curve crosses
// {axis = c} exactly once.
OBLONG_INLINE bool strictlyBetween(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b, int axis, double c) {
  double x0 = double(min(a.uv[axis], b.uv[axis])), x1 = double(max(a.uv[axis], b.uv[axis]));
  return c > x0 && c < x1;
}

OBLONG_KERNELS_END

#ifdef __cplusplus
OBLONG_KERNELS_BEGIN
// The driver's state and loop as members; H (the CPU's RayPatch) supplies the hooks.
template <typename H>
struct RayPatchLoop {
#define OBLONG_HOOK(f) static_cast<H*>(this)->f
#define OBLONG_RP_STACK OBLONG_TRAV_STACK
#include "core/kernels/ray_patch_body.h"
#undef OBLONG_RP_STACK
#undef OBLONG_HOOK
};
OBLONG_KERNELS_END
#endif

#endif
