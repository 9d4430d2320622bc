// The body of core/kernels/invert.h, written once over the scalar KS (float or double)
// and included once per scalar; read invert.h, which defines the names this file uses:
//   KS, KS3       the scalar and its 3-vector (float, vec3 / double, dvec3)
//   KFrame, KCubic, KResult  the struct names of this scalar
//   KDOT, KCROSS, KLENGTH, KFINITE, KCOPYSIGN, KCBRT  its vector and scalar functions
//   KDIV, KSQRT   its quotient and square root (float: lang.h's divF, sqrtF)
//   K_DROP_EPS, K_ROOT_TOL, K_TIE_EPS, K_OUTSIDE_EPS  its precision-dependent constants
// No include guard: it is meant to be included more than once, and it undefines those
// names at its end. Every literal is written
// KS(...): in C++ an unsuffixed literal would make float arithmetic double.

// T in a local frame at p0 (inversion/inverter.h): F(u,v,s) = e1 u + e2 v + s N(u,v) − W
// with W = X − p0; computing W first keeps float accuracy far from the origin.
struct KFrame {
  KS3 p0, e1, e2, n0, f1, f2;  // p0, p1-p0, p2-p0, n0, n1-n0, n2-n0
  KS L;                        // length scale: the longest edge
};

OBLONG_INLINE KFrame invFrame(OBLONG_IN(KS3) p0, OBLONG_IN(KS3) p1, OBLONG_IN(KS3) p2, OBLONG_IN(KS3) n0,
                              OBLONG_IN(KS3) n1, OBLONG_IN(KS3) n2) {
  KFrame F;
  F.p0 = p0;
  F.e1 = p1 - p0;
  F.e2 = p2 - p0;
  F.n0 = n0;
  F.f1 = n1 - n0;
  F.f2 = n2 - n0;
  OBLONG_PRECISE KS3 e3 = F.e2 - F.e1;
  OBLONG_PRECISE KS l2 = max(max(KDOT(F.e1, F.e1), KDOT(F.e2, F.e2)), KDOT(e3, e3));
  F.L = KSQRT(l2);
  return F;
}

// N(u,v), the interpolated (unnormalised) normal.
OBLONG_INLINE KS3 invN(OBLONG_IN(KFrame) F, KS u, KS v) {
  OBLONG_PRECISE KS3 r = F.n0 + u * F.f1 + v * F.f2;
  return r;
}

OBLONG_INLINE KS det3(OBLONG_IN(KS3) a, OBLONG_IN(KS3) b, OBLONG_IN(KS3) c) { return KDOT(a, KCROSS(b, c)); }

// The outcome of an inversion: barycentrics (u, v), height h = s·|N(u,v)|.
struct KResult {
  KS u, v, h;
  bool converged;
  int iterations;
};

// Fills the result from (u,v,s); converged also asks for finite values.
OBLONG_INLINE KResult invFinish(OBLONG_IN(KFrame) F, KS u, KS v, KS s, bool converged, int iterations) {
  KResult r;
  r.u = u;
  r.v = v;
  OBLONG_PRECISE KS h = s * KLENGTH(invN(F, u, v));
  r.h = h;
  r.converged = converged && KFINITE(u) && KFINITE(v) && KFINITE(h);
  r.iterations = iterations;
  return r;
}

// How far (u, v) lies outside T in barycentric units (0 inside).
OBLONG_INLINE KS invOutside(KS u, KS v) {
  OBLONG_PRECISE KS w = u + v - KS(1);
  return max(max(KS(0), -u), max(-v, w));
}

// One Newton step on F at (u,v,s) (Cramer's rule on J = [e1 + s f1, e2 + s f2, N]).
// Returns false (and leaves the state) when J is singular or the step is not finite.
OBLONG_FORCE_INLINE bool newtonStep(OBLONG_IN(KFrame) F, OBLONG_IN(KS3) W, OBLONG_INOUT(KS) u, OBLONG_INOUT(KS) v,
                                    OBLONG_INOUT(KS) s, OBLONG_OUT(KS) du, OBLONG_OUT(KS) dv, OBLONG_OUT(KS) ds) {
  du = KS(0);
  dv = KS(0);
  ds = KS(0);
  OBLONG_PRECISE KS3 N = invN(F, u, v);
  OBLONG_PRECISE KS3 r = F.e1 * u + F.e2 * v + s * N - W;
  OBLONG_PRECISE KS3 a = F.e1 + s * F.f1;
  OBLONG_PRECISE KS3 b = F.e2 + s * F.f2;
  KS3 bxN = KCROSS(b, N);
  KS D = KDOT(a, bxN);
  if (!(abs(D) > KS(0))) return false;
  OBLONG_PRECISE KS inv = KDIV(KS(1), D);
  OBLONG_PRECISE KS su = -KDOT(r, bxN) * inv;
  OBLONG_PRECISE KS sv = -KDOT(a, KCROSS(r, N)) * inv;
  OBLONG_PRECISE KS ss = -KDOT(a, KCROSS(b, r)) * inv;
  if (!KFINITE(su) || !KFINITE(sv) || !KFINITE(ss)) return false;
  du = su;
  dv = sv;
  ds = ss;
  u += su;
  v += sv;
  s += ss;
  return true;
}

// Newton's stopping rule (inversion/newton.h): max(|du|,|dv|) <= tol, |ds| <= tol·(L+|s|).
OBLONG_INLINE bool newtonConverged(OBLONG_IN(KFrame) F, KS du, KS dv, KS ds, KS s, KS tol) {
  OBLONG_PRECISE KS sTol = tol * (F.L + abs(s));
  return max(abs(du), abs(dv)) <= tol && abs(ds) <= sTol;
}

// ---- the cubic (inversion/cubic.h) ------------------------------------------------------

// The cubic in σ = s/L of W = X − p0, with the edges and W scaled by 1/L as its roots'
// barycentrics need them.
struct KCubic {
  KS3 e1, e2, w;
  KS a0, a1, a2, a3;
};

OBLONG_INLINE KCubic cubicOf(OBLONG_IN(KFrame) F, OBLONG_IN(KS3) W) {
  KCubic C;
  OBLONG_PRECISE KS iL = KDIV(KS(1), F.L);
  C.e1 = F.e1 * iL;
  C.e2 = F.e2 * iL;
  C.w = W * iL;
  C.a0 = det3(C.e1, C.e2, C.w);
  OBLONG_PRECISE KS a1 = det3(F.f1, C.e2, C.w) + det3(C.e1, F.f2, C.w) - det3(C.e1, C.e2, F.n0);
  OBLONG_PRECISE KS a2 = det3(F.f1, F.f2, C.w) - det3(F.f1, C.e2, F.n0) - det3(C.e1, F.f2, F.n0);
  C.a1 = a1;
  C.a2 = a2;
  C.a3 = -det3(F.f1, F.f2, F.n0);
  return C;
}

// Two Newton steps on a3 x³ + a2 x² + a1 x + a0 from x, each kept only if it reduces |f|
// (near a double root f' vanishes and a step could throw x far away).
OBLONG_INLINE KS polishPolyRoot(KS a0, KS a1, KS a2, KS a3, KS x) {
  OBLONG_PRECISE KS f = ((a3 * x + a2) * x + a1) * x + a0;
  for (int k = 0; k < 2; ++k) {
    OBLONG_PRECISE KS df = (KS(3) * a3 * x + KS(2) * a2) * x + a1;
    if (!(abs(df) > KS(0))) break;
    OBLONG_PRECISE KS nx = x - KDIV(f, df);
    OBLONG_PRECISE KS nf = ((a3 * nx + a2) * nx + a1) * nx + a0;
    if (!(abs(nf) < abs(f))) break;
    x = nx;
    f = nf;
  }
  return x;
}

// Real roots of c2 x² + c1 x + c0 (c2 != 0) by the stable formula, into x[n], x[n+1];
// a slightly negative discriminant (a double root split by rounding) counts as zero.
// Returns the new count.
OBLONG_INLINE int quadRoots(KS c0, KS c1, KS c2, OBLONG_INOUT(KS) x0, OBLONG_INOUT(KS) x1) {
  OBLONG_PRECISE KS D = c1 * c1 - KS(4) * c2 * c0;
  OBLONG_PRECISE KS lim = -KS(16) * KS(K_DROP_EPS) * (c1 * c1 + abs(KS(4) * c2 * c0));
  if (D < KS(0) && D > lim) D = KS(0);
  if (!(D >= KS(0))) return 0;
  OBLONG_PRECISE KS q = KS(-0.5) * (c1 + KCOPYSIGN(KSQRT(D), c1));
  if (q == KS(0)) {  // c1 = 0 and D = 0: double root at 0
    x0 = KS(0);
    return 1;
  }
  x0 = KDIV(q, c2);
  x1 = KDIV(c0, q);
  return 2;
}

// Real roots of a3 x³ + a2 x² + a1 x + a0 (inversion/cubic.h: the degree-dropping rule,
// Cardano or the trigonometric form for the largest root, deflation, polishing, the root
// filter). Returns how many were written to x; `degree` receives the degree used.
OBLONG_INLINE int polyRoots(KS a0, KS a1, KS a2, KS a3, OBLONG_OUT_ARRAY KS x[3], OBLONG_OUT(int) degree) {
  x[0] = KS(0);
  x[1] = KS(0);
  x[2] = KS(0);
  degree = 0;
  KS M = max(max(abs(a0), abs(a1)), max(abs(a2), abs(a3)));
  if (!(M > KS(0)) || !KFINITE(M)) return 0;
  // A leading coefficient is dropped when the root it adds is beyond 1/eps: all of
  // |a_{k-1}/a_k|, |a_{k-2}/a_k|^(1/2), ... exceed 1/eps.
  OBLONG_PRECISE KS big = KDIV(KS(1), KS(K_DROP_EPS));
  OBLONG_PRECISE KS big2 = big * big;
  OBLONG_PRECISE KS big3 = big2 * big;
  bool cubic = abs(a2) < big * abs(a3) || abs(a1) < big2 * abs(a3) || abs(a0) < big3 * abs(a3);
  bool quadratic = abs(a1) < big * abs(a2) || abs(a0) < big2 * abs(a2);
  int n = 0;
  KS y0 = KS(0), y1 = KS(0), first = KS(0);
  int m = 0;
  bool solveQ = false;
  if (cubic) {
    degree = 3;
    OBLONG_PRECISE KS A = KDIV(a2, a3);
    OBLONG_PRECISE KS B = KDIV(a1, a3);
    OBLONG_PRECISE KS C = KDIV(a0, a3);
    OBLONG_PRECISE KS A3 = KDIV(A, KS(3));
    OBLONG_PRECISE KS p = B - A * A3;
    OBLONG_PRECISE KS q = KS(2) * A3 * A3 * A3 - A3 * B + C;
    OBLONG_PRECISE KS D = KDIV(q * q, KS(4)) + KDIV(p * p * p, KS(27));
    OBLONG_PRECISE KS r;
    if (D > KS(0)) {
      OBLONG_PRECISE KS w = KDIV(-q, KS(2)) - KCOPYSIGN(KSQRT(D), q);
      OBLONG_PRECISE KS t = KCBRT(w);
      OBLONG_PRECISE KS tt = t != KS(0) ? t - KDIV(p, KS(3) * t) : KS(0);
      r = tt - A3;
    } else if (p == KS(0)) {
      r = -A3;
    } else {
      OBLONG_PRECISE KS rr = KSQRT(KDIV(-p, KS(3)));
      OBLONG_PRECISE KS c = clamp(KDIV(KS(3) * q, KS(2) * p) * KSQRT(KDIV(KS(-3), p)), KS(-1), KS(1));
      OBLONG_PRECISE KS phi = KDIV(acos(c), KS(3));
      r = KS(0);
      for (int k = 0; k < 3; ++k) {
        OBLONG_PRECISE KS t = KS(2) * rr * cos(phi - KS(k) * KS(OBLONG_TWO_PI_OVER_3)) - A3;
        if (abs(t) > abs(r)) r = t;
      }
    }
    if (!KFINITE(r)) return 0;
    first = r;
  } else if (quadratic) {
    degree = 2;
    solveQ = true;
  } else if (abs(a1) > KS(K_DROP_EPS) * M) {
    degree = 1;
    first = KDIV(-a0, a1);
  }
  // The roots polished, and the quadratic solved, from one call site each (a shader
  // inlines every call): root 0 is the one found directly (the cubic's largest, or the
  // linear root), roots 1 and 2 the quadratic's (degree 2, or the cubic deflated by its
  // polished largest root).
  KS qc0 = a0, qc1 = a1, qc2 = a2;
  for (int i = 0; i < 3; ++i) {
    if (i == 1 && solveQ) m = quadRoots(qc0, qc1, qc2, y0, y1);
    if (i == 0 ? degree != 3 && degree != 1 : i > m) continue;
    x[n] = polishPolyRoot(a0, a1, a2, a3, i == 0 ? first : i == 1 ? y0 : y1);
    if (i == 0 && degree == 3) {
      KS r = x[n];
      OBLONG_PRECISE KS b2 = a2 + a3 * r;  // synthetic division from the top: a3 x² + b2 x + b1
      if (r != KS(0) && abs(r) * r * r * abs(a3) >= abs(a0)) {
        // r is the largest root: deflate from the bottom (keeps small roots accurate).
        OBLONG_PRECISE KS c1 = -(a1 + KDIV(a0, r));
        OBLONG_PRECISE KS c2 = a3 * r;
        qc0 = -a0;
        qc1 = c1;
        qc2 = c2;
      } else {
        OBLONG_PRECISE KS c0 = a1 + r * b2;
        qc0 = c0;
        qc1 = b2;
        qc2 = a3;
      }
      solveQ = true;
    }
    ++n;
  }
  // Keep finite candidates that are roots: |f| <= tol · Σ|a_k||x|^k rejects the real parts
  // of complex pairs that the near-double rule let through.
  int kept = 0;
  for (int i = 0; i < n; ++i) {
    KS xi = x[i];
    KS ax = abs(xi);
    OBLONG_PRECISE KS f = ((a3 * xi + a2) * xi + a1) * xi + a0;
    OBLONG_PRECISE KS scale = ((abs(a3) * ax + abs(a2)) * ax + abs(a1)) * ax + abs(a0);
    if (KFINITE(xi) && abs(f) <= KS(K_ROOT_TOL) * scale) x[kept++] = xi;
  }
  return kept;
}

// The barycentrics of X in the offset triangle at σ (X − q0 = u·(q1−q0) + v·(q2−q0), by
// cross products). False when that triangle is degenerate or the result is not finite.
OBLONG_INLINE bool offsetBary(OBLONG_IN(KFrame) F, OBLONG_IN(KCubic) C, KS sg, OBLONG_OUT(KS) u, OBLONG_OUT(KS) v) {
  u = KS(0);
  v = KS(0);
  OBLONG_PRECISE KS3 A = C.e1 + sg * F.f1;
  OBLONG_PRECISE KS3 B = C.e2 + sg * F.f2;
  OBLONG_PRECISE KS3 R = C.w - sg * F.n0;
  KS3 nS = KCROSS(A, B);
  KS d = KDOT(nS, nS);
  if (!(d > KS(0))) return false;
  OBLONG_PRECISE KS cu = KDIV(KDOT(KCROSS(R, B), nS), d);
  OBLONG_PRECISE KS cv = KDIV(KDOT(KCROSS(A, R), nS), d);
  if (!KFINITE(cu) || !KFINITE(cv)) return false;
  u = cu;
  v = cv;
  return true;
}

// The cubic's choice: of the roots, the one whose barycentrics are inside T or nearest to
// it; among roots inside T (a prism folded over itself), the smallest |s|. False when no
// root gives a non-degenerate offset triangle.
OBLONG_INLINE bool cubicRoot(OBLONG_IN(KFrame) F, OBLONG_IN(KS3) W, OBLONG_OUT(KS) u, OBLONG_OUT(KS) v,
                             OBLONG_OUT(KS) s, OBLONG_OUT(int) degree) {
  KCubic C = cubicOf(F, W);
  KS roots[3];
  int n = polyRoots(C.a0, C.a1, C.a2, C.a3, roots, degree);
  bool found = false;
  KS bu = KS(0), bv = KS(0), bs = KS(0), bOut = KS(0);
  for (int i = 0; i < n; ++i) {
    KS sg = roots[i];
    KS cu, cv;
    if (!offsetBary(F, C, sg, cu, cv)) continue;
    KS o = invOutside(cu, cv);
    OBLONG_PRECISE KS lo = bOut - KS(K_TIE_EPS);
    OBLONG_PRECISE KS hi = bOut + KS(K_TIE_EPS);
    bool better = !found || o < lo || (o <= hi && abs(sg) < abs(bs));
    if (better) {
      found = true;
      bu = cu;
      bv = cv;
      bs = sg;
      bOut = o;
    }
  }
  u = bu;
  v = bv;
  OBLONG_PRECISE KS sL = bs * F.L;
  s = sL;
  return found;
}

// The cubic inverter: the chosen root, then `polish` Newton steps on F.
OBLONG_INLINE KResult cubicSolve(OBLONG_IN(KFrame) F, OBLONG_IN(KS3) X, int polish, OBLONG_OUT(int) degree) {
  OBLONG_PRECISE KS3 W = X - F.p0;
  KS u, v, s;
  if (!cubicRoot(F, W, u, v, s, degree)) return invFinish(F, KDIV(KS(1), KS(3)), KDIV(KS(1), KS(3)), KS(0), false, 0);
  int it = 0;
  for (; it < polish; ++it) {
    KS du, dv, ds;
    if (!newtonStep(F, W, u, v, s, du, dv, ds)) break;
  }
  return invFinish(F, u, v, s, true, it);
}

// ---- Newton (inversion/newton.h) ---------------------------------------------------------

// Newton from the centroid (1/3, 1/3, 0), at most maxIt steps; with `fallback`, a result
// not converged (unless tol = 0: a fixed step count), not finite, or outside T by more than
// K_OUTSIDE_EPS is replaced by the cubic's root and `polish` steps (fellBack set,
// iterations = Newton's steps plus the polish steps). One Newton-step site for both
// passes: the shaders inline every call.
OBLONG_INLINE KResult newtonSolve(OBLONG_IN(KFrame) F, OBLONG_IN(KS3) X, KS tol, int maxIt, bool fallback, int polish,
                                  OBLONG_OUT(bool) fellBack) {
  fellBack = false;
  OBLONG_PRECISE KS3 W = X - F.p0;
  KS u = KDIV(KS(1), KS(3)), v = KDIV(KS(1), KS(3)), s = KS(0);
  bool conv = false;
  int it = 0, newtonIt = 0;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      KResult r = invFinish(F, u, v, s, conv, it);
      bool bad = (!r.converged && tol > KS(0)) || !KFINITE(u) || !KFINITE(v) ||
                 !(invOutside(u, v) <= KS(K_OUTSIDE_EPS));
      if (!fallback || !bad) return r;
      fellBack = true;
      newtonIt = it;
      it = 0;
      int degree;
      if (!cubicRoot(F, W, u, v, s, degree)) return invFinish(F, KDIV(KS(1), KS(3)), KDIV(KS(1), KS(3)), KS(0), false, newtonIt);
      conv = true;
    }
    int steps = pass == 0 ? maxIt : polish;
    for (int k = 0; k < steps; ++k) {
      KS du, dv, ds;
      if (!newtonStep(F, W, u, v, s, du, dv, ds)) break;
      ++it;
      if (pass == 0 && newtonConverged(F, du, dv, ds, s, tol)) {
        conv = true;
        break;
      }
    }
  }
  return invFinish(F, u, v, s, conv, newtonIt + it);
}

#undef KS
#undef KDIV
#undef KSQRT
#undef KS3
#undef KFrame
#undef KCubic
#undef KResult
#undef KDOT
#undef KCROSS
#undef KLENGTH
#undef KFINITE
#undef KCOPYSIGN
#undef KCBRT
#undef K_DROP_EPS
#undef K_ROOT_TOL
#undef K_TIE_EPS
#undef K_OUTSIDE_EPS
