// The "tfdm" baseline (Thonat et al. 2021, as traversal/tfdm.cpp traverses) for one ray
// and triangle: roots, 2D node rejection, boxes in T's texture frame, children in a fixed
// order, leaves tested with the shared micro-cells, no early exit. The node kernels are the
// CPU's own (core/kernels/tfdm.h), as are the boxes (rect_bounds.h), the micro-cells and the
// micro-triangle test; what is written here is the pyramid's fetch and the node stack.
// Needs traversal.glsl's per-ray state (initPatch: g_O, g_Ot, g_invDt, g_boxPad, g_tAbs,
// the closest hit and the counters).

#include "core/kernels/tfdm.h"

// The pyramid (records.cpp): level L's row in the layer table, rmipLayers[m.rmipLayers +
// L] = (first node, width, height, 0), its nodes at m.rmipData (bits 16: one word of
// codes decoded with m.rmipBase + code · m.rmipStep; bits 32: the lo and hi floats).
int tfWrap(int i, int n) {  // i mod n in [0, n)
  int r = i - (i / n) * n;
  return r < 0 ? r + n : r;
}
uint tfIndex(ivec4 d, int x, int y) { return uint(d.x) + uint(tfWrap(y, d.z)) * uint(d.y) + uint(tfWrap(x, d.y)); }
uint tfCodes(uint at) { return rmipWordAt(g_mesh.rmipData + at, g_mesh.chunkShift); }
vec2 tfFloats(uint at) {
  uint a = g_mesh.rmipData + 2u * at;
  return vec2(uintBitsToFloat(rmipWordAt(a, g_mesh.chunkShift)), uintBitsToFloat(rmipWordAt(a + 1u, g_mesh.chunkShift)));
}
vec2 tfDecode(uint w) {  // Quantizer16::decodePair
  if ((w & 0xffffu) > (w >> 16)) return vec2(kInfF, -kInfF);
  return vec2(rmipDecode(g_mesh, w & 0xffffu), rmipDecode(g_mesh, w >> 16));
}
// CellPyramid::node: the raw [min, max] over node (x, y) of level L; above the stored
// levels, the union of the stored nodes it covers (the host refuses maps where that is
// more than CellPyramid::kMaxFold nodes).
vec2 tfNode(int L, int x, int y) {
  int s = g_mesh.tfStored - 1;
  int k = L <= s ? 0 : L - s;
  ivec4 d = rmipLayers[g_mesh.rmipLayers + uint(L - k)];
  int nx = k >= 30 ? d.y : min(1 << k, d.y), ny = k >= 30 ? d.z : min(1 << k, d.z);
  uint c = 0xffffu;
  vec2 r = vec2(kInfF, -kInfF);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      uint at = tfIndex(d, (x << k) + i, (y << k) + j);
      if (g_mesh.rmipBits == 16) {
        c = joinCodes16(c, tfCodes(at));
      } else {
        vec2 v = tfFloats(at);
        r = vec2(minCpp(r.x, v.x), maxCpp(r.y, v.y));
      }
    }
  return g_mesh.rmipBits == 16 ? tfDecode(c) : r;
}

// Tfdm::intersect after the prism's set-up (initPatch). Returns whether a micro-triangle
// was hit (the closest, in g_hitT and g_hv*).
ivec3 g_tfStack[OBLONG_TFDM_STACK];
bool runTfdm() {
  precise double maxO = max(max(abs(g_O.x), abs(g_O.y)), abs(g_O.z));
  // TextureFrame::pad(boxPad, maxO + maxAbsVertex(T) + |a| + |b|).
  precise double mag = maxO + TRI.maxP + abs(TRI.a) + abs(TRI.b);
  double boxPad = texFramePad(g_boxPad, mag);
  g_tAbs = double(OBLONG_TRAV_T_ABS_PADS) * boxPad / lengthD(g_D);  // tfdm's t slack: from the frame's pad
  double mMin = double(TRI.minNormalLength);
  double sigma = tfdmSigma(TRI.S[0], TRI.S[1], TRI.S[2]);
  dvec2 dl = dirLocal();
  int ax = dl.x < 0.0 ? 1 : 0, ay = dl.y < 0.0 ? 1 : 0;
  ivec2 cLo = TRI.cellLo + TRI.origin, cHi = TRI.cellHi + TRI.origin;
  int L0 = tfdmRootLevel(cLo, cHi);
  ivec2 r0 = ivec2(cLo.x >> L0, cLo.y >> L0), r1 = ivec2(cHi.x >> L0, cHi.y >> L0);
  // The fixed order of children (and roots): nearest the ray's start first.
  ivec2 order[4] = ivec2[4](ivec2(ax, ay), ivec2(ax, 1 - ay), ivec2(1 - ax, ay), ivec2(1 - ax, 1 - ay));
  int sp = 0;
  for (int k = 3; k >= 0; --k) {
    ivec2 p = ivec2(order[k].x != 0 ? r1.x : r0.x, order[k].y != 0 ? r1.y : r0.y);
    bool dup = false;
    for (int q = 0; q < k; ++q)
      dup = dup || (ivec2(order[q].x != 0 ? r1.x : r0.x, order[q].y != 0 ? r1.y : r0.y) == p);
    if (dup) continue;
    g_tfStack[sp++] = ivec3(p, L0);
  }
  while (sp > 0) {
    ivec3 n = g_tfStack[--sp];
    ivec2 clo, chi;
    if (!tfdmNodeCells(n.x, n.y, n.z, cLo, cHi, clo, chi)) continue;
    if (tfdmOutside(TRI.S[0], TRI.S[1], TRI.S[2], sigma, double(clo.x), double(clo.y), double(chi.x + 1),
                    double(chi.y + 1)))
      continue;
    ++g_boxes;
    ++g_rangeQueries;
    vec2 h = rpToHeight(tfNode(n.z, n.x, n.y));
    dvec2 lo = max(dvec2(double(clo.x - TRI.origin.x), double(clo.y - TRI.origin.y)), TRI.sbLo);
    dvec2 hi = min(dvec2(double(chi.x + 1 - TRI.origin.x), double(chi.y + 1 - TRI.origin.y)), TRI.sbHi);
    dvec3 blo, bhi;
    boxOverRect(TRI.tPc, TRI.tPX, TRI.tPY, TRI.tNc, TRI.tNX, TRI.tNY, mMin, lo, hi, double(h.x), double(h.y), boxPad,
                blo, bhi);
    double t0 = double(g_tmin) - slack(double(g_tmin)), t1 = bestLimit();
    clipBox(blo, bhi, g_Ot, g_invDt, t0, t1);
    if (!(t0 <= t1)) continue;
    if (n.z == 0) {
      ++g_cells;
      g_microTris += microCell(n.x, n.y);
      continue;
    }
    for (int k = 3; k >= 0; --k) g_tfStack[sp++] = ivec3(2 * n.x + order[k].x, 2 * n.y + order[k].y, n.z - 1);
  }
  return g_found;
}
