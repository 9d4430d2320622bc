// Conservative world box of the micro-geometry over a uv rectangle (docs/design.md
// invariant 2; RMIP Alg. 1 line 12, "surface bounds(triangle, bound, rmip)"), and the
// ray's slab test against it; written once for the CPU (traversal/ray_patch.h,
// traversal/tfdm.cpp) and the Vulkan shaders, in the subset of core/kernels/lang.h.
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
// Precision: the boxes are float (boxOverRectF, clipBoxF below): this interval arithmetic
// relative to an anchor near T, padded by the micro-vertices' own float error, the ray
// test's rounding and a rigorous bound on the box's own rounding, whose scales are T's,
// computed once per triangle (boxFrameF). clipBox is the slab test in double for the
// prism's boxes at a ray's set-up.
#ifndef OBLONG_KERNELS_RECT_BOUNDS_H
#define OBLONG_KERNELS_RECT_BOUNDS_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

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

// ---- the boxes in float ----------------------------------------------------------------
// The float error analysis, u = 2^-24 (float's unit roundoff), for a box over a rectangle
// of local coordinates with |X| <= xm, |Y| <= ym (T's cells) and heights with |h/|N|| <= K,
// magP >= |PX_k|·xm + |PY_k|·ym and magN >= |Nc_k| + |NX_k|·xm + |NY_k|·ym over the axes k,
// M = magP + K·magN. P's range is off by at most 4u·magP (its coefficients, the corners
// and the products round: 3u each term; the sum: u), N's by 5u·magN, k by u·|k|, so k·N by
// 7u·K·magN, and adding it to P's rounds once more: a side is off by at most 9u·M. The
// box is widened by 16u·M (2^-20; its own rounding and the final subtraction's, u·M each,
// are covered too), and `pad` comes in rounded up by 4u, more than the two roundings it
// goes through. The ray's float origin O (relative to the anchor) is off by at most u·|O|
// plus the double subtraction's error; oErr is four times that, and a slab's t is off by
// at most that error times |invD| plus 4u·|t| (the division's, the difference's and the
// product's rounding): clipBoxF widens each t by oErr·|invD| + 2^-21·|t|.
#define OBLONG_U2M17 7.62939453125e-6     // 2^-17
#define OBLONG_U2M20 9.5367431640625e-7   // 2^-20
#define OBLONG_U2M21 4.76837158203125e-7  // 2^-21
#define OBLONG_U2M22 2.384185791015625e-7 // 2^-22
#define OBLONG_U2M23 1.1920928955078125e-7 // 2^-23
#define OBLONG_U2M50 8.8817841970012523e-16 // 2^-50

// T's float box frame: its P and N in the texture frame, relative to the anchor (P at
// local (0, 0), the frame's Pc), rounded to float; invM >= 1/min|N| (rect_bounds' k); magP
// and magN the error scales above, rounded up.
struct BoxFrameF {
  vec3 PX, PY, Nc, NX, NY;
  float invM, magP, magN;
};

// One ray in a triangle's float box frame: its origin relative to the anchor (rounded),
// 1/D per axis (infinite where D's component is 0), and oErr >= 4× the origin's error.
struct BoxRayF {
  vec3 O, invD, oErr;
};

// The float nearest to x on the side away from +∞ (floatBelow) or -∞ (floatAbove), for a
// double x computed with an error at most 2^-52·mag: x moved by 4u·|x| (more than the
// rounding to float) and by the double error, before the rounding.
OBLONG_INLINE float floatBelow(double x, double mag) {
  OBLONG_PRECISE double y = x - (OBLONG_U2M22 * abs(x) + OBLONG_U2M50 * mag + 1e-30);
  return float(y);
}
OBLONG_INLINE float floatAbove(double x, double mag) {
  OBLONG_PRECISE double y = x + (OBLONG_U2M22 * abs(x) + OBLONG_U2M50 * mag + 1e-30);
  return float(y);
}

// T's BoxFrameF from its texture frame (PX ... NY, in double), invM (a float already
// rounded up) and the largest |X|, |Y| of its cells' rectangle (local sample coordinates).
OBLONG_INLINE BoxFrameF boxFrameF(OBLONG_IN(dvec3) PX, OBLONG_IN(dvec3) PY, OBLONG_IN(dvec3) Nc, OBLONG_IN(dvec3) NX,
                                  OBLONG_IN(dvec3) NY, float invM, OBLONG_IN(dvec2) xym) {
  BoxFrameF B;
  B.PX = vec3(PX);
  B.PY = vec3(PY);
  B.Nc = vec3(Nc);
  B.NX = vec3(NX);
  B.NY = vec3(NY);
  B.invM = invM;
  double mp = 0.0, mn = 0.0;
  for (int k = 0; k < 3; ++k) {
    OBLONG_PRECISE double p = abs(PX[k]) * xym.x + abs(PY[k]) * xym.y;
    OBLONG_PRECISE double n = abs(Nc[k]) + abs(NX[k]) * xym.x + abs(NY[k]) * xym.y;
    mp = max(mp, p);
    mn = max(mn, n);
  }
  B.magP = floatAbove(mp, mp);
  B.magN = floatAbove(mn, mn);
  return B;
}

// x − anchor rounded to the float below (relBelowF) or above (relAboveF), per axis.
OBLONG_INLINE vec3 relBelowF(OBLONG_IN(dvec3) x, OBLONG_IN(dvec3) anchor) {
  OBLONG_PRECISE dvec3 d = x - anchor;
  vec3 r;
  for (int k = 0; k < 3; ++k) r[k] = floatBelow(d[k], abs(x[k]) + abs(anchor[k]));
  return r;
}
OBLONG_INLINE vec3 relAboveF(OBLONG_IN(dvec3) x, OBLONG_IN(dvec3) anchor) {
  OBLONG_PRECISE dvec3 d = x - anchor;
  vec3 r;
  for (int k = 0; k < 3; ++k) r[k] = floatAbove(d[k], abs(x[k]) + abs(anchor[k]));
  return r;
}

// The ray (Ot, Dt: origin and direction in the texture frame, double) in the float box
// frame anchored at `anchor`.
OBLONG_INLINE BoxRayF boxRayF(OBLONG_IN(dvec3) Ot, OBLONG_IN(dvec3) Dt, OBLONG_IN(dvec3) anchor) {
  BoxRayF R;
  OBLONG_PRECISE dvec3 o = Ot - anchor;
  R.O = vec3(o);
  for (int k = 0; k < 3; ++k) {  // ∞ where D's component is 0; else finite (a float conversion must not overflow)
    double id = 1.0 / Dt[k];
    R.invD[k] = isinfD(id) ? float(id) : float(clamp(id, -3.0e38, 3.0e38));
  }
  for (int k = 0; k < 3; ++k) R.oErr[k] = floatAbove(4.0 * OBLONG_U2M22 * abs(o[k]), abs(Ot[k]) + abs(anchor[k]));
  return R;
}

// boxOverRect in float over local rectangle [lo, hi] (the same rectangle as above) with
// heights [hlo, hhi], relative to the anchor; pad (rounded up by the caller) as above.
OBLONG_INLINE void boxOverRectF(OBLONG_IN(BoxFrameF) B, OBLONG_IN(vec2) lo, OBLONG_IN(vec2) hi, float hlo, float hhi,
                                float pad, OBLONG_OUT(vec3) blo, OBLONG_OUT(vec3) bhi) {
  OBLONG_PRECISE vec3 Nlo, Nhi;
  for (int k = 0; k < 3; ++k) {
    OBLONG_PRECISE float px0 = B.PX[k] * lo.x, px1 = B.PX[k] * hi.x, py0 = B.PY[k] * lo.y, py1 = B.PY[k] * hi.y;
    blo[k] = min(px0, px1) + min(py0, py1);
    bhi[k] = max(px0, px1) + max(py0, py1);
    OBLONG_PRECISE float nx0 = B.NX[k] * lo.x, nx1 = B.NX[k] * hi.x, ny0 = B.NY[k] * lo.y, ny1 = B.NY[k] * hi.y;
    Nlo[k] = B.Nc[k] + min(nx0, nx1) + min(ny0, ny1);
    Nhi[k] = B.Nc[k] + max(nx0, nx1) + max(ny0, ny1);
  }
  // k = h/|N|, |N| in [m, 1]: 1 - 2^-20 covers unit normals' float rounding (|N| <= 1 + 3u).
  OBLONG_PRECISE float klo = hlo < 0.0f ? hlo * B.invM : hlo * 0.99999904632568359375f;
  OBLONG_PRECISE float khi = hhi > 0.0f ? hhi * B.invM : hhi * 0.99999904632568359375f;
  for (int k = 0; k < 3; ++k) {
    OBLONG_PRECISE float a = klo * Nlo[k], b = klo * Nhi[k], c = khi * Nlo[k], d = khi * Nhi[k];
    blo[k] += min(min(a, b), min(c, d));
    bhi[k] += max(max(a, b), max(c, d));
  }
  OBLONG_PRECISE float K = max(abs(klo), abs(khi));
  OBLONG_PRECISE float p = pad + float(OBLONG_U2M20) * (B.magP + K * B.magN);
  blo -= vec3(p);
  bhi += vec3(p);
}

// The slab test of clipBox for a float box and ray, on the traversal's double [t0, t1]:
// each slab's t widened by its float error (above). A t beyond ±1e30 is clamped there
// first (a bound still, and no ∞ − ∞ in the widening).
OBLONG_INLINE void clipBoxF(OBLONG_IN(vec3) lo, OBLONG_IN(vec3) hi, OBLONG_IN(BoxRayF) R, OBLONG_INOUT(double) t0,
                            OBLONG_INOUT(double) t1) {
  for (int k = 0; k < 3; ++k) {
    if (isinfF(R.invD[k])) {  // parallel to the slab
      if (R.O[k] + R.oErr[k] < lo[k] || R.O[k] - R.oErr[k] > hi[k]) t0 = kInfD;
      continue;
    }
    OBLONG_PRECISE float a = (lo[k] - R.O[k]) * R.invD[k], b = (hi[k] - R.O[k]) * R.invD[k];
    if (a > b) {
      float s = a;
      a = b;
      b = s;
    }
    a = clamp(a, -1e30f, 1e30f);
    b = clamp(b, -1e30f, 1e30f);
    OBLONG_PRECISE float e = R.oErr[k] * abs(R.invD[k]);
    OBLONG_PRECISE float a2 = a - (e + float(OBLONG_U2M21) * abs(a));
    OBLONG_PRECISE float b2 = b + (e + float(OBLONG_U2M21) * abs(b));
    t0 = max(t0, double(a2));
    t1 = min(t1, double(b2));
  }
}

OBLONG_KERNELS_END

#endif
