// The per-ray, per-prism traversal (traversal/ray_patch.h's RayPatch) in GLSL, for
// the intersection shader. Mirrors the CPU code function by function (same names, same
// order of operations, double where the CPU uses double, float where it uses float), with
// the CPU's constants (core/kernels/constants.h). tests/vulkan_test.cpp holds it to
// the CPU step for step: same hits and the same per-ray work on one-triangle scenes.
//
// What runs: TraversalMesh::missesPrism (the early reject), then RayPatch::run for
// well-posed triangles — ray / inflated prism crossings,
// the curve's monotone pieces (ψ turning points, inversion), a stack of pieces front to
// back, RMIP range query + conservative box + ray clip per piece, inversion during
// traversal, midpoint2d splits (closed-form crossing of ψ with the middle line, else the
// t-midpoint by inversion), texel marching of the cells within ε of a piece — and the
// projection-free box subdivision (runBoxOnly / processBox) wherever the CPU uses it.
// Differences from the CPU (docs/vulkan.md): the inverter is the CPU's newton with its
// cubic fallback (core/kernels/invert.h), but the cubic's cbrt / acos / cos are GLSL's (not
// bit-identical; every curve point is validated by its residual either way); the
// per-ray counters are kept, the statistics registry is not.
//
// NIR inlines every function call, and lavapipe's compile time grows quickly with the
// inlined size, so each large piece of code has one call site: the cells to test come
// from one generator (nextCell: a box range or a marched piece), tested at one place in
// runLoop.

#include "core/kernels/constants.h"  // shared with the CPU traversal and inversion/newton.h
// The per-patch kernels, the CPU's own code (core/kernels/, docs/architecture.md).
#include "core/kernels/lang.h"
#include "core/kernels/patch_math.h"
#include "core/kernels/rect_bounds.h"
#include "core/kernels/prism.h"
#include "core/kernels/curve_point.h"
#include "core/kernels/invert.h"

#define kInfF uintBitsToFloat(0x7f800000u)

// ---- per invocation state (RayPatch's members; g_tri, g_mesh in prism.rint) ----------
PatchFrame g_F;  // the triangle's frame (core/kernels/patch_math.h), from TRI in initPatch
Psi g_psi;
ClaimBounds g_claim;  // TRI's bounds on the claims' errors (makePoint)
float g_tmin, g_tmax;             // the ray's [tmin, tmax] (float, as Ray)
dvec3 g_O, g_D, g_invD;
dvec3 g_boxLo, g_boxHi;           // prismBox_
dvec3 g_Ot, g_invDt;              // the ray in the texture frame (originT_, invDirT_)
dvec3 g_texLo, g_texHi;           // texPrismBox_
double g_texPad;                  // texPad_
bool g_wideEps;                   // wideEps_
double g_leafScale;               // leafScale_
double g_boxPad, g_tAbs;
dvec2 g_dvd;
ivec2 g_cellLo, g_cellHi;
dvec2 g_sbLo, g_sbHi;
// ClosestHit
bool g_found;
float g_hitT;
McVertex g_hv0, g_hv1, g_hv2;
vec3 g_hb;
// counters
int g_boxes, g_rangeQueries, g_inversions, g_cells, g_microTris;
bool g_boxOnly;

// ---- ClosestHit::test ----------------------------------------------------------------
void testMicro(McVertex v0, McVertex v1, McVertex v2) {
  float t;
  vec3 b;
  float hi = g_found ? (g_hitT < g_tmax ? g_hitT : g_tmax) : g_tmax;  // std::min(tmax, t)
  if (intersectMicro(g_wr, v0.p, v1.p, v2.p, g_tmin, hi, t, b) && (!g_found || t < g_hitT)) {
    g_hitT = t;
    g_found = true;
    g_hv0 = v0;
    g_hv1 = v1;
    g_hv2 = v2;
    g_hb = b;
  }
}

// ---- RMIP range query: the kernel (core/kernels/rmip_query.h) over the mesh record's
// layer table and entries (bits 16: one word of codes; bits 32: two float words) --------
#define RmipAccess MeshGpu
#define RmipAcc vec2
#include "core/kernels/rmip_query.h"
// Quantizer16::decode, unfused as on the CPU.
float rmipDecode(MeshGpu m, uint code) {
  precise float scaled = float(code) * m.rmipStep;
  precise float v = m.rmipBase + scaled;
  return v;
}
RmipLayerRef rmipLayer(MeshGpu m, int index) {
  ivec4 L = rmipLayers[m.rmipLayers + uint(index)];  // offset, nx, shiftX, shiftY
  return RmipLayerRef(uint(L.x), L.y, L.z, L.w);
}
void rmipJoin(MeshGpu m, uint idx, inout vec2 r) {
  vec2 v;
  if (m.rmipBits == 16) {
    uint w = rmipWordAt(m.rmipData + idx, m.chunkShift);
    v = vec2(rmipDecode(m, w & 0xffffu), rmipDecode(m, w >> 16));
  } else {
    uint at = m.rmipData + 2u * idx;
    v = vec2(uintBitsToFloat(rmipWordAt(at, m.chunkShift)), uintBitsToFloat(rmipWordAt(at + 1u, m.chunkShift)));
  }
  r.x = v.x < r.x ? v.x : r.x;
  r.y = r.y < v.y ? v.y : r.y;
}
vec2 rmipRawRange(MeshGpu m, int sx0, int sy0, int sx1, int sy1) {
  RmipGeom g = RmipGeom(m.rmipF, m.W, m.H, m.rmipW, m.rmipH, m.rmipP, m.rmipQ, m.rmipFirst, m.rmipWrap != 0);
  vec2 r = vec2(kInfF, -kInfF);
  rmipRange(m, g, sx0, sy0, sx1, sy1, r);
  return r;
}
// LodBandQuery::rawRange: under a λ per ray, the hull of this level's range and the
// next level's over the coarse samples around it (one call site for rmipRawRange).
vec2 rangeRaw(int sx0, int sy0, int sx1, int sy1) {
  vec2 r = vec2(kInfF, -kInfF);
  int n = g_mesh.lodNext >= 0 ? 2 : 1;
  for (int s = 0; s < n; ++s) {
    MeshGpu m = s == 0 ? g_mesh : g_next;
    int sh = s == 0 ? 0 : 1;
    vec2 v = rmipRawRange(m, sx0 >> sh, sy0 >> sh, (sx1 + s) >> sh, (sy1 + s) >> sh);
    r.x = min(r.x, v.x);
    r.y = max(r.y, v.y);
  }
  return r;
}
// Displacement::toHeight
vec2 toHeight(vec2 raw) {
  precise float a = g_mesh.scale * (raw.x + g_mesh.bias), b = g_mesh.scale * (raw.y + g_mesh.bias);
  return vec2(min(a, b), max(a, b));
}

// ---- RayPatch helpers -----------------------------------------------------------------
double slack(double t) { return OBLONG_TRAV_SLACK_REL * abs(t) + g_tAbs; }
double bestLimit() { return g_found ? double(g_hitT) + slack(double(g_hitT)) : double(g_tmax) + slack(double(g_tmax)); }

dvec2 dirLocal() { return approxDirLocal(g_F, TRI.N13, g_D); }

// clipToBox: the ray interval through the box of the micro-geometry over local cells
// with heights h (toHeight), in T's texture frame; clipToCells: with the range query's.
bool clipToBox(ivec2 clo, ivec2 chi, vec2 h, inout double t0, inout double t1) {
  dvec2 lo = max(dvec2(clo), g_sbLo), hi = min(dvec2(chi + 1), g_sbHi);
  dvec3 blo, bhi;
  boxOverRect(TRI.tPc, TRI.tPX, TRI.tPY, TRI.tNc, TRI.tNX, TRI.tNY, double(TRI.minNormalLength), lo, hi, double(h.x), double(h.y), g_texPad, blo, bhi);
  blo = max(blo, g_texLo);
  bhi = min(bhi, g_texHi);
  if (blo.x > bhi.x || blo.y > bhi.y || blo.z > bhi.z) return false;
  clipBox(blo, bhi, g_Ot, g_invDt, t0, t1);
  return t0 <= t1;
}
bool clipToCells(ivec2 clo, ivec2 chi, inout double t0, inout double t1) {
  ivec2 o = TRI.origin;
  ++g_rangeQueries;
  ++g_boxes;
  vec2 h = toHeight(rangeRaw(clo.x + o.x, clo.y + o.y, chi.x + 1 + o.x, chi.y + 1 + o.y));
  return clipToBox(clo, chi, h, t0, t1);
}

// One step of the march: a cell, rejected by its box (TFDM's leaf test: the four corner
// samples bound every micro-vertex of the cell) or tested.
void testCell(int i, int j) {
  ++g_cells;
  int I = i + TRI.origin.x, J = j + TRI.origin.y;
  float a = mapAt(I, J), b = mapAt(I + 1, J), c = mapAt(I, J + 1), e = mapAt(I + 1, J + 1);
  double t0 = double(g_tmin) - slack(double(g_tmin)), t1 = bestLimit();
  vec2 h = toHeight(vec2(minCpp(minCpp(minCpp(a, b), c), e), maxCpp(maxCpp(maxCpp(a, b), c), e)));
  if (!clipToBox(ivec2(i, j), ivec2(i, j), h, t0, t1)) return;
  g_microTris += microCell(I, J);
}


// ---- the inflated prism: the CPU's own code (core/kernels/prism.h) ----------------------
PrismShape g_P;

// ---- curve points (RayPatch::makePoint, invertAt) ------------------------------------
dvec2 pieceLo(CurvePoint a, CurvePoint b) { return min(a.uv - a.pad, b.uv - b.pad); }
dvec2 pieceHi(CurvePoint a, CurvePoint b) { return max(a.uv + a.pad, b.uv + b.pad); }

dvec2 g_eps;

bool makePoint(double t, dvec2 b, double s, out CurvePoint outp) {
  return makePoint(g_F, g_claim, g_O, g_D, t, b, s, outp);
}

// ---- the inverter: newton with its cubic fallback (core/kernels/invert.h), in float as
// the CPU traversal calls Newton::invert --------------------------------------------------
void invertFloat(vec3 X, out vec2 bary, out float h) {
  InvFrameF F = invFrame(TRI.p[0], TRI.p[1], TRI.p[2], TRI.n[0], TRI.n[1], TRI.n[2]);
  bool fellBack;
  InvResultF r = newtonSolve(F, X, OBLONG_NEWTON_TOLERANCE, OBLONG_NEWTON_MAX_ITERATIONS, true,
                             OBLONG_NEWTON_FALLBACK_POLISH, fellBack);
  bary = vec2(r.u, r.v);
  h = r.h;
}

bool invertAt(double t, out CurvePoint outp) {
  outp = CurvePoint(t, dvec2(0.0), dvec2(0.0));
  ++g_inversions;
  precise dvec3 X = g_O + t * g_D;
  vec2 bary;
  float h;
  invertFloat(vec3(X), bary, h);
  dvec2 b = dvec2(bary);
  double nl = lengthD(frameN(g_F, b));
  if (!(nl > 0.0) || isinf(h) || isnan(h)) return false;
  return makePoint(t, b, double(h) / nl, outp);
}

// RayPatch::crossing (SplitContext): the curve point on {axis = c}, unique, strictly
// between the piece's ends.
bool crossingAt(CurvePoint pa, CurvePoint pb, int axis, double c, out CurvePoint outp) {
  outp = pa;
  double q2, q1, q0, w[2], rp[2];
  psiOnLine(g_psi, axis, c, q2, q1, q0);
  int n = quadraticRoots(q2, q1, q0, w, rp);
  if (n <= 0) return false;
  int mi = 1 - axis;
  dvec2 lo = pieceLo(pa, pb), hi = pieceHi(pa, pb);
  int found = 0;
  for (int k = 0; k < n; ++k) {
    if (w[k] < lo[mi] - rp[k] || w[k] > hi[mi] + rp[k]) continue;
    dvec2 uv = axis == 0 ? dvec2(c, w[k]) : dvec2(w[k], c);
    double t, s;
    if (!rayParamAt(g_F, g_O, g_D, uv, t, s)) continue;
    if (!(t > pa.t && t < pb.t)) continue;
    CurvePoint cp;
    if (!makePoint(t, frameBary(g_F, uv), s, cp)) continue;
    outp = cp;
    ++found;
  }
  return found == 1;
}

// ---- the stack ---------------------------------------------------------------------------
struct Entry {
  CurvePoint a, b;  // curve mode
  ivec4 cells;      // box mode: local cell range clo, chi
  double ta, tb;    // box mode: ray interval
  bool box;
};
Entry g_st[OBLONG_TRAV_STACK_GPU];
int g_sp;

void pushPiece(CurvePoint a, CurvePoint b) {
  g_st[g_sp].a = a;
  g_st[g_sp].b = b;
  g_st[g_sp].box = false;
  ++g_sp;
}
void pushBox(ivec2 lo, ivec2 hi, double ta, double tb) {
  g_st[g_sp].cells = ivec4(lo, hi);
  g_st[g_sp].ta = ta;
  g_st[g_sp].tb = tb;
  g_st[g_sp].box = true;
  ++g_sp;
}

// RayPatch::snap: local cells touching [lo, hi], clipped to T's cells.
bool snapCells(dvec2 lo, dvec2 hi, out ivec2 clo, out ivec2 chi) {
  double lim = OBLONG_TRAV_SNAP_LIMIT;
  for (int k = 0; k < 2; ++k) {
    precise double eta = OBLONG_TRAV_SNAP_ETA * (1.0 + abs(lo[k]) + abs(hi[k]));
    clo[k] = int(clamp(floor(lo[k] - eta), -lim, lim));
    chi[k] = int(clamp(floor(hi[k] + eta), -lim, lim));
  }
  clo = max(clo, g_cellLo);
  chi = min(chi, g_cellHi);
  return clo.x <= chi.x && clo.y <= chi.y;
}

// ---- the cells to test: one generator, one call site of the micro-geometry ------------
// Mode 1: a cell range (RayPatch::testCells order); mode 2: texel marching of a piece
// (RayPatch::march, minorAt), column by column.
int g_gen;
ivec2 g_gLo, g_gHi;
int g_gi, g_gj, g_gsx, g_gsy;
CurvePoint g_ma, g_mb;
int g_mAx, g_mSa, g_mSm, g_mK, g_mJ, g_mJ0, g_mJ1;
bool g_mCol;
// RayPatch::march's stop: cells past the curve's point at the best hit's limit.
bool g_mStopSet;
bvec2 g_mCertain, g_mStopAxis;
dvec2 g_mStop;

void startCells(ivec2 clo, ivec2 chi) {
  g_gen = 1;
  g_gLo = clo;
  g_gHi = chi;
  g_gsx = g_dvd.x >= 0.0 ? 1 : -1;
  g_gsy = g_dvd.y >= 0.0 ? 1 : -1;
  g_gi = g_gsx > 0 ? clo.x : chi.x;
  g_gj = g_gsy > 0 ? clo.y : chi.y;
}

void startMarch(CurvePoint a, CurvePoint b) {
  precise dvec2 d = b.uv - a.uv;
  int ax = abs(d.x) >= abs(d.y) ? 0 : 1, mi = 1 - ax;
  ivec2 clo, chi;
  if (!snapCells(pieceLo(a, b) - g_eps, pieceHi(a, b) + g_eps, clo, chi)) return;
  g_gen = 2;
  g_ma = a;
  g_mb = b;
  g_mAx = ax;
  g_gLo = clo;
  g_gHi = chi;
  g_mSa = d[ax] >= 0.0 ? 1 : -1;
  g_mSm = d[mi] >= 0.0 ? 1 : -1;
  g_mK = g_mSa > 0 ? clo[ax] : chi[ax];
  g_mCol = false;
  for (int k = 0; k < 2; ++k) g_mCertain[k] = abs(d[k]) > a.pad[k] + b.pad[k];
  g_mStopSet = !g_mCertain.x && !g_mCertain.y;
  g_mStopAxis = bvec2(false);
  g_mStop = dvec2(0.0);
}

// RayPatch::pointBetween: the curve point at t between curve points a and b without an
// inversion (linear guess, least-squares s, one Newton step in double), validated by
// makePoint; refused when its pad exceeds OBLONG_TRAV_CLAIM_PAD.
bool pointBetween(CurvePoint a, CurvePoint b, double t, out CurvePoint outp) {
  outp = CurvePoint(t, dvec2(0.0), dvec2(0.0));
  dvec2 nb;
  double ns;
  if (!claimBetween(g_F, g_O, g_D, a, b, t, nb, ns)) return false;
  if (!makePoint(t, nb, ns, outp)) return false;
  return outp.pad.x + outp.pad.y <= OBLONG_TRAV_CLAIM_PAD;
}

// RayPatch::pointFromHit: the curve point at t from the closest hit (its texture
// position, the least-squares s of X(t)), validated by makePoint like any other.
bool pointFromHit(double t, out CurvePoint outp) {
  outp = CurvePoint(t, dvec2(0.0), dvec2(0.0));
  if (!g_found) return false;
  precise dvec2 uv = double(g_hb.x) * dvec2(g_hv0.uv) + double(g_hb.y) * dvec2(g_hv1.uv) +
                     double(g_hb.z) * dvec2(g_hv2.uv);
  precise dvec2 loc = toSample(uv) - dvec2(TRI.origin);
  dvec2 b = frameBary(g_F, loc);
  precise dvec3 X = g_O + t * g_D;
  return makePoint(t, b, heightOnLine(g_F, X, b), outp);
}

// False when no cell of the marched piece can hold a better hit (RayPatch::march).
bool setStop() {
  g_mStopSet = true;
  double tStar = bestLimit();
  if (tStar <= g_ma.t) return false;
  CurvePoint m;
  if (tStar < g_mb.t && (pointFromHit(tStar, m) || invertAt(tStar, m)))
    for (int k = 0; k < 2; ++k)
      if (g_mCertain[k]) {
        precise double margin = m.pad[k] + g_ma.pad[k] + g_mb.pad[k];
        int sg = k == g_mAx ? g_mSa : g_mSm;
        g_mStop[k] = sg > 0 ? m.uv[k] + margin : m.uv[k] - margin;
        g_mStopAxis[k] = true;
      }
  return true;
}
bool pastStop(int a, int k) {
  int sg = a == g_mAx ? g_mSa : g_mSm;
  return g_mStopAxis[a] && (sg > 0 ? double(k) - g_eps[a] > g_mStop[a] : double(k + 1) + g_eps[a] < g_mStop[a]);
}

// RayPatch::minorAt: the minor coordinate range of the marched piece where its major
// coordinate is c.
void minorAt(double c, out double wlo, out double whi) {
  int ax = g_mAx, mi = 1 - ax;
  dvec2 lo = pieceLo(g_ma, g_mb), hi = pieceHi(g_ma, g_mb);
  wlo = kInfD;
  whi = -kInfD;
  for (int k = 0; k < 2; ++k) {
    CurvePoint e = k == 0 ? g_ma : g_mb;
    if (abs(c - e.uv[ax]) <= e.pad[ax] * OBLONG_TRAV_END_PAD_REL + OBLONG_TRAV_END_PAD_ABS) {
      wlo = min(wlo, e.uv[mi] - e.pad[mi]);
      whi = max(whi, e.uv[mi] + e.pad[mi]);
    }
  }
  double q2, q1, q0, w[2], rp[2];
  psiOnLine(g_psi, ax, c, q2, q1, q0);
  int n = quadraticRoots(q2, q1, q0, w, rp);
  if (n < 0) {
    wlo = lo[mi];
    whi = hi[mi];
    return;
  }
  for (int k = 0; k < n; ++k)
    if (w[k] >= lo[mi] - rp[k] && w[k] <= hi[mi] + rp[k]) {
      wlo = min(wlo, w[k] - rp[k]);
      whi = max(whi, w[k] + rp[k]);
    }
  if (!(wlo <= whi)) {
    wlo = lo[mi];
    whi = hi[mi];
  }
  wlo = max(wlo, lo[mi]);
  whi = min(whi, hi[mi]);
}

bool nextCell(out int ci, out int cj) {
  ci = 0;
  cj = 0;
  if (g_gen == 1) {
    if (g_gsy > 0 ? g_gj > g_gHi.y : g_gj < g_gLo.y) return false;
    ci = g_gi;
    cj = g_gj;
    g_gi += g_gsx;
    if (g_gsx > 0 ? g_gi > g_gHi.x : g_gi < g_gLo.x) {
      g_gi = g_gsx > 0 ? g_gLo.x : g_gHi.x;
      g_gj += g_gsy;
    }
    return true;
  }
  int ax = g_mAx, mi = 1 - ax;
  for (;;) {
    if (!g_mCol) {
      if (g_mSa > 0 ? g_mK > g_gHi[ax] : g_mK < g_gLo[ax]) return false;
      if (!g_mStopSet && g_found && !setStop()) return false;
      if (pastStop(ax, g_mK)) return false;
      dvec2 lo = pieceLo(g_ma, g_mb), hi = pieceHi(g_ma, g_mb);
      precise double c0 = max(double(g_mK) - g_eps[ax], lo[ax]), c1 = min(double(g_mK + 1) + g_eps[ax], hi[ax]);
      if (c0 > c1) {
        g_mK += g_mSa;
        continue;
      }
      double r[4];
      for (int k = 0; k < 2; ++k) minorAt(k == 0 ? c0 : c1, r[2 * k], r[2 * k + 1]);
      precise double wlo = min(r[0], r[2]) - g_eps[mi], whi = max(r[1], r[3]) + g_eps[mi];
      precise double eta = OBLONG_TRAV_SNAP_ETA * (1.0 + abs(wlo) + abs(whi));
      g_mJ0 = max(int(floor(wlo - eta)), g_gLo[mi]);
      g_mJ1 = min(int(floor(whi + eta)), g_gHi[mi]);
      g_mJ = g_mSm > 0 ? g_mJ0 : g_mJ1;
      g_mCol = true;
    }
    if (g_mSm > 0 ? g_mJ <= g_mJ1 : g_mJ >= g_mJ0) {
      if (!g_mStopSet && g_found && !setStop()) return false;
      if (pastStop(mi, g_mJ)) {
        g_mCol = false;
        g_mK += g_mSa;
        continue;
      }
      ci = ax == 0 ? g_mK : g_mJ;
      cj = ax == 0 ? g_mJ : g_mK;
      g_mJ += g_mSm;
      return true;
    }
    g_mCol = false;
    g_mK += g_mSa;
  }
  return false;
}

// ---- RayPatch::processPiece (midpoint2d) and processBox -----------------------------------
bool pieceSmall(CurvePoint a, CurvePoint b) {
  dvec2 ext = pieceHi(a, b) - pieceLo(a, b);
  dvec2 pads = a.pad + b.pad;
  int la = ext.x >= ext.y ? 0 : 1;
  return ext[la] <= g_leafScale || pads[la] > OBLONG_TRAV_PAD_DOMINANCE * ext[la];
}
bool strictlyBetween(CurvePoint a, CurvePoint b, int axis, double c) {
  double x0 = min(a.uv[axis], b.uv[axis]), x1 = max(a.uv[axis], b.uv[axis]);
  return c > x0 && c < x1;
}

// RayPatch::leaf: a piece too small to split is marched, or, where ε is wider than the
// marching scale, subdivided as a box.
void leafPiece(CurvePoint a, CurvePoint b) {
  if (!g_wideEps) {
    startMarch(a, b);
    return;
  }
  ivec2 clo, chi;
  if (!snapCells(pieceLo(a, b) - g_eps, pieceHi(a, b) + g_eps, clo, chi)) return;
  pushBox(clo, chi, a.t, min(b.t, bestLimit()));
}

void processPiece(CurvePoint a, CurvePoint b) {
  if (a.t > bestLimit()) return;
  if (pieceSmall(a, b)) {
    leafPiece(a, b);
    return;
  }
  ivec2 clo, chi;
  if (!snapCells(pieceLo(a, b) - g_eps, pieceHi(a, b) + g_eps, clo, chi)) return;
  double t0 = a.t, t1 = min(b.t, bestLimit());
  if (!clipToCells(clo, chi, t0, t1)) return;
  // Up to three inversions, at one call site: the clipped ends (Fig. 5a: inversion
  // during traversal, their projections can give a much smaller rectangle), then the
  // midpoint2d split — the crossing with the middle of the longer side, else of the
  // other side (split::middleCrossing), else the t-midpoint by inversion.
  precise dvec2 gainExt = pieceHi(a, b) - pieceLo(a, b);
  precise double gainDt = b.t - a.t;
  precise double minGain =
      max(OBLONG_TRAV_MIN_GAIN * gainDt, OBLONG_TRAV_MIN_GAIN_CELLS * gainDt / max(gainExt.x, gainExt.y));
  CurvePoint m;
  bool ok = false;
  for (int e = g_mesh.inversionInTraversal != 0 ? 0 : 2; e < 3; ++e) {
    bool need;
    double t;
    if (e < 2) {
      need = e == 0 ? t0 > a.t + minGain : t1 < b.t - minGain;
      t = e == 0 ? t0 : t1;
    } else {
      if (pieceSmall(a, b)) {
        leafPiece(a, b);
        return;
      }
      if (g_sp + 2 > g_mesh.stackDepth) {  // overflow: correct, just not hierarchical
        startMarch(a, b);
        return;
      }
      dvec2 lo = pieceLo(a, b), hi = pieceHi(a, b);
      dvec2 ext = hi - lo;
      int first = ext.x >= ext.y ? 0 : 1;
      for (int k = 0; k < 2 && !ok; ++k) {
        int axis = k == 0 ? first : 1 - first;
        precise double c = 0.5 * (lo[axis] + hi[axis]);
        if (!strictlyBetween(a, b, axis, c)) c = 0.5 * (a.uv[axis] + b.uv[axis]);
        ok = strictlyBetween(a, b, axis, c) && crossingAt(a, b, axis, c, m);
      }
      need = !ok;
      t = 0.5 * (a.t + b.t);
    }
    CurvePoint q;
    if (need && ((e < 2 && pointBetween(a, b, t, q)) || invertAt(t, q))) {
      if (e == 0) a = q;
      else if (e == 1) b = q;
      else {
        m = q;
        ok = true;
      }
    }
  }
  if (!ok) {
    pushBox(clo, chi, t0, t1);
    return;
  }
  pushPiece(m, b);
  pushPiece(a, m);
}

void processBox(ivec2 clo, ivec2 chi, double ta, double tb) {
  double limit = bestLimit();
  if (ta > limit) return;
  ivec2 n = chi - clo + 1;
  float block = g_wideEps ? min(float(OBLONG_TRAV_WIDE_BOX_CELLS), g_mesh.marchingScale) : g_mesh.marchingScale;
  if (float(max(n.x, n.y)) <= max(float(OBLONG_TRAV_MIN_BOX_CELLS), block)) {
    startCells(clo, chi);
    return;
  }
  double t0 = ta, t1 = min(tb, limit);
  if (!clipToCells(clo, chi, t0, t1)) return;
  if (g_sp + 2 > g_mesh.stackDepth) {
    startCells(clo, chi);
    return;
  }
  int ax = n.x >= n.y ? 0 : 1;
  int mid = clo[ax] + (n[ax] - 1) / 2;
  ivec2 aHi = chi, bLo = clo;
  aHi[ax] = mid;
  bLo[ax] = mid + 1;
  // Lower half first when the ray runs towards +axis (order matters for speed only).
  if (g_dvd[ax] >= 0.0) {
    pushBox(bLo, chi, t0, t1);
    pushBox(clo, aHi, t0, t1);
  } else {
    pushBox(clo, aHi, t0, t1);
    pushBox(bLo, chi, t0, t1);
  }
}

// Front to back until the stack and the current cell generator are empty.
void runLoop() {
  for (;;) {
    if (g_gen != 0) {
      int ci, cj;
      if (nextCell(ci, cj)) {
        testCell(ci, cj);
        continue;
      }
      g_gen = 0;
    }
    if (g_sp == 0) break;
    --g_sp;
    Entry e = g_st[g_sp];
    if (e.box) processBox(e.cells.xy, e.cells.zw, e.ta, e.tb);
    else processPiece(e.a, e.b);
  }
}

// RayPatch::runBoxOnly's set-up: the whole of T's cells as one box entry.
void setupBoxOnly() {
  g_boxOnly = true;
  g_sp = 0;
  double t0 = double(g_tmin) - slack(double(g_tmin)), t1 = bestLimit();
  clipBox(g_boxLo, g_boxHi, g_O, g_invD, t0, t1);
  if (!(t0 <= t1)) return;
  g_dvd = dirLocal();
  pushBox(g_cellLo, g_cellHi, t0, t1);
}

// RayPatch::run up to the stack: 0 = no hit possible, 1 = box-only, 2 = pieces pushed.
int setupCurve() {
  if (TRI.wellPosed == 0) return 1;
  // The inflated prism (with the margin for the watertight test's rounding): the one
  // TraversalMesh precomputes for origins within the budget, else the ray's own.
  precise double maxO = max(max(abs(g_O.x), abs(g_O.y)), abs(g_O.z));
  bool pre = maxO <= TRI.budget;
  precise double rayErr = OBLONG_TRAV_RAY_ERR * (TRI.maxP + (pre ? TRI.budget : maxO) + abs(TRI.a) + abs(TRI.b));
  precise double extraB = (TRI.kb.x + TRI.kb.y) * double(OBLONG_TRAV_RAY_ERR_FACTOR) * rayErr,
                 extraS = TRI.ks * double(OBLONG_TRAV_RAY_ERR_FACTOR) * rayErr;
  g_P = prismInflated(g_F, TRI.a - TRI.inflateS - extraS, TRI.b + TRI.inflateS + extraS, TRI.inflateB + extraB);
  dvec3 plo, phi;
  prismBox(g_P, plo, phi);  // Prism::bounds(), padded
  precise double ppad = pre ? TRI.vertexErr + rayErr : g_boxPad;
  plo -= dvec3(ppad);
  phi += dvec3(ppad);
  double t0 = double(g_tmin) - slack(double(g_tmin)), t1 = double(g_tmax) + slack(double(g_tmax));
  clipBox(plo, phi, g_O, g_invD, t0, t1);
  if (!(t0 <= t1)) return 0;
  Crossing first, last;
  int nc = prismCrossings(g_P, g_O, g_D, first, last);
  if (nc == 0) return 0;  // the line misses the inflated prism
  if (nc < 2) return 1;   // grazed
  double tIn = max(first.t, double(g_tmin) - slack(double(g_tmin)));
  double tOut = min(last.t, double(g_tmax) + slack(double(g_tmax)));
  if (!(tIn <= tOut)) return 0;
  g_psi = psiMake(g_F, g_O, g_D);
  g_dvd = dirLocal();
  double ts[4];
  int ns = monotoneSplits(g_F, g_psi, g_O, g_D, tIn, tOut, ts);
  // Curve points: the two ends (prism crossings; where the ray starts or ends inside,
  // claimed between the crossings' points or inverted), then the turning points.
  CurvePoint pts[6];
  bool okEnds = true;
  CurvePoint F, L;
  bool okF = makePoint(first.t, first.bary, first.s, F), okL = makePoint(last.t, last.bary, last.s, L);
  for (int k = 0; k < ns + 2; ++k) {
    if (k == 2 && !okEnds) return 1;
    Crossing c = k == 0 ? first : last;
    double t = k == 0 ? tIn : (k == 1 ? tOut : ts[k - 2]);
    bool ok;
    CurvePoint p;
    if (k < 2 && t == c.t) {
      p = k == 0 ? F : L;
      ok = k == 0 ? okF : okL;
    } else {
      ok = (k < 2 && okF && okL && pointBetween(F, L, t, p)) || invertAt(t, p);
    }
    if (!ok && k >= 2) return 1;
    okEnds = okEnds && ok;
    pts[k == 0 ? 0 : (k == 1 ? ns + 1 : k - 1)] = p;
  }
  if (!okEnds) return 1;
  g_sp = 0;
  for (int k = ns; k >= 0; --k) pushPiece(pts[k], pts[k + 1]);
  return 2;
}

// RayPatch::run.
bool runPatch() {
  g_gen = 0;
  g_sp = 0;
  g_eps = TRI.eps + TRI.kxy * (double(OBLONG_TRAV_RAY_ERR_FACTOR) *
                               (OBLONG_TRAV_RAY_ERR * (TRI.maxP + max(max(abs(g_O.x), abs(g_O.y)), abs(g_O.z)) +
                                                       abs(TRI.a) + abs(TRI.b))));
  precise double maxDil = max(g_eps.x, g_eps.y);
  g_wideEps = maxDil > OBLONG_TRAV_WIDE_EPS_REL * double(g_mesh.marchingScale);
  g_leafScale = g_wideEps ? max(double(g_mesh.marchingScale), OBLONG_TRAV_WIDE_LEAF_EPS * maxDil) : double(g_mesh.marchingScale);
  int r = setupCurve();
  if (r == 1) setupBoxOnly();
  if (r != 0) runLoop();
  return g_found;
}

// TraversalMesh::missesPrism, which Traversal::intersect runs before RayPatch: the CPU's
// own kernel (core/kernels/prism.h) on the host's boxes (TriGpu infPad*, obb*).
bool missesPrism() {
  double maxO = max(max(abs(g_O.x), abs(g_O.y)), abs(g_O.z));
  return missesPrism(double(g_tmin), double(g_tmax), maxO, TRI.budget, TRI.budgetPad, lengthD(g_D), g_O, g_D, g_invD,
                     TRI.infPadLo, TRI.infPadHi, TRI.obbValid != 0, TRI.obbAxis, TRI.obbLo, TRI.obbHi);
}

// RayPatch's constructor: per ray and triangle constants.
void initPatch(vec3 o, vec3 d, float tmin, float tmax) {
  g_tmin = tmin;
  g_tmax = tmax;
  g_O = dvec3(o);
  g_D = dvec3(d);
  g_invD = 1.0 / g_D;
  g_cellLo = TRI.cellLo;
  g_cellHi = TRI.cellHi;
  g_sbLo = TRI.sbLo;
  g_sbHi = TRI.sbHi;
  g_F.bc = TRI.bc;
  g_F.bX = TRI.bX;
  g_F.bY = TRI.bY;
  g_F.sc = TRI.sc;
  g_F.sU = TRI.sU;
  g_F.sV = TRI.sV;
  g_F.p0 = TRI.p0d;
  g_F.e1 = TRI.e1;
  g_F.e2 = TRI.e2;
  g_F.n0 = TRI.n0d;
  g_F.f1 = TRI.f1;
  g_F.f2 = TRI.f2;
  g_F.Pc = TRI.Pc;
  g_F.PX = TRI.PX;
  g_F.PY = TRI.PY;
  g_F.Nc = TRI.Nc;
  g_F.NX = TRI.NX;
  g_F.NY = TRI.NY;
  g_claim = ClaimBounds(TRI.domainB, TRI.domainS0, TRI.domainS1, TRI.kb, TRI.ks, TRI.kxy);
  double maxO = max(max(abs(g_O.x), abs(g_O.y)), abs(g_O.z));
  bool pre = maxO <= TRI.budget;
  // RayMargins::make(P, maxAbsVertex(T), maxO): this ray's own pads.
  precise double rayErr = OBLONG_TRAV_RAY_ERR * (TRI.maxP + maxO + abs(TRI.a) + abs(TRI.b));
  g_boxPad = TRI.vertexErr + rayErr;
  g_tAbs = double(OBLONG_TRAV_T_ABS_PADS) * g_boxPad / lengthD(g_D);
  if (pre) {  // TraversalMesh::prismBoxes, padded for the budget
    g_boxLo = TRI.boxPadLo;
    g_boxHi = TRI.boxPadHi;
  } else {
    g_boxLo = TRI.boxLo - dvec3(g_boxPad);
    g_boxHi = TRI.boxHi + dvec3(g_boxPad);
  }
  // The ray and the boxes in the texture frame (RayPatch: originT_, invDirT_, texPad_,
  // texPrismBox_; TextureFrame::pad).
  g_Ot = dvec3(dotD(TRI.texAxis[0], g_O), dotD(TRI.texAxis[1], g_O), dotD(TRI.texAxis[2], g_O));
  g_invDt = 1.0 / dvec3(dotD(TRI.texAxis[0], g_D), dotD(TRI.texAxis[1], g_D), dotD(TRI.texAxis[2], g_D));
  precise double texPad = 1.75 * g_boxPad + OBLONG_TRAV_OBB_ROUND * ((maxO + TRI.maxP + (abs(TRI.a) + abs(TRI.b))) + 1.0);
  g_texPad = texPad;
  double tMag = pre ? TRI.budget : maxO;
  tMag = tMag < TRI.texMag ? TRI.texMag : tMag;  // std::max
  precise double tPad = 1.75 * (pre ? TRI.budgetPad : g_boxPad) + OBLONG_TRAV_OBB_ROUND * (tMag + 1.0);
  g_texLo = TRI.texBoxLo - dvec3(tPad);
  g_texHi = TRI.texBoxHi + dvec3(tPad);
  g_dvd = dvec2(1.0);
  g_wr = makeWatertightRay(o, d);
  g_found = false;
  g_hitT = kInfF;
  g_boxes = 0;
  g_rangeQueries = 0;
  g_inversions = 0;
  g_cells = 0;
  g_microTris = 0;
  g_boxOnly = false;
}
