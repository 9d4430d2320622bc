// Rays that start far outside the scene (docs/design.md invariant 7: the hit must not depend on
// how far along its line a ray starts). A float origin 1e7 away is exact, but every test
// that subtracts it in float (Embree's box test over the BVH, Embree's triangle test, the
// micro-triangles' edge functions) then works at ulp(1e7) = 1: coarser than the scene.
// Such a ray is moved along its own line to just before the scene, once, in double
// (o' = o + s·d rounded to float: the line moves by ulp(|o'|), not ulp(|o|)), traced, and
// its t given back as s + t'. The CPU (EmbreeScene) and the Vulkan path (VulkanScene,
// on the host) move the same rays the same way. Rays that start near the scene are not
// touched.
#pragma once

#include "core/scene.h"

#include <algorithm>
#include <cmath>

namespace oblong {

// The world box of every mesh's surface (vertices widened by the largest |height|: a
// displaced point lies within |h| of its base point) and the box's size.
struct SceneReach {
  dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
  double size = 0.0;
};

inline SceneReach sceneReach(const Scene& s) {
  SceneReach r;
  for (const SceneMesh& sm : s.meshes) {
    dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
    for (size_t v = 0; v < sm.mesh.positions.size(); ++v) lo = glm::min(lo, sm.mesh.world(v)), hi = glm::max(hi, sm.mesh.world(v));
    double h = 0.0;
    if (sm.displacement) {
      const Displacement& d = *sm.displacement;
      for (const auto* m : {d.map.get(), d.next.get(), d.level0.get()})
        if (m) {
          const Interval hr = d.toHeight(m->range());
          h = std::max({h, std::abs(double(hr.lo)), std::abs(double(hr.hi))});
        }
    }
    r.lo = glm::min(r.lo, lo - dvec3(h)), r.hi = glm::max(r.hi, hi + dvec3(h));
  }
  const dvec3 e = r.hi - r.lo;
  r.size = std::max({e.x, e.y, e.z, 0.0});
  return r;
}

// A ray moved to the scene: `ray` is traced instead of the original, whose t is
// shift + t'. `misses`: the ray cannot reach the scene's box (nothing to trace).
struct NearRay {
  Ray ray;
  double shift = 0.0;
  bool misses = false;
};

// Origins within kFarRayFactor scene sizes of the box are left as they are.
constexpr double kFarRayFactor = 16.0;

inline NearRay nearScene(const Ray& r, const SceneReach& b) {
  NearRay n{r};
  if (!(b.size > 0.0) || !(b.lo.x <= b.hi.x)) return n;
  const dvec3 o(r.o), d(r.d);
  const dvec3 gap = glm::max(glm::max(b.lo - o, o - b.hi), dvec3(0.0));
  if (std::max({gap.x, gap.y, gap.z}) <= kFarRayFactor * b.size) return n;
  // Entry into the box widened by its size: o' lands about one size before the surface.
  double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const double lo = b.lo[k] - b.size, hi = b.hi[k] + b.size;
    if (d[k] == 0.0) {
      if (o[k] < lo || o[k] > hi) t0 = std::numeric_limits<double>::infinity();
      continue;
    }
    double a = (lo - o[k]) / d[k], c = (hi - o[k]) / d[k];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a), t1 = std::min(t1, c);
  }
  if (!(t0 <= t1) || t1 < double(r.tmin) || t0 > double(r.tmax)) {
    n.misses = true;
    return n;
  }
  n.shift = t0;
  n.ray.o = vec3(o + t0 * d);
  n.ray.tmin = float(std::max(double(r.tmin) - t0, 0.0));
  n.ray.tmax = std::isinf(r.tmax) ? r.tmax : float(double(r.tmax) - t0);
  return n;
}

// The original ray's t of a hit at t' on the moved ray.
inline float unshift(float t, double shift) { return shift == 0.0 ? t : float(shift + double(t)); }

}  // namespace oblong
