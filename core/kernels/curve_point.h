// Points of the ray's texture-space curve with their error bounds (RMIP paper §4.3: the
// curve's points come from inverting ray points), written once for the CPU
// (traversal/ray_patch.h) and the Vulkan shaders, in the subset of core/kernels/lang.h.
//
// A curve point is claimed from prism coordinates (b, s) said to be the projection of
// the ray point X(t). The residual r = G(b, s) − X(t) bounds the error: G is bilinear in
// (b, s), so J(b, s_true)·(Δb, Δs) = −r exactly and |Δu| ≤ kb.x |r|, |Δv| ≤ kb.y |r|
// while both points stay in the analysed domain (traversal/prism.h, the shell analysis).
// Claims and their residuals are float, in T's frame from a per-ray anchor; what is
// exact is the double frame and ray.
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

// The ray near T in T's frame, for the claims in float: X(t) − p0 = XA + (t − tA)·D, with
// XA = X(tA) − p0 computed in double and rounded to float once per ray and triangle (tA:
// the middle of the ray's interval in the prism), so that the float terms are of T's size
// wherever the ray comes from. XAerr bounds each component of XA's distance from the exact
// O + tA·D − p0 (the double arithmetic's 2^-50 of its terms, the rounding's 2^-24). The
// residual's rounding bound (claimResidual) is linear in the claim's |u|, |v|, |s| and
// |t − tA| with coefficients of the frame's and the ray's L1 norms, here times 10u and
// rounded up: kE (e1, e2), kN (n0, f1, f2), kD (D), and the constant k0 (XA's magnitude
// and three times XAerr).
struct ClaimAnchor {
  double tA;
  vec3 XA, Df;  // Df: D rounded to float
  float XAerr;
  vec2 kE;
  vec3 kN;
  float kD, k0;
};
OBLONG_INLINE double maxAbs3(OBLONG_IN(dvec3) v) { return max(max(abs(v.x), abs(v.y)), abs(v.z)); }

OBLONG_INLINE ClaimAnchor claimAnchor(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D, double tA) {
  ClaimAnchor A;
  A.tA = tA;
  OBLONG_PRECISE dvec3 X = (O + tA * D) - F.p0;
  A.XA = vec3(X);
  A.Df = vec3(D);
  OBLONG_PRECISE double terms = maxAbs3(O) + abs(tA) * maxAbs3(D) + maxAbs3(F.p0);
  OBLONG_PRECISE double err = 0.5 * OBLONG_U2M23 * maxAbs3(X) + OBLONG_U2M50 * terms;
  A.XAerr = floatAbove(err, err);
  // The seven coefficients from one call site (a shader inlines each call).
  float c[7];
  for (int k = 0; k < 7; ++k) {
    dvec3 v = k == 0 ? F.e1 : k == 1 ? F.e2 : k == 2 ? F.n0 : k == 3 ? F.f1 : k == 4 ? F.f2 : k == 5 ? D : X;
    OBLONG_PRECISE double m = 10.0 * (0.5 * OBLONG_U2M23) * (abs(v.x) + abs(v.y) + abs(v.z)) +
                              (k == 6 ? 3.0 * double(A.XAerr) : 0.0);
    c[k] = floatAbove(m, m);
  }
  A.kE = vec2(c[0], c[1]);
  A.kN = vec3(c[2], c[3], c[4]);
  A.kD = c[5];
  A.k0 = c[6];
  return A;
}

// T's frame in float (PatchFrame's P and N over barycentrics, relative to p0).
struct FrameF {
  vec3 e1, e2, n0, f1, f2;
};
OBLONG_INLINE FrameF frameF(OBLONG_IN(PatchFrame) F) {
  FrameF R;
  R.e1 = vec3(F.e1);
  R.e2 = vec3(F.e2);
  R.n0 = vec3(F.n0);
  R.f1 = vec3(F.f1);
  R.f2 = vec3(F.f2);
  return R;
}

// A bound on the residual |G(b, s) − X(t)| of the claim (b, s) at t (G, X exact in the
// double frame and ray), evaluated in float in T's frame: the computed |G − X| (its dot
// product and root within 2^-20, a GPU's sqrt included) plus the evaluation's error. Per
// component, with u = 2^-24 and the frame's constants rounded to float: G = e1·u + e2·v +
// s·(n0 + f1·u + f2·v) is off by at most 6u of MG = |e1·u| + |e2·v| + |s|·(|n0| + |f1·u| +
// |f2·v|); X = XA + dt·Df (dt = t − tA rounded) by 5u of MX = |XA| + |dt·Df| plus XAerr; the
// difference by u of both: 7u·MG + 5u·MX + XAerr, and the Euclidean norm of the errors is
// at most their sum over the three components, 10u·(|u|·‖e1‖₁ + |v|·‖e2‖₁ + |s|·(‖n0‖₁ +
// |u|·‖f1‖₁ + |v|·‖f2‖₁) + ‖XA‖₁ + |dt|·‖D‖₁) + 3·XAerr with the anchor's coefficients
// (10u covers the float magnitudes' own rounding); the bound itself is rounded up by
// 2^-20.
OBLONG_INLINE float claimResidual(OBLONG_IN(FrameF) R, OBLONG_IN(ClaimAnchor) A, double t, OBLONG_IN(vec2) b,
                                  float s) {
  float dt = float(t - A.tA);
  OBLONG_PRECISE vec3 dX = dt * A.Df;
  OBLONG_PRECISE vec3 X = A.XA + dX;
  OBLONG_PRECISE vec3 fu = R.f1 * b.x, fv = R.f2 * b.y, eu = R.e1 * b.x, ev = R.e2 * b.y;
  OBLONG_PRECISE vec3 N = R.n0 + fu + fv;
  OBLONG_PRECISE vec3 G = eu + ev + s * N;
  OBLONG_PRECISE vec3 d = G - X;
  OBLONG_PRECISE float rf = sqrt(dotF(d, d));
  OBLONG_PRECISE float au = abs(b.x), av = abs(b.y);
  OBLONG_PRECISE float err = A.k0 + au * A.kE.x + av * A.kE.y + abs(s) * (A.kN.x + au * A.kN.y + av * A.kN.z) +
                             abs(dt) * A.kD;
  OBLONG_PRECISE float r = (rf * (1.0f + float(OBLONG_U2M20)) + err) * (1.0f + float(OBLONG_U2M20));
  return r;
}

// The curve point for the claim (b, s) at t (R: F in float); false when the claim lies
// outside the analysed domain or its error bound is too large to trust the first-order
// bounds.
OBLONG_INLINE bool makePoint(OBLONG_IN(PatchFrame) F, OBLONG_IN(FrameF) R, OBLONG_IN(ClaimBounds) K,
                             OBLONG_IN(ClaimAnchor) A, double t, OBLONG_IN(vec2) b, float s,
                             OBLONG_OUT(CurvePoint) outp) {
  outp.t = t;
  outp.uv = vec2(0.0f);
  outp.pad = vec2(0.0f);
  dvec2 bd = dvec2(b);
  double sd = double(s), dom = K.domainB;
  if (!(bd.x >= -dom && bd.y >= -dom && bd.x + bd.y <= 1.0 + dom)) return false;
  if (!(sd >= K.domainS0 && sd <= K.domainS1)) return false;
  double r = double(claimResidual(R, A, t, b, s));
  OBLONG_PRECISE dvec2 db = K.kb * r * OBLONG_TRAV_RESIDUAL_SAFETY;
  if (!(db.x + db.y < OBLONG_TRAV_MAX_POINT_ERR) ||
      !(K.ks * r < OBLONG_TRAV_MAX_POINT_ERR * (K.domainS1 - K.domainS0) + OBLONG_TRAV_TINY))
    return false;
  dvec2 uv = frameLocal(F, bd);
  // uv rounded to the nearest float moves by at most u·|uv| (u = 2^-24), and the float
  // rectangle's uv ± pad (pieceLo, pieceHi) rounds by at most u·(|uv| + pad) more: 2u·|uv|
  // added, and the pad rounded up by more than its own u.
  OBLONG_PRECISE dvec2 pad = K.kxy * (r * OBLONG_TRAV_RESIDUAL_SAFETY) + OBLONG_TRAV_SNAP_ETA * (1.0 + abs(uv)) +
                             OBLONG_U2M23 * abs(uv);
  outp.uv = vec2(uv);
  for (int k = 0; k < 2; ++k) outp.pad[k] = floatAbove(pad[k], pad[k]);
  return finiteF(outp.uv.x) && finiteF(outp.uv.y) && finiteF(outp.pad.x) && finiteF(outp.pad.y);
}

// One Newton step on G(b, s) = X(t) in float in T's frame from barycentrics bc, with s
// its least-squares height on bc's displacement line (J = [∂G/∂u, ∂G/∂v, N], G bilinear
// in (b, s), Cramer's rule): the claim (nb, ns). False when J is singular. Its quotients
// need not be correctly rounded (a GPU's `/`): makePoint bounds the claim's error
// whatever it is.
OBLONG_INLINE bool newtonClaim(OBLONG_IN(FrameF) R, OBLONG_IN(ClaimAnchor) A, double t, OBLONG_IN(vec2) bc,
                               OBLONG_OUT(vec2) nb, OBLONG_OUT(float) ns) {
  nb = vec2(0.0f);
  ns = 0.0f;
  float dt = float(t - A.tA);
  OBLONG_PRECISE vec3 X = A.XA + dt * A.Df;
  OBLONG_PRECISE vec3 N = R.n0 + R.f1 * bc.x + R.f2 * bc.y;
  OBLONG_PRECISE vec3 P = R.e1 * bc.x + R.e2 * bc.y;
  OBLONG_PRECISE float s = dotF(X - P, N) / dotF(N, N);
  OBLONG_PRECISE vec3 r = X - (P + s * N);
  OBLONG_PRECISE vec3 Gu = R.e1 + s * R.f1, Gv = R.e2 + s * R.f2;
  vec3 c0 = crossF(Gv, N), c1 = crossF(N, Gu), c2 = crossF(Gu, Gv);
  float det = dotF(Gu, c0);
  if (!(abs(det) > 0.0f)) return false;
  OBLONG_PRECISE vec2 b1 = bc + vec2(dotF(r, c0), dotF(r, c1)) / det;
  OBLONG_PRECISE float s1 = s + dotF(r, c2) / det;
  nb = b1;
  ns = s1;
  return finiteF(b1.x) && finiteF(b1.y) && finiteF(s1);
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
