// The "tfdm" baseline (traversal/tfdm.cpp) for one ray and triangle: its traversal and
// node kernels are the CPU's own (core/kernels/tfdm_body.h, tfdm.h), as are the boxes
// (rect_bounds.h) and the micro-cells; here are its hooks: the pyramid's words in the mesh
// record, the boxes' pad and the counters. Needs traversal.glsl's per-ray state
// (initPatch: g_O, g_bray, g_texPadF, the closest hit and the counters).

// The pyramid (records.cpp): level L's row in the layer table, rmipLayers[m.rmipLayers +
// L] = (first node, width, height, 0), its nodes at m.rmipData (bits 16: one word of
// codes; bits 32: the lo and hi floats).
#define TfdmPyr MeshGpu
#include "core/kernels/tfdm.h"
uint tfdmFirst(MeshGpu m, int L) { return uint(rmipLayers[m.rmipLayers + uint(L)].x); }
ivec2 tfdmDims(MeshGpu m, int L) { return rmipLayers[m.rmipLayers + uint(L)].yz; }
uint tfdmCode(MeshGpu m, int L, uint at) { return rmipWordAt(m.rmipData + tfdmFirst(m, L) + at, m.chunkShift); }
vec2 tfdmPair(MeshGpu m, int L, uint at) {
  uint a = m.rmipData + 2u * (tfdmFirst(m, L) + at);
  return vec2(uintBitsToFloat(rmipWordAt(a, m.chunkShift)), uintBitsToFloat(rmipWordAt(a + 1u, m.chunkShift)));
}
vec2 tfdmDecode(MeshGpu m, uint w) {  // Quantizer16::decodePair
  if ((w & 0xffffu) > (w >> 16)) return vec2(kInfF, -kInfF);
  return vec2(rmipDecode(m, w & 0xffffu), rmipDecode(m, w >> 16));
}

vec2 tfdmHeights(int L, int x, int y) {
  return rpToHeight(tfdmNode(g_mesh, g_mesh.rmipBits, g_mesh.tfStored - 1, L, x, y));
}
void tfdmBox(vec2 lo, vec2 hi, vec2 h, out vec3 blo, out vec3 bhi) { rpBoxOverRect(lo, hi, h, blo, bhi); }
double tfdmLimit() { return limitNow(); }
int tfdmLeaf(int x, int y) { return microCell(x, y); }
#include "core/kernels/tfdm_body.h"

// Tfdm::intersect after the prism's set-up (initPatch, whose g_texPad is tfdm's boxes'
// pad): the t slack of that pad. Returns whether a micro-triangle was hit (the closest,
// in g_hitT and g_hv*).
bool runTfdm() {
  g_tAbs = tSlackAbs(g_texPad, lengthD(g_D));
  TfdmWork w;
  tfdmTraverse(TRI.cellLo + TRI.origin, TRI.cellHi + TRI.origin, TRI.origin, TRI.edges.S[0], TRI.edges.S[1], TRI.edges.S[2], TRI.sbLo,
               TRI.sbHi, dirLocal(), g_bray, double(g_tmin) - slack(double(g_tmin)), w);
  g_boxes = w.boxes;
  g_rangeQueries = w.boxes;
  g_cells = w.leaves;
  g_microTris = w.microTris;
  return g_found;
}
