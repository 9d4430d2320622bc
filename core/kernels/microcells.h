// The micro-geometry cell by cell (docs/design.md §1), written once for MicroCells
// (core/microgeometry.h: the oracle, the tessellated baseline and the CPU traversal) and
// the Vulkan shaders: each cell of the sample grid split by its diagonal (i,j)-(i+1,j+1),
// each half clipped in sample coordinates against T's edges (Sutherland-Hodgman,
// tracking the line each polygon edge lies on), every vertex mapped by Eq. 1.
//
// Watertightness: every vertex on an edge of T (edge/grid-line crossings, grid points
// exactly on the edge, T's vertices) is computed from that edge alone, with its
// endpoints in a canonical order (lexicographic in uv), so the two triangles sharing an
// edge produce bit-identical points along it.
//
// The storage is each side's own, as in rmip_query.h:
//   - the polygon buffer (McBuf, 16 vertices: two of kMcPoly that Sutherland-Hodgman
//     ping-pongs), element k written OBLONG_MC_AT(buf, k): in C++ a pointer, in GLSL a
//     private array this header declares;
//   - the heights, a type McHeights with three functions the includer provides (C++:
//     template parameter; GLSL: a macro naming a type, functions defined after this
//     header, which declares them):
//       float mcRaw(McHeights h, int i, int j)          raw texel of sample (i, j)
//       bool mcGridCached(McHeights h, int i, int j, out McVertex v)  a grid point inside T
//                                     when the includer keeps it (the CPU's cache; GLSL: none)
//       vec2 mcGridUV(McHeights h, int i, int j)        Displacement::sampleToUV
// Every operation is OBLONG_PRECISE: no fused multiply-add in the shaders, so vertices
// come out as the CPU computes them, which watertightness and parity rely on.
#ifndef OBLONG_KERNELS_MICROCELLS_H
#define OBLONG_KERNELS_MICROCELLS_H

#include "core/kernels/heights.h"  // the micro-triangle at a sample point
#include "core/kernels/lang.h"

// Where a polygon vertex comes from (decides how its world position is computed).
#define OBLONG_MC_GRID 0     // grid point (a, b) = (i, j)
#define OBLONG_MC_TVERTEX 1  // vertex a of T
#define OBLONG_MC_CROSS 2    // edge a of T crossing the grid line (lineType, lineC)
// Lines of the construction: grid verticals x = c, horizontals y = c, diagonals x - y = c
// (sample coordinates), and edge c of T.
#define OBLONG_MC_LINE_V 0
#define OBLONG_MC_LINE_H 1
#define OBLONG_MC_LINE_D 2
#define OBLONG_MC_LINE_EDGE 3
// Vertices of one polygon buffer: a triangle clipped by three half-planes has at most 6.
#define OBLONG_MC_POLY 8

OBLONG_KERNELS_BEGIN

struct McPV {
  dvec2 s;  // sample coordinates (for the side tests)
  int kind;
  int a, b;
  int lineType, lineC;  // OBLONG_MC_CROSS: the grid line crossed
  int nextType, nextC;  // the line carrying the polygon edge to the next vertex
};

// T in sample coordinates: per edge e (joining vertices e and e+1), its canonical
// endpoints A, B, the sign sigma of orient(S[A], S[B], opposite vertex) (the inside), and
// the corner of a cell (offset 0 or 1 on each axis) where sigma·orient, as computed, is
// least: every rounding step of orient is monotone in each coordinate of the point, so it
// is the same corner for every cell.
struct McEdges {
  dvec2 S[3];
  dvec2 SA[3], SB[3];  // S[A[e]], S[B[e]]: read for every cell
  int A[3], B[3];
  double sigma[3];
  ivec2 least[3];
};

// T's float data as the micro-vertices read it (DisplacedTriangle), with the height
// transform of its displacement (height = scale · (raw + bias)).
struct McTri {
  vec3 p[3], n[3];
  vec2 t[3];
  // T's barycentrics (u, v) of sample point (i, j): bc + bX·(i − origin.x) + bY·(j − origin.y),
  // an affine map computed in double from T's sample coordinates (mcBaryMap) and rounded
  // to float: a grid point's barycentrics come from its integer offset, not from its
  // rounded uv (whose rounding, at a fine texel, was most of the micro-vertices' error).
  vec2 bc, bX, bY;
  ivec2 origin;
  float scale, bias;
};

struct McVertex {
  vec3 p;   // position (the mesh's frame)
  vec2 uv;  // texture coordinates (before tiling)
};

#ifdef __cplusplus
using McBuf = McPV*;
#define OBLONG_MC_AT(buf, k) (buf)[k]
#else
#ifndef McHeights
#define McHeights int  // the shaders' heights are globals (render/vulkan/shaders/microcells.glsl)
#endif
McPV g_mcBuf[2 * OBLONG_MC_POLY];
#define McBuf int
#define OBLONG_MC_AT(buf, k) g_mcBuf[k]
float mcRaw(McHeights h, int i, int j);
bool mcGridCached(McHeights h, int i, int j, out McVertex v);
vec2 mcGridUV(McHeights h, int i, int j);
#endif

OBLONG_FORCE_INLINE double mcOrient(OBLONG_IN(dvec2) a, OBLONG_IN(dvec2) b, OBLONG_IN(dvec2) p) {
  OBLONG_PRECISE double r = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
  return r;
}

OBLONG_INLINE bool mcUvLess(OBLONG_IN(vec2) a, OBLONG_IN(vec2) b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }

// S: T's vertices in sample coordinates (Displacement::toSample of t).
OBLONG_INLINE McEdges mcEdges(OBLONG_IN_ARRAY dvec2 S[3], OBLONG_IN_ARRAY vec2 t[3]) {
  McEdges E;
  for (int k = 0; k < 3; ++k) E.S[k] = S[k];
  for (int e = 0; e < 3; ++e) {
    int A = e, B = (e + 1) % 3;
    if (mcUvLess(t[B], t[A])) {
      int s = A;
      A = B;
      B = s;
    }
    E.A[e] = A;
    E.B[e] = B;
    E.SA[e] = S[A];
    E.SB[e] = S[B];
    E.sigma[e] = mcOrient(S[A], S[B], S[3 - A - B]) > 0.0 ? 1.0 : -1.0;
    // sigma·orient grows with x where sigma·(SB − SA).y < 0 and with y where sigma·(SB − SA).x > 0.
    OBLONG_PRECISE dvec2 d = S[B] - S[A];
    E.least[e] = ivec2(E.sigma[e] * d.y < 0.0 ? 0 : 1, E.sigma[e] * d.x > 0.0 ? 0 : 1);
  }
  return E;
}

// McTri's barycentric map from T's vertices S in sample coordinates: the exact inverse of
// the affine map b -> S (in double, then rounded to float), anchored at the sample below
// and left of T's lowest coordinates, so that a grid point's offsets from it are small
// integers. sum bounds |bc| + |bX|·x + |bY|·y per component over T's sample box (x, y its
// offsets from the anchor), the scale of the float evaluation's error
// (traversal/prism.cpp, vertexErr).
OBLONG_INLINE void mcBaryMap(OBLONG_IN_ARRAY dvec2 S[3], OBLONG_INOUT(McTri) T, OBLONG_OUT(double) sum) {
  double lim = 1e9;  // keeps the int conversion defined for absurd tilings
  dvec2 lo = min(min(S[0], S[1]), S[2]), hi = max(max(S[0], S[1]), S[2]);
  ivec2 o = ivec2(int(clamp(floor(lo.x), -lim, lim)), int(clamp(floor(lo.y), -lim, lim)));
  OBLONG_PRECISE dvec2 sU = S[1] - S[0], sV = S[2] - S[0];
  OBLONG_PRECISE double det = sU.x * sV.y - sU.y * sV.x;
  double id = det != 0.0 ? 1.0 / det : 0.0;
  OBLONG_PRECISE dvec2 bX = dvec2(sV.y * id, -sU.y * id), bY = dvec2(-sV.x * id, sU.x * id);
  OBLONG_PRECISE dvec2 s0 = S[0] - dvec2(o);
  OBLONG_PRECISE dvec2 bc = -(bX * s0.x + bY * s0.y);
  T.bc = vec2(bc);
  T.bX = vec2(bX);
  T.bY = vec2(bY);
  T.origin = o;
  OBLONG_PRECISE dvec2 ext = max(hi - dvec2(o), dvec2(0.0)) + 1.0;
  OBLONG_PRECISE dvec2 m = abs(bc) + abs(bX) * ext.x + abs(bY) * ext.y;
  sum = max(m.x, m.y);
}

// sigma·orient of p against edge e.
OBLONG_FORCE_INLINE double mcSide(OBLONG_IN(McEdges) E, int e, OBLONG_IN(dvec2) p) {
  OBLONG_PRECISE double r = E.sigma[e] * mcOrient(E.SA[e], E.SB[e], p);
  return r;
}
OBLONG_FORCE_INLINE bool mcInside(OBLONG_IN(McEdges) E, int e, OBLONG_IN(dvec2) p) { return mcSide(E, e, p) >= 0.0; }

// The cell's four corners lie strictly inside every edge (tested at each edge's least corner).
OBLONG_FORCE_INLINE bool mcInterior(OBLONG_IN(McEdges) E, int i, int j) {
  for (int e = 0; e < 3; ++e)
    if (!(mcSide(E, e, dvec2(i + E.least[e].x, j + E.least[e].y)) > 0.0)) return false;
  return true;
}

// The edges a cell is clipped against (bit e): not those whose inner half-plane holds the
// whole cell with a margin. Sutherland-Hodgman returns an all-inside polygon unchanged
// (same vertices, same order), and every vertex the other clips create lies in the cell up
// to rounding far below the margin. A cell on one edge of T clips once per half instead
// of three times.
OBLONG_INLINE int mcClipMask(OBLONG_IN(McEdges) E, int i, int j) {
  int mask = 0;
  for (int e = 0; e < 3; ++e) {
    dvec2 SA = E.SA[e];
    OBLONG_PRECISE dvec2 d = E.SB[e] - SA;
    OBLONG_PRECISE double margin =
        1e-9 * (abs(d.x) + abs(d.y)) * (1.0 + abs(double(i)) + abs(double(j)) + abs(SA.x) + abs(SA.y));
    if (!(mcSide(E, e, dvec2(i + E.least[e].x, j + E.least[e].y)) > margin)) mask |= 1 << e;
  }
  return mask;
}

// Parameter along edge e's line (canonical direction) where it meets grid line (type, c).
// Not clamped: Sutherland-Hodgman clips against whole lines, and an intermediate crossing
// may lie beyond T's vertices (later clips remove it).
OBLONG_INLINE double mcCrossParamRaw(OBLONG_IN(McEdges) E, int e, int type, int c) {
  dvec2 a = E.SA[e], b = E.SB[e];
  OBLONG_PRECISE double t;
  if (type == OBLONG_MC_LINE_V) t = (double(c) - a.x) / (b.x - a.x);
  else if (type == OBLONG_MC_LINE_H) t = (double(c) - a.y) / (b.y - a.y);
  else t = (double(c) - (a.x - a.y)) / ((b.x - b.y) - (a.x - a.y));
  return finiteD(t) ? t : 0.0;
}

OBLONG_INLINE McPV mcGridPV(int i, int j, int nextType, int nextC) {
  McPV v;
  v.s = dvec2(i, j);
  v.kind = OBLONG_MC_GRID;
  v.a = i;
  v.b = j;
  v.lineType = 0;
  v.lineC = 0;
  v.nextType = nextType;
  v.nextC = nextC;
  return v;
}

OBLONG_INLINE bool mcSame(OBLONG_IN(McPV) v, OBLONG_IN(McPV) o) {
  if (v.kind != o.kind) return false;
  if (v.kind == OBLONG_MC_CROSS) return v.a == o.a && v.lineType == o.lineType && v.lineC == o.lineC;
  return v.a == o.a && (v.kind == OBLONG_MC_TVERTEX || v.b == o.b);
}

// Sutherland-Hodgman: the polygon at buf[inBase, inBase + n) against edge e into
// buf[outBase, ...); returns its vertex count.
OBLONG_INLINE int mcClip(OBLONG_IN(McEdges) E, int e, McBuf buf, int inBase, int n, int outBase) {
  int m = 0;
  for (int k = 0; k < n; ++k) {
    McPV a = OBLONG_MC_AT(buf, inBase + k);
    bool ia = mcInside(E, e, a.s), ib = mcInside(E, e, OBLONG_MC_AT(buf, inBase + (k + 1) % n).s);
    if (ia) OBLONG_MC_AT(buf, outBase + m++) = a;
    if (ia != ib) {
      McPV x;
      x.b = 0;
      x.lineType = 0;
      x.lineC = 0;
      if (a.nextType == OBLONG_MC_LINE_EDGE) {  // two edges of T meet at a vertex of T
        int e2 = a.nextC;
        int k3 = (e2 + 1) % 3 == e ? e : ((e + 1) % 3 == e2 ? e2 : -1);
        x.kind = OBLONG_MC_TVERTEX;
        x.a = k3 >= 0 ? k3 : 0;
        x.s = E.S[x.a];
      } else {
        x.kind = OBLONG_MC_CROSS;
        x.a = e;
        x.lineType = a.nextType;
        x.lineC = a.nextC;
        double t = mcCrossParamRaw(E, e, a.nextType, a.nextC);
        dvec2 SA = E.SA[e];
        OBLONG_PRECISE dvec2 s = SA + t * (E.SB[e] - SA);
        x.s = s;
      }
      // Leaving: the polygon continues along T's edge; entering: along a's line.
      x.nextType = ia ? OBLONG_MC_LINE_EDGE : a.nextType;
      x.nextC = ia ? e : a.nextC;
      OBLONG_MC_AT(buf, outBase + m++) = x;
    }
  }
  return m;
}

// Half `side` of cell (i, j) (0: (i,j) (i+1,j) (i+1,j+1); 1: (i,j) (i+1,j+1) (i,j+1))
// clipped against the edges in `mask`, repeated vertices dropped (a grid point on an edge
// can appear twice). Returns the vertex count; the polygon is at buf[base, base + count).
OBLONG_INLINE int mcHalf(OBLONG_IN(McEdges) E, int i, int j, int side, int mask, McBuf buf, OBLONG_OUT(int) base) {
  int poly = 0, tmp = OBLONG_MC_POLY;
  if (side == 0) {
    OBLONG_MC_AT(buf, 0) = mcGridPV(i, j, OBLONG_MC_LINE_H, j);
    OBLONG_MC_AT(buf, 1) = mcGridPV(i + 1, j, OBLONG_MC_LINE_V, i + 1);
    OBLONG_MC_AT(buf, 2) = mcGridPV(i + 1, j + 1, OBLONG_MC_LINE_D, i - j);
  } else {
    OBLONG_MC_AT(buf, 0) = mcGridPV(i, j, OBLONG_MC_LINE_D, i - j);
    OBLONG_MC_AT(buf, 1) = mcGridPV(i + 1, j + 1, OBLONG_MC_LINE_H, j + 1);
    OBLONG_MC_AT(buf, 2) = mcGridPV(i, j + 1, OBLONG_MC_LINE_V, i);
  }
  int n = 3;
  for (int e = 0; e < 3 && n > 0; ++e) {
    if ((mask >> e & 1) == 0) continue;
    n = mcClip(E, e, buf, poly, n, tmp);
    int s = poly;
    poly = tmp;
    tmp = s;
  }
  int m = 0;
  for (int k = 0; k < n; ++k)
    if (m == 0 || !mcSame(OBLONG_MC_AT(buf, poly + k), OBLONG_MC_AT(buf, tmp + m - 1)))
      OBLONG_MC_AT(buf, tmp + m++) = OBLONG_MC_AT(buf, poly + k);
  while (m > 1 && mcSame(OBLONG_MC_AT(buf, tmp), OBLONG_MC_AT(buf, tmp + m - 1))) --m;
  base = tmp;
  return m;
}

// ---- the vertices (Eq. 1 with T's own P and N) ----------------------------------------

// glm::normalize: v · (1 / sqrt(dot(v, v))).
OBLONG_FORCE_INLINE vec3 mcNormalize(OBLONG_IN(vec3) v) {
  OBLONG_PRECISE float inv = rcpSqrtF(dotF(v, v));
  OBLONG_PRECISE vec3 r = v * inv;
  return r;
}

// A vertex before its normal is normalised: P + h·N/|N| at uv with h from the raw height
// (mcVertexAt). The two kinds of vertex computed this way (on an edge of T, at a grid
// point inside it) meet in mcWorld at one call site of mcVertexAt, so a shader inlines
// one normalisation.
struct McPre {
  vec3 P, N;
  vec2 uv;
  float raw;
};
OBLONG_INLINE McPre mcPre(OBLONG_IN(vec3) P, OBLONG_IN(vec3) N, OBLONG_IN(vec2) uv, float raw) {
  McPre q;
  q.P = P;
  q.N = N;
  q.uv = uv;
  q.raw = raw;
  return q;
}
OBLONG_FORCE_INLINE McVertex mcVertexAt(OBLONG_IN(McTri) T, OBLONG_IN(McPre) q) {
  McVertex v;
  OBLONG_PRECISE float h = T.scale * (q.raw + T.bias);
  OBLONG_PRECISE vec3 p = q.P + h * mcNormalize(q.N);
  v.p = p;
  v.uv = q.uv;
  return v;
}

// The point of edge e at parameter t (canonical direction) with raw height `raw`.
OBLONG_INLINE McPre mcOnEdgePre(OBLONG_IN(McTri) T, OBLONG_IN(McEdges) E, int e, double t, float raw) {
  int A = E.A[e], B = E.B[e];
  float tf = float(t);
  OBLONG_PRECISE float w = 1.0f - tf;
  OBLONG_PRECISE vec3 P = w * T.p[A] + tf * T.p[B];
  OBLONG_PRECISE vec3 N = w * T.n[A] + tf * T.n[B];
  OBLONG_PRECISE vec2 uv = w * T.t[A] + tf * T.t[B];
  return mcPre(P, N, uv, raw);
}

// A grid point (i, j) not on any edge of T, at texture coordinates uv
// (Displacement::sampleToUV) with raw height raw: T's barycentrics of the sample point
// (McTri's map), T's P and N there.
OBLONG_FORCE_INLINE McPre mcGridPre(OBLONG_IN(McTri) T, int i, int j, OBLONG_IN(vec2) uv, float raw) {
  float x = float(i - T.origin.x), y = float(j - T.origin.y);
  OBLONG_PRECISE vec2 b = T.bc + T.bX * x + T.bY * y;
  OBLONG_PRECISE float w = 1.0f - b.x - b.y;
  OBLONG_PRECISE vec3 P = w * T.p[0] + b.x * T.p[1] + b.y * T.p[2];
  OBLONG_PRECISE vec3 N = w * T.n[0] + b.x * T.n[1] + b.y * T.n[2];
  return mcPre(P, N, uv, raw);
}
OBLONG_FORCE_INLINE McVertex mcGridInterior(OBLONG_IN(McTri) T, int i, int j, OBLONG_IN(vec2) uv, float raw) {
  return mcVertexAt(T, mcGridPre(T, i, j, uv, raw));
}

// Raw height on grid line (type, c) at sample point s: linear between the line's samples.
// The height along grid line (type, c) at s: linear between the line's two samples
// around s, ends (i0, j0), (i1, j1) and fraction f from the first.
OBLONG_INLINE void mcLineEnds(int type, int c, OBLONG_IN(dvec2) s, OBLONG_OUT(ivec2) e0, OBLONG_OUT(ivec2) e1,
                              OBLONG_OUT(float) f) {
  int i0, j0, i1, j1;
  double at;
  if (type == OBLONG_MC_LINE_V) {
    j0 = int(floor(s.y));
    i0 = c, i1 = c, j1 = j0 + 1, at = s.y - double(j0);
  } else if (type == OBLONG_MC_LINE_H) {
    i0 = int(floor(s.x));
    j0 = c, i1 = i0 + 1, j1 = c, at = s.x - double(i0);
  } else {
    j0 = int(floor(s.y));
    i0 = j0 + c, i1 = i0 + 1, j1 = j0 + 1, at = s.y - double(j0);
  }
  e0 = ivec2(i0, j0);
  e1 = ivec2(i1, j1);
  f = float(at);
}

// The world point of polygon vertex v. Grid points exactly on an edge of T are computed
// from that edge alone; only edges the cell is clipped against (mask) can pass through
// one (for the others sigma·orient is positive at every corner of the cell). A point at
// an end of its edge is T's vertex there, computed as that vertex: a grid line through a
// vertex of T also makes a crossing there, and computed along the edge (another height
// and normalisation) it came out an ulp apart, so that the degenerate polygon a half-cell
// leaves along an edge fanned into slivers of non-zero area (whose normals cancel).
OBLONG_TEMPLATE1(McHeights)
OBLONG_INLINE McVertex mcWorld(OBLONG_IN(McTri) T, OBLONG_IN(McEdges) E, McHeights hs, OBLONG_IN(McPV) v, int mask) {
  int edge = -1;
  double t = 0.0;
  dvec2 s = v.s;
  bool grid = false;  // a grid point inside T
  if (v.kind == OBLONG_MC_CROSS) {
    edge = v.a;
    t = clamp(mcCrossParamRaw(E, v.a, v.lineType, v.lineC), 0.0, 1.0);  // a final vertex: on the segment
    dvec2 SA = E.SA[edge];
    OBLONG_PRECISE dvec2 p = SA + t * (E.SB[edge] - SA);
    s = p;
  } else if (v.kind != OBLONG_MC_TVERTEX) {  // a grid point, maybe on an edge of T
    for (int e = 0; e < 3 && edge < 0; ++e)
      if ((mask >> e & 1) != 0 && mcOrient(E.SA[e], E.SB[e], v.s) == 0.0) {
        dvec2 SA = E.SA[e];
        OBLONG_PRECISE dvec2 ab = E.SB[e] - SA;
        OBLONG_PRECISE dvec2 q = v.s - SA;
        OBLONG_PRECISE double u = (q.x * ab.x + q.y * ab.y) / (ab.x * ab.x + ab.y * ab.y);
        t = clamp(u, 0.0, 1.0);
        edge = e;
      }
    if (edge < 0) {
      McVertex c;
      if (mcGridCached(hs, v.a, v.b, c)) return c;
      grid = true;
    }
  }
  int k = -1;  // T's vertex, when v is one
  if (!grid && (v.kind == OBLONG_MC_TVERTEX || t == 0.0 || t == 1.0))
    k = v.kind == OBLONG_MC_TVERTEX ? v.a : t == 0.0 ? E.A[edge] : E.B[edge];
  // The texels of its height, fetched from one call site (in a shader each call site is
  // a copy of the lookup with its level-of-detail blend): T's vertex k from the micro-
  // triangle at its sample point (Displacement::microAtSample), a crossing from its grid
  // line's two samples, a grid point from its own.
  DispMicroTri mt = dispMicroTri(k >= 0 ? E.S[k] : s);
  ivec2 at[3];
  float f = 0.0f;
  int n = 1;
  at[0] = ivec2(v.a, v.b);
  if (k >= 0) {
    n = 3;
    for (int q = 0; q < 3; ++q) at[q] = dispMicroCorner(mt, q);
  } else if (v.kind == OBLONG_MC_CROSS) {
    n = 2;
    mcLineEnds(v.lineType, v.lineC, s, at[0], at[1], f);
  }
  float h[3];
  for (int q = 0; q < n; ++q) h[q] = mcRaw(hs, at[q].x, at[q].y);
  if (k >= 0) {
    McVertex r;
    float hk = dispMicroHeight(mt, h[0], h[1], h[2], T.scale, T.bias);
    OBLONG_PRECISE vec3 p = T.p[k] + hk * T.n[k];  // n[k] is unit
    r.p = p;
    r.uv = T.t[k];
    return r;
  }
  float raw = h[0];
  if (n == 2) {
    OBLONG_PRECISE float r = h[0] + f * (h[1] - h[0]);
    raw = r;
  }
  McPre q = grid ? mcGridPre(T, v.a, v.b, mcGridUV(hs, v.a, v.b), raw) : mcOnEdgePre(T, E, edge, t, raw);
  return mcVertexAt(T, q);
}

OBLONG_KERNELS_END

#endif
