// The traversal's inflated prism and the ray's crossings of its boundary (traversal/prism.h
// says how it is built and why it holds the micro-geometry), written once for the CPU and
// the Vulkan shaders in the subset of core/kernels/lang.h.
#ifndef OBLONG_KERNELS_PRISM_H
#define OBLONG_KERNELS_PRISM_H

#include "core/kernels/constants.h"
#include "core/kernels/lang.h"
#include "core/kernels/patch_math.h"
#include "core/kernels/rect_bounds.h"

OBLONG_KERNELS_BEGIN

// A prism G(T' × [a, b]) of a triangle T' given in T's barycentrics.
struct PrismShape {
  dvec3 q[3];   // base points of the three vertices
  dvec3 n[3];   // their displacement directions
  dvec2 bv[3];  // T's barycentrics of the three vertices
  double a, b;  // prism coordinates of the caps
};

struct Crossing {
  double t;
  dvec2 bary;  // T's barycentrics (u, v) of the crossing point
  double s;    // its prism coordinate
};

// T_δ (T grown by δ in barycentric units) with caps at a and b.
OBLONG_INLINE PrismShape prismInflated(OBLONG_IN(PatchFrame) F, double a, double b, double delta) {
  PrismShape P;
  P.bv[0] = dvec2(-delta, -delta);
  P.bv[1] = dvec2(1.0 + 2.0 * delta, -delta);
  P.bv[2] = dvec2(-delta, 1.0 + 2.0 * delta);
  for (int k = 0; k < 3; ++k) {
    P.q[k] = frameP(F, P.bv[k]);
    P.n[k] = frameN(F, P.bv[k]);
  }
  P.a = a;
  P.b = b;
  return P;
}

// How far the base triangle is grown beyond T, in barycentrics (prismInflated's delta).
OBLONG_INLINE double prismGrowth(OBLONG_IN(PrismShape) P) { return -P.bv[0].x; }

// The box of the six vertices: G(b, s) is a convex combination of them (affine in b at
// fixed s, affine in s at fixed b), so it contains the prism.
OBLONG_INLINE void prismBox(OBLONG_IN(PrismShape) P, OBLONG_OUT(dvec3) lo, OBLONG_OUT(dvec3) hi) {
  lo = dvec3(kInfD);
  hi = dvec3(-kInfD);
  for (int k = 0; k < 6; ++k) {
    OBLONG_PRECISE dvec3 v = P.q[k >> 1] + ((k & 1) != 0 ? P.b : P.a) * P.n[k >> 1];
    lo = min(lo, v);
    hi = max(hi, v);
  }
}

// Lexicographic order of (point, direction): the canonical endpoint order of an edge, so
// that the two prisms sharing a wall compute it from the same end.
OBLONG_INLINE bool lexLess(OBLONG_IN(dvec3) p, OBLONG_IN(dvec3) n, OBLONG_IN(dvec3) q, OBLONG_IN(dvec3) m) {
  for (int k = 0; k < 3; ++k)
    if (p[k] != q[k]) return p[k] < q[k];
  for (int k = 0; k < 3; ++k)
    if (n[k] != m[k]) return n[k] < m[k];
  return false;
}

OBLONG_INLINE double det3D(OBLONG_IN(dvec3) a, OBLONG_IN(dvec3) b, OBLONG_IN(dvec3) c) { return dotD(a, crossD(b, c)); }

// Records a crossing: the first and last by t, and how many.
OBLONG_INLINE void addCrossing(double t, OBLONG_IN(dvec2) bary, double s, OBLONG_INOUT(Crossing) first,
                               OBLONG_INOUT(Crossing) last, OBLONG_INOUT(int) count) {
  Crossing c;
  c.t = t;
  c.bary = bary;
  c.s = s;
  if (count == 0 || t < first.t) first = c;
  if (count == 0 || t > last.t) last = c;
  ++count;
}

// ---- the crossings (prismCrossings, below), in steps -----------------------------------
// The relative tolerance of the crossings' parameters.
#define OBLONG_PRISM_TOL 1e-9

// The crossings of the two caps, flat triangles q_k + s n_k (Möller–Trumbore in double):
// first, last and their count, the walls' to be added.
OBLONG_INLINE void capCrossings(OBLONG_IN(PrismShape) P, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D,
                                OBLONG_OUT(Crossing) first, OBLONG_OUT(Crossing) last, OBLONG_OUT(int) count) {
  first.t = 0.0;
  first.bary = dvec2(0.0);
  first.s = 0.0;
  last = first;
  count = 0;
  double tol = OBLONG_PRISM_TOL;
  for (int cap = 0; cap < 2; ++cap) {
    double s = cap == 1 ? P.b : P.a;
    OBLONG_PRECISE dvec3 v0 = P.q[0] + s * P.n[0], v1 = P.q[1] + s * P.n[1], v2 = P.q[2] + s * P.n[2];
    OBLONG_PRECISE dvec3 e1 = v1 - v0, e2 = v2 - v0;
    dvec3 pv = crossD(D, e2);
    double det = dotD(e1, pv);
    if (det == 0.0) continue;
    OBLONG_PRECISE double inv = 1.0 / det;
    OBLONG_PRECISE dvec3 tv = O - v0;
    OBLONG_PRECISE double b1 = dotD(tv, pv) * inv;
    dvec3 qv = crossD(tv, e1);
    OBLONG_PRECISE double b2 = dotD(D, qv) * inv;
    if (b1 < -tol || b2 < -tol || b1 + b2 > 1.0 + tol) continue;
    OBLONG_PRECISE double t = dotD(e2, qv) * inv;
    if (!finiteD(t)) continue;
    OBLONG_PRECISE dvec2 bb = P.bv[0] + b1 * (P.bv[1] - P.bv[0]) + b2 * (P.bv[2] - P.bv[0]);
    addCrossing(t, bb, s, first, last, count);
  }
}

// Wall e, the ruled surface between the displacement lines of its edge's ends A and B (in
// the canonical endpoint order): the line at τ ∈ [0, 1] meets the ray where
// det(O − Pτ, Nτ, D) = 0, the quadratic k2 τ² + k1 τ + k0.
OBLONG_INLINE void wallQuadratic(OBLONG_IN(PrismShape) P, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D, int e,
                                 OBLONG_OUT(int) A, OBLONG_OUT(int) B, OBLONG_OUT(double) k2, OBLONG_OUT(double) k1,
                                 OBLONG_OUT(double) k0) {
  A = e;
  B = (e + 1) % 3;
  if (lexLess(P.q[B], P.n[B], P.q[A], P.n[A])) {
    int x = A;
    A = B;
    B = x;
  }
  OBLONG_PRECISE dvec3 c = O - P.q[A], ed = P.q[B] - P.q[A], g = P.n[B] - P.n[A];
  OBLONG_PRECISE double a0 = det3D(c, P.n[A], D);
  OBLONG_PRECISE double a1 = det3D(c, g, D) - det3D(ed, P.n[A], D);
  OBLONG_PRECISE double a2 = -det3D(ed, g, D);
  k2 = a2;
  k1 = a1;
  k0 = a0;
}

// The wall's displacement line at root τ (error bound pad): its base point Pt, direction Nt
// and T's barycentrics bb of the base point. False when τ lies beyond the edge.
OBLONG_INLINE bool wallLine(OBLONG_IN(PrismShape) P, int A, int B, double ta, double pad, OBLONG_OUT(dvec3) Pt,
                            OBLONG_OUT(dvec3) Nt, OBLONG_OUT(dvec2) bb) {
  double tol = OBLONG_PRISM_TOL;
  Pt = dvec3(0.0);
  Nt = dvec3(0.0);
  bb = dvec2(0.0);
  if (ta < -tol - pad || ta > 1.0 + tol + pad) return false;
  double tc = clamp(ta, 0.0, 1.0);
  OBLONG_PRECISE dvec3 Pv = P.q[A] + tc * (P.q[B] - P.q[A]), Nv = P.n[A] + tc * (P.n[B] - P.n[A]);
  OBLONG_PRECISE dvec2 b = P.bv[A] + tc * (P.bv[B] - P.bv[A]);
  Pt = Pv;
  Nt = Nv;
  bb = b;
  return true;
}

// Whether the ray's closest point (t, s) on a wall's line is a crossing: s between the
// caps (with the tolerance) and t finite. (A ray along the line lies in the wall: no
// closest point, no crossing.)
OBLONG_INLINE bool wallKeeps(OBLONG_IN(PrismShape) P, double t, double s) {
  OBLONG_PRECISE double sTol = OBLONG_PRISM_TOL * (abs(P.a) + abs(P.b) + 1e-3);
  return !(s < P.a - sTol || s > P.b + sTol) && finiteD(t);
}

// Every crossing of the line O + tD with the prism's boundary (2 caps, 3 walls), with a
// relative tolerance so that grazing and edge crossings are kept: how many were found,
// and the first and last (the prism's hull along the ray line). Written as the steps above
// (capCrossings; per wall wallQuadratic, its roots, wallLine and wallKeeps), which the
// traversal's set-up runs in one loop with the turning points' lines
// (core/kernels/ray_patch_body.h, setupCurve).
OBLONG_INLINE int prismCrossings(OBLONG_IN(PrismShape) P, OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D,
                                 OBLONG_OUT(Crossing) first, OBLONG_OUT(Crossing) last) {
  int count;
  capCrossings(P, O, D, first, last, count);
  for (int e = 0; e < 3; ++e) {
    int A, B;
    double k2, k1, k0, tau[2], pad[2];
    wallQuadratic(P, O, D, e, A, B, k2, k1, k0);
    int nr = quadraticRoots(k2, k1, k0, tau, pad);
    for (int r = 0; r < nr; ++r) {
      dvec3 Pt, Nt;
      dvec2 bb;
      double t, s;
      if (wallLine(P, A, B, tau[r], pad[r], Pt, Nt, bb) && closestOnLines(Pt, Nt, O, D, t, s) && wallKeeps(P, t, s))
        addCrossing(t, bb, s, first, last, count);
    }
  }
  return count;
}

// The slabs of the oriented box around the inflated prism (PrismOBB: the face normal,
// edge 0 and the in-plane perpendiculars of the three edges): [t0, t1] clipped to
// lo[k] − slack <= axis[k]·(O + t D) <= hi[k] + slack, stopping at the first miss.
OBLONG_INLINE void clipPrismSlabs(OBLONG_IN_ARRAY dvec3 axis[5], OBLONG_IN_ARRAY double lo[5],
                                  OBLONG_IN_ARRAY double hi[5], OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D, double slack,
                                  OBLONG_INOUT(double) t0, OBLONG_INOUT(double) t1) {
  for (int k = 0; k < 5 && t0 <= t1; ++k) {
    OBLONG_PRECISE double o = dotD(axis[k], O), d = dotD(axis[k], D);
    OBLONG_PRECISE double l = lo[k] - slack, h = hi[k] + slack;
    if (d == 0.0) {
      if (o < l || o > h) t0 = kInfD;
      continue;
    }
    OBLONG_PRECISE double a = (l - o) / d, b = (h - o) / d;
    if (a > b) {
      double x = a;
      a = b;
      b = x;
    }
    t0 = t0 < a ? a : t0;
    t1 = b < t1 ? b : t1;
  }
}

// The absolute part of the traversal's t slack for boxes padded by `pad` (a ray of
// direction length lenD moves by pad over pad / lenD): rpInit's, missesPrism's, tfdm's.
OBLONG_INLINE double tSlackAbs(double pad, double lenD) {
  OBLONG_PRECISE double r = double(OBLONG_TRAV_T_ABS_PADS) * pad / lenD;
  return r;
}

// TraversalMesh::missesPrism, the cheap exact reject before any per-ray set-up: true when
// [tmin, tmax] (with the traversal's slack for a box pad `budgetPad`) misses the padded
// box around the inflated prism [infLo, infHi] or its oriented slabs. Only for origins
// within the budget (max-norm maxO <= budget); beyond it, false (the full test decides).
OBLONG_INLINE bool missesPrism(double tmin, double tmax, double maxO, double budget, double budgetPad, double lenD,
                               OBLONG_IN(dvec3) O, OBLONG_IN(dvec3) D, OBLONG_IN(dvec3) invD, OBLONG_IN(dvec3) infLo,
                               OBLONG_IN(dvec3) infHi, bool obbValid, OBLONG_IN_ARRAY dvec3 axis[5],
                               OBLONG_IN_ARRAY double lo[5], OBLONG_IN_ARRAY double hi[5]) {
  if (!(maxO <= budget)) return false;
  double tAbs = tSlackAbs(budgetPad, lenD);
  OBLONG_PRECISE double t0 = tmin - (OBLONG_TRAV_SLACK_REL * abs(tmin) + tAbs);
  OBLONG_PRECISE double t1 = tmax + (OBLONG_TRAV_SLACK_REL * abs(tmax) + tAbs);
  clipBox(infLo, infHi, O, invD, t0, t1);
  if (!(t0 <= t1)) return true;
  if (obbValid) clipPrismSlabs(axis, lo, hi, O, D, OBLONG_TRAV_OBB_ROUND * (maxO + 1.0), t0, t1);
  return !(t0 <= t1);
}

OBLONG_KERNELS_END

#endif
