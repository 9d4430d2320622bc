#include "render/renderer.h"

#include "render/camera.h"

#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>

namespace oblong {

RenderResult renderDirect(const Scene& scene, const EmbreeScene& accel, const RenderOptions& opts) {
  RenderResult res;
  res.image = Image(opts.size.x, opts.size.y);
  PinholeCamera cam(scene.camera, opts.size);
  std::atomic<int64_t> shadow{0}, hits{0};
  std::unique_ptr<tbb::global_control> limit;
  if (opts.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, opts.threads);
  const auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range2d<int>(0, opts.size.y, 16, 0, opts.size.x, 16), [&](const auto& tile) {
    int64_t localShadow = 0, localHits = 0;
    for (int y = tile.rows().begin(); y < tile.rows().end(); ++y)
      for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
        const Ray r = cam.generate(x + 0.5f, y + 0.5f);
        const Hit h = accel.intersect(r);
        vec3 c(0.05f, 0.06f, 0.08f);  // background
        if (h.valid()) {
          ++localHits;
          vec3 n = h.ng;
          if (glm::dot(n, r.d) > 0) n = -n;  // shade the side facing the camera
          const vec3 p = r.at(h.t);
          const vec3 albedo = scene.meshes[h.mesh].albedo;
          c = 0.08f * albedo;  // ambient
          for (const Light& L : scene.lights) {
            vec3 wi;
            float dist = kInfinity, falloff = 1.0f;
            if (L.type == Light::Type::Directional) {
              wi = -glm::normalize(L.direction);
            } else {
              wi = L.position - p;
              dist = glm::length(wi);
              wi /= dist;
              falloff = 1.0f / (dist * dist);
            }
            const float cosTheta = glm::dot(n, wi);
            if (cosTheta <= 0) continue;
            // Offset scaled to the hit's magnitude: avoids self-hits on the flat micro-triangle.
            const float eps = 1e-4f * std::max(1.0f, glm::length(p));
            Ray s{p + eps * n, wi, 0.0f, dist * (1.0f - 1e-4f)};
            ++localShadow;
            if (!accel.occluded(s)) c += albedo * L.intensity * (cosTheta * falloff / 3.14159265f);
          }
        }
        res.image.at(x, y) = c;
      }
    shadow += localShadow;
    hits += localHits;
  });
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  res.primaryRays = int64_t(opts.size.x) * opts.size.y;
  res.shadowRays = shadow;
  res.hits = hits;
  return res;
}

}  // namespace oblong
