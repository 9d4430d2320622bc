// The ray / micro-triangle test for the C++ side: the kernel is core/kernels/microtri.h
// (shared with the Vulkan shaders), which says how it is watertight and how t is found.
#pragma once

#include "core/math.h"
#include "core/microgeometry.h"
#include "core/kernels/microtri.h"


namespace oblong {

struct WatertightRay : shared::WatertightRay {
  explicit WatertightRay(const Ray& r) : shared::WatertightRay(shared::makeWatertightRay(r.o, r.d)) {}
};

struct MicroHit {
  float t;
  float b0, b1, b2;  // barycentrics of v[0], v[1], v[2]
};

using ShearedVertex = vec2;
[[gnu::always_inline]] inline ShearedVertex shear(const WatertightRay& R, const vec3& p) {
  return shared::shearVertex(R, p);
}

[[gnu::always_inline]] inline bool intersectSheared(const WatertightRay& R, const ShearedVertex& a,
                                                    const ShearedVertex& b, const ShearedVertex& c, const vec3& p0,
                                                    const vec3& p1, const vec3& p2, float tmin, float tmax,
                                                    MicroHit& h) {
  float t;
  vec3 bary;
  if (!shared::intersectSheared(R, a, b, c, p0, p1, p2, tmin, tmax, t, bary)) return false;
  h = {t, bary.x, bary.y, bary.z};
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
