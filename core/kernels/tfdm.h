// The "tfdm" baseline's kernels (Thonat et al. 2021 §4, as traversal/tfdm.cpp builds and
// describes it), written once for the CPU's `tfdm` and the Vulkan intersection shader
// tfdm.rint in the subset of core/kernels/lang.h: the roots of a triangle, a node's cells
// within the triangle's cell range, the 2D rejection of a node whose square misses the
// triangle, a node's [min, max] from the stored pyramid (the 16-bit code join is
// quantize16.h's) and the child order. The traversal itself is tfdm_body.h. Cell indices
// are ints: the Vulkan path refuses maps whose cell indices could leave ±2^29
// (records.cpp), the CPU passes its CellRange's ints.
//
// The pyramid's words are each side's own (as in rmip_query.h): a type TfdmPyr with
// functions the includer provides (C++: template parameter; GLSL: a macro naming a type,
// functions defined after this header, which declares them):
//   ivec2 tfdmDims(TfdmPyr p, int L)        stored level L's width and height in nodes
//   uint  tfdmCode(TfdmPyr p, int L, uint at)   node `at` (row-major) of level L: its
//                                           16-bit code pair (bits 16)
//   vec2  tfdmPair(TfdmPyr p, int L, uint at)   ... its float [min, max] (bits 32)
//   vec2  tfdmDecode(TfdmPyr p, uint codes)  Quantizer16::decodePair ((inf, -inf): empty)
#ifndef OBLONG_KERNELS_TFDM_H
#define OBLONG_KERNELS_TFDM_H

#include "core/kernels/constants.h"
#include "core/kernels/lang.h"
#include "core/kernels/quantize16.h"
#include "core/kernels/rect_bounds.h"

OBLONG_KERNELS_BEGIN

#ifndef __cplusplus
ivec2 tfdmDims(TfdmPyr p, int L);
uint tfdmCode(TfdmPyr p, int L, uint at);
vec2 tfdmPair(TfdmPyr p, int L, uint at);
vec2 tfdmDecode(TfdmPyr p, uint codes);
#endif

// The work of one ray against one triangle (RayCounters: boxes and range queries are
// `boxes`, cells_marched `leaves`).
struct TfdmWork {
  int boxes;      // nodes whose box was tested
  int leaves;     // leaf cells whose micro-triangles were tested
  int microTris;  // micro-triangles tested
  int outside;    // nodes skipped as outside T's uv triangle (no box test)
  bool overflow;  // the node stack was full (cannot happen: depth <= 3 per level + 4)
};

// The roots of a triangle whose cells are [lo, hi] (inclusive): the level at which the
// range spans at most two nodes per axis (arithmetic shifts: floor division).
OBLONG_INLINE int tfdmRootLevel(OBLONG_IN(ivec2) lo, OBLONG_IN(ivec2) hi) {
  int L = 0;
  while ((hi.x >> L) - (lo.x >> L) > 1 || (hi.y >> L) - (lo.y >> L) > 1) ++L;
  return L;
}

// The cells [clo, chi] of node (x, y) at level L within the cell range [lo, hi]; false
// when there are none.
OBLONG_INLINE bool tfdmNodeCells(int x, int y, int L, OBLONG_IN(ivec2) lo, OBLONG_IN(ivec2) hi,
                                 OBLONG_OUT(ivec2) clo, OBLONG_OUT(ivec2) chi) {
  clo = ivec2(max(x << L, lo.x), max(y << L, lo.y));
  chi = ivec2(min(((x + 1) << L) - 1, hi.x), min(((y + 1) << L) - 1, hi.y));
  return clo.x <= chi.x && clo.y <= chi.y;
}

// The sign that makes T's uv triangle S (sample coordinates) counter-clockwise.
OBLONG_INLINE double tfdmSigma(OBLONG_IN(dvec2) S0, OBLONG_IN(dvec2) S1, OBLONG_IN(dvec2) S2) {
  OBLONG_PRECISE double orient = (S1.x - S0.x) * (S2.y - S0.y) - (S1.y - S0.y) * (S2.x - S0.x);
  return orient > 0.0 ? 1.0 : -1.0;
}

// True when the corner p lies strictly outside edge a→b, by more than rounding (`tol`).
OBLONG_INLINE bool tfdmCornerOut(OBLONG_IN(dvec2) a, OBLONG_IN(dvec2) ab, double sigma, double tol, double px,
                                 double py) {
  OBLONG_PRECISE double side = sigma * (ab.x * (py - a.y) - ab.y * (px - a.x));
  return !(side >= -tol);
}

// True when the square [x0, x1] × [y0, y1] (sample coordinates) lies strictly outside one
// edge of T's uv triangle S, by more than rounding: its cells' micro-triangles are then
// empty (a square touching T only along a line gives degenerate pieces, which no ray hits).
OBLONG_INLINE bool tfdmOutside(OBLONG_IN(dvec2) S0, OBLONG_IN(dvec2) S1, OBLONG_IN(dvec2) S2, double sigma, double x0,
                               double y0, double x1, double y1) {
  double mag = 1.0 + max(max(abs(x0), abs(x1)), max(abs(y0), abs(y1)));
  for (int e = 0; e < 3; ++e) {
    dvec2 a = e == 0 ? S0 : (e == 1 ? S1 : S2);
    dvec2 b = e == 0 ? S1 : (e == 1 ? S2 : S0);
    OBLONG_PRECISE dvec2 ab = b - a;
    OBLONG_PRECISE double tol = 1e-9 * (abs(ab.x) + abs(ab.y)) * mag;
    if (tfdmCornerOut(a, ab, sigma, tol, x0, y0) && tfdmCornerOut(a, ab, sigma, tol, x1, y0) &&
        tfdmCornerOut(a, ab, sigma, tol, x0, y1) && tfdmCornerOut(a, ab, sigma, tol, x1, y1))
      return true;
  }
  return false;
}

// i mod n in [0, n) (n > 0).
OBLONG_INLINE int tfdmWrap(int i, int n) {
  int r = i - (i / n) * n;
  return r < 0 ? r + n : r;
}

// The raw [min, max] over node (x, y) of level L (absolute cell indices, unwrapped:
// levels are periodic) from the stored levels 0..s: level L's node, or above s the union
// of the stored nodes it covers (at most the whole level s). The CPU answers nodes whose
// union would exceed CellPyramid::kMaxFold nodes otherwise; the Vulkan path refuses them.
OBLONG_TEMPLATE1(TfdmPyr)
OBLONG_INLINE vec2 tfdmNode(OBLONG_IN(TfdmPyr) p, int bits, int s, int L, int x, int y) {
  int k = L <= s ? 0 : L - s;
  ivec2 d = tfdmDims(p, L - k);
  // Beyond 2^30 nodes per axis the union is the whole level whatever its start.
  int nx = k >= 30 ? d.x : min(1 << k, d.x), ny = k >= 30 ? d.y : min(1 << k, d.y);
  int x0 = k >= 30 ? 0 : x << k, y0 = k >= 30 ? 0 : y << k;
  uint c = 0xffffu;  // codes are joined and decoded once
  vec2 r = vec2(kInfF, -kInfF);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      uint at = uint(tfdmWrap(y0 + j, d.y)) * uint(d.x) + uint(tfdmWrap(x0 + i, d.x));
      if (bits == 16) {
        c = joinCodes16(c, tfdmCode(p, L - k, at));
      } else {
        vec2 v = tfdmPair(p, L - k, at);
        r = vec2(min(r.x, v.x), max(r.y, v.y));
      }
    }
  return bits == 16 ? tfdmDecode(p, c) : r;
}

// The k-th child (or root) in the fixed order, nearest the ray's start first: (ax, ay)
// are 1 where the ray's texture-space direction is negative.
OBLONG_INLINE ivec2 tfdmOrder(int k, int ax, int ay) {
  return ivec2(k < 2 ? ax : 1 - ax, (k & 1) == 0 ? ay : 1 - ay);
}

OBLONG_KERNELS_END

#ifdef __cplusplus
OBLONG_KERNELS_BEGIN
// The traversal as a member; H (the CPU's tfdm) supplies the hooks.
template <typename H>
struct TfdmLoop {
#define OBLONG_HOOK(f) static_cast<H*>(this)->f
#include "core/kernels/tfdm_body.h"
#undef OBLONG_HOOK
};
OBLONG_KERNELS_END
#endif

#endif
