// Ray / micro-triangle test shared by every Intersector (traversals and baselines), so
// that they agree bit for bit on each micro-triangle.
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
#pragma once

#include "core/math.h"
#include "core/microgeometry.h"

#include <limits>

namespace oblong {

struct WatertightRay {
  vec3 o, d;
  int kx = 0, ky = 1, kz = 2;
  float Sx = 0, Sy = 0;

  explicit WatertightRay(const Ray& r) : o(r.o), d(r.d) {
    const vec3 ad = glm::abs(r.d);
    kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    kx = (kz + 1) % 3;
    ky = (kx + 1) % 3;
    if (r.d[kz] < 0.0f) std::swap(kx, ky);  // keep the winding
    Sx = -r.d[kx] / r.d[kz];
    Sy = -r.d[ky] / r.d[kz];
  }
};

struct MicroHit {
  float t;
  float b0, b1, b2;  // barycentrics of v[0], v[1], v[2]
};

// A vertex in the ray's frame: permuted, translated to the origin and sheared in x and
// y (the 2D edge functions need only those; t comes from planeT).
struct ShearedVertex {
  float x, y;
};
[[gnu::always_inline]] inline ShearedVertex shear(const WatertightRay& R, const vec3& p) {
  // Plain arrays: glm's operator[] is a switch, two branches for every component read.
  const float A[3] = {p.x - R.o.x, p.y - R.o.y, p.z - R.o.z};
  return {A[R.kx] + R.Sx * A[R.kz], A[R.ky] + R.Sy * A[R.kz]};
}

// The ray's t at the plane of (p0, p1, p2): edges and p0 − o exact in double, the
// normal and both dot products rounded once per operation (spelled out: the GLSL port
// evaluates the same expressions in the same order). NaN when the ray lies in the plane.
inline float planeT(const WatertightRay& R, const vec3& p0, const vec3& p1, const vec3& p2) {
  const double ax = double(p1.x) - p0.x, ay = double(p1.y) - p0.y, az = double(p1.z) - p0.z;
  const double bx = double(p2.x) - p0.x, by = double(p2.y) - p0.y, bz = double(p2.z) - p0.z;
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double qx = double(p0.x) - R.o.x, qy = double(p0.y) - R.o.y, qz = double(p0.z) - R.o.z;
  const double num = qx * nx + qy * ny + qz * nz;
  const double den = double(R.d.x) * nx + double(R.d.y) * ny + double(R.d.z) * nz;
  return den != 0.0 ? float(num / den) : std::numeric_limits<float>::quiet_NaN();
}

// The test on vertices already in the ray's frame (a vertex shared by two triangles is
// transformed once, with the same float operations); p0..p2 are the same vertices
// untransformed, for t.
[[gnu::always_inline]] inline bool intersectSheared(const WatertightRay& R, const ShearedVertex& a,
                                                    const ShearedVertex& b, const ShearedVertex& c, const vec3& p0,
                                                    const vec3& p1, const vec3& p2, float tmin, float tmax,
                                                    MicroHit& h) {
  float U = c.x * b.y - c.y * b.x;
  float V = a.x * c.y - a.y * c.x;
  float W = b.x * a.y - b.y * a.x;
  if (U == 0.0f || V == 0.0f || W == 0.0f) {  // on an edge in float: decide in double
    U = float(double(c.x) * b.y - double(c.y) * b.x);
    V = float(double(a.x) * c.y - double(a.y) * c.x);
    W = float(double(b.x) * a.y - double(b.y) * a.x);
  }
  if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return false;
  const float det = U + V + W;
  if (det == 0.0f) return false;
  const float inv = 1.0f / det;
  const float t = planeT(R, p0, p1, p2);
  if (!(t >= tmin && t <= tmax)) return false;
  h = {t, U * inv, V * inv, W * inv};
  return true;
}

// Hit with t in [tmin, tmax]? (Degenerate triangles and rays in their plane miss.)
inline bool intersectMicro(const WatertightRay& R, const vec3& p0, const vec3& p1, const vec3& p2, float tmin,
                           float tmax, MicroHit& h) {
  return intersectSheared(R, shear(R, p0), shear(R, p1), shear(R, p2), p0, p1, p2, tmin, tmax, h);
}

// Fills a TriangleHit-like result: uv interpolated, unit geometric normal
// (v1 - v0) x (v2 - v0), the convention of Embree's Ng and of the tessellated baseline.
inline void microHitAttributes(const MicroTriangle& m, const MicroHit& h, vec2& uv, vec3& ng) {
  uv = h.b0 * m.v[0].uv + h.b1 * m.v[1].uv + h.b2 * m.v[2].uv;
  const vec3 n = glm::cross(m.v[1].p - m.v[0].p, m.v[2].p - m.v[0].p);
  const float len = glm::length(n);
  ng = len > 0.0f ? n / len : vec3(0.0f);
}

}  // namespace oblong
