// The integrator: the one bounce loop and direct-light loop of oblong, as a wavefront
// over a batch of camera samples, traced through a TraceBackend (render/trace_backend.h).
// The CPU renderer (render/renderer.cpp: Embree, tiles in parallel), the Vulkan renderer
// (the same file: bands of samples on one queue) and oblong_vkbench (a baked scene on a
// GPU machine) all integrate with it, so every device shades, draws random numbers and
// spawns rays alike (docs/render.md, "Integrators").
//
//   primary  the shading normal of the first hit (0.5·n + 0.5), no secondary rays
//   ao       ambient occlusion: one cosine-weighted ray per sample, radius aoRadius
//   path     a small diffuse path tracer with next-event estimation towards the scene's
//            point and directional lights, a constant sky, Russian roulette after depth 3
//
// A batch is traced pass by pass: every camera ray, then (ao) every occlusion ray, or
// (path) per bounce every shadow ray and then every bounce ray. Each sample keeps its own
// random stream and state between the passes, and its arithmetic is that of tracing it
// alone, depth first: the value of a sample does not depend on the batch it is in (nor
// on the thread count), so the CPU's images are those of the former per-sample renderer
// bit for bit.
//
// Header-only, with no CPU library (Embree, TBB, OpenImageIO): oblong_vkbench compiles it.
#pragma once

#include "core/error.h"
#include "core/math.h"
#include "core/scene.h"
#include "render/camera.h"
#include "render/sampling.h"
#include "render/trace_backend.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace oblong {

enum class Integrator { Primary, AO, Path };

inline Integrator parseIntegrator(const std::string& name) {  // throws oblong::Error
  if (name == "primary") return Integrator::Primary;
  if (name == "ao") return Integrator::AO;
  if (name == "path") return Integrator::Path;
  fail("--integrator", "unknown integrator '{}' (primary | ao | path)", name);
}

inline const char* integratorName(Integrator i) {
  switch (i) {
    case Integrator::Primary: return "primary";
    case Integrator::AO: return "ao";
    case Integrator::Path: return "path";
  }
  return "?";
}

// What the integrator needs of the scene and the options.
struct IntegratorSettings {
  Integrator integrator = Integrator::Path;
  int maxDepth = 5;               // path: vertices
  vec3 sky{0.12f, 0.14f, 0.18f};  // path: radiance of rays that leave the scene
  float aoRadius = 1.0f;          // ao: world units
  std::vector<Light> lights;
  std::vector<vec3> albedo;  // per mesh (Hit::mesh)
  bool counters = true;      // trace with per-ray counters (SampleBatch::work, ::counters)
};

// The seed of pixel px's streams: one PCG32 per pixel sample (stream = sample index),
// seeded from the render's seed and the pixel index, so no random number depends on the
// order the samples are traced in.
inline uint64_t pixelSeed(uint64_t seed, uint64_t px) { return seed * 0x9E3779B97F4A7C15ULL + px; }

// Sample s of pixel px (row-major) of a `width`-pixel-wide image: its random stream,
// and its camera ray, through the pixel centre for sample 0 and jittered by the stream's
// first two numbers for the others.
inline Ray cameraSample(const PinholeCamera& cam, int width, uint64_t seed, size_t px, int s, Rng& rng) {
  rng = Rng(pixelSeed(seed, px), uint64_t(s));
  const float jx = s == 0 ? 0.5f : rng.uniform(), jy = s == 0 ? 0.5f : rng.uniform();
  return cam.generate(float(px % size_t(width)) + jx, float(px / size_t(width)) + jy);
}

// `--normals micro`: the hit micro-triangle's geometric normal, turned towards the ray,
// as geometric (ngf) and shading (ns) normal. A Normals callable of integrate().
inline void microNormals(const Ray& r, const Hit& h, vec3& ngf, vec3& ns) {
  ngf = glm::dot(h.ng, r.d) > 0 ? -h.ng : h.ng;
  ns = ngf;
}

// One batch of camera samples: the caller sets `camera` and `rng`; integrate() fills the
// rest.
struct SampleBatch {
  std::vector<Ray> camera;  // camera rays, with their λ (Ray::lod) when there is one
  std::vector<Rng> rng;     // each camera ray's stream, past the camera's draws
  // One entry per camera ray:
  std::vector<vec3> value;        // the sample's radiance (primary: the normal as a colour)
  std::vector<Hit> hit;           // the camera ray's first hit
  std::vector<vec3> normal;       // its shading normal, 0 on a miss
  std::vector<RayCounters> work;  // the camera ray's traversal work (empty without counters)
  // Totals of the batch:
  int64_t hits = 0;           // camera rays that hit
  int64_t secondaryRays = 0;  // shadow, ambient occlusion and bounce rays traced
  RayCounters counters;       // every ray's work
  double seconds = 0;         // the backend's seconds, summed over its calls
};

// Integrates every sample of the batch (values, first hits, counters); `normals` is a
// callable (const Ray&, const Hit&, vec3& ngf, vec3& ns) giving the geometric normal
// facing the ray and the shading normal on the same side (microNormals, or the
// renderer's shadingNormals). Secondary rays start at p + ε·n_g on the side of n_g they
// leave by (spawnOrigin) and keep the camera ray's λ: at any other λ the surface they
// start on is another one, up to the height range away (docs/lod.md).
template <class Normals>
void integrate(const TraceBackend& backend, const IntegratorSettings& set, const Normals& normals, SampleBatch& b) {
  const size_t n = b.camera.size();
  b.value.assign(n, vec3(0.0f));
  b.hit.assign(n, Hit{});
  b.normal.assign(n, vec3(0.0f));
  b.work.assign(set.counters ? n : 0, RayCounters{});
  b.seconds += backend.traceHits(RayKind::Camera, b.camera, b.hit, b.work);
  for (const RayCounters& c : b.work) b.counters += c;

  // The secondary rays of one pass, the sample each belongs to, and their work.
  std::vector<Ray> queue;
  std::vector<size_t> owner;
  std::vector<RayCounters> work;
  std::vector<uint8_t> blocked;
  auto traceOcclusion = [&](RayKind kind) {
    blocked.assign(queue.size(), 0);
    work.assign(set.counters ? queue.size() : 0, RayCounters{});
    b.seconds += backend.traceOcclusion(kind, queue, blocked, work);
    b.secondaryRays += int64_t(queue.size());
    for (const RayCounters& c : work) b.counters += c;
  };

  // One sample's path between the passes (path only).
  struct Path {
    vec3 L{0.0f}, beta{1.0f}, pos{0.0f}, nrm{0.0f}, geo{0.0f};
    int mesh = -1;
    bool alive = false;
  };
  std::vector<Path> paths(set.integrator == Integrator::Path ? n : 0);

  // First hits: the primary colour, the shading normal, and the start of ao and path.
  for (size_t i = 0; i < n; ++i) {
    const Ray& r = b.camera[i];
    const Hit& h = b.hit[i];
    if (!h.valid()) {
      b.value[i] = set.integrator == Integrator::Path ? set.sky : vec3(0.0f);
      continue;
    }
    ++b.hits;
    vec3 ng, ns;
    normals(r, h, ng, ns);
    b.normal[i] = ns;
    if (set.integrator == Integrator::Primary) {
      b.value[i] = 0.5f * ns + 0.5f;
    } else if (set.integrator == Integrator::AO) {
      const vec3 d = cosineSample(ns, b.rng[i]);
      if (glm::dot(d, ng) <= 0) continue;  // below the geometric surface: occluded
      owner.push_back(i);
      queue.push_back(Ray{spawnOrigin(r.at(h.t), ng, d), d, 0.0f, set.aoRadius, r.lod});
    } else {
      Path& p = paths[i];
      p.pos = r.at(h.t), p.nrm = ns, p.geo = ng, p.mesh = h.mesh, p.alive = true;
    }
  }
  if (set.integrator == Integrator::AO) {
    if (!queue.empty()) traceOcclusion(RayKind::Ambient);
    for (size_t q = 0; q < queue.size(); ++q) b.value[owner[q]] = vec3(blocked[q] ? 0.0f : 1.0f);
    return;
  }
  if (set.integrator != Integrator::Path) return;

  // Path tracing: diffuse surfaces (cosine-weighted sampling of a Lambertian BRDF),
  // next-event estimation at every vertex, the sky on escape.
  struct Shadow {
    size_t path;
    vec3 contribution;
  };
  std::vector<Shadow> shadows;
  std::vector<vec3> direct;
  for (int depth = 0;; ++depth) {
    // Direct light at every live vertex: one shadow ray per light that can light it
    // (the surface itself shadows the others), then the sum over the lights in order.
    shadows.clear();
    queue.clear();
    for (size_t i = 0; i < n; ++i) {
      const Path& p = paths[i];
      if (!p.alive) continue;
      const vec3 albedo = set.albedo[size_t(p.mesh)];
      for (const Light& light : set.lights) {
        vec3 wi;
        float dist = kInfinity, falloff = 1.0f;
        if (light.type == Light::Type::Directional) {
          wi = -glm::normalize(light.direction);
        } else {
          wi = light.position - p.pos;
          dist = glm::length(wi);
          if (!(dist > 0)) continue;
          wi /= dist;
          falloff = 1.0f / (dist * dist);
        }
        const float cosTheta = glm::dot(p.nrm, wi);
        if (cosTheta <= 0 || glm::dot(p.geo, wi) <= 0) continue;
        shadows.push_back({i, albedo * light.intensity * (cosTheta * falloff / kPi)});
        queue.push_back(Ray{p.pos + spawnEps(p.pos) * p.geo, wi, 0.0f, dist * (1.0f - 1e-4f), b.camera[i].lod});
      }
    }
    if (!queue.empty()) {
      traceOcclusion(RayKind::Shadow);
      direct.assign(n, vec3(0.0f));
      for (size_t q = 0; q < shadows.size(); ++q)
        if (!blocked[q]) direct[shadows[q].path] += shadows[q].contribution;
      for (size_t i = 0; i < n; ++i)
        if (paths[i].alive) paths[i].L += paths[i].beta * direct[i];
    }
    // Continue or end each path (the path length, Russian roulette from the fourth
    // vertex on, a bounce into the surface); queue the bounce rays.
    owner.clear();
    queue.clear();
    for (size_t i = 0; i < n; ++i) {
      Path& p = paths[i];
      if (!p.alive) continue;
      if (depth + 1 >= set.maxDepth) {
        p.alive = false;
        continue;
      }
      p.beta *= set.albedo[size_t(p.mesh)];
      if (depth >= 3) {
        const float q = std::min(0.95f, std::max({p.beta.x, p.beta.y, p.beta.z}));
        if (b.rng[i].uniform() >= q) {
          p.alive = false;
          continue;
        }
        p.beta /= q;
      }
      const vec3 d = cosineSample(p.nrm, b.rng[i]);
      if (glm::dot(d, p.geo) <= 0) {  // into the surface (smooth normals only): absorbed
        p.alive = false;
        continue;
      }
      owner.push_back(i);
      queue.push_back(Ray{spawnOrigin(p.pos, p.geo, d), d, 0.0f, kInfinity, b.camera[i].lod});
    }
    if (queue.empty()) break;
    std::vector<Hit> bounce(queue.size());
    work.assign(set.counters ? queue.size() : 0, RayCounters{});
    b.seconds += backend.traceHits(RayKind::Bounce, queue, bounce, work);
    b.secondaryRays += int64_t(queue.size());
    for (const RayCounters& c : work) b.counters += c;
    for (size_t q = 0; q < queue.size(); ++q) {
      Path& p = paths[owner[q]];
      if (!bounce[q].valid()) {
        p.L += p.beta * set.sky;
        p.alive = false;
        continue;
      }
      normals(queue[q], bounce[q], p.geo, p.nrm);
      p.pos = queue[q].at(bounce[q].t);
      p.mesh = bounce[q].mesh;
    }
  }
  for (size_t i = 0; i < n; ++i)
    if (b.hit[i].valid()) b.value[i] = paths[i].L;
}

}  // namespace oblong
