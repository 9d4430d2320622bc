// Per-patch math of the traversal (RMIP paper §4.2, Eq. 3-4), written once for the CPU
// (traversal/psi.h, traversal/ray_patch.h) and the Vulkan shaders (traversal.glsl), in
// the subset of core/kernels/lang.h.
//
// Everything works in *local sample coordinates* (X, Y): the sample coordinates of
// docs/design.md §1 (s = tiling ⊙ uv ⊙ (W,H) − ½, texel centres at integers, grid cells
// [i,i+1]×[j,j+1]) minus an integer origin near T. Barycentrics b = (u, v), P and N are
// affine in (X, Y) (PatchFrame), so ψ(X,Y) = det(P(X,Y) − O, N(X,Y), D) is a quadratic
// in (X, Y); its zero set (a conic) is the projection of the whole ray line along the
// displacement directions. ψ_X = 0 and ψ_Y = 0 are lines; where the conic meets them the
// curve's Y (resp. X) is stationary: the turning points. Between consecutive turning
// points the curve is monotone in X and Y, so the rectangle spanned by a piece's
// endpoints bounds it (Patterson et al. 1991). All in double: per ray and prism, not per
// step.
#ifndef OBLONG_KERNELS_PATCH_MATH_H
#define OBLONG_KERNELS_PATCH_MATH_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

// Affine maps of one base triangle over local sample coordinates (LocalFrame::make builds
// it on the host; the GPU reads it from TriGpu).
struct PatchFrame {
  dvec2 bc, bX, bY;  // barycentrics (u, v) = bc + bX X + bY Y
  dvec2 sc, sU, sV;  // local sample coordinates (X, Y) = sc + sU u + sV v
  // World quantities: P = p0 + e1 u + e2 v, N = n0 + f1 u + f2 v (N not normalised).
  dvec3 p0, e1, e2, n0, f1, f2;
  // The same over (X, Y): P = Pc + PX X + PY Y, N = Nc + NX X + NY Y.
  dvec3 Pc, PX, PY, Nc, NX, NY;
};

OBLONG_INLINE dvec2 frameBary(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec2) p) {
  OBLONG_PRECISE dvec2 r = F.bc + F.bX * p.x + F.bY * p.y;
  return r;
}
OBLONG_INLINE dvec2 frameLocal(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec2) b) {
  OBLONG_PRECISE dvec2 r = F.sc + F.sU * b.x + F.sV * b.y;
  return r;
}
OBLONG_INLINE dvec3 frameP(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec2) b) {
  OBLONG_PRECISE dvec3 r = F.p0 + F.e1 * b.x + F.e2 * b.y;
  return r;
}
OBLONG_INLINE dvec3 frameN(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec2) b) {
  OBLONG_PRECISE dvec3 r = F.n0 + F.f1 * b.x + F.f2 * b.y;
  return r;
}

// ψ over local sample coordinates: c0 + cX X + cY Y + cXX X² + cXY XY + cYY Y².
struct Psi {
  double c0, cX, cY, cXX, cXY, cYY;
};

OBLONG_INLINE Psi psiMake(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D) {
  // D · (A × N) with A = P − O affine, N affine.
  OBLONG_PRECISE dvec3 A0 = F.Pc - O;
  Psi p;
  p.c0 = dotD(D, crossD(A0, F.Nc));
  p.cX = dotD(D, crossD(A0, F.NX) + crossD(F.PX, F.Nc));
  p.cY = dotD(D, crossD(A0, F.NY) + crossD(F.PY, F.Nc));
  p.cXX = dotD(D, crossD(F.PX, F.NX));
  p.cYY = dotD(D, crossD(F.PY, F.NY));
  p.cXY = dotD(D, crossD(F.PX, F.NY) + crossD(F.PY, F.NX));
  return p;
}
OBLONG_INLINE double psiEval(OBLONG_IN(Psi) s, OBLONG_IN(dvec2) p) {
  OBLONG_PRECISE double r = s.c0 + p.x * (s.cX + s.cXX * p.x + s.cXY * p.y) + p.y * (s.cY + s.cYY * p.y);
  return r;
}
OBLONG_INLINE dvec2 psiGrad(OBLONG_IN(Psi) s, OBLONG_IN(dvec2) p) {
  OBLONG_PRECISE dvec2 r = dvec2(s.cX + 2.0 * s.cXX * p.x + s.cXY * p.y, s.cY + s.cXY * p.x + 2.0 * s.cYY * p.y);
  return r;
}
// ψ on the line {axis = c} as a quadratic q2 w² + q1 w + q0 in the other coordinate w.
OBLONG_INLINE void psiOnLine(OBLONG_IN(Psi) s, int axis, double c, OBLONG_OUT(double) q2, OBLONG_OUT(double) q1,
                             OBLONG_OUT(double) q0) {
  OBLONG_PRECISE double a2, a1, a0;
  if (axis == 0) {
    a2 = s.cYY;
    a1 = s.cY + s.cXY * c;
    a0 = s.c0 + c * (s.cX + s.cXX * c);
  } else {
    a2 = s.cXX;
    a1 = s.cX + s.cXY * c;
    a0 = s.c0 + c * (s.cY + s.cYY * c);
  }
  q2 = a2;
  q1 = a1;
  q0 = a0;
}

// Real roots of q2 w² + q1 w + q0 (stable formulas; a slightly negative discriminant
// counts as a double root). pad[k] bounds the error of root k: an error δ of the
// polynomial's value (coefficients rounded relative 1e-13) moves a simple root by
// δ / |q'(w)|, a double root by at most √(δ / |q2|). Returns the count (0..2); a
// quadratic that vanishes identically returns -1.
OBLONG_INLINE int quadraticRoots(double q2, double q1, double q0, OBLONG_OUT_ARRAY double w[2], OBLONG_OUT_ARRAY double pad[2]) {
  w[0] = 0.0;
  w[1] = 0.0;
  pad[0] = 0.0;
  pad[1] = 0.0;
  double scale = max(max(abs(q2), abs(q1)), abs(q0));
  if (!(scale > 0.0) || !finiteD(scale)) return scale == 0.0 ? -1 : 0;
  double e = 1e-14;
  int n = 0;
  if (abs(q2) <= e * scale) {  // linear (a huge second root is dropped)
    if (abs(q1) <= e * scale) return abs(q0) <= e * scale ? -1 : 0;
    w[n++] = -q0 / q1;
  } else {
    OBLONG_PRECISE double disc = q1 * q1 - 4.0 * q2 * q0;
    OBLONG_PRECISE double discErr = 1e-13 * (q1 * q1 + 4.0 * abs(q2 * q0));
    if (disc < 0.0) {
      if (disc < -discErr) return 0;
      disc = 0.0;
    }
    OBLONG_PRECISE double q = -0.5 * (q1 + copysignD(sqrt(disc), q1));
    if (q != 0.0) {
      w[n++] = q / q2;
      w[n++] = q0 / q;
    } else {
      w[n++] = -q1 / (2.0 * q2);
    }
  }
  for (int k = 0; k < n; ++k) {
    OBLONG_PRECISE double x = w[k];
    OBLONG_PRECISE double delta = 1e-13 * (abs(q2) * x * x + abs(q1 * x) + abs(q0));
    OBLONG_PRECISE double slope = abs(2.0 * q2 * x + q1);
    // min(δ / |q'|, √(δ / |q2|)), the square root only where it is the smaller
    // (δ·|q2| ≥ q'²; at a near-tie the two agree to rounding).
    OBLONG_PRECISE double a2 = abs(q2);
    OBLONG_PRECISE double p = kInfD;
    if (a2 > 0.0 && !(delta * a2 < slope * slope)) p = sqrt(delta / a2);
    else if (slope > 0.0) p = delta / slope;
    pad[k] = 4.0 * p + 1e-14 * abs(x);
  }
  return n;
}


// The ray parameter t and the line parameter s where the line P + sN comes closest to the
// ray O + tD (least squares on O + tD = P + sN). False when the two are parallel.
OBLONG_INLINE bool closestOnLines(OBLONG_IN(dvec3) P, OBLONG_IN(dvec3) N, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D,
                                  OBLONG_OUT(double) t, OBLONG_OUT(double) s) {
  t = 0.0;
  s = 0.0;
  OBLONG_PRECISE dvec3 A = P - O;
  OBLONG_PRECISE double dd = dotD(D, D), nn = dotD(N, N), dn = dotD(D, N);
  OBLONG_PRECISE double den = dd * nn - dn * dn;
  if (!(den > 1e-24 * dd * nn)) return false;
  OBLONG_PRECISE double da = dotD(D, A), na = dotD(N, A);
  // minimise |tD − sN − A|²: [dd, −dn; −dn, nn] [t; s] = [da; −na]
  OBLONG_PRECISE double tt = (nn * da - dn * na) / den, ss = (dn * da - dd * na) / den;
  t = tt;
  s = ss;
  return true;
}

// The ray parameter t and prism coordinate s where the displacement line through the
// local point p comes closest to the ray (they meet when ψ(p) = 0). False when the two
// lines are parallel (ray along N).
OBLONG_INLINE bool rayParamAt(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D, OBLONG_IN(dvec2) p,
                              OBLONG_OUT(double) t, OBLONG_OUT(double) s) {
  dvec2 b = frameBary(F, p);
  return closestOnLines(frameP(F, b), frameN(F, b), O, D, t, s) && finiteD(t) && finiteD(s);
}

// ---- the turning points (monotoneSplits, below), in steps ------------------------------
// Line L of the turning points, a X + b Y + c = 0 (ψ_X = 0 for L = 0: (2cXX, cXY, cX); ψ_Y = 0
// for L = 1: (cXY, 2cYY, cY)), as Q + τR with |R| = 1, and ψ on it as q2 τ² + q1 τ + q0.
// False when ψ_X (or ψ_Y) is constant: no turning point of that kind.
OBLONG_INLINE bool turnLine(OBLONG_IN(Psi) psi, int L, OBLONG_OUT(dvec2) Q, OBLONG_OUT(dvec2) R, OBLONG_OUT(double) q2,
                            OBLONG_OUT(double) q1, OBLONG_OUT(double) q0) {
  Q = dvec2(0.0);
  R = dvec2(0.0);
  q2 = 0.0;
  q1 = 0.0;
  q0 = 0.0;
  OBLONG_PRECISE double a = L == 0 ? 2.0 * psi.cXX : psi.cXY, b = L == 0 ? psi.cXY : 2.0 * psi.cYY,
                        c = L == 0 ? psi.cX : psi.cY;
  OBLONG_PRECISE double nn = a * a + b * b;
  if (!(nn > 0.0)) return false;
  OBLONG_PRECISE dvec2 Qv = -c / nn * dvec2(a, b);
  OBLONG_PRECISE dvec2 Rv = dvec2(-b, a) / sqrt(nn);
  // ψ(Q + τ R) = ψ(Q) + τ ∇ψ(Q)·R + τ² Rᵀ H R / 2, H = [[2cXX, cXY], [cXY, 2cYY]].
  OBLONG_PRECISE double p0 = psiEval(psi, Qv);
  OBLONG_PRECISE dvec2 g = psiGrad(psi, Qv);
  OBLONG_PRECISE double p1 = g.x * Rv.x + g.y * Rv.y;
  OBLONG_PRECISE double p2 = psi.cXX * Rv.x * Rv.x + psi.cXY * Rv.x * Rv.y + psi.cYY * Rv.y * Rv.y;
  Q = Qv;
  R = Rv;
  q2 = p2;
  q1 = p1;
  q0 = p0;
  return true;
}

// The candidate at root τ of ψ on a turning line (error bound pad along R): its barycentrics
// b and the displacement line there (P(b), N(b)), for the ray's closest point. False when
// farB >= 0 and b lies beyond T grown by farB at its largest over the error bound.
OBLONG_INLINE bool turnCandidate(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec2) Q, OBLONG_IN(dvec2) R, double tau, double pad,
                                 double farB, OBLONG_OUT(dvec2) b, OBLONG_OUT(dvec3) P, OBLONG_OUT(dvec3) N) {
  OBLONG_PRECISE dvec2 cand = Q + tau * R;
  // Its barycentrics, each at its largest over the root's error pad along R.
  dvec2 bc = frameBary(F, cand);
  b = bc;
  P = dvec3(0.0);
  N = dvec3(0.0);
  OBLONG_PRECISE dvec2 db = F.bX * R.x + F.bY * R.y;
  OBLONG_PRECISE dvec3 lam = dvec3(bc.x, bc.y, 1.0 - bc.x - bc.y) + abs(dvec3(db.x, db.y, db.x + db.y)) * pad;
  if (farB >= 0.0 && !(lam.x >= -farB && lam.y >= -farB && lam.z >= -farB)) return false;
  P = frameP(F, bc);
  N = frameN(F, bc);
  return true;
}

// The four splits' slots, zeroed.
OBLONG_INLINE void clearSplits(OBLONG_OUT_ARRAY double ts[4], OBLONG_OUT_ARRAY dvec2 bs[4],
                               OBLONG_OUT_ARRAY double ss[4]) {
  for (int k = 0; k < 4; ++k) {
    ts[k] = 0.0;
    bs[k] = dvec2(0.0);
    ss[k] = 0.0;
  }
}

// The splits ts (with bs, ss) sorted by t and made distinct; returns their count.
OBLONG_INLINE int sortSplits(OBLONG_INOUT_ARRAY double ts[4], OBLONG_INOUT_ARRAY dvec2 bs[4],
                             OBLONG_INOUT_ARRAY double ss[4], int m) {
  for (int i = 1; i < m; ++i)  // insertion sort (m <= 4)
    for (int j = i; j > 0 && ts[j] < ts[j - 1]; --j) {
      double x = ts[j];
      ts[j] = ts[j - 1];
      ts[j - 1] = x;
      dvec2 xb = bs[j];
      bs[j] = bs[j - 1];
      bs[j - 1] = xb;
      double xs = ss[j];
      ss[j] = ss[j - 1];
      ss[j - 1] = xs;
    }
  int u = 0;
  for (int i = 0; i < m; ++i)
    if (u == 0 || ts[i] != ts[u - 1]) {
      ts[u] = ts[i];
      bs[u] = bs[i];
      ss[u] = ss[i];
      ++u;
    }
  return u;
}

// The initial split (paper Alg. 1 line 5): ray parameters in (tIn, tOut) where the curve
// may turn, sorted and distinct. Candidates are the points of the conic ψ = 0 on the
// lines ψ_X = 0 and ψ_Y = 0 (other branches of the conic show up too), each taken to the
// ray by rayParamAt. The caller finds the curve's point at each (by inversion) and splits
// [tIn, tOut] there into pieces that are monotone in X and Y. Returns the count (≤ 4);
// bs and ss: each split's candidate as prism coordinates (its barycentrics and
// rayParamAt's s), from which the curve point is claimed without an inversion (its
// residual bounds its error, as for any claim). With farB >= 0 the caller knows that the
// curve's points in (tIn, tOut) have barycentrics within T grown by less than farB: a
// candidate beyond that by its root's whole error bound is not one of them (another
// branch of ψ = 0) and is dropped (a NaN one too). Written as the steps above, which the
// traversal's set-up runs in one loop with the prism's walls (core/kernels/ray_patch_body.h,
// setupCurve).
OBLONG_INLINE int monotoneSplits(OBLONG_IN(PatchFrame) F, OBLONG_IN(Psi) psi, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D,
                                 double tIn, double tOut, double farB, OBLONG_OUT_ARRAY double ts[4],
                                 OBLONG_OUT_ARRAY dvec2 bs[4], OBLONG_OUT_ARRAY double ss[4]) {
  clearSplits(ts, bs, ss);
  int m = 0;
  for (int L = 0; L < 2; ++L) {
    dvec2 Q, R;
    double q2, q1, q0;
    if (!turnLine(psi, L, Q, R, q2, q1, q0)) continue;
    double tau[2], pad[2];
    int nr = quadraticRoots(q2, q1, q0, tau, pad);
    for (int k = 0; k < nr; ++k) {
      dvec2 bc;
      dvec3 P, N;
      double t, s;
      if (!turnCandidate(F, Q, R, tau[k], pad[k], farB, bc, P, N)) continue;
      if (!closestOnLines(P, N, O, D, t, s) || !finiteD(t) || !finiteD(s)) continue;
      if (!(t > tIn && t < tOut)) continue;
      ts[m] = t;
      bs[m] = bc;
      ss[m] = s;
      ++m;
    }
  }
  return sortSplits(ts, bs, ss, m);
}

// Approximate direction of a ray's texture-space curve in local sample coordinates
// (ordering only: front-to-back order in the traversal, child order in tfdm): the ray
// direction solved in the frame (PX, PY, N) at T's centroid, N = frameN(F, (1/3, 1/3))
// (computed by the caller: 1.0 / 3.0 is a float quotient in GLSL).
OBLONG_INLINE dvec2 approxDirLocal(OBLONG_IN(PatchFrame) F, OBLONG_IN(dvec3) N, OBLONG_IN(dvec3) dir) {
  OBLONG_PRECISE double det = dotD(F.PX, crossD(F.PY, N));
  if (!(abs(det) > 0.0)) return dvec2(1.0);
  OBLONG_PRECISE dvec2 r = dvec2(dotD(dir, crossD(F.PY, N)) / det, dotD(F.PX, crossD(dir, N)) / det);
  return r;
}

OBLONG_KERNELS_END

#endif
