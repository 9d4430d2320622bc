// The grazing ray family of bench_traversal and of the traversal tests: rays within
// [0.5, 6] degrees of the base surface (DESIGN §1's P and N) at random points of the
// displaced meshes, descending towards a random height of the shell, starting half a
// scene diagonal before it. Deterministic for a seed.
#pragma once

#include "core/scene.h"

#include <random>
#include <vector>

namespace oblong {

inline std::vector<Ray> grazingRays(const Scene& s, int count, uint32_t seed = 7) {
  AABB box;
  std::vector<const SceneMesh*> displaced;
  for (const SceneMesh& sm : s.meshes) {
    for (size_t v = 0; v < sm.mesh.positions.size(); ++v) box.extend(vec3(sm.mesh.world(v)));
    if (sm.displacement) displaced.push_back(&sm);
  }
  std::vector<Ray> r;
  if (displaced.empty()) return r;
  const float diag = glm::length(box.extent());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  constexpr float kDeg = 3.14159265f / 180.0f;
  while (int(r.size()) < count) {
    const SceneMesh& sm = *displaced[size_t(U(rng) * float(displaced.size())) % displaced.size()];
    const DisplacedTriangle T =
        sm.mesh.triangle(size_t(U(rng) * float(sm.mesh.triangles.size())) % sm.mesh.triangles.size());
    if (T.uvArea2 == 0.0f) continue;
    float u = U(rng), v = U(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;
    const vec3 n = glm::normalize(T.N(u, v));
    vec3 t = glm::cross(n, glm::normalize(vec3(U(rng), U(rng), U(rng)) - 0.5f));
    if (!(glm::length(t) > 1e-3f)) continue;
    t = glm::normalize(t);
    const Displacement& d = *sm.displacement;
    const Interval raw = d.map->range();
    const float h0 = d.scale * (raw.lo + d.bias), h1 = d.scale * (raw.hi + d.bias);
    const float h = h0 + U(rng) * (h1 - h0), a = (0.5f + 5.5f * U(rng)) * kDeg;
    const vec3 q = vec3(dvec3(T.P(u, v) + h * n) + sm.mesh.origin);
    const vec3 dir = std::cos(a) * t - std::sin(a) * n;
    r.push_back(Ray{q - 0.5f * diag * dir, dir, 0.0f, kInfinity});
  }
  return r;
}

}  // namespace oblong
