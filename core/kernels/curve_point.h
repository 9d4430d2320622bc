// Points of the ray's texture-space curve with their error bounds (RMIP paper §4.3: the
// curve's points come from inverting ray points), written once for the CPU
// (traversal/ray_patch.h) and the Vulkan shaders, in the subset of core/kernels/lang.h.
//
// A curve point is claimed from prism coordinates (b, s) said to be the projection of
// the ray point X(t). The residual r = G(b, s) − X(t) bounds the error: G is bilinear in
// (b, s), so J(b, s_true)·(Δb, Δs) = −r exactly and |Δu| ≤ kb.x |r|, |Δv| ≤ kb.y |r|
// while both points stay in the analysed domain (traversal/prism.h, the shell analysis).
#ifndef OBLONG_KERNELS_CURVE_POINT_H
#define OBLONG_KERNELS_CURVE_POINT_H

#include "core/kernels/constants.h"
#include "core/kernels/lang.h"
#include "core/kernels/patch_math.h"
#include "core/kernels/rect_bounds.h"

OBLONG_KERNELS_BEGIN

// A point of the curve: ray parameter, local sample coordinates and their error bound
// (24 bytes: a stack entry is two). t is double and exact (the point is made there); uv
// is the point's coordinates rounded to float, and pad, rounded up, covers that rounding
// with the claim's error.
struct CurvePoint {
  double t;
  vec2 uv;
  vec2 pad;
};

// What the shell analysis (PrismParams) bounds, for the claims: the analysed domain of
// barycentrics (T grown by domainB) and of s, and the first-order error factors.
struct ClaimBounds {
  double domainB, domainS0, domainS1;
  dvec2 kb;   // |Δu|, |Δv| per unit residual
  double ks;  // |Δs| per unit residual
  dvec2 kxy;  // |ΔX|, |ΔY| (local sample coordinates) per unit residual
};

// The curve point for the claim (b, s) at t; false when the claim lies outside the
// analysed domain or its error bound is too large to trust the first-order bounds.
OBLONG_INLINE bool makePoint(OBLONG_IN(PatchFrame) F, OBLONG_IN(ClaimBounds) K, OBLONG_IN(dvec3) O,
                             OBLONG_IN(dvec3) D, double t, OBLONG_IN(dvec2) b, double s,
                             OBLONG_OUT(CurvePoint) outp) {
  outp.t = t;
  outp.uv = vec2(0.0f);
  outp.pad = vec2(0.0f);
  double dom = K.domainB;
  if (!(b.x >= -dom && b.y >= -dom && b.x + b.y <= 1.0 + dom)) return false;
  if (!(s >= K.domainS0 && s <= K.domainS1)) return false;
  OBLONG_PRECISE dvec3 X = O + t * D;
  OBLONG_PRECISE dvec3 G = frameP(F, b) + s * frameN(F, b);
  double mag = max(max(max(abs(X.x), abs(X.y)), max(abs(X.z), abs(G.x))), max(abs(G.y), abs(G.z)));
  OBLONG_PRECISE double r = lengthD(G - X) + OBLONG_TRAV_RESIDUAL_ROUND * mag;
  OBLONG_PRECISE dvec2 db = K.kb * r * OBLONG_TRAV_RESIDUAL_SAFETY;
  if (!(db.x + db.y < OBLONG_TRAV_MAX_POINT_ERR) ||
      !(K.ks * r < OBLONG_TRAV_MAX_POINT_ERR * (K.domainS1 - K.domainS0) + OBLONG_TRAV_TINY))
    return false;
  dvec2 uv = frameLocal(F, b);
  // uv rounded to the nearest float moves by at most u·|uv| (u = 2^-24), and the float
  // rectangle's uv ± pad (pieceLo, pieceHi) rounds by at most u·(|uv| + pad) more: 2u·|uv|
  // added, and the pad rounded up by more than its own u.
  OBLONG_PRECISE dvec2 pad = K.kxy * (r * OBLONG_TRAV_RESIDUAL_SAFETY) + OBLONG_TRAV_SNAP_ETA * (1.0 + abs(uv)) +
                             OBLONG_U2M23 * abs(uv);
  outp.uv = vec2(uv);
  for (int k = 0; k < 2; ++k) outp.pad[k] = floatAbove(pad[k], pad[k]);
  return finiteF(outp.uv.x) && finiteF(outp.uv.y) && finiteF(outp.pad.x) && finiteF(outp.pad.y);
}

// The least-squares s of the point X on b's displacement line.
OBLONG_INLINE double heightOnLine(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec3) X, OBLONG_IN(dvec2) b) {
  dvec3 N = frameN(F, b);
  OBLONG_PRECISE double s = dotD(X - frameP(F, b), N) / dotD(N, N);
  return s;
}

// One Newton step on G(b, s) = X(t) in double from barycentrics bc, with s its least
// squares height on bc's displacement line (J = [∂G/∂u, ∂G/∂v, N], G bilinear in (b, s),
// Cramer's rule): the claim (nb, ns). False when J is singular; makePoint bounds the
// claim's error whatever it is.
OBLONG_INLINE bool newtonClaim(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D, double t,
                               OBLONG_IN(dvec2) bc, OBLONG_OUT(dvec2) nb, OBLONG_OUT(double) ns) {
  nb = dvec2(0.0);
  ns = 0.0;
  OBLONG_PRECISE dvec3 X = O + t * D;
  dvec3 N = frameN(F, bc);
  double s = heightOnLine(F, X, bc);
  OBLONG_PRECISE dvec3 r = X - (frameP(F, bc) + s * N);
  OBLONG_PRECISE dvec3 Gu = F.e1 + s * F.f1, Gv = F.e2 + s * F.f2;
  dvec3 c0 = crossD(Gv, N), c1 = crossD(N, Gu), c2 = crossD(Gu, Gv);
  double det = dotD(Gu, c0);
  if (!(abs(det) > 0.0)) return false;
  OBLONG_PRECISE dvec2 b1 = bc + dvec2(dotD(r, c0), dotD(r, c1)) / det;
  OBLONG_PRECISE double s1 = s + dotD(r, c2) / det;
  nb = b1;
  ns = s1;
  return true;
}

// The uv at t on the chord between curve points a and b (linear in t: exact where T's
// normals are parallel), where a claim between them starts (newtonClaim).
OBLONG_INLINE dvec2 chordAt(double ta, OBLONG_IN(dvec2) ua, double tb, OBLONG_IN(dvec2) ub, double t) {
  OBLONG_PRECISE double tau = (t - ta) / (tb - ta);
  OBLONG_PRECISE dvec2 g = ua + tau * (ub - ua);
  return g;
}
OBLONG_INLINE dvec2 chordUv(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b, double t) {
  return chordAt(a.t, dvec2(a.uv), b.t, dvec2(b.uv), t);
}

OBLONG_KERNELS_END

#endif
