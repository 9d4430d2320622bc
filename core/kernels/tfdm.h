// The "tfdm" baseline's per-node kernels (Thonat et al. 2021 §4, as traversal/tfdm.cpp
// traverses): the roots of a triangle, a node's cells within the triangle's cell range,
// the 2D rejection of a node whose square misses the triangle; the join of the pyramid's
// 16-bit codes is quantize16.h's. Written once for the CPU's `tfdm` and the Vulkan
// intersection shader tfdm.rint, in the subset of core/kernels/lang.h; the node's box is
// rect_bounds.h's boxOverRect and a leaf's micro-triangles are microcells.h's, as in the
// canonical traversal. Cell indices are ints: the Vulkan path refuses maps whose cell
// indices could leave ±2^29 (records.cpp), the CPU passes its CellRange's ints.
#ifndef OBLONG_KERNELS_TFDM_H
#define OBLONG_KERNELS_TFDM_H

#include "core/kernels/lang.h"
#include "core/kernels/quantize16.h"  // the pyramid's code join, which tfdm.glsl takes from here

OBLONG_KERNELS_BEGIN

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

OBLONG_KERNELS_END

#endif
