// The micro-geometry cell by cell (docs/design.md §1): a line-for-line GLSL port of
// core/microgeometry.cpp's MicroCells::cell (interior cells, Sutherland-Hodgman clipping
// against T's edges with the line bookkeeping, canonical edge evaluation; the CPU skips
// the clips against edges whose half-plane holds the whole cell and reuses cached grid
// points, which yields the same triangles bit for bit — the parity tests compare them
// with this port, which clips against all three); the watertight ray/micro-triangle test
// is the CPU's own (core/kernels/microtri.h). Every float and double
// operation is `precise` (SPIR-V NoContraction): no fused multiply-add, so the
// micro-vertices, edge functions and t come out as the CPU computes them, which both
// watertightness and CPU/GPU parity rely on. Needs the globals of traversal.glsl:
// g_tri, g_mesh, the ray (g_wr) and the closest hit (g_hit*).

#include "core/kernels/lang.h"
#include "core/kernels/microtri.h"
#include "core/kernels/texels.h"  // wrapIndex

// ---- height map (core/heightmap.h) --------------------------------------------------
float levelAt(MeshGpu m, int i, int j) {  // HeightMap::at of a record's map
  return texelAt(m.texelOffset + uint(wrapIndex(j, m.H)) * uint(m.W) + uint(wrapIndex(i, m.W)), m.chunkShift);
}
// std::min, std::max and std::clamp as the CPU evaluates them (which argument wins a tie).
float minCpp(float a, float b) { return b < a ? b : a; }
float maxCpp(float a, float b) { return a < b ? b : a; }
float clampCpp(float v, float lo, float hi) { return v < lo ? lo : hi < v ? hi : v; }
// Displacement::lodHeight: level k's height h at its point (i, j), blended by f toward
// level k + 1's micro-geometry there (g_next).
float lodHeight(float h, int i, int j, float f) {
  int a = i >> 1, b = j >> 1;
  float p = levelAt(g_next, a, b);
  bool ei = (i & 1) == 0, ej = (j & 1) == 0;
  float q = ei && ej ? p : ej ? levelAt(g_next, a + 1, b) : ei ? levelAt(g_next, a, b + 1) : levelAt(g_next, a + 1, b + 1);
  precise float s = 0.5 * (p + q);
  float L = clampCpp(s, minCpp(p, q), maxCpp(p, q));
  precise float w = (1.0 - f) * h + f * L;
  return clampCpp(w, minCpp(h, L), maxCpp(h, L));
}
// Displacement::raw: the ray's blend fraction g_blend is 0 unless it has a λ per ray.
float mapAt(int i, int j) {
  float h = levelAt(g_mesh, i, j);
  return g_blend == 0.0 ? h : lodHeight(h, i, j, g_blend);
}
// A λ per ray (PerRayLod::intersect, Displacement::blendOf): the record of level ⌊λ⌋
// (λ clamped to [0, last level]; NaN: 0) and the fraction toward the next level.
void selectLevel(float rayLod) {
  float l = rayLod > 0.0 ? rayLod : 0.0;
  int k = int(min(floor(l), float(g_mesh.lodLevels - 1)));
  g_mesh = meshes[g_mesh.lodFirst + uint(k)];
  if (g_mesh.lodNext < 0) return;
  g_next = meshes[g_mesh.lodNext];
  if (rayLod > g_mesh.lod) g_blend = min(float(double(rayLod) - double(g_mesh.lod)), 1.0);
}
// Displacement::sampleToUV
vec2 sampleToUV(int i, int j) {
  precise double x = (double(i) + double(g_mesh.sampleOffset)) / (double(g_mesh.W) * double(g_mesh.tiling.x));
  precise double y = (double(j) + double(g_mesh.sampleOffset)) / (double(g_mesh.H) * double(g_mesh.tiling.y));
  return vec2(float(x), float(y));
}
// Displacement::toSample
dvec2 toSample(dvec2 uv) {
  precise dvec2 r = dvec2(uv.x * double(g_mesh.tiling.x) * double(g_mesh.W) - double(g_mesh.sampleOffset),
                          uv.y * double(g_mesh.tiling.y) * double(g_mesh.H) - double(g_mesh.sampleOffset));
  return r;
}
// Displacement::microAtSample
float microAtSample(dvec2 s) {
  precise double fi = floor(s.x), fj = floor(s.y);
  int i = int(fi), j = int(fj);
  precise float fx = float(s.x - fi), fy = float(s.y - fj);
  precise float h00 = mapAt(i, j), h11 = mapAt(i + 1, j + 1);
  precise float H;
  if (fx >= fy) {
    precise float h10 = mapAt(i + 1, j);
    H = h00 + fx * (h10 - h00) + fy * (h11 - h10);
  } else {
    precise float h01 = mapAt(i, j + 1);
    H = h00 + fy * (h01 - h00) + fx * (h11 - h01);
  }
  precise float r = g_mesh.scale * (H + g_mesh.bias);
  return r;
}

// ---- float helpers as glm computes them (lengthF, crossF: core/kernels/lang.h) ------
vec3 normalizeF(vec3 v) {  // glm::normalize: v * (1 / sqrt(dot(v, v)))
  precise float d = v.x * v.x + v.y * v.y + v.z * v.z;
  precise float inv = 1.0 / sqrt(d);
  precise vec3 r = v * inv;
  return r;
}
vec3 triP(float u, float v) {  // DisplacedTriangle::P
  precise float w = 1.0 - u - v;
  precise vec3 r = w * TRI.p[0] + u * TRI.p[1] + v * TRI.p[2];
  return r;
}
vec3 triN(float u, float v) {
  precise float w = 1.0 - u - v;
  precise vec3 r = w * TRI.n[0] + u * TRI.n[1] + v * TRI.n[2];
  return r;
}
vec2 baryOfUV(vec2 uv) {  // uvToBary * (uv - t0), glm::mat2 * vec2
  precise vec2 q = uv - TRI.t[0];
  precise vec4 m = TRI.uvToBary;
  precise vec2 r = vec2(m.x * q.x + m.z * q.y, m.y * q.x + m.w * q.y);
  return r;
}

// ---- MicroCells ----------------------------------------------------------------------
#define KIND_GRID 0
#define KIND_TVERTEX 1
#define KIND_CROSS 2
#define LINE_V 0
#define LINE_H 1
#define LINE_D 2
#define LINE_EDGE 3

struct PV {
  dvec2 s;
  int kind;
  int a, b;
  int lineType, lineC;  // Cross: the grid line crossed
  int nextType, nextC;  // line carrying the polygon edge to the next vertex
};

struct MicroVertex {
  vec3 p;
  vec2 uv;
};

bool pvSame(PV v, PV o) {
  if (v.kind != o.kind) return false;
  if (v.kind == KIND_CROSS) return v.a == o.a && v.lineType == o.lineType && v.lineC == o.lineC;
  return v.a == o.a && (v.kind == KIND_TVERTEX || v.b == o.b);
}

double orient2(dvec2 a, dvec2 b, dvec2 p) {
  precise double r = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
  return r;
}
dvec2 edgeSA(int e) { return TRI.S[TRI.edgeA[e]]; }
dvec2 edgeSB(int e) { return TRI.S[TRI.edgeB[e]]; }
bool insideEdge(int e, dvec2 p) {
  precise double o = double(TRI.edgeSigma[e]) * orient2(edgeSA(e), edgeSB(e), p);
  return o >= 0.0;
}
bool strictlyInside(dvec2 p) {
  for (int e = 0; e < 3; ++e) {
    precise double o = double(TRI.edgeSigma[e]) * orient2(edgeSA(e), edgeSB(e), p);
    if (!(o > 0.0)) return false;
  }
  return true;
}
double crossParamRaw(int e, int type, int c) {
  precise dvec2 a = edgeSA(e), b = edgeSB(e);
  precise double t;
  if (type == LINE_V) t = (double(c) - a.x) / (b.x - a.x);
  else if (type == LINE_H) t = (double(c) - a.y) / (b.y - a.y);
  else t = (double(c) - (a.x - a.y)) / ((b.x - b.y) - (a.x - a.y));
  return (isinf(t) || isnan(t)) ? 0.0 : t;
}
double crossParam(int e, int type, int c) { return clamp(crossParamRaw(e, type, c), 0.0, 1.0); }

MicroVertex onEdge(int e, double t, float rawHeight) {
  int A = TRI.edgeA[e], B = TRI.edgeB[e];
  precise float tf = float(t);
  precise float w = 1.0 - tf;
  precise vec3 P = w * TRI.p[A] + tf * TRI.p[B];
  precise vec3 N = w * TRI.n[A] + tf * TRI.n[B];
  precise float h = g_mesh.scale * (rawHeight + g_mesh.bias);
  precise vec3 pos = P + h * normalizeF(N);
  precise vec2 uv = w * TRI.t[A] + tf * TRI.t[B];
  return MicroVertex(pos, uv);
}

float lineHeight(int type, int c, dvec2 s) {
  precise float r;
  if (type == LINE_V) {
    int j = int(floor(s.y));
    precise float f = float(s.y - double(j));
    r = mapAt(c, j) + f * (mapAt(c, j + 1) - mapAt(c, j));
  } else if (type == LINE_H) {
    int i = int(floor(s.x));
    precise float f = float(s.x - double(i));
    r = mapAt(i, c) + f * (mapAt(i + 1, c) - mapAt(i, c));
  } else {
    int j = int(floor(s.y)), i = j + c;
    precise float f = float(s.y - double(j));
    r = mapAt(i, j) + f * (mapAt(i + 1, j + 1) - mapAt(i, j));
  }
  return r;
}

MicroVertex gridInterior(int i, int j) {
  precise float raw = mapAt(i, j);
  precise vec2 uv = sampleToUV(i, j);
  precise vec2 b = baryOfUV(uv);
  precise vec3 N = triN(b.x, b.y);
  precise float h = g_mesh.scale * (raw + g_mesh.bias);
  precise vec3 pos = triP(b.x, b.y) + h * normalizeF(N);
  return MicroVertex(pos, uv);
}

// MicroCells::world. One call site per helper (NIR inlines every call: code size is
// compile time on lavapipe), so the edge cases pick (edge, t, height) and share onEdge.
MicroVertex worldPV(PV v) {
  if (v.kind == KIND_TVERTEX) {
    int k = v.a;
    precise float h = microAtSample(TRI.S[k]);
    precise vec3 pos = TRI.p[k] + h * TRI.n[k];
    return MicroVertex(pos, TRI.t[k]);
  }
  int edge = -1;
  precise double t = 0.0;
  float raw = 0.0;
  if (v.kind == KIND_CROSS) {
    edge = v.a;
    t = crossParam(v.a, v.lineType, v.lineC);
    precise dvec2 s = edgeSA(v.a) + t * (edgeSB(v.a) - edgeSA(v.a));
    raw = lineHeight(v.lineType, v.lineC, s);
  } else {
    // A grid point exactly on an edge of T is computed from that edge alone.
    for (int e = 0; e < 3 && edge < 0; ++e)
      if (orient2(edgeSA(e), edgeSB(e), v.s) == 0.0) {
        precise dvec2 ab = edgeSB(e) - edgeSA(e);
        precise dvec2 q = v.s - edgeSA(e);
        t = clamp((q.x * ab.x + q.y * ab.y) / (ab.x * ab.x + ab.y * ab.y), 0.0, 1.0);
        raw = mapAt(v.a, v.b);
        edge = e;
      }
    if (edge < 0) return gridInterior(v.a, v.b);
  }
  return onEdge(edge, t, raw);
}

// Polygon buffers of MicroCells::clipped (two of 8; Sutherland-Hodgman ping-pongs).
PV g_pv[16];

PV gridPV(int i, int j, int nextType, int nextC) {
  PV v;
  v.s = dvec2(i, j);
  v.kind = KIND_GRID;
  v.a = i;
  v.b = j;
  v.lineType = 0;
  v.lineC = 0;
  v.nextType = nextType;
  v.nextC = nextC;
  return v;
}

// MicroCells::clip: polygon at g_pv[inBase..] against edge e into g_pv[outBase..].
int clipPoly(int e, int inBase, int n, int outBase) {
  int m = 0;
  for (int k = 0; k < n; ++k) {
    PV a = g_pv[inBase + k];
    PV b = g_pv[inBase + (k + 1) % n];
    bool ia = insideEdge(e, a.s), ib = insideEdge(e, b.s);
    if (ia) g_pv[outBase + m++] = a;
    if (ia != ib) {
      PV x;
      x.lineType = 0;
      x.lineC = 0;
      if (a.nextType == LINE_EDGE) {
        int e2 = a.nextC;
        int k3 = (e2 + 1) % 3 == e ? e : ((e + 1) % 3 == e2 ? e2 : -1);
        x.kind = KIND_TVERTEX;
        x.a = k3 >= 0 ? k3 : 0;
        x.b = 0;
        x.s = TRI.S[x.a];
      } else {
        x.kind = KIND_CROSS;
        x.a = e;
        x.b = 0;
        x.lineType = a.nextType;
        x.lineC = a.nextC;
        precise double t = crossParamRaw(e, a.nextType, a.nextC);
        x.s = edgeSA(e) + t * (edgeSB(e) - edgeSA(e));
      }
      if (ia) {
        x.nextType = LINE_EDGE;
        x.nextC = e;
      } else {
        x.nextType = a.nextType;
        x.nextC = a.nextC;
      }
      g_pv[outBase + m++] = x;
    }
  }
  return m;
}

bool cellInterior(int i, int j) {
  for (int k = 0; k < 4; ++k)
    if (!strictlyInside(dvec2(i + (k & 1), j + (k >> 1)))) return false;
  return true;
}

void testMicro(MicroVertex v0, MicroVertex v1, MicroVertex v2);  // traversal.glsl

// MicroCells::cell, each micro-triangle tested as it is emitted (same order as the
// CPU's buffer). Returns how many. An interior cell (four corners strictly inside T)
// is the fan of its corners (v00, v10, v11, v01): the CPU's two triangles (v00, v10,
// v11), (v00, v11, v01); its corners go through worldPV, whose on-edge test fails for
// points strictly inside, so they come from gridInterior as on the CPU. One loop and
// one call site for the vertices and the test keep the inlined shader small.
int microCell(int i, int j) {
  if (TRI.uvArea2 == 0.0) return 0;
  bool interior = cellInterior(i, j);
  int count = 0;
  for (int hf = 0; hf < (interior ? 1 : 2); ++hf) {
    int poly = 0, tmp = 8;
    int m = 0;
    if (interior) {
      g_pv[tmp + 0] = gridPV(i, j, LINE_H, j);
      g_pv[tmp + 1] = gridPV(i + 1, j, LINE_V, i + 1);
      g_pv[tmp + 2] = gridPV(i + 1, j + 1, LINE_H, j + 1);
      g_pv[tmp + 3] = gridPV(i, j + 1, LINE_V, i);
      m = 4;
    } else {
      int n = 0;
      if (hf == 0) {  // lower: (i,j) (i+1,j) (i+1,j+1)
        g_pv[poly + n++] = gridPV(i, j, LINE_H, j);
        g_pv[poly + n++] = gridPV(i + 1, j, LINE_V, i + 1);
        g_pv[poly + n++] = gridPV(i + 1, j + 1, LINE_D, i - j);
      } else {  // upper: (i,j) (i+1,j+1) (i,j+1)
        g_pv[poly + n++] = gridPV(i, j, LINE_D, i - j);
        g_pv[poly + n++] = gridPV(i + 1, j + 1, LINE_H, j + 1);
        g_pv[poly + n++] = gridPV(i, j + 1, LINE_V, i);
      }
      for (int e = 0; e < 3 && n > 0; ++e) {
        n = clipPoly(e, poly, n, tmp);
        int s = poly;
        poly = tmp;
        tmp = s;
      }
      // Drop repeated vertices (a grid point on an edge can appear twice).
      for (int k = 0; k < n; ++k)
        if (m == 0 || !pvSame(g_pv[poly + k], g_pv[tmp + m - 1])) g_pv[tmp + m++] = g_pv[poly + k];
      while (m > 1 && pvSame(g_pv[tmp], g_pv[tmp + m - 1])) --m;
    }
    if (m < 3) continue;
    int nv = min(m, 8);
    MicroVertex w[8];
    for (int k = 0; k < nv; ++k) w[k] = worldPV(g_pv[tmp + k]);
    for (int k = 1; k + 1 < nv; ++k) {
      testMicro(w[0], w[k], w[k + 1]);
      ++count;
    }
  }
  return count;
}

// ---- watertight ray / micro-triangle test: the CPU's own code (core/kernels/microtri.h) --
WatertightRay g_wr;

