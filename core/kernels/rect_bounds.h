// Conservative world box of the micro-geometry over a uv rectangle (docs/design.md
// invariant 2; RMIP Alg. 1 line 12, "surface bounds(triangle, bound, rmip)"), and the
// ray's slab test against it; written once for the CPU (traversal/rect_bounds.h) and the
// Vulkan shaders, in the subset of core/kernels/lang.h.
//
// The caller passes the rectangle already snapped outward to whole grid cells (the
// micro-triangles touching a rectangle reach one texel beyond it) and clipped to T's uv
// box (every micro-vertex is a point of S inside T), in local sample coordinates, and
// the RangeQuery's heights [hlo, hhi] over those cells. Every micro-vertex is then
//     P(x) + h·N(x)/|N(x)| = P(x) + (h/|N(x)|)·N(x),   x in the rectangle, h in [hlo, hhi],
// and is bounded with interval arithmetic: P and N are affine in x (their ranges over
// the rectangle are exact), and |N| over T lies in [m, 1] (m is T's smallest |N|, and N
// interpolates unit normals, so |N| <= 1 by convexity), so k = h/|N| lies in
// [min(h/m, h), max(h/m, h)] and k·N is an interval product. The four corners alone are
// NOT enough (normalised normals bulge). Micro-triangles are convex hulls of their
// vertices, so the box holds them too. P = Pc + PX X + PY Y and N = Nc + NX X + NY Y are
// given in any orthonormal basis (the world's, or tfdm's texture frame); invM >= 1/m is
// T's, rounded up once per triangle (invNormalLengthBound, core/triangle.h). T's bounds on |N| rather
// than the rectangle's own: a box costs no square root and no division, and is looser
// only by about h·(1/m - 1/min over the rectangle of |N|) along N: nothing where T's
// normals are parallel (m = 1), little on a finely tessellated curved mesh (m near 1).
//
// Precision: computed in double and padded explicitly by `pad` (the float error of the
// micro-vertices plus the ray test's own rounding) and by its own rounding; the box is
// never converted to float (the ray/box test runs in double).
#ifndef OBLONG_KERNELS_RECT_BOUNDS_H
#define OBLONG_KERNELS_RECT_BOUNDS_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

OBLONG_INLINE void boxOverRect(OBLONG_IN(dvec3) Pc, OBLONG_IN(dvec3) PX, OBLONG_IN(dvec3) PY, OBLONG_IN(dvec3) Nc,
                               OBLONG_IN(dvec3) NX, OBLONG_IN(dvec3) NY, double invM, OBLONG_IN(dvec2) lo,
                               OBLONG_IN(dvec2) hi, double hlo, double hhi, double pad, OBLONG_OUT(dvec3) blo,
                               OBLONG_OUT(dvec3) bhi) {
  OBLONG_PRECISE dvec3 Nlo, Nhi;
  for (int k = 0; k < 3; ++k) {
    OBLONG_PRECISE double px0 = PX[k] * lo.x, px1 = PX[k] * hi.x, py0 = PY[k] * lo.y, py1 = PY[k] * hi.y;
    blo[k] = Pc[k] + min(px0, px1) + min(py0, py1);
    bhi[k] = Pc[k] + max(px0, px1) + max(py0, py1);
    OBLONG_PRECISE double nx0 = NX[k] * lo.x, nx1 = NX[k] * hi.x, ny0 = NY[k] * lo.y, ny1 = NY[k] * hi.y;
    Nlo[k] = Nc[k] + min(nx0, nx1) + min(ny0, ny1);
    Nhi[k] = Nc[k] + max(nx0, nx1) + max(ny0, ny1);
  }
  // k = h/|N|, |N| in [m, 1] (1 + 1e-12: unit normals' rounding); invM's margin covers
  // the products' rounding.
  OBLONG_PRECISE double klo = hlo < 0.0 ? hlo * invM : hlo * (1.0 - 1e-12);
  OBLONG_PRECISE double khi = hhi > 0.0 ? hhi * invM : hhi * (1.0 - 1e-12);
  for (int k = 0; k < 3; ++k) {
    OBLONG_PRECISE double a = klo * Nlo[k], b = klo * Nhi[k], c = khi * Nlo[k], d = khi * Nhi[k];
    blo[k] += min(min(a, b), min(c, d));
    bhi[k] += max(max(a, b), max(c, d));
  }
  OBLONG_PRECISE double mag =
      max(max(max(abs(blo.x), abs(blo.y)), max(abs(blo.z), abs(bhi.x))), max(abs(bhi.y), abs(bhi.z)));
  OBLONG_PRECISE double p = pad + 1e-14 * mag;  // plus double rounding of the above
  blo -= dvec3(p);
  bhi += dvec3(p);
}

// Slab test in double: [t0, t1] ∩ the ray's parameters inside [lo, hi] (t0 > t1 when
// missed); invD = 1 / D, infinite along an axis the ray is parallel to.
OBLONG_INLINE void clipBox(OBLONG_IN(dvec3) lo, OBLONG_IN(dvec3) hi, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) invD,
                           OBLONG_INOUT(double) t0, OBLONG_INOUT(double) t1) {
  for (int k = 0; k < 3; ++k) {
    if (isinfD(invD[k])) {  // parallel to the slab
      if (O[k] < lo[k] || O[k] > hi[k]) t0 = kInfD;
      continue;
    }
    OBLONG_PRECISE double a = (lo[k] - O[k]) * invD[k], b = (hi[k] - O[k]) * invD[k];
    if (a > b) {
      double s = a;
      a = b;
      b = s;
    }
    t0 = max(t0, a);
    t1 = min(t1, b);
  }
}

OBLONG_KERNELS_END

#endif
