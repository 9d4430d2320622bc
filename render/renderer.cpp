#include "render/renderer.h"

#include "core/error.h"
#include "render/camera.h"
#include "render/output.h"
#include "render/sampling.h"

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace oblong {

namespace {

struct Tracer {
  const Scene& scene;
  const EmbreeScene& accel;
  const RenderOptions& opts;
  float aoRadius;
  // Smooth normals: every mesh's triangles, prepared once (indexed by Hit::prim).
  std::vector<std::vector<DisplacedTriangle>> triangles;

  // Under --lod cone, a camera ray's λ from its cone (EmbreeScene::coneLod); otherwise
  // none. Rays leaving a hit (shadow, ambient occlusion, bounces) keep the λ of the ray
  // that found it: at any other λ the surface they start on is another one, up to the
  // height range away, and they would hit it at once (docs/lod.md, measured).
  void setLod(Ray& r, const RayCone& c) const {
    if (scene.lodCone) r.lod = accel.coneLod(r, c, scene.lodBias);
  }

  void normals(const Ray& r, const Hit& h, vec3& ngf, vec3& ns) const {
    shadingNormals(scene, triangles, opts.normals, r, h, ngf, ns);
  }
  static vec3 spawn(const vec3& p, const vec3& ngf, const vec3& d) { return spawnOrigin(p, ngf, d); }

  // Direct light from every light at p (geometric normal ng and shading normal n facing
  // the incoming ray).
  vec3 direct(const vec3& p, const vec3& ng, const vec3& n, const vec3& albedo, float lod, RayCounters& c,
              int64_t& rays) const {
    vec3 L(0.0f);
    for (const Light& light : scene.lights) {
      vec3 wi;
      float dist = kInfinity, falloff = 1.0f;
      if (light.type == Light::Type::Directional) {
        wi = -glm::normalize(light.direction);
      } else {
        wi = light.position - p;
        dist = glm::length(wi);
        if (!(dist > 0)) continue;
        wi /= dist;
        falloff = 1.0f / (dist * dist);
      }
      const float cosTheta = glm::dot(n, wi);
      if (cosTheta <= 0 || glm::dot(ng, wi) <= 0) continue;  // the surface itself shadows p
      ++rays;
      const Ray s{p + spawnEps(p) * ng, wi, 0.0f, dist * (1.0f - 1e-4f), lod};
      if (!accel.occluded(s, &c)) L += albedo * light.intensity * (cosTheta * falloff / kPi);
    }
    return L;
  }

  // Radiance along a camera ray whose first hit is h; every ray of the path keeps the
  // camera ray's level of detail (setLod).
  vec3 shade(const Ray& r, const Hit& h, Rng& rng, RayCounters& c, int64_t& rays) const {
    if (!h.valid()) return opts.integrator == Integrator::Path ? opts.sky : vec3(0.0f);
    vec3 ng, n;
    normals(r, h, ng, n);
    if (opts.integrator == Integrator::Primary) return 0.5f * n + 0.5f;
    const vec3 p = r.at(h.t);
    if (opts.integrator == Integrator::AO) {
      const vec3 d = cosineSample(n, rng);
      if (glm::dot(d, ng) <= 0) return vec3(0.0f);  // below the geometric surface: occluded
      ++rays;
      const Ray a{spawn(p, ng, d), d, 0.0f, aoRadius, r.lod};
      return vec3(accel.occluded(a, &c) ? 0.0f : 1.0f);
    }
    // Path tracing: diffuse surfaces, NEE at every vertex, sky on escape.
    vec3 L(0.0f), beta(1.0f);
    vec3 pos = p, nrm = n, geo = ng;
    int mesh = h.mesh;
    for (int depth = 0;; ++depth) {
      const vec3 albedo = scene.meshes[size_t(mesh)].albedo;
      L += beta * direct(pos, geo, nrm, albedo, r.lod, c, rays);
      if (depth + 1 >= opts.maxDepth) break;
      beta *= albedo;  // cosine-weighted sampling of a Lambertian BRDF
      if (depth >= 3) {
        const float q = std::min(0.95f, std::max({beta.x, beta.y, beta.z}));
        if (rng.uniform() >= q) break;
        beta /= q;
      }
      const vec3 d = cosineSample(nrm, rng);
      if (glm::dot(d, geo) <= 0) break;  // into the surface (smooth normals only): absorbed
      const Ray b{spawn(pos, geo, d), d, 0.0f, kInfinity, r.lod};
      ++rays;
      const Hit bh = accel.intersect(b, &c);
      if (!bh.valid()) {
        L += beta * opts.sky;
        break;
      }
      normals(b, bh, geo, nrm);
      pos = b.at(bh.t);
      mesh = bh.mesh;
    }
    return L;
  }
};

}  // namespace

Integrator parseIntegrator(const std::string& name) {
  if (name == "primary") return Integrator::Primary;
  if (name == "ao") return Integrator::AO;
  if (name == "path") return Integrator::Path;
  fail("--integrator", "unknown integrator '{}' (primary | ao | path)", name);
}

ShadingNormals parseShadingNormals(const std::string& name) {
  if (name == "micro") return ShadingNormals::Micro;
  if (name == "smooth") return ShadingNormals::Smooth;
  fail("--normals", "unknown shading normals '{}' (micro | smooth)", name);
}

const char* shadingNormalsName(ShadingNormals n) { return n == ShadingNormals::Smooth ? "smooth" : "micro"; }

vec2 bilinearHeightGradient(const Displacement& d, const vec2& uv) {
  const dvec2 s = d.toSample(uv);
  const double fi = std::floor(s.x), fj = std::floor(s.y);
  const int i = int(fi), j = int(fj);
  const float fx = float(s.x - fi), fy = float(s.y - fj);
  const HeightMap& m = *d.map;
  const float h00 = m.at(i, j), h10 = m.at(i + 1, j), h01 = m.at(i, j + 1), h11 = m.at(i + 1, j + 1);
  // ∂H/∂sample, then the chain rule through toSample (samples per uv unit per axis).
  const float dx = (1 - fy) * (h10 - h00) + fy * (h11 - h01), dy = (1 - fx) * (h01 - h00) + fx * (h11 - h10);
  return d.scale * vec2(dx * d.tiling.x * float(m.width()), dy * d.tiling.y * float(m.height()));
}

vec3 smoothDisplacedNormal(const DisplacedTriangle& T, const Displacement* d, float u, float v) {
  const vec3 Pu = T.p[1] - T.p[0], Pv = T.p[2] - T.p[0], Ng = glm::cross(Pu, Pv);
  const vec3 N = T.N(u, v);
  const float lenN = glm::length(N), lenG = glm::length(Ng);
  if (!(lenN > 0) || !(lenG > 0)) return vec3(0.0f);
  // P_u × P_v replaced by n̂ of the same length and side (vertex normals may point against
  // the winding); the gradient terms keep n̂ as it is, the direction heights go.
  const vec3 nh = N / lenN;
  vec3 n = (glm::dot(N, Ng) < 0 ? -lenG : lenG) * nh;
  if (d && d->map) {
    const vec2 g = bilinearHeightGradient(*d, T.UV(u, v));
    const float hu = glm::dot(g, T.t[1] - T.t[0]), hv = glm::dot(g, T.t[2] - T.t[0]);  // ∂h/∂(u, v)
    n += hv * glm::cross(Pu, nh) + hu * glm::cross(nh, Pv);
  }
  const float len = glm::length(n);
  return len > 0 && std::isfinite(len) ? n / len : vec3(0.0f);
}

void shadingNormals(const Scene& scene, const std::vector<std::vector<DisplacedTriangle>>& triangles,
                    ShadingNormals kind, const Ray& r, const Hit& h, vec3& ngf, vec3& ns) {
  ngf = glm::dot(h.ng, r.d) > 0 ? -h.ng : h.ng;
  ns = ngf;
  if (kind != ShadingNormals::Smooth) return;
  const SceneMesh& sm = scene.meshes[size_t(h.mesh)];
  const DisplacedTriangle& T = triangles[size_t(h.mesh)][size_t(h.prim)];
  // Displaced hits carry T's uv (exact barycentrics); plain ones only the point.
  vec2 b = sm.displacement ? T.baryOfUV(h.uv) : baryOfPoint(T, vec3(dvec3(r.at(h.t)) - sm.mesh.origin));
  b = glm::clamp(b, vec2(0.0f), vec2(1.0f));  // rounding can leave T by an ulp
  if (b.x + b.y > 1.0f) b /= b.x + b.y;
  const vec3 n = smoothDisplacedNormal(T, sm.displacement ? &*sm.displacement : nullptr, b.x, b.y);
  if (n == vec3(0.0f)) return;
  ns = glm::dot(n, ngf) < 0 ? -n : n;
}

const char* integratorName(Integrator i) {
  switch (i) {
    case Integrator::Primary: return "primary";
    case Integrator::AO: return "ao";
    case Integrator::Path: return "path";
  }
  return "?";
}

void AOVs::allocate(ivec2 size) {
  const size_t npx = size_t(size.x) * size_t(size.y);
  color = Image(size.x, size.y);
  depth.assign(npx, kInfinity);
  normal.assign(npx, vec3(0.0f));
  steps.assign(npx, 0.0f);
  rangeQueries.assign(npx, 0.0f);
  inversions.assign(npx, 0.0f);
  cellsMarched.assign(npx, 0.0f);
}

RenderResult render(const Scene& scene, const EmbreeScene& accel, const RenderOptions& opts) {
  if (opts.size.x <= 0 || opts.size.y <= 0) fail("render", "image size must be positive");
  if (opts.spp <= 0) fail("--spp", "must be >= 1, got {}", opts.spp);
  RenderResult res;
  const int W = opts.size.x, H = opts.size.y;
  const size_t npx = size_t(W) * H;
  AOVs& aov = res.aov;
  aov.allocate(opts.size);

  const PinholeCamera cam(scene.camera, opts.size);
  const RayCone camCone{0.0f, cam.pixelSpread()};
  Tracer tracer{scene, accel, opts, opts.aoRadius > 0 ? opts.aoRadius : 0.25f * sceneDiagonal(scene), {}};
  if (opts.normals == ShadingNormals::Smooth)
    for (const SceneMesh& sm : scene.meshes) {
      std::vector<DisplacedTriangle>& tris = tracer.triangles.emplace_back(sm.mesh.triangles.size());
      for (size_t i = 0; i < tris.size(); ++i) tris[i] = sm.mesh.triangle(i);
    }
  std::atomic<int64_t> secondary{0}, hits{0};
  std::mutex countersMutex;
  std::unique_ptr<tbb::global_control> limit;
  if (opts.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, opts.threads);
  std::atomic<int64_t> pixelsDone{0};
  const auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range2d<int>(0, H, 16, 0, W, 16), [&](const auto& tile) {
    if (opts.interrupt && opts.interrupt->load(std::memory_order_relaxed)) return;
    int64_t localRays = 0, localHits = 0, localLodZero = 0;
    double localLod = 0;
    RayCounters tileCounters;
    for (int y = tile.rows().begin(); y < tile.rows().end(); ++y) {
      for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
        const size_t px = size_t(y) * W + x;
        vec3 sum(0.0f);
        RayCounters primary;
        for (int s = 0; s < opts.spp; ++s) {
          Rng rng(opts.seed * 0x9E3779B97F4A7C15ULL + px, uint64_t(s));
          // Sample 0 goes through the pixel centre (AOVs); the others are jittered.
          const float jx = s == 0 ? 0.5f : rng.uniform(), jy = s == 0 ? 0.5f : rng.uniform();
          Ray r = cam.generate(x + jx, y + jy);
          tracer.setLod(r, camCone);
          localLod += std::max(r.lod, 0.0f), localLodZero += r.lod <= 0.0f;
          RayCounters camera;
          const Hit h = accel.intersect(r, &camera);
          primary += camera;
          tileCounters += camera;
          if (s == 0 && h.valid()) {
            vec3 ng;
            aov.depth[px] = h.t;
            tracer.normals(r, h, ng, aov.normal[px]);
          }
          localHits += h.valid();
          sum += tracer.shade(r, h, rng, tileCounters, localRays);
        }
        aov.color.at(x, y) = sum / float(opts.spp);
        const float inv = 1.0f / float(opts.spp);
        aov.steps[px] = float(primary.steps()) * inv;
        aov.rangeQueries[px] = float(primary.rangeQueries) * inv;
        aov.inversions[px] = float(primary.inversions) * inv;
        aov.cellsMarched[px] = float(primary.cellsMarched) * inv;
      }
      if (opts.progress) opts.progress->add(int64_t(tile.cols().size()));
    }
    {
      std::lock_guard<std::mutex> lock(countersMutex);
      res.counters += tileCounters;
      res.cameraLodSum += localLod, res.cameraLodZero += localLodZero;
    }
    secondary += localRays;
    hits += localHits;
    pixelsDone += int64_t(tile.rows().size()) * int64_t(tile.cols().size());
  });
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  res.pixelsDone = pixelsDone;
  res.partial = res.pixelsDone < int64_t(npx);
  res.primaryRays = res.pixelsDone * opts.spp;
  res.secondaryRays = secondary;
  res.hits = hits;
  return res;
}

void writeAOVs(const AOVs& aov, const std::string& path) {
  const int W = aov.color.width, H = aov.color.height;
  const size_t npx = size_t(W) * H;
  const char* names[] = {"R", "G", "B", "Z", "N.X", "N.Y", "N.Z", "steps", "range_queries", "inversions", "cells_marched"};
  constexpr int C = 11;
  std::vector<float> px(npx * C);
  for (size_t i = 0; i < npx; ++i) {
    float* o = &px[i * C];
    const vec3& c = aov.color.pixels[i];
    o[0] = c.x, o[1] = c.y, o[2] = c.z;
    o[3] = aov.depth[i];
    o[4] = aov.normal[i].x, o[5] = aov.normal[i].y, o[6] = aov.normal[i].z;
    o[7] = aov.steps[i], o[8] = aov.rangeQueries[i], o[9] = aov.inversions[i], o[10] = aov.cellsMarched[i];
  }
  writeOutput(path, [&](const std::string& tmp) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) fail(path, "cannot write AOVs ({})", OIIO::geterror());
    OIIO::ImageSpec spec(W, H, C, OIIO::TypeDesc::FLOAT);
    spec.channelnames.assign(std::begin(names), std::end(names));
    spec.z_channel = 3;
    if (!out->open(tmp, spec)) fail(path, "cannot write AOVs ({})", out->geterror());
    if (!out->write_image(OIIO::TypeDesc::FLOAT, px.data()) || !out->close())
      fail(path, "cannot write AOVs ({})", out->geterror());
  });
}

namespace {
// A compact perceptual colour map (viridis-like, 5 stops, linear in between).
vec3 colormap(float t) {
  static const vec3 stops[] = {{0.267f, 0.005f, 0.329f}, {0.229f, 0.322f, 0.546f}, {0.128f, 0.567f, 0.551f},
                               {0.369f, 0.789f, 0.383f}, {0.993f, 0.906f, 0.144f}};
  t = std::clamp(t, 0.0f, 1.0f) * 4.0f;
  const int i = std::min(3, int(t));
  return glm::mix(stops[i], stops[i + 1], t - float(i));
}
}  // namespace

void writeHeatMap(const AOVs& aov, const std::string& path, float maxSteps) {
  const int W = aov.color.width, H = aov.color.height;
  float mx = maxSteps;
  if (mx <= 0)
    for (float s : aov.steps) mx = std::max(mx, s);
  mx = std::max(mx, 1.0f);
  const int bar = std::max(4, H / 40);  // colour bar at the bottom, log scale 1 .. mx
  Image img(W, H + bar);
  const float denom = std::log1p(mx);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float s = aov.steps[size_t(y) * W + x];
      // Linear values: writeImage sRGB-encodes PNGs, so undo that for the colour map.
      const vec3 c = s <= 0 ? vec3(0.0f) : colormap(std::log1p(s) / denom);
      img.at(x, y) = glm::pow(c, vec3(2.2f));
    }
  for (int y = H; y < H + bar; ++y)
    for (int x = 0; x < W; ++x) img.at(x, y) = glm::pow(colormap(float(x) / float(std::max(1, W - 1))), vec3(2.2f));
  writeImage(img, path);
}

}  // namespace oblong
