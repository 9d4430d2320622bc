// The traversal of a displaced triangle's prism for the intersection shader: the driver
// of core/kernels/ray_patch.h (the CPU's own code) with the GPU's hooks. What is the GPU's
// own: the triangle and mesh records (TRI, g_mesh), the closest hit, the inverter (the
// CPU's newton with its cubic fallback, core/kernels/invert.h: the cubic's cbrt / acos /
// cos are GLSL's, not bit-identical, and every curve point is validated by its residual
// either way), the splitter (midpoint2d, the one the Vulkan path runs), the range query
// over the mesh record's RMIP layers and the per-ray counters (the statistics registry is
// the CPU's). tests/vulkan_test.cpp holds it to the CPU step for step: same hits and the
// same per-ray work.

#include "core/kernels/constants.h"
#include "core/kernels/lang.h"
#include "core/kernels/patch_math.h"
#include "core/kernels/rect_bounds.h"
#include "core/kernels/prism.h"
#include "core/kernels/curve_point.h"
#include "core/kernels/invert.h"
#include "core/kernels/ray_patch.h"
#include "core/kernels/midpoint2d.h"
#include "core/kernels/quantize16.h"

// ---- the closest hit (ClosestHit) ------------------------------------------------------
bool g_found;
float g_hitT;
McVertex g_hv0, g_hv1, g_hv2;
vec3 g_hb;

// ---- RMIP range query: the kernel (core/kernels/rmip_query.h) over the mesh record's
// layer table and entries (bits 16: one word of codes; bits 32: two float words) --------
#define RmipAccess MeshGpu
#define RmipAcc vec2
#include "core/kernels/rmip_query.h"
float rmipDecode(MeshGpu m, uint code) { return decodeCode16(m.rmipBase, m.rmipStep, code); }
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

// ---- the hooks of core/kernels/ray_patch.h -------------------------------------------------
// RangeQuery::rawRange; under a λ per ray (LodBandQuery), the hull of this level's range
// and the next level's over the coarse samples around it (one call site for rmipRawRange).
vec2 rpRangeRaw(int sx0, int sy0, int sx1, int sy1) {
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
vec2 rpToHeight(vec2 raw) {
  precise float a = g_mesh.scale * (raw.x + g_mesh.bias), b = g_mesh.scale * (raw.y + g_mesh.bias);
  return vec2(min(a, b), max(a, b));
}
float rpRaw(int I, int J) { return mapAt(I, J); }
int rpCellMicro(int I, int J) { return microCell(I, J); }
// The inverter, in float as the CPU traversal calls Newton::invert.
void rpInvert(vec3 X, out vec2 bary, out float h) {
  InvFrameF F = invFrame(TRI.mc.p[0], TRI.mc.p[1], TRI.mc.p[2], TRI.mc.n[0], TRI.mc.n[1], TRI.mc.n[2]);
  bool fellBack;
  InvResultF r = newtonSolve(F, X, OBLONG_NEWTON_TOLERANCE, OBLONG_NEWTON_MAX_ITERATIONS, true,
                             OBLONG_NEWTON_FALLBACK_POLISH, fellBack);
  bary = vec2(r.u, r.v);
  h = r.h;
}
int rpSplit(CurvePoint a, CurvePoint b, inout int line, out CurvePoint m, out double t);  // after the driver
bool rpHitFound() { return g_found; }
float rpHitT() { return g_hitT; }
dvec2 rpHitUV() {
  precise dvec2 uv = double(g_hb.x) * dvec2(g_hv0.uv) + double(g_hb.y) * dvec2(g_hv1.uv) +
                     double(g_hb.z) * dvec2(g_hv2.uv);
  return uv;
}
dvec2 rpToSample(dvec2 uv) { return toSample(uv); }
// After the driver (they read its state):
void rpBoxOverRect(vec2 lo, vec2 hi, vec2 h, out vec3 blo, out vec3 bhi);
void rpInflatedBox(out dvec3 lo, out dvec3 hi);
PrismShape rpPrism();
void rpStat(int what) {}

// ---- the driver --------------------------------------------------------------------------
// The triangle's constants are read from its record where the driver uses them.
#define OBLONG_RP_TRIANGLE_RECORD
#define g_F TRI.F
#define g_N13 TRI.N13
#define g_claim TRI.claim
#define g_wellPosed (TRI.wellPosed != 0)
#define g_cellLo TRI.cellLo
#define g_cellHi TRI.cellHi
#define g_sbLo TRI.sbLo
#define g_sbHi TRI.sbHi
#define g_origin TRI.origin
#define OBLONG_HOOK(f) f
#define OBLONG_RP_STACK OBLONG_TRAV_STACK_GPU
#include "core/kernels/ray_patch_body.h"

double maxNormO() { return max(max(abs(g_O.x), abs(g_O.y)), abs(g_O.z)); }

void rpBoxOverRect(vec2 lo, vec2 hi, vec2 h, out vec3 blo, out vec3 bhi) {
  boxOverRectF(TRI.box, lo, hi, h.x, h.y, g_texPadF, blo, bhi);
}
// The inflated prism (RayMargins::prism): with the budget's margins within it (what
// TraversalMesh precomputes on the CPU), else with the ray's own.
PrismShape g_P;
RayMargin marginAt(double maxO) {
  return rayMargin(TRI.maxP, maxO, TRI.a, TRI.b, TRI.vertexErr, TRI.inflateS, TRI.inflateB, TRI.claim.kb, TRI.claim.ks);
}
void rpInflatedBox(out dvec3 lo, out dvec3 hi) {
  double maxO = maxNormO();
  RayMargin m = marginAt(maxO <= TRI.budget ? TRI.budget : maxO);
  g_P = prismInflated(g_F, m.lo, m.hi, m.delta);
  prismBox(g_P, lo, hi);  // Prism::bounds(), padded
  lo -= dvec3(m.boxPad);
  hi += dvec3(m.boxPad);
}
PrismShape rpPrism() { return g_P; }

// ClosestHit::test (microcells.glsl calls it per micro-triangle): closed range
// [tmin, min(tmax, t)], then strict, so that the first of equal-t hits wins.
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


// midpoint2d (strategies/midpoint2d.h): the crossing with the middle of the longer side,
// else of the other side (core/kernels/midpoint2d.h), else the t-midpoint by inversion.
int rpSplit(CurvePoint a, CurvePoint b, inout int line, out CurvePoint m, out double t) {
  m = a;
  t = 0.5 * (a.t + b.t);
  for (; line < 2; ++line) {
    int axis;
    double c;
    if (midpointLine(a, b, line, axis, c) && crossingOn(a, b, axis, c, m)) return 3;
  }
  return 2;
}

// TraversalMesh::missesPrism, which Traversal::intersect runs before RayPatch: the CPU's
// own kernel (core/kernels/prism.h) on the host's boxes (TriGpu infPad*, obb*).
bool missesPrism() {
  return missesPrism(double(g_tmin), double(g_tmax), maxNormO(), TRI.budget, TRI.budgetPad, lengthD(g_D), g_O, g_D,
                     g_invD, TRI.infPadLo, TRI.infPadHi, TRI.obbValid != 0, TRI.obbAxis, TRI.obbLo, TRI.obbHi);
}

// RayPatch's constructor: the ray and the triangle's record.
void initPatch(vec3 o, vec3 d, float tmin, float tmax) {
  g_tmin = tmin;
  g_tmax = tmax;
  g_O = dvec3(o);
  g_D = dvec3(d);
  g_invD = 1.0 / g_D;
  g_marchingScale = g_mesh.marchingScale;
  g_stackDepth = g_mesh.stackDepth;
  g_inversionInTraversal = g_mesh.inversionInTraversal != 0;
  double maxO = maxNormO();
  rpInit(marginAt(maxO), TRI.maxP, maxO, TRI.a, TRI.b, TRI.eps, TRI.claim.kxy, lengthD(g_D));
  bool pre = maxO <= TRI.budget;
  if (pre) {  // TraversalMesh::prismBoxes, padded for the budget
    g_boxLo = TRI.boxPadLo;
    g_boxHi = TRI.boxPadHi;
  } else {
    g_boxLo = TRI.boxLo - dvec3(g_boxPad);
    g_boxHi = TRI.boxHi + dvec3(g_boxPad);
  }
  // The ray and the exact prism's box in the texture frame (TraversalMesh::texPrismBox).
  dvec3 Ot = dvec3(dotD(TRI.texAxis[0], g_O), dotD(TRI.texAxis[1], g_O), dotD(TRI.texAxis[2], g_O));
  dvec3 Dt = dvec3(dotD(TRI.texAxis[0], g_D), dotD(TRI.texAxis[1], g_D), dotD(TRI.texAxis[2], g_D));
  g_bray = boxRayF(Ot, Dt, TRI.tPc);
  double tPad = texBoxPad(pre ? TRI.budgetPad : g_boxPad, pre ? TRI.budget : maxO, TRI.texMag);
  precise dvec3 tlo = TRI.texBoxLo - dvec3(tPad), thi = TRI.texBoxHi + dvec3(tPad);
  g_texLo = relBelowF(tlo, TRI.tPc);
  g_texHi = relAboveF(thi, TRI.tPc);
  g_wr = makeWatertightRay(o, d);
  g_found = false;
  g_hitT = kInfF;
}
