// Ray / micro-triangle test shared by every Intersector (traversals and baselines) and
// the Vulkan shaders, so that they agree bit for bit on each micro-triangle; in the
// subset of core/kernels/lang.h.
//
// Watertight (Woop, Benthin, Wald 2013, "Watertight Ray/Triangle Intersection", as in
// pbrt-v4 and Embree's robust mode): the ray is made the +z axis by a permutation and a
// shear computed once per ray; the three 2D edge functions of the transformed vertices
// decide the hit and are recomputed in double when one is exactly zero. Two triangles
// sharing an edge (bit-identical vertices, as the micro-geometry guarantees) therefore
// cannot both miss a ray that crosses the edge.
//
// t is the ray's crossing of the triangle's plane, computed in double from the float
// vertices (exact edge differences): the edge functions decide the hit, but t taken from
// them (Σ U·z / Σ U) loses most of its digits on a thin triangle (a texel 1e-4 wide and
// 1 long: 2e-4 relative), where Embree's plane-based t does not.
//
// t is accepted in the closed range [tmin, tmax]. Ties between triangles are resolved by
// the caller's strict `t < best` (the first tested wins), which is deterministic for a
// fixed traversal order.
#ifndef OBLONG_KERNELS_MICROTRI_H
#define OBLONG_KERNELS_MICROTRI_H

#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

struct WatertightRay {
  vec3 o, d;
  int kx, ky, kz;  // permutation: the ray runs along +kz
  float Sx, Sy;    // shear
};

OBLONG_INLINE WatertightRay makeWatertightRay(OBLONG_IN(vec3) o, OBLONG_IN(vec3) d) {
  WatertightRay R;
  R.o = o;
  R.d = d;
  vec3 ad = abs(d);
  R.kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  R.kx = (R.kz + 1) % 3;
  R.ky = (R.kx + 1) % 3;
  if (d[R.kz] < 0.0f) {  // keep the winding
    int s = R.kx;
    R.kx = R.ky;
    R.ky = s;
  }
  // Sx and Sy from one call site of divF (a shader inlines each call's correction).
  float S[2];
  for (int k = 0; k < 2; ++k) S[k] = divF(-d[k == 0 ? R.kx : R.ky], d[R.kz]);
  R.Sx = S[0];
  R.Sy = S[1];
  return R;
}

// A vertex in the ray's frame: permuted, translated to the origin and sheared in x and y
// (the 2D edge functions need only those; t comes from planeT). A vertex shared by two
// triangles is transformed once, with the same float operations.
OBLONG_FORCE_INLINE vec2 shearVertex(OBLONG_IN(WatertightRay) R, OBLONG_IN(vec3) p) {
  // An array, not a vector: glm's operator[] is a switch, two branches a component read.
  OBLONG_PRECISE float A[3];
  A[0] = p.x - R.o.x;
  A[1] = p.y - R.o.y;
  A[2] = p.z - R.o.z;
  OBLONG_PRECISE float x = A[R.kx] + R.Sx * A[R.kz], y = A[R.ky] + R.Sy * A[R.kz];
  return vec2(x, y);
}

// The ray's t at the plane of (p0, p1, p2): edges and p0 − o exact in double, the normal
// and both dot products rounded once per operation. NaN when the ray lies in the plane.
OBLONG_INLINE float planeT(OBLONG_IN(WatertightRay) R, OBLONG_IN(vec3) p0, OBLONG_IN(vec3) p1, OBLONG_IN(vec3) p2) {
  OBLONG_PRECISE double ax = double(p1.x) - double(p0.x), ay = double(p1.y) - double(p0.y),
                        az = double(p1.z) - double(p0.z);
  OBLONG_PRECISE double bx = double(p2.x) - double(p0.x), by = double(p2.y) - double(p0.y),
                        bz = double(p2.z) - double(p0.z);
  OBLONG_PRECISE double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  OBLONG_PRECISE double qx = double(p0.x) - double(R.o.x), qy = double(p0.y) - double(R.o.y),
                        qz = double(p0.z) - double(R.o.z);
  OBLONG_PRECISE double num = qx * nx + qy * ny + qz * nz;
  OBLONG_PRECISE double den = double(R.d.x) * nx + double(R.d.y) * ny + double(R.d.z) * nz;
  if (den == 0.0) return kNaNF;
  OBLONG_PRECISE double t = num / den;
  return float(t);
}

// The test on vertices already in the ray's frame (a, b, c: shearVertex of p0, p1, p2).
// On a hit with t in [tmin, tmax] writes t and the barycentrics of p0, p1, p2.
// Degenerate triangles and rays in their plane miss.
OBLONG_FORCE_INLINE bool intersectSheared(OBLONG_IN(WatertightRay) R, OBLONG_IN(vec2) a, OBLONG_IN(vec2) b,
                                          OBLONG_IN(vec2) c, OBLONG_IN(vec3) p0, OBLONG_IN(vec3) p1,
                                          OBLONG_IN(vec3) p2, float tmin, float tmax, OBLONG_OUT(float) ht,
                                          OBLONG_OUT(vec3) hb) {
  OBLONG_PRECISE float U = c.x * b.y - c.y * b.x;
  OBLONG_PRECISE float V = a.x * c.y - a.y * c.x;
  OBLONG_PRECISE float W = b.x * a.y - b.y * a.x;
  if (U == 0.0f || V == 0.0f || W == 0.0f) {  // on an edge in float: decide in double
    OBLONG_PRECISE double u = double(c.x) * double(b.y) - double(c.y) * double(b.x);
    OBLONG_PRECISE double v = double(a.x) * double(c.y) - double(a.y) * double(c.x);
    OBLONG_PRECISE double w = double(b.x) * double(a.y) - double(b.y) * double(a.x);
    U = float(u);
    V = float(v);
    W = float(w);
  }
  if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return false;
  OBLONG_PRECISE float det = U + V + W;
  if (det == 0.0f) return false;
  OBLONG_PRECISE float inv = divF(1.0f, det);
  float t = planeT(R, p0, p1, p2);
  if (!(t >= tmin && t <= tmax)) return false;
  ht = t;
  hb = vec3(U * inv, V * inv, W * inv);
  return true;
}

OBLONG_FORCE_INLINE bool intersectMicro(OBLONG_IN(WatertightRay) R, OBLONG_IN(vec3) p0, OBLONG_IN(vec3) p1,
                                        OBLONG_IN(vec3) p2, float tmin, float tmax, OBLONG_OUT(float) ht,
                                        OBLONG_OUT(vec3) hb) {
  return intersectSheared(R, shearVertex(R, p0), shearVertex(R, p1), shearVertex(R, p2), p0, p1, p2, tmin, tmax, ht,
                          hb);
}

OBLONG_KERNELS_END

#endif
