// A displacement's sample grid and the heights of its micro-geometry (Displacement,
// core/heightmap.h: docs/design.md §1, docs/lod.md), written once for the CPU and the
// Vulkan shaders.
//
// The texels are each side's own, as in rmip_query.h: a type Maps with functions the
// includer provides (C++: template parameter; GLSL: a macro naming a type, functions
// defined after this header, which declares them):
//   float dispTexel(Maps m, int next, int i, int j)
//                                          texel (i, j) of the ray's level (next 0) or
//                                          of the next level (next 1, a λ per ray), wrapped
//   float dispRaw(Maps m, int i, int j)    the raw height of sample (i, j) for the ray
//                                          (dispLodHeight at its blend fraction)
#ifndef OBLONG_KERNELS_HEIGHTS_H
#define OBLONG_KERNELS_HEIGHTS_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

#ifndef __cplusplus
#ifndef Maps
#define Maps int  // the shaders' maps are globals (render/vulkan/shaders/microcells.glsl)
#endif
float dispTexel(Maps m, int next, int i, int j);
float dispRaw(Maps m, int i, int j);
#endif

// Continuous sample coordinates of a uv on a W x H map tiled `tiling` times, uv 0 at
// sample −offset (½ at level 0: the texel centre of texel (i, j) is (i, j)).
OBLONG_INLINE dvec2 dispToSample(OBLONG_IN(dvec2) uv, OBLONG_IN(vec2) tiling, int W, int H, double offset) {
  OBLONG_PRECISE dvec2 r = dvec2(uv.x * double(tiling.x) * double(W) - offset, uv.y * double(tiling.y) * double(H) - offset);
  return r;
}
// The uv of sample point (i, j): the inverse of dispToSample.
OBLONG_INLINE vec2 dispSampleToUV(double i, double j, OBLONG_IN(vec2) tiling, int W, int H, double offset) {
  OBLONG_PRECISE double x = (i + offset) / (double(W) * double(tiling.x));
  OBLONG_PRECISE double y = (j + offset) / (double(H) * double(tiling.y));
  return vec2(float(x), float(y));
}

// std::clamp, written out: GLSL's clamp (FClamp) may return either zero of a tie of zeros.
OBLONG_FORCE_INLINE float dispClamp(float v, float lo, float hi) { return v < lo ? lo : (hi < v ? hi : v); }

// The height at level k's point (i, j) of the surface at λ = k + f: level k's height h
// blended toward level k + 1's micro-geometry there (docs/lod.md), each step clamped into
// the values it is made of, so float rounding never leaves their range. Level k + 1 at
// level k's point (i/2, j/2) is a coarse sample, the middle of a coarse cell edge, or (both
// odd) the middle of the cell's diagonal (a, b)-(a+1, b+1), which the micro-geometry's split
// puts in both of its triangles. Minima, maxima and clamps break ties as std:: does.
OBLONG_TEMPLATE1(Maps)
OBLONG_INLINE float dispLodHeight(Maps m, int i, int j, float f) {
  // Its texels h (level k at (i, j)), p and q (level k + 1 at (a, b) and at the coarse
  // neighbour), fetched from one call site (in a shader each call site is a copy).
  int a = i >> 1, b = j >> 1;
  int n = f == 0.0f ? 1 : ((i | j) & 1) == 0 ? 2 : 3;
  float v[3];
  for (int k = 0; k < n; ++k)
    v[k] = dispTexel(m, k == 0 ? 0 : 1, k == 0 ? i : k == 1 ? a : a + (i & 1), k == 0 ? j : k == 1 ? b : b + (j & 1));
  float h = v[0];
  if (n == 1) return h;
  float p = v[1];
  float q = n == 2 ? p : v[2];
  OBLONG_PRECISE float mid = 0.5f * (p + q);
  float L = dispClamp(mid, q < p ? q : p, p < q ? q : p);
  OBLONG_PRECISE float w = (1.0f - f) * h + f * L;
  return dispClamp(w, L < h ? L : h, h < L ? L : h);
}

// The micro-geometry's height at sample point s: piecewise linear on the two triangles of
// each grid cell split by the diagonal (i,j)-(i+1,j+1), then height = scale · (raw + bias).
// In three parts, so that a caller with other lookups fetches all from one call site (in a
// shader each call site is a copy of the lookup): the triangle s lies in, its corner k,
// and the height from the corners' raw texels.
struct DispMicroTri {
  int i, j;      // the cell
  float fx, fy;  // s in the cell
};
OBLONG_INLINE DispMicroTri dispMicroTri(OBLONG_IN(dvec2) s) {
  double fi = floor(s.x), fj = floor(s.y);
  DispMicroTri r;
  r.i = int(fi), r.j = int(fj);
  OBLONG_PRECISE float fx = float(s.x - fi), fy = float(s.y - fj);
  r.fx = fx, r.fy = fy;
  return r;
}
// Corner k: (i,j), (i+1,j+1), then (i+1,j) (lower triangle, fx >= fy) or (i,j+1) (upper).
OBLONG_INLINE ivec2 dispMicroCorner(OBLONG_IN(DispMicroTri) c, int k) {
  bool lower = c.fx >= c.fy;
  return ivec2(c.i + (k == 0 ? 0 : k == 1 ? 1 : lower ? 1 : 0), c.j + (k == 0 ? 0 : k == 1 ? 1 : lower ? 0 : 1));
}
OBLONG_INLINE float dispMicroHeight(OBLONG_IN(DispMicroTri) c, float h00, float h11, float h2, float scale,
                                    float bias) {
  float fx = c.fx, fy = c.fy;
  OBLONG_PRECISE float H;
  if (fx >= fy) {  // lower triangle (i,j), (i+1,j), (i+1,j+1): h2 = h10
    H = h00 + fx * (h2 - h00) + fy * (h11 - h2);
  } else {  // upper triangle (i,j), (i+1,j+1), (i,j+1): h2 = h01
    H = h00 + fy * (h2 - h00) + fx * (h11 - h2);
  }
  OBLONG_PRECISE float r = scale * (H + bias);
  return r;
}
OBLONG_TEMPLATE1(Maps)
OBLONG_INLINE float dispMicroAt(Maps m, OBLONG_IN(dvec2) s, float scale, float bias) {
  DispMicroTri c = dispMicroTri(s);
  float h[3];
  for (int k = 0; k < 3; ++k) {  // one call site
    ivec2 q = dispMicroCorner(c, k);
    h[k] = dispRaw(m, q.x, q.y);
  }
  return dispMicroHeight(c, h[0], h[1], h[2], scale, bias);
}

OBLONG_KERNELS_END

#endif
