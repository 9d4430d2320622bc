// Sampling helpers of the integrator (render/integrator.h), which every device renders
// with: random streams, cosine sampling, ray spawning. Header-only (oblong_vkbench
// compiles it).
#pragma once

#include "core/math.h"
#include "core/scene.h"
#include "core/triangle.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace oblong {

inline constexpr float kPi = 3.14159265358979f;

// PCG32 (O'Neill 2014), seeded per pixel sample: deterministic whatever the schedule.
struct Rng {
  uint64_t state, inc;
  Rng() : Rng(0, 0) {}
  Rng(uint64_t seed, uint64_t stream) : state(0), inc((stream << 1u) | 1u) {
    next();
    state += seed;
    next();
  }
  uint32_t next() {
    const uint64_t old = state;
    state = old * 6364136223846793005ULL + inc;
    const uint32_t x = uint32_t(((old >> 18u) ^ old) >> 27u), rot = uint32_t(old >> 59u);
    return (x >> rot) | (x << ((-rot) & 31));
  }
  float uniform() { return float(next() >> 8) * (1.0f / 16777216.0f); }  // [0,1)
};

// Orthonormal basis around n (Duff et al. 2017).
inline void basis(const vec3& n, vec3& t, vec3& b) {
  const float s = std::copysign(1.0f, n.z);
  const float a = -1.0f / (s + n.z), c = n.x * n.y * a;
  t = vec3(1.0f + s * n.x * n.x * a, s * c, -s * n.x);
  b = vec3(c, s + n.y * n.y * a, -n.y);
}

inline vec3 cosineSample(const vec3& n, Rng& rng) {
  const float u1 = rng.uniform(), u2 = rng.uniform();
  const float r = std::sqrt(u1), phi = 2.0f * kPi * u2;
  vec3 t, b;
  basis(n, t, b);
  return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + std::sqrt(std::max(0.0f, 1.0f - u1)) * n);
}

// Offset of a spawned ray's origin along the facing normal (relative to |p|).
inline float spawnEps(const vec3& p) {
  return 1e-4f * std::max(1.0f, std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}));
}

// Origin of a ray leaving p in direction d, offset to the side of ngf it leaves by.
inline vec3 spawnOrigin(const vec3& p, const vec3& ngf, const vec3& d) {
  return p + (glm::dot(ngf, d) < 0 ? -spawnEps(p) : spawnEps(p)) * ngf;
}

// Barycentrics (u, v) of the point of T's plane nearest to p (Ericson 2004, §3.4).
inline vec2 baryOfPoint(const DisplacedTriangle& T, const vec3& p) {
  const vec3 e1 = T.p[1] - T.p[0], e2 = T.p[2] - T.p[0], w = p - T.p[0];
  const float d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
  const float w1 = glm::dot(w, e1), w2 = glm::dot(w, e2), den = d11 * d22 - d12 * d12;
  if (!(den > 0)) return vec2(1.0f / 3.0f);
  return vec2((d22 * w1 - d12 * w2) / den, (d11 * w2 - d12 * w1) / den);
}

inline float sceneDiagonal(const Scene& s) {
  AABB b;
  for (const auto& sm : s.meshes)
    for (size_t v = 0; v < sm.mesh.positions.size(); ++v) b.extend(vec3(sm.mesh.world(v)));
  return b.isEmpty() ? 1.0f : glm::length(b.extent());
}

}  // namespace oblong
