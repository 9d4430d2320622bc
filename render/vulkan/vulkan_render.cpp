// Rendering on Vulkan (see vulkan_render.h). Random numbers, sampling and ray spawning
// come from render/sampling.h, shared with render/renderer.cpp; tests/vulkan_test.cpp
// compares the images of the two paths for every integrator.
#include "render/vulkan/vulkan_render.h"

#include "core/error.h"
#include "core/memory.h"
#include "render/camera.h"
#include "render/cone_lod.h"
#include "render/sampling.h"

namespace oblong::vk {

namespace {

// Host memory of one sample in flight (its path, camera ray, hit, counters, value, and
// its share of the shadow and bounce queues: a few hundred bytes with one light, not
// measured here; 1 KiB leaves room for more lights) and of one pixel (the samples' sum and the camera rays' counters).
constexpr size_t kBytesPerSample = 1024;
constexpr size_t kBytesPerPixel = sizeof(vec3) + sizeof(RayCounters);
// Samples traced per band: large enough to fill a GPU, small enough to bound memory
// (~256 MiB) and to answer Ctrl-C within one band.
constexpr size_t kBandSamples = size_t(1) << 18;
constexpr size_t kMinBandSamples = size_t(1) << 10;

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

// Samples per band: the requested (or default) band, smaller where the memory budget
// left after the per-pixel buffers is smaller, never below kMinBandSamples.
size_t bandSamples(const RenderOptions& opts) {
  const size_t npx = size_t(std::max(opts.size.x, 0)) * size_t(std::max(opts.size.y, 0));
  const size_t ns = npx * size_t(std::max(opts.spp, 1));
  const size_t budget = structureBudgetBytes(), pixels = npx * kBytesPerPixel;
  const size_t fit = budget > pixels ? (budget - pixels) / kBytesPerSample : 0;
  const size_t asked = opts.bandSamples > 0 ? opts.bandSamples : kBandSamples;
  return std::max<size_t>(1, std::min({ns, asked, std::max(fit, kMinBandSamples)}));
}

void checkRenderFits(const RenderOptions& opts) {
  const size_t npx = size_t(std::max(opts.size.x, 0)) * size_t(std::max(opts.size.y, 0));
  const size_t band = std::min(bandSamples(opts), kMinBandSamples);
  checkFits("--device vulkan", "rendering on Vulkan", npx * kBytesPerPixel + band * kBytesPerSample,
            "choose a smaller --size",
            fmt::format("{} pixels at {} bytes and at least {} samples in flight at {} bytes", npx, kBytesPerPixel,
                        band, kBytesPerSample));
}

RenderResult render(const Scene& scene, VulkanScene& accel, const RenderOptions& opts) {
  if (opts.size.x <= 0 || opts.size.y <= 0) fail("render", "image size must be positive");
  if (opts.spp <= 0) fail("--spp", "must be >= 1, got {}", opts.spp);
  const int W = opts.size.x, spp = opts.spp;
  const size_t npx = size_t(W) * size_t(opts.size.y), ns = npx * size_t(spp);
  // The wavefront's host memory grows with the samples in flight: they go in bands of
  // at most kBandSamples, in sample order, so any --size and --spp render in bounded
  // memory, and Ctrl-C is taken between bands. Each sample's path depends on its own
  // random stream only, so the image does not depend on the banding.
  checkRenderFits(opts);
  const size_t band = bandSamples(opts);
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
  std::vector<vec3> pixelSum(npx, vec3(0.0f));    // the samples' values, summed in order
  std::vector<RayCounters> pixelWork(npx);         // the camera rays' counters

  // Samples [k0, k1) of the image (sample k: pixel k / spp, sample k % spp).
  auto renderBand = [&](size_t k0, size_t k1) {
    const size_t nb = k1 - k0;
    std::vector<Path> paths(nb);
    std::vector<Ray> rays(nb);
    for (size_t j = 0; j < nb; ++j) {
      const size_t k = k0 + j, px = k / size_t(spp);
      const int s = int(k % size_t(spp)), x = int(px % size_t(W)), y = int(px / size_t(W));
      Path& p = paths[j];
      p.rng = Rng(opts.seed * 0x9E3779B97F4A7C15ULL + px, uint64_t(s));
      const float jx = s == 0 ? 0.5f : p.rng.uniform(), jy = s == 0 ? 0.5f : p.rng.uniform();
      Ray& r = rays[j];
      r = cam.generate(float(x) + jx, float(y) + jy);
      if (cone) r.lod = cone->lod(r, camCone, scene.lodBias);
      res.cameraLodSum += std::max(r.lod, 0.0f), res.cameraLodZero += r.lod <= 0.0f;
    }
    std::vector<RayCounters> camera, more;
    double seconds = 0;
    const std::vector<Hit> hits = accel.trace(rays, &camera, &seconds);
    res.seconds += seconds;
    for (const RayCounters& c : camera) res.counters += c;

    // First hits: primary colour, AOVs, and the start of ao / path.
    std::vector<vec3> value(nb, vec3(0.0f));
    std::vector<size_t> owner;  // path of each queued secondary ray
    std::vector<Ray> queue;
    for (size_t j = 0; j < nb; ++j) {
      const size_t k = k0 + j;
      const Ray& r = rays[j];
      const Hit& h = hits[j];
      Path& p = paths[j];
      if (!h.valid()) {
        value[j] = opts.integrator == Integrator::Path ? opts.sky : vec3(0.0f);
        continue;
      }
      ++res.hits;
      vec3 ng, n;
      sh.normals(r, h, ng, n);
      if (k % size_t(spp) == 0) {
        aov.depth[k / size_t(spp)] = h.t;
        aov.normal[k / size_t(spp)] = n;
      }
      if (opts.integrator == Integrator::Primary) {
        value[j] = 0.5f * n + 0.5f;
      } else if (opts.integrator == Integrator::AO) {
        const vec3 pt = r.at(h.t);
        const vec3 d = cosineSample(n, p.rng);
        if (glm::dot(d, ng) <= 0) continue;  // below the geometric surface: occluded
        owner.push_back(j);
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
        for (size_t j = 0; j < nb; ++j) {
          const Path& p = paths[j];
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
            shadows.push_back({j, albedo * light.intensity * (cosTheta * falloff / kPi)});
            queue.push_back(Ray{p.pos + spawnEps(p.pos) * p.geo, wi, 0.0f, dist * (1.0f - 1e-4f), rays[j].lod});
          }
        }
        if (!queue.empty()) {
          const std::vector<Hit> occ = traceQueue(true);
          std::vector<vec3> direct(nb, vec3(0.0f));
          for (size_t q = 0; q < shadows.size(); ++q)
            if (!occ[q].valid()) direct[shadows[q].path] += shadows[q].contribution;
          for (size_t j = 0; j < nb; ++j)
            if (paths[j].alive) paths[j].L += paths[j].beta * direct[j];
        }
        // Continue or end each path; queue the bounce rays.
        owner.clear();
        queue.clear();
        for (size_t j = 0; j < nb; ++j) {
          Path& p = paths[j];
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
          owner.push_back(j);
          queue.push_back(Ray{spawnOrigin(p.pos, p.geo, d), d, 0.0f, kInfinity, rays[j].lod});
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
      for (size_t j = 0; j < nb; ++j)
        if (hits[j].valid()) value[j] = paths[j].L;
    }
    for (size_t j = 0; j < nb; ++j) {
      const size_t px = (k0 + j) / size_t(spp);
      pixelSum[px] += value[j];
      pixelWork[px] += camera[j];
    }
    res.primaryRays += int64_t(nb);
  };

  size_t done = 0;
  while (done < ns) {
    if (opts.interrupt && opts.interrupt->load()) {
      res.partial = true;
      break;
    }
    const size_t next = std::min(ns, done + band);
    renderBand(done, next);
    if (opts.progress) opts.progress->add(int64_t(next / size_t(spp)) - int64_t(done / size_t(spp)));
    done = next;
  }
  // Pixels whose every sample was traced; the rest stay black when interrupted.
  res.pixelsDone = int64_t(done / size_t(spp));
  for (size_t px = 0; px < size_t(res.pixelsDone); ++px) {
    aov.color.pixels[px] = pixelSum[px] / float(spp);
    const float inv = 1.0f / float(spp);
    const RayCounters& primary = pixelWork[px];
    aov.steps[px] = float(primary.steps()) * inv;
    aov.rangeQueries[px] = float(primary.rangeQueries) * inv;
    aov.inversions[px] = float(primary.inversions) * inv;
    aov.cellsMarched[px] = float(primary.cellsMarched) * inv;
  }
  for (size_t px = size_t(res.pixelsDone); px < npx; ++px) aov.depth[px] = kInfinity, aov.normal[px] = vec3(0.0f);
  return res;
}

}  // namespace oblong::vk
