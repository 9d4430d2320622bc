// The driver of the RMIP traversal: its state and its loop (core/kernels/ray_patch.h says
// what it does, where this is included and which hooks the includer supplies). No include
// guard and no namespace: in C++ this is the body of shared::RayPatchLoop, in GLSL the
// global scope of the intersection shader.
//
// The `g_` variables are the state of one ray against one triangle: C++ members, GLSL
// globals. Each large step has one call site (the cells to test come from one generator,
// nextCell, tested at one place in rpLoop; every claim near a known point and every
// inversion is made in pieceEnd's one loop; every box is tested at one place in rpLoop):
// GLSL inlines every call, and the inlined size is what the shader compiler pays for.

// ---- the state ------------------------------------------------------------------------
// Set by the includer before rpInit: the triangle's constants. An includer that defines
// OBLONG_RP_TRIANGLE_RECORD names them itself instead, as macros that read its record
// where they are used: the shader does, so that they are loads inside the loop rather
// than held live across it (docs/vulkan.md, "Live state").
#ifndef OBLONG_RP_TRIANGLE_RECORD
PatchFrame g_F;        // the triangle's frame (core/kernels/patch_math.h)
dvec3 g_N13;           // its normal at the centroid, frameN(g_F, (1/3, 1/3))
ClaimBounds g_claim;   // its bounds on the claims' errors
bool g_wellPosed;      // the shell analysis vouches for the curve machinery
ivec2 g_cellLo, g_cellHi;  // the triangle's cells, local sample coordinates
dvec2 g_sbLo, g_sbHi;      // the triangle's uv box, local sample coordinates
ivec2 g_origin;            // the absolute sample index of local (0, 0)
#endif
// Set by the includer before rpInit: the ray.
float g_tmin, g_tmax;  // the ray's [tmin, tmax] (float, as Ray)
dvec3 g_O, g_D, g_invD;
dvec3 g_boxLo, g_boxHi;  // the exact prism's world box, padded (box-only subdivision)
BoxRayF g_bray;           // the ray in T's float box frame (rect_bounds.h)
vec3 g_texLo, g_texHi;    // the exact prism's box in that frame, padded, rounded outward
float g_marchingScale;
int g_stackDepth;              // entries used of the stack
bool g_inversionInTraversal;   // Fig. 5a
// Set by rpInit.
double g_boxPad, g_tAbs;  // the ray's pad of the per-step boxes; slack for float t
double g_texPad;          // g_boxPad in the texture frame
float g_texPadF;          // g_texPad rounded up: the float boxes' pad
dvec2 g_eps;              // ε: cells within it of the curve are marched
vec2 g_epsF;              // ε rounded up (the pieces' float rectangles)
bool g_wideEps;           // ε wide against the marching scale: leaves are boxes
double g_leafScale;       // pieces up to this many texels are leaves
Psi g_psi;                // the ray's implicit curve in texture space (Eq. 3)
ClaimAnchor g_anchor;     // the ray in T's frame for the float claims (setupCurve)
dvec2 g_dvd;              // approximate curve direction (front-to-back order)
// The work done (RayCounters).
int g_boxes, g_rangeQueries, g_inversions, g_cells, g_microTris;
bool g_boxOnly;
// The stack.
RpEntry g_st[OBLONG_RP_STACK];
int g_sp;

// The per-ray margins, from the ray's own (m: rayMargin at the ray's origin magnitude
// maxO) and the triangle's magnitudes (maxP: its largest vertex coordinate; [a, b]: its
// heights), and the ray's direction length lenD; resets the work counters.
void rpInit(OBLONG_IN(RayMargin) m, double maxP, double maxO, double a, double b, OBLONG_IN(dvec2) eps,
            OBLONG_IN(dvec2) kxy, double lenD) {
  g_boxPad = m.boxPad;
  g_tAbs = tSlackAbs(g_boxPad, lenD);
  g_texPad = texPiecePad(g_boxPad, maxO, maxP, a, b);
  g_texPadF = floatAbove(g_texPad, g_texPad);
  OBLONG_PRECISE dvec2 e = eps + kxy * (double(OBLONG_TRAV_RAY_ERR_FACTOR) * m.rayErr);
  g_eps = e;
  g_epsF = vec2(floatAbove(e.x, e.x), floatAbove(e.y, e.y));
  double maxDil = max(g_eps.x, g_eps.y);
  g_wideEps = maxDil > OBLONG_TRAV_WIDE_EPS_REL * double(g_marchingScale);
  g_leafScale = g_wideEps ? max(double(g_marchingScale), OBLONG_TRAV_WIDE_LEAF_EPS * maxDil) : double(g_marchingScale);
  g_dvd = dvec2(1.0);
  g_anchor.tA = 0.0;  // set by setupCurve; until then every claim is refused
  g_anchor.XA = vec3(0.0f);
  g_anchor.Df = vec3(0.0f);
  g_anchor.XAerr = kInfF;
  g_anchor.kE = vec2(0.0f);
  g_anchor.kN = vec3(0.0f);
  g_anchor.kD = 0.0f;
  g_anchor.k0 = kInfF;
  g_boxes = 0;
  g_rangeQueries = 0;
  g_inversions = 0;
  g_cells = 0;
  g_microTris = 0;
  g_boxOnly = false;
  g_sp = 0;
}

// ---- small steps -------------------------------------------------------------------------
double slack(double t) { return OBLONG_TRAV_SLACK_REL * abs(t) + g_tAbs; }
// The far end of what is left to search: the closest hit's t, else tmax, with its slack.
double limitNow() {
  double t = OBLONG_HOOK(rpHitFound)() ? double(OBLONG_HOOK(rpHitT)()) : double(g_tmax);
  return t + slack(t);
}
// The same, kept in g_limit where the hit can change (rpRun's start, after a cell's
// micro-triangles), read at every other place that needs it; g_tLo and g_tHi: the ray's
// [tmin, tmax] with their slack (rpRun).
double g_limit, g_tLo, g_tHi;
double bestLimit() { return g_limit; }
dvec2 dirLocal() { return approxDirLocal(g_F, g_N13, g_D); }

// A point to be made: its t, a uv to start from and how to make it (pad.x, negative,
// which a made point's pad never is: OBLONG_RP_PENDING_*).
bool pending(OBLONG_IN(CurvePoint) p) { return p.pad.x < 0.0; }
CurvePoint pendingPoint(double t, OBLONG_IN(dvec2) g, double how) {
  CurvePoint p;
  p.t = t;
  p.uv = vec2(g);
  p.pad = vec2(float(how), 0.0f);
  return p;
}

// Prism coordinates (b, s) for the curve point p.t, made as its pad.x says (a pending
// point): by the inverter (invert); at prism coordinates already known (a crossing of the
// prism, or a turning point's candidate on ψ = 0: b = p.uv, s = p.pad.y); or claimed
// without inversion from uv p.uv near the point (on the chord between two curve points,
// chordUv; at the closest hit): s by least squares and one Newton step in float
// (newtonClaim). Either way makePoint's residual bounds the point's error.
bool coordsAt(OBLONG_IN(CurvePoint) p, bool invert, OBLONG_IN(FrameF) R, OBLONG_OUT(vec2) b, OBLONG_OUT(float) s) {
  b = p.uv;
  s = p.pad.y;
  if (!invert && (p.pad.x == OBLONG_RP_PENDING_CROSSING || p.pad.x == OBLONG_RP_PENDING_TURN)) return true;
  if (!invert) {  // from uv's barycentrics (a starting point: float is enough)
    OBLONG_PRECISE vec2 bc = vec2(g_F.bc) + vec2(g_F.bX) * p.uv.x + vec2(g_F.bY) * p.uv.y;
    return newtonClaim(R, g_anchor, p.t, bc, b, s);
  }
  ++g_inversions;
  OBLONG_PRECISE dvec3 X = g_O + p.t * g_D;
  vec2 bary;
  float h;
  OBLONG_HOOK(rpInvert)(vec3(X), bary, h);
  b = bary;
  double nl = lengthD(frameN(g_F, dvec2(b)));
  if (!(nl > 0.0) || !finiteF(h)) return false;
  s = float(double(h) / nl);
  return true;
}

// The curve point for pending point p (OBLONG_RP_PENDING_*): a claim first where p says
// so (near uv when PENDING_CLAIM and at a turning point's prism coordinates, each kept
// only when its pad is at most OBLONG_TRAV_CLAIM_PAD; at the closest hit whatever its pad;
// at a crossing's prism coordinates), else or then by inversion (never for the hit's and
// the crossings' claims). The one call site of the claim's residual (makePoint) and of
// the inverter: pieceEnd's loop.
bool curvePointAt(OBLONG_IN(CurvePoint) p, OBLONG_OUT(CurvePoint) outp) {
  double how = p.pad.x;
  bool claim = how == OBLONG_RP_PENDING_CLAIM || how == OBLONG_RP_PENDING_HIT || how == OBLONG_RP_PENDING_CROSSING ||
               how == OBLONG_RP_PENDING_TURN;
  bool invert = how != OBLONG_RP_PENDING_HIT && how != OBLONG_RP_PENDING_CROSSING;
  outp.t = p.t;
  outp.uv = vec2(0.0f);
  outp.pad = vec2(0.0f);
  FrameF R = frameF(g_F);  // the frame's float copy, for the claim and its residual
  for (int at = claim ? 0 : 1; at < (invert ? 2 : 1); ++at) {
    vec2 b;
    float s;
    if (coordsAt(p, at == 1, R, b, s) && makePoint(g_F, R, g_claim, g_anchor, p.t, b, s, outp) &&
        (at == 1 || (how != OBLONG_RP_PENDING_CLAIM && how != OBLONG_RP_PENDING_TURN) ||
         double(outp.pad.x) + double(outp.pad.y) <= OBLONG_TRAV_CLAIM_PAD))
      return true;
  }
  if (invert) OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_BAD_INVERSION);
  return false;
}

// The curve point at t by inversion (the CPU's SplitContext::pointAt).
bool invertAt(double t, OBLONG_OUT(CurvePoint) outp) {
  return curvePointAt(pendingPoint(t, dvec2(0.0), OBLONG_RP_PENDING_INVERT), outp);
}

// The curve's crossing of {axis = c} strictly between the piece's ends (closed form on
// ψ, paper Eq. 3-4; the splitters' SplitContext::crossing), to be claimed at its prism
// coordinates: the one root of ψ on the line within the piece's padded rectangle whose ray
// parameter lies between the ends' (the piece is monotone: it crosses the line once).
// False unless exactly one root qualifies.
bool crossingOn(OBLONG_IN(CurvePoint) pa, OBLONG_IN(CurvePoint) pb, int axis, double c, OBLONG_OUT(CurvePoint) outp) {
  outp = pa;
  double q2, q1, q0, w[2], rp[2];
  psiOnLine(g_psi, axis, c, q2, q1, q0);
  int n = quadraticRoots(q2, q1, q0, w, rp);
  if (n <= 0) return false;
  int mi = 1 - axis;
  dvec2 lo = dvec2(pieceLo(pa, pb)), hi = dvec2(pieceHi(pa, pb));
  int found = 0;
  for (int k = 0; k < n; ++k) {
    if (w[k] < lo[mi] - rp[k] || w[k] > hi[mi] + rp[k]) continue;
    dvec2 uv = axis == 0 ? dvec2(c, w[k]) : dvec2(w[k], c);
    double t, s;
    if (!rayParamAt(g_F, g_O, g_D, uv, t, s)) continue;
    if (!(t > pa.t && t < pb.t)) continue;
    outp = pendingPoint(t, frameBary(g_F, uv), OBLONG_RP_PENDING_CROSSING);
    outp.pad.y = float(s);
    ++found;
  }
  return found == 1;
}
// That crossing made (the CPU's SplitContext::crossing; the shader's splitter leaves it
// pending for pieceEnd's loop).
bool crossingAt(OBLONG_IN(CurvePoint) pa, OBLONG_IN(CurvePoint) pb, int axis, double c, OBLONG_OUT(CurvePoint) outp) {
  CurvePoint p;
  outp = pa;
  return crossingOn(pa, pb, axis, c, p) && curvePointAt(p, outp);
}

// ---- boxes ---------------------------------------------------------------------------------
// The ray interval [t0, t1] (clipped in place) through the box of the micro-geometry over
// local cells [clo, chi] with heights h, in T's float box frame. False when empty.
bool clipToBox(OBLONG_IN(ivec2) clo, OBLONG_IN(ivec2) chi, OBLONG_IN(vec2) h, OBLONG_INOUT(double) t0,
               OBLONG_INOUT(double) t1) {
  vec2 lo = vec2(max(dvec2(clo), g_sbLo)), hi = vec2(min(dvec2(chi + 1), g_sbHi));
  vec3 blo, bhi;
  OBLONG_HOOK(rpBoxOverRect)(lo, hi, h, blo, bhi);
  blo = max(blo, g_texLo);
  bhi = min(bhi, g_texHi);
  if (blo.x > bhi.x || blo.y > bhi.y || blo.z > bhi.z) return false;
  clipBoxF(blo, bhi, g_bray, t0, t1);
  return t0 <= t1;
}
// Every box of the traversal (a piece's, a box range's, a marched cell's) is tested at one
// place, rpLoop's box step: its heights come from the range query over the cells, or for
// one marched cell from its four corner samples (TFDM's leaf test: they bound every
// micro-vertex of the cell, docs/design.md invariant 2).

// ---- the stack -----------------------------------------------------------------------------
void pushPiece(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b) {
  g_st[g_sp].a = a;
  g_st[g_sp].b = b;
  ++g_sp;
}
void pushBox(OBLONG_IN(ivec2) lo, OBLONG_IN(ivec2) hi, double ta, double tb) {
  g_st[g_sp].a.t = ta;
  g_st[g_sp].a.uv = vec2(lo);
  g_st[g_sp].a.pad = vec2(float(OBLONG_RP_BOX_ENTRY), 0.0f);
  g_st[g_sp].b.t = tb;
  g_st[g_sp].b.uv = vec2(hi);
  g_st[g_sp].b.pad = vec2(0.0f);
  ++g_sp;
}
bool isBox(OBLONG_IN(RpEntry) e) { return e.a.pad.x == OBLONG_RP_BOX_ENTRY; }

// Local cells touching [lo, hi] (a float rectangle dilated by ε in float: lo − ε and
// hi + ε are off by at most 2^-24 of their magnitude, and lo − η by as much again, so the
// allowance η = 2^-22·(1 + |lo| + |hi|) keeps every cell), clipped to T's cells. False
// when empty.
bool snapCells(OBLONG_IN(vec2) lo, OBLONG_IN(vec2) hi, OBLONG_OUT(ivec2) clo, OBLONG_OUT(ivec2) chi) {
  float lim = float(OBLONG_TRAV_SNAP_LIMIT);
  for (int k = 0; k < 2; ++k) {
    OBLONG_PRECISE float eta = float(OBLONG_U2M22) * (1.0f + abs(lo[k]) + abs(hi[k]));
    OBLONG_PRECISE float l = lo[k] - eta, h = hi[k] + eta;
    clo[k] = int(clamp(floor(l), -lim, lim));
    chi[k] = int(clamp(floor(h), -lim, lim));
  }
  clo = max(clo, g_cellLo);
  chi = min(chi, g_cellHi);
  return clo.x <= chi.x && clo.y <= chi.y;
}

// ---- the cells to test: one generator ----------------------------------------------------
// Mode 1: a cell range, front to back along the approximate direction; mode 2: texel
// marching of a piece (§4.4) by a walk over the cells it may cross, column by column along
// its major axis.
int g_gen;
ivec2 g_gLo, g_gHi;
int g_gi, g_gj, g_gsx, g_gsy;
CurvePoint g_ma, g_mb;
int g_mAx, g_mSa, g_mSm, g_mK, g_mJ, g_mJ0, g_mJ1;
bool g_mCol;
// The walk: a cell is reached when the interval test (mayCross) says the piece may cross
// it dilated by ε, and it is in its column's seeds — the rows reached in the column
// before (g_mPLo..g_mPHi), the rows of the start block (the cells within ε of the first
// end's pad box, g_mSLo..g_mSHi) in its columns, or every row where the piece's direction
// is uncertain (g_mAll) — or right after a reached row (g_mRun). The piece is monotone, so
// every cell it crosses is reached from the start block by steps along its major and minor
// directions through cells it crosses; other branches of ψ = 0 only add cells. The walk
// runs over the piece's rectangle unclamped (g_mRLo..g_mRHi: a piece may start outside T's
// cells) and returns the cells within T's (g_gLo..g_gHi). The test is float (mayCross):
// ψ re-centred at the rectangle's low cell g_mA (g_mQ1: ψ and its gradient there; g_mQ2:
// its second-order coefficients), the rectangle and the dilation ε + η relative to it
// rounded outward (g_mRectLo, g_mRectHi, g_mDil), ψ's error over the rectangle in
// absolute coordinates rounded up (g_mErr); the cells within ε + η of an end's pad box
// (g_mSLo..g_mSHi, g_mELo..g_mEHi) are crossed; where the float form cannot hold (ψ not
// finite, a rectangle past float's integers) every cell is (g_mAny).
ivec2 g_mRLo, g_mRHi, g_mSLo, g_mSHi, g_mELo, g_mEHi, g_mA;
int g_mPLo, g_mPHi, g_mCLo, g_mCHi;
bool g_mAll, g_mRun, g_mAny;
vec3 g_mQ1, g_mQ2;
vec2 g_mRectLo, g_mRectHi, g_mDil;
float g_mErr;
// The march's stop: once a hit is known, cells past the curve's point at the best hit's
// limit t* cannot hold a better one (the piece is monotone, so its points before t* lie on
// this side of that point's padded coordinates, and every hit lies within ε of its cell).
// Per axis, only where the piece's direction along it is certain.
bool g_mStopSet;
bvec2 g_mCertain, g_mStopAxis;
dvec2 g_mStop;

void startCells(OBLONG_IN(ivec2) clo, OBLONG_IN(ivec2) chi) {
  g_gen = 1;
  g_gLo = clo;
  g_gHi = chi;
  g_gsx = g_dvd.x >= 0.0 ? 1 : -1;
  g_gsy = g_dvd.y >= 0.0 ? 1 : -1;
  g_gi = g_gsx > 0 ? clo.x : chi.x;
  g_gj = g_gsy > 0 ? clo.y : chi.y;
  OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_LEAF);
}

void startMarch(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b) {
  OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_LEAF);
  OBLONG_PRECISE dvec2 d = dvec2(b.uv) - dvec2(a.uv);
  int ax = abs(d.x) >= abs(d.y) ? 0 : 1, mi = 1 - ax;
  dvec2 lo = dvec2(pieceLo(a, b)), hi = dvec2(pieceHi(a, b));
  // Snapped to cells per axis, from one site (snapCells' rounding allowance, unclamped): the piece's
  // rectangle dilated by ε (q = 0: g_mRLo..g_mRHi), the start and the end block (q = 1, 2:
  // an end's pad box dilated by dil, ε and the allowance over the rectangle).
  dvec2 dil;
  double lim = OBLONG_TRAV_SNAP_LIMIT;
  for (int k = 0; k < 2; ++k) {
    OBLONG_PRECISE double m = max(abs(lo[k] - g_eps[k]), abs(hi[k] + g_eps[k]));
    OBLONG_PRECISE double e = g_eps[k] + 2.0 * OBLONG_TRAV_SNAP_ETA * (2.0 + 2.0 * m);
    dil[k] = e;
    for (int q = 0; q < 3; ++q) {
      CurvePoint p = q == 1 ? a : b;
      OBLONG_PRECISE double l = q == 0 ? lo[k] - g_eps[k] : double(p.uv[k]) - double(p.pad[k]) - dil[k];
      OBLONG_PRECISE double h = q == 0 ? hi[k] + g_eps[k] : double(p.uv[k]) + double(p.pad[k]) + dil[k];
      OBLONG_PRECISE double eta = OBLONG_TRAV_SNAP_ETA * (1.0 + abs(l) + abs(h));
      int c0 = int(clamp(floor(l - eta), -lim, lim)), c1 = int(clamp(floor(h + eta), -lim, lim));
      if (q == 0) {
        g_mRLo[k] = c0;
        g_mRHi[k] = c1;
      } else if (q == 1) {
        g_mSLo[k] = c0;
        g_mSHi[k] = c1;
      } else {
        g_mELo[k] = c0;
        g_mEHi[k] = c1;
      }
    }
  }
  // The blocks within the rectangle (their larger allowance may reach a cell beyond it,
  // which no point of the piece is within ε of).
  g_mSLo = max(g_mSLo, g_mRLo);
  g_mSHi = min(g_mSHi, g_mRHi);
  g_mELo = max(g_mELo, g_mRLo);
  g_mEHi = min(g_mEHi, g_mRHi);
  ivec2 clo = max(g_mRLo, g_cellLo), chi = min(g_mRHi, g_cellHi);  // snapCells' cells
  if (!(clo.x <= chi.x && clo.y <= chi.y)) return;
  g_gen = 2;
  g_ma = a;
  g_mb = b;
  g_mAx = ax;
  g_gLo = clo;
  g_gHi = chi;
  g_mSa = d[ax] >= 0.0 ? 1 : -1;
  g_mSm = d[mi] >= 0.0 ? 1 : -1;
  for (int k = 0; k < 2; ++k) g_mCertain[k] = abs(d[k]) > double(a.pad[k]) + double(b.pad[k]);
  g_mAll = !g_mCertain.x || !g_mCertain.y;
  // ψ re-centred at A (exact algebra; the double rounding is far inside g_mErr's margin)
  // and rounded to float; its error over the rectangle: OBLONG_TRAV_PSI_ERR of its terms'
  // magnitude at the rectangle's largest absolute coordinates.
  g_mA = g_mRLo;
  dvec2 A = dvec2(g_mA);
  double q0 = psiEval(g_psi, A);
  dvec2 qg = psiGrad(g_psi, A);
  g_mQ1 = vec3(float(q0), float(qg.x), float(qg.y));
  g_mQ2 = vec3(float(g_psi.cXX), float(g_psi.cXY), float(g_psi.cYY));
  OBLONG_PRECISE dvec2 M = max(abs(dvec2(g_mRLo) - 1.0), abs(dvec2(g_mRHi) + 2.0));
  OBLONG_PRECISE double mag = abs(g_psi.c0) + abs(g_psi.cX) * M.x + abs(g_psi.cY) * M.y + abs(g_psi.cXX) * M.x * M.x +
                              abs(g_psi.cXY) * M.x * M.y + abs(g_psi.cYY) * M.y * M.y;
  g_mErr = floatAbove(OBLONG_TRAV_PSI_ERR * mag, mag);
  for (int k = 0; k < 2; ++k) {
    g_mRectLo[k] = floatBelow(lo[k] - A[k], abs(lo[k]) + abs(A[k]));
    g_mRectHi[k] = floatAbove(hi[k] - A[k], abs(hi[k]) + abs(A[k]));
    g_mDil[k] = floatAbove(dil[k], dil[k]);
  }
  g_mAny = !(finiteF(g_mQ1.x) && finiteF(g_mQ1.y) && finiteF(g_mQ1.z) && finiteF(g_mQ2.x) && finiteF(g_mQ2.y) &&
             finiteF(g_mQ2.z) && finiteF(g_mErr) && max(g_mRHi.x - g_mRLo.x, g_mRHi.y - g_mRLo.y) < 1000000);
  g_mK = g_mAll ? (g_mSa > 0 ? g_mRLo[ax] : g_mRHi[ax]) : (g_mSa > 0 ? g_mSLo[ax] : g_mSHi[ax]);
  g_mPLo = 1;  // no row reached yet
  g_mPHi = 0;
  g_mCol = false;
  g_mStopSet = !g_mCertain.x && !g_mCertain.y;
  g_mStopAxis = bvec2(false, false);
  g_mStop = dvec2(0.0);
}

// The stop's point, the curve point at the best hit's limit t* (g_mStopT), is claimed
// from the closest hit in pieceEnd's loop (OBLONG_RP_PENDING_HIT), not inverted: the hit's
// texture position gives T's barycentrics, from which one Newton step in double claims
// (b, s) (newtonClaim: the hit lies on a flat micro-triangle, off the displacement line
// through its barycentrics by the micro-surface's bulge); makePoint's residual bounds
// the error as for any claim. Where it refuses the claim the march runs on without a stop
// (a saving only, so no inversion is spent on it: none was needed on the shipped and
// paper scenes once the hit's claim took its Newton step). stopAt sets the stop from it.
double g_mStopT;
void stopAt(OBLONG_IN(CurvePoint) m) {
  for (int k = 0; k < 2; ++k)
    if (g_mCertain[k]) {
      OBLONG_PRECISE double margin = double(m.pad[k]) + double(g_ma.pad[k]) + double(g_mb.pad[k]);
      int sg = k == g_mAx ? g_mSa : g_mSm;
      OBLONG_PRECISE double stop = sg > 0 ? double(m.uv[k]) + margin : double(m.uv[k]) - margin;
      g_mStop[k] = stop;
      g_mStopAxis[k] = true;
    }
}
bool pastStop(int a, int k) {
  int sg = a == g_mAx ? g_mSa : g_mSm;
  return g_mStopAxis[a] && (sg > 0 ? double(k) - g_eps[a] > g_mStop[a] : double(k + 1) + g_eps[a] < g_mStop[a]);
}

// The interval test of the walk, in float: may the piece cross cell (k, j) (major, minor)
// dilated by ε + η? It is within that of an end's pad box, or ψ may vanish on the dilated
// cell clipped to the piece's rectangle: |ψ| at the box's centre against ψ's variation
// over it (gradient and second-order terms: exact for a quadratic) plus ψ's error — its
// coefficients' (g_mErr) and the float evaluation's: the coefficients' rounding to float
// (2^-24 each), ψ's dozen roundings, the gradient's in the variation and the variation's
// own come to at most about 2.6·2^-20 of the terms' magnitude over the box; 2^-17 of it.
// The box's half-size is widened by 2^-21 of its coordinates, more than the rounding of
// its sides, centre and size.
bool mayCross(int k, int j) {
  ivec2 c = g_mAx == 0 ? ivec2(k, j) : ivec2(j, k);
  if (g_mAny || (c.x >= g_mSLo.x && c.x <= g_mSHi.x && c.y >= g_mSLo.y && c.y <= g_mSHi.y) ||
      (c.x >= g_mELo.x && c.x <= g_mEHi.x && c.y >= g_mELo.y && c.y <= g_mEHi.y))
    return true;
  vec2 p = vec2(c - g_mA);  // exact: the rectangle spans less than 2^24 cells
  OBLONG_PRECISE vec2 lo = max(p - g_mDil, g_mRectLo), hi = min(p + 1.0f + g_mDil, g_mRectHi);
  if (!(lo.x <= hi.x && lo.y <= hi.y)) return false;
  OBLONG_PRECISE vec2 m = 0.5f * (lo + hi);
  OBLONG_PRECISE vec2 r = 0.5f * (hi - lo) + float(OBLONG_U2M21) * (abs(lo) + abs(hi));
  vec3 Q = g_mQ2;
  OBLONG_PRECISE float v = g_mQ1.x + m.x * (g_mQ1.y + Q.x * m.x + Q.y * m.y) + m.y * (g_mQ1.z + Q.z * m.y);
  OBLONG_PRECISE float gx = g_mQ1.y + 2.0f * Q.x * m.x + Q.y * m.y, gy = g_mQ1.z + Q.y * m.x + 2.0f * Q.z * m.y;
  OBLONG_PRECISE float var = abs(gx) * r.x + abs(gy) * r.y + abs(Q.x) * r.x * r.x + abs(Q.y) * r.x * r.y +
                             abs(Q.z) * r.y * r.y;
  OBLONG_PRECISE vec2 M = abs(m) + r;
  OBLONG_PRECISE float mag = abs(g_mQ1.x) + abs(g_mQ1.y) * M.x + abs(g_mQ1.z) * M.y + abs(Q.x) * M.x * M.x +
                             abs(Q.y) * M.x * M.y + abs(Q.z) * M.y * M.y;
  OBLONG_PRECISE float bound = var + float(OBLONG_U2M17) * (var + mag) + g_mErr;
  return abs(v) <= bound;
}

// The next cell of the current generator: 1 a cell, 2 the march's stop point is wanted
// first (at g_mStopT), 0 the generator is exhausted.
int nextCell(OBLONG_OUT(int) ci, OBLONG_OUT(int) cj) {
  ci = 0;
  cj = 0;
  if (g_gen == 1) {
    if (g_gsy > 0 ? g_gj > g_gHi.y : g_gj < g_gLo.y) return 0;
    ci = g_gi;
    cj = g_gj;
    g_gi += g_gsx;
    if (g_gsx > 0 ? g_gi > g_gHi.x : g_gi < g_gLo.x) {
      g_gi = g_gsx > 0 ? g_gLo.x : g_gHi.x;
      g_gj += g_gsy;
    }
    return 1;
  }
  int ax = g_mAx, mi = 1 - ax;
  for (;;) {
    if (!g_mCol && (g_mSa > 0 ? g_mK > g_mRHi[ax] : g_mK < g_mRLo[ax])) return 0;
    // The first hit found bounds the march: no cell past t* can hold a better hit.
    if (!g_mStopSet && OBLONG_HOOK(rpHitFound)()) {
      g_mStopSet = true;
      g_mStopT = bestLimit();
      if (g_mStopT <= g_ma.t) {
        OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_MARCH_STOP);
        return 0;
      }
      if (g_mStopT < g_mb.t) return 2;
    }
    if (!g_mCol) {
      if (pastStop(ax, g_mK)) {
        OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_MARCH_STOP);
        return 0;
      }
      // The column's seeds; none: no cell of the piece is left.
      int lo = g_mPLo, hi = g_mPHi;
      if (g_mK >= g_mSLo[ax] && g_mK <= g_mSHi[ax]) {
        bool none = lo > hi;
        lo = none ? g_mSLo[mi] : min(lo, g_mSLo[mi]);
        hi = none ? g_mSHi[mi] : max(hi, g_mSHi[mi]);
      }
      if (g_mAll) {
        lo = g_mRLo[mi];
        hi = g_mRHi[mi];
      }
      if (lo > hi) return 0;
      g_mJ0 = lo;
      g_mJ1 = hi;
      g_mJ = g_mSm > 0 ? lo : hi;
      g_mRun = false;
      g_mCLo = 1;
      g_mCHi = 0;
      g_mCol = true;
    }
    // The column goes on within its seeds, or right after a reached row, up to the stop.
    bool end = g_mJ < g_mRLo[mi] || g_mJ > g_mRHi[mi] || !(g_mRun || (g_mJ >= g_mJ0 && g_mJ <= g_mJ1));
    bool stop = !end && pastStop(mi, g_mJ);
    if (stop) OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_MARCH_STOP);
    if (end || stop) {
      g_mPLo = g_mCLo;
      g_mPHi = g_mCHi;
      g_mCol = false;
      g_mK += g_mSa;
      continue;
    }
    int j = g_mJ;
    g_mJ += g_mSm;
    g_mRun = mayCross(g_mK, j);
    if (!g_mRun) continue;
    bool first = g_mCLo > g_mCHi;
    g_mCLo = first ? j : min(g_mCLo, j);
    g_mCHi = first ? j : max(g_mCHi, j);
    ci = ax == 0 ? g_mK : j;
    cj = ax == 0 ? j : g_mK;
    if (ci < g_gLo.x || ci > g_gHi.x || cj < g_gLo.y || cj > g_gHi.y) continue;  // outside T's cells
    return 1;
  }
  return 0;
}

// ---- pieces and boxes ----------------------------------------------------------------------
// Pads that dominate the rectangle cannot be split away: such a piece is a leaf too.
bool pieceSmall(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b) {
  OBLONG_PRECISE vec2 ext = pieceHi(a, b) - pieceLo(a, b);
  OBLONG_PRECISE vec2 pads = a.pad + b.pad;
  int la = ext.x >= ext.y ? 0 : 1;
  return double(ext[la]) <= g_leafScale || pads[la] > float(OBLONG_TRAV_PAD_DOMINANCE) * ext[la];
}

// A piece too small to split is marched (pieceEnd), unless ε (float rounding at a
// fine texel) is wide against the marching scale; then its cells are subdivided as boxes,
// down to blocks of OBLONG_TRAV_WIDE_BOX_CELLS, which prune across the curve where the
// march would test every cell within ε of it.
void wideLeaf(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b) {
  OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_WIDE_LEAF);
  ivec2 clo, chi;
  if (!snapCells(pieceLo(a, b) - g_epsF, pieceHi(a, b) + g_epsF, clo, chi)) return;
  pushBox(clo, chi, a.t, min(b.t, bestLimit()));
}

// A piece popped from the stack, before its box: 0 = nothing to do; 1 = box-test cells
// [clo, chi] over [t0, t1] first (rpLoop), then pieceEnd; 2 = pieceEnd without a box.
// leaf: 1 when the piece is too small to split.
int pieceBegin(OBLONG_IN(CurvePoint) a, OBLONG_IN(CurvePoint) b, OBLONG_OUT(ivec2) clo, OBLONG_OUT(ivec2) chi,
               OBLONG_OUT(double) t0, OBLONG_OUT(double) t1, OBLONG_OUT(int) leaf) {
  clo = ivec2(0);
  chi = ivec2(0);
  t0 = a.t;
  t1 = b.t;
  leaf = 0;
  if (a.t > bestLimit()) return 0;
  // An end setupCurve left pending is made first, in pieceEnd's loop, and the piece goes
  // back on the stack: that loop is the one call site of the claim and of the inverter.
  if (pending(a) || pending(b)) return 2;
  if (pieceSmall(a, b)) leaf = 1;
  if (!snapCells(pieceLo(a, b) - g_epsF, pieceHi(a, b) + g_epsF, clo, chi)) return 0;
  // A marched leaf of two cells or more is box-tested first: a missed box skips it.
  if (leaf == 0 || (!g_wideEps && (clo.x != chi.x || clo.y != chi.y))) {
    t1 = min(b.t, bestLimit());
    return 1;
  }
  return 2;
}

// The rest of a piece after pieceBegin (and its box, which clipped [t0, t1]).
// leaf = 3: no piece, the march's stop point (nextCell), made at the same call site.
void pieceEnd(CurvePoint a, CurvePoint b, ivec2 clo, ivec2 chi, double t0, double t1, int leaf) {
  bool stop = leaf == 3;
  bool pendA = !stop && pending(a), pendB = !stop && pending(b), pend = pendA || pendB;
  OBLONG_PRECISE double minGain = 0.0;
  // leaf, when not split: 1 = too small to split, 2 = marched at a stack overflow (set
  // below; one call site of the march).
  if (stop) leaf = 0;
  if (!pend && !stop && leaf == 0) {
    // The clipped ends are worth a new point (Fig. 5a: their projections can give a much
    // smaller rectangle) when they gain this much.
    OBLONG_PRECISE vec2 gainExt = pieceHi(a, b) - pieceLo(a, b);
    OBLONG_PRECISE double gainDt = b.t - a.t;
    minGain = max(OBLONG_TRAV_MIN_GAIN * gainDt, OBLONG_TRAV_MIN_GAIN_CELLS * gainDt / double(max(gainExt.x, gainExt.y)));
  }
  // Up to three points at one call site: the pending ends (e = -2, -1), or the clipped
  // ends (inversion during traversal) and then the split's point when the splitter asks
  // for the curve point at a t; or the march's stop (e = 3).
  CurvePoint m = a;
  bool ok = false, failed = false;
  int line = 0;  // the splitter's first choice of cut to try (rpSplit)
  int e0 = stop ? 3 : (pend ? -2 : (g_inversionInTraversal ? 0 : 2)), e1 = stop ? 4 : (pend ? 0 : 3);
  for (int e = e0; leaf == 0 && !failed && e < e1; ++e) {
    bool need = true;
    int r = 0;         // what the splitter returned
    CurvePoint p = a;  // the point to make, pending
    if (e < 0) {
      p = e == -2 ? a : b;
      need = e == -2 ? pendA : pendB;
    } else if (e < 2) {
      need = e == 0 ? t0 > a.t + minGain : t1 < b.t - minGain;
      double t = e == 0 ? t0 : t1;
      p = pendingPoint(t, chordUv(a, b, t), OBLONG_RP_PENDING_CLAIM);
    } else if (e == 3) {
      p = pendingPoint(g_mStopT, OBLONG_HOOK(rpToSample)(OBLONG_HOOK(rpHitUV)()) - dvec2(g_origin),
                       OBLONG_RP_PENDING_HIT);
    } else {
      if (pieceSmall(a, b)) {
        leaf = 1;
        break;
      }
      if (g_sp + 2 > g_stackDepth) {  // overflow: correct, just not hierarchical
        OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_OVERFLOW);
        leaf = 2;
        break;
      }
      double t = 0.0;
      r = OBLONG_HOOK(rpSplit)(a, b, line, m, t);
      ok = r == 1;
      need = r >= 2;
      p = r == 3 ? m : pendingPoint(t, dvec2(0.0), OBLONG_RP_PENDING_INVERT);
    }
    CurvePoint q;
    bool made = need && curvePointAt(p, q);
    if (need && !made && e < 0) failed = true;
    if (r == 3 && !made) {  // the crossing's claim refused: the splitter's next choice
      ++line;
      --e;
      continue;
    }
    if (made) {
      if (e < 0) {
        if (p.pad.x == OBLONG_RP_PENDING_TURN) OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_TURNING);
        if (e == -2) a = q;
        else b = q;
      } else if (e == 0) a = q;
      else if (e == 1) b = q;
      else {
        m = q;
        ok = true;
      }
    }
  }
  if (stop) {
    if (ok) stopAt(m);
    return;
  }
  if (leaf != 0) {
    if (leaf == 1 && g_wideEps) wideLeaf(a, b);
    else startMarch(a, b);
    return;
  }
  if (pend && !failed) {
    // The piece below starts where this one ends (setupCurve pushed them in order).
    if (pendB && g_sp > 0 && !isBox(g_st[g_sp - 1]) && pending(g_st[g_sp - 1].a) && g_st[g_sp - 1].a.t == b.t)
      g_st[g_sp - 1].a = b;
    pushPiece(a, b);
    return;
  }
  if (pend || !ok) {
    // No point: this piece's interval by boxes over all of T's cells (a pending end not
    // made), or over its cells (no split point).
    OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_BOX_ONLY_PIECE);
    if (pend) {
      clo = g_cellLo;
      chi = g_cellHi;
      t0 = a.t;
      t1 = min(b.t, bestLimit());
    }
    pushBox(clo, chi, t0, t1);
    return;
  }
  pushPiece(m, b);
  pushPiece(a, m);
}

// A box range popped from the stack, before its box: 0 = nothing more to do (beyond the
// hit, or small: its cells are tested one by one); 1 = box-test it over [t0, t1] first
// (rpLoop), then boxEnd.
int boxBegin(OBLONG_IN(ivec2) clo, OBLONG_IN(ivec2) chi, double ta, double tb, OBLONG_OUT(double) t0,
             OBLONG_OUT(double) t1) {
  double limit = bestLimit();
  t0 = ta;
  t1 = min(tb, limit);
  if (ta > limit) return 0;
  ivec2 n = chi - clo + 1;
  float block = g_wideEps ? min(float(OBLONG_TRAV_WIDE_BOX_CELLS), g_marchingScale) : g_marchingScale;
  if (float(max(n.x, n.y)) <= max(float(OBLONG_TRAV_MIN_BOX_CELLS), block)) {
    startCells(clo, chi);
    return 0;
  }
  return 1;
}

// A box range whose box [t0, t1] the ray crosses: halved along its longer side.
void boxEnd(ivec2 clo, ivec2 chi, double t0, double t1) {
  ivec2 n = chi - clo + 1;
  if (g_sp + 2 > g_stackDepth) {
    OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_OVERFLOW);
    startCells(clo, chi);
    return;
  }
  int ax = n.x >= n.y ? 0 : 1;
  int mid = clo[ax] + (n[ax] - 1) / 2;
  ivec2 aHi = chi, bLo = clo;
  aHi[ax] = mid;
  bLo[ax] = mid + 1;
  // Lower half first when the ray runs towards +axis (order matters for speed only): the
  // upper pushed first. One call site (a shader inlines each call).
  bool upperFirst = g_dvd[ax] >= 0.0;
  for (int q = 0; q < 2; ++q) {
    bool upper = (q == 0) == upperFirst;
    pushBox(upper ? bLo : clo, upper ? chi : aHi, t0, t1);
  }
}

// Front to back until the stack and the current cell generator are empty. Each iteration
// is one step: a marched cell, a box range or a piece; the box of every kind is tested at
// one place (in a shader, one inlined copy of the box, the clip and the range query, and
// the lanes of a warp test their boxes together whatever their steps).
void rpLoop() {
  for (;;) {
    int kind = 0;  // 1: a cell of the generator, 2: a box range, 3: a piece, 4: the march's stop
    ivec2 clo = ivec2(0), chi = ivec2(0);
    if (g_gen != 0) {
      int r = nextCell(clo.x, clo.y);
      if (r == 0) g_gen = 0;
      else kind = r == 1 ? 1 : 4;
    }
    RpEntry e;
    e.a = g_ma;  // e is read only for kinds 2 and 3; set so that no compiler sees it read unset
    e.b = g_ma;
    if (kind == 0) {
      if (g_sp == 0) break;
      --g_sp;
      e = g_st[g_sp];
      kind = isBox(e) ? 2 : 3;
    }
    double t0, t1;
    int leaf = 0, go;
    if (kind == 1) {
      ++g_cells;
      chi = clo;
      t0 = g_tLo;
      t1 = bestLimit();
      go = 1;
    } else if (kind == 2) {
      clo = ivec2(e.a.uv);
      chi = ivec2(e.b.uv);
      go = boxBegin(clo, chi, e.a.t, e.b.t, t0, t1);
    } else if (kind == 3) {
      go = pieceBegin(e.a, e.b, clo, chi, t0, t1, leaf);
    } else {
      t0 = 0.0;
      t1 = 0.0;
      leaf = 3;
      go = 2;
    }
    if (go == 0) continue;
    if (go == 1) {  // the box step
      ivec2 o = g_origin;
      vec2 raw;
      if (kind == 1) {
        // The four corners from one call site (each is a copy of the texel lookup with
        // its level-of-detail blend in a shader); heights are finite (HeightMap).
        raw = vec2(kInfF, -kInfF);
        for (int k = 0; k < 4; ++k) {
          float v = OBLONG_HOOK(rpRaw)(clo.x + o.x + (k & 1), clo.y + o.y + (k >> 1));
          raw = vec2(min(raw.x, v), max(raw.y, v));
        }
      } else {
        ++g_rangeQueries;
        ++g_boxes;
        raw = OBLONG_HOOK(rpRangeRaw)(clo.x + o.x, clo.y + o.y, chi.x + 1 + o.x, chi.y + 1 + o.y);
      }
      if (!clipToBox(clo, chi, OBLONG_HOOK(rpToHeight)(raw), t0, t1)) continue;
    }
    if (kind == 1) {
      g_microTris += OBLONG_HOOK(rpCellMicro)(clo.x + g_origin.x, clo.y + g_origin.y);
      g_limit = limitNow();
    } else if (kind == 2) {
      boxEnd(clo, chi, t0, t1);
    } else {
      pieceEnd(e.a, e.b, clo, chi, t0, t1, leaf);
    }
  }
}

// Projection-free subdivision of all of T's cells (ill-posed triangles, fallbacks).
void setupBoxOnly() {
  OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_BOX_ONLY_PRISM);
  g_boxOnly = true;
  g_sp = 0;
  double t0 = g_tLo, t1 = bestLimit();
  clipBox(g_boxLo, g_boxHi, g_O, g_invD, t0, t1);
  if (!(t0 <= t1)) return;
  pushBox(g_cellLo, g_cellHi, t0, t1);
}

// Up to the stack: 0 = no hit possible, 1 = box-only, 2 = pieces pushed.
int setupCurve() {
  if (!g_wellPosed) {
    OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_ILL_POSED);
    return 1;
  }
  // 1. The inflated prism (with the margin for the watertight test's rounding).
  dvec3 plo, phi;
  OBLONG_HOOK(rpInflatedBox)(plo, phi);
  double t0 = g_tLo, t1 = g_tHi;
  clipBox(plo, phi, g_O, g_invD, t0, t1);
  if (!(t0 <= t1)) return 0;
  // 2. Its crossings (prism.h's prismCrossings) and ψ's turning points in (tIn, tOut)
  // (patch_math.h's monotoneSplits), their five quadratics solved in one loop: the three
  // walls' (q < 3), then the two turning lines' (one call site each of the quadratic and
  // of the ray's closest point to a displacement line, which a shader inlines per call).
  PrismShape P = OBLONG_HOOK(rpPrism)();
  Crossing first, last;
  int nc;
  capCrossings(P, g_O, g_D, first, last, nc);
  double tIn = 0.0, tOut = 0.0, farB = -1.0;
  double ts[4], ss[4];
  dvec2 bs[4];
  clearSplits(ts, bs, ss);
  int m = 0;
  for (int q = 0; q < 5; ++q) {
    if (q == 3) {  // the crossings are known
      if (nc == 0) return 0;  // the line misses the inflated prism
      if (nc < 2) {
        OBLONG_HOOK(rpStat)(OBLONG_RP_STAT_GRAZE);
        return 1;
      }
      tIn = max(first.t, g_tLo);
      tOut = min(last.t, g_tHi);
      if (!(tIn <= tOut)) return 0;
      g_psi = psiMake(g_F, g_O, g_D);
      // With two crossings the ray runs inside the inflated prism from the first to the
      // last, so its curve's points there lie on the prism's base triangle, T grown by
      // its growth: a candidate more than a whole triangle beyond that lies on another
      // branch of ψ = 0 (a focal point's: on a sphere every displacement line meets the
      // centre) and is dropped.
      farB = nc == 2 ? 1.0 + prismGrowth(P) : -1.0;
    }
    int A = 0, B = 0;
    dvec2 Q = dvec2(0.0), R = dvec2(0.0);
    double k2, k1, k0;
    if (q < 3) wallQuadratic(P, g_O, g_D, q, A, B, k2, k1, k0);
    else if (!turnLine(g_psi, q - 3, Q, R, k2, k1, k0)) continue;
    double w[2], pad[2];
    int nr = quadraticRoots(k2, k1, k0, w, pad);
    for (int r = 0; r < nr; ++r) {
      dvec3 Pt, Nt;
      dvec2 bb;
      double t, s;
      bool line = q < 3 ? wallLine(P, A, B, w[r], pad[r], Pt, Nt, bb)
                        : turnCandidate(g_F, Q, R, w[r], pad[r], farB, bb, Pt, Nt);
      if (!line || !closestOnLines(Pt, Nt, g_O, g_D, t, s)) continue;
      if (q < 3) {
        if (wallKeeps(P, t, s)) addCrossing(t, bb, s, first, last, nc);
      } else if (finiteD(t) && finiteD(s) && t > tIn && t < tOut) {
        ts[m] = t;
        bs[m] = bb;
        ss[m] = s;
        ++m;
      }
    }
  }
  int ns = sortSplits(ts, bs, ss, m);
  g_anchor = claimAnchor(g_F, g_O, g_D, 0.5 * (tIn + tOut));  // every claim comes after this
  // 3. Monotone pieces, between ψ's turning points, all their ends left pending, made
  // by pieceEnd when their piece is popped: the crossings' claims at their prism
  // coordinates; an end inside the prism (where the ray starts or ends) claimed near the
  // chord between the crossings, else inverted; the turning points claimed at their
  // candidates' prism coordinates, else inverted.
  CurvePoint pts[6];
  for (int k = 0; k < 2; ++k) {
    Crossing c = k == 0 ? first : last;
    double t = k == 0 ? tIn : tOut;
    CurvePoint p;
    if (t == c.t) {
      p = pendingPoint(t, c.bary, OBLONG_RP_PENDING_CROSSING);
      p.pad.y = float(c.s);
    } else {  // the chord between the crossings' uv (a claim's uv is frameLocal of its b)
      dvec2 g = chordAt(first.t, frameLocal(g_F, first.bary), last.t, frameLocal(g_F, last.bary), t);
      p = pendingPoint(t, g, OBLONG_RP_PENDING_CLAIM);
    }
    pts[k == 0 ? 0 : ns + 1] = p;
  }
  for (int k = 0; k < ns; ++k) {
    pts[k + 1] = pendingPoint(ts[k], bs[k], OBLONG_RP_PENDING_TURN);
    pts[k + 1].pad.y = float(ss[k]);
  }
  g_sp = 0;
  for (int k = ns; k >= 0; --k) pushPiece(pts[k], pts[k + 1]);
  return 2;
}

// One ray against one triangle after rpInit: true when a micro-triangle was hit (the hit
// is the includer's, through rpCellMicro).
bool rpRun() {
  g_tLo = double(g_tmin) - slack(double(g_tmin));
  g_tHi = double(g_tmax) + slack(double(g_tmax));
  g_limit = limitNow();
  g_gen = 0;
  g_sp = 0;
  int r = setupCurve();
  if (r == 1) setupBoxOnly();
  if (r == 0) return false;
  g_dvd = dirLocal();  // the order of the stack's children and of a cell range's cells
  rpLoop();
  return OBLONG_HOOK(rpHitFound)();
}
