// Rendering on Vulkan (see vulkan_render.h). Random numbers, sampling and ray spawning
// come from render/sampling.h, shared with render/renderer.cpp; tests/vulkan_test.cpp
// compares the images of the two paths for every integrator.
#include "render/vulkan/vulkan_render.h"

#include "core/error.h"
#include "render/camera.h"
#include "render/cone_lod.h"
#include "render/sampling.h"

namespace oblong::vk {

namespace {

struct Shader {
  const Scene& scene;
  const RenderOptions& opts;
  std::vector<std::vector<DisplacedTriangle>> triangles;  // smooth normals only

  void normals(const Ray& r, const Hit& h, vec3& ngf, vec3& ns) const {
    shadingNormals(scene, triangles, opts.normals, r, h, ngf, ns);
  }
};

// One camera sample's path (Tracer::shade's locals, kept across the wavefront rounds).
struct Path {
  Rng rng{0, 0};
  vec3 L{0.0f}, beta{1.0f}, pos{0.0f}, nrm{0.0f}, geo{0.0f};
  int mesh = -1;
  bool alive = false;
};

}  // namespace

RenderResult render(const Scene& scene, VulkanScene& accel, const RenderOptions& opts) {
  if (opts.size.x <= 0 || opts.size.y <= 0) fail("render", "image size must be positive");
  if (opts.spp <= 0) fail("--spp", "must be >= 1, got {}", opts.spp);
  const int W = opts.size.x, H = opts.size.y, spp = opts.spp;
  const size_t npx = size_t(W) * H, ns = npx * size_t(spp);
  RenderResult res;
  AOVs& aov = res.aov;
  aov.allocate(opts.size);
  Shader sh{scene, opts, {}};
  if (opts.normals == ShadingNormals::Smooth)
    for (const SceneMesh& sm : scene.meshes) {
      std::vector<DisplacedTriangle>& t = sh.triangles.emplace_back(sm.mesh.triangles.size());
      for (size_t i = 0; i < t.size(); ++i) t[i] = sm.mesh.triangle(i);
    }
  const float aoRadius = opts.aoRadius > 0 ? opts.aoRadius : 0.25f * sceneDiagonal(scene);

  // Camera rays: sample 0 through the pixel centre, the others jittered; under --lod
  // cone each gets its λ from its cone by the CPU renderer's rule (ConeLod), and every
  // ray of its path keeps it (render/renderer.cpp, Tracer::setLod).
  const PinholeCamera cam(scene.camera, opts.size);
  const RayCone camCone{0.0f, cam.pixelSpread()};
  std::unique_ptr<ConeLod> cone;
  if (scene.lodCone) cone = std::make_unique<ConeLod>(scene);
  std::vector<Path> paths(ns);
  std::vector<Ray> rays(ns);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t px = size_t(y) * W + x;
      for (int s = 0; s < spp; ++s) {
        Path& p = paths[px * spp + s];
        p.rng = Rng(opts.seed * 0x9E3779B97F4A7C15ULL + px, uint64_t(s));
        const float jx = s == 0 ? 0.5f : p.rng.uniform(), jy = s == 0 ? 0.5f : p.rng.uniform();
        Ray& r = rays[px * spp + s];
        r = cam.generate(x + jx, y + jy);
        if (cone) r.lod = cone->lod(r, camCone, scene.lodBias);
        res.cameraLodSum += std::max(r.lod, 0.0f), res.cameraLodZero += r.lod <= 0.0f;
      }
    }
  std::vector<RayCounters> camera, more;
  double seconds = 0;
  const std::vector<Hit> hits = accel.trace(rays, &camera, &seconds);
  res.seconds += seconds;
  for (const RayCounters& c : camera) res.counters += c;

  // First hits: primary colour, AOVs, and the start of ao / path.
  std::vector<vec3> value(ns, vec3(0.0f));
  std::vector<size_t> owner;  // path of each queued secondary ray
  std::vector<Ray> queue;
  for (size_t k = 0; k < ns; ++k) {
    const Ray& r = rays[k];
    const Hit& h = hits[k];
    Path& p = paths[k];
    if (!h.valid()) {
      value[k] = opts.integrator == Integrator::Path ? opts.sky : vec3(0.0f);
      continue;
    }
    ++res.hits;
    vec3 ng, n;
    sh.normals(r, h, ng, n);
    if (k % spp == 0) {
      aov.depth[k / spp] = h.t;
      aov.normal[k / spp] = n;
    }
    if (opts.integrator == Integrator::Primary) {
      value[k] = 0.5f * n + 0.5f;
    } else if (opts.integrator == Integrator::AO) {
      const vec3 pt = r.at(h.t);
      const vec3 d = cosineSample(n, p.rng);
      if (glm::dot(d, ng) <= 0) continue;  // below the geometric surface: occluded
      owner.push_back(k);
      queue.push_back(Ray{spawnOrigin(pt, ng, d), d, 0.0f, aoRadius, r.lod});
    } else {
      p.pos = r.at(h.t), p.nrm = n, p.geo = ng, p.mesh = h.mesh, p.alive = true;
    }
  }
  auto traceQueue = [&](bool anyHit) {
    std::vector<Hit> out = accel.trace(queue, &more, &seconds, anyHit);
    res.seconds += seconds;
    res.secondaryRays += int64_t(queue.size());
    for (const RayCounters& c : more) res.counters += c;
    return out;
  };
  if (opts.integrator == Integrator::AO && !queue.empty()) {
    const std::vector<Hit> occ = traceQueue(true);
    for (size_t q = 0; q < queue.size(); ++q) value[owner[q]] = vec3(occ[q].valid() ? 0.0f : 1.0f);
  }
  if (opts.integrator == Integrator::Path) {
    for (int depth = 0;; ++depth) {
      // Direct light at every live vertex (Tracer::direct): one shadow ray per light
      // that can light it, then the sum over the lights in order.
      struct Shadow {
        size_t path;
        vec3 contribution;
      };
      std::vector<Shadow> shadows;
      queue.clear();
      for (size_t k = 0; k < ns; ++k) {
        const Path& p = paths[k];
        if (!p.alive) continue;
        const vec3 albedo = scene.meshes[size_t(p.mesh)].albedo;
        for (const Light& light : scene.lights) {
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
          shadows.push_back({k, albedo * light.intensity * (cosTheta * falloff / kPi)});
          queue.push_back(Ray{p.pos + spawnEps(p.pos) * p.geo, wi, 0.0f, dist * (1.0f - 1e-4f), rays[k].lod});
        }
      }
      if (!queue.empty()) {
        const std::vector<Hit> occ = traceQueue(true);
        std::vector<vec3> direct(ns, vec3(0.0f));
        for (size_t q = 0; q < shadows.size(); ++q)
          if (!occ[q].valid()) direct[shadows[q].path] += shadows[q].contribution;
        for (size_t k = 0; k < ns; ++k)
          if (paths[k].alive) paths[k].L += paths[k].beta * direct[k];
      }
      // Continue or end each path; queue the bounce rays.
      owner.clear();
      queue.clear();
      for (size_t k = 0; k < ns; ++k) {
        Path& p = paths[k];
        if (!p.alive) continue;
        if (depth + 1 >= opts.maxDepth) {
          p.alive = false;
          continue;
        }
        p.beta *= scene.meshes[size_t(p.mesh)].albedo;
        if (depth >= 3) {
          const float q = std::min(0.95f, std::max({p.beta.x, p.beta.y, p.beta.z}));
          if (p.rng.uniform() >= q) {
            p.alive = false;
            continue;
          }
          p.beta /= q;
        }
        const vec3 d = cosineSample(p.nrm, p.rng);
        if (glm::dot(d, p.geo) <= 0) {
          p.alive = false;
          continue;
        }
        owner.push_back(k);
        queue.push_back(Ray{spawnOrigin(p.pos, p.geo, d), d, 0.0f, kInfinity, rays[k].lod});
      }
      if (queue.empty()) break;
      const std::vector<Hit> bh = traceQueue(false);
      for (size_t q = 0; q < queue.size(); ++q) {
        Path& p = paths[owner[q]];
        if (!bh[q].valid()) {
          p.L += p.beta * opts.sky;
          p.alive = false;
          continue;
        }
        sh.normals(queue[q], bh[q], p.geo, p.nrm);
        p.pos = queue[q].at(bh[q].t);
        p.mesh = bh[q].mesh;
      }
    }
    for (size_t k = 0; k < ns; ++k)
      if (hits[k].valid()) value[k] = paths[k].L;
  }

  for (size_t px = 0; px < npx; ++px) {
    vec3 sum(0.0f);
    RayCounters primary;
    for (int s = 0; s < spp; ++s) {
      sum += value[px * spp + s];
      primary += camera[px * spp + s];
    }
    aov.color.pixels[px] = sum / float(spp);
    const float inv = 1.0f / float(spp);
    aov.steps[px] = float(primary.steps()) * inv;
    aov.rangeQueries[px] = float(primary.rangeQueries) * inv;
    aov.inversions[px] = float(primary.inversions) * inv;
    aov.cellsMarched[px] = float(primary.cellsMarched) * inv;
  }
  res.primaryRays = int64_t(ns);
  return res;
}

}  // namespace oblong::vk
