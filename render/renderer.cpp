#include "render/renderer.h"

#include "core/error.h"
#include "core/memory.h"
#include "render/camera.h"
#include "render/sampling.h"

#include <fmt/core.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>

namespace oblong {

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
  microNormals(r, h, ngf, ns);
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

IntegratorSettings integratorSettings(const Scene& scene, const RenderOptions& opts) {
  IntegratorSettings set;
  set.integrator = opts.integrator;
  set.maxDepth = opts.maxDepth;
  set.sky = opts.sky;
  set.aoRadius = opts.aoRadius > 0 ? opts.aoRadius : 0.25f * sceneDiagonal(scene);
  set.lights = scene.lights;
  for (const SceneMesh& sm : scene.meshes) set.albedo.push_back(sm.albedo);
  return set;
}

namespace {

// Bands: host memory of one sample in flight (its camera ray, stream, path, hit,
// counters, value, and its share of the shadow and bounce queues: a few hundred bytes
// with one light, not measured here; 1 KiB leaves room for more lights) and of one pixel
// (the samples' sum and the camera rays' counters).
constexpr size_t kBytesPerSample = 1024;
constexpr size_t kBytesPerPixel = sizeof(vec3) + sizeof(RayCounters);
// Samples traced per band: large enough to fill a GPU, small enough to bound memory
// (~256 MiB) and to answer Ctrl-C within one band.
constexpr size_t kBandSamples = size_t(1) << 18;
constexpr size_t kMinBandSamples = size_t(1) << 10;
// Tiles: samples per batch (a 16x16 tile at 16 spp), bounding the memory of a tile at
// any --spp.
constexpr size_t kTileBatchSamples = 4096;

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

// What the camera rays and the integrator's passes add up to, per tile or band.
struct Totals {
  int64_t hits = 0, secondaryRays = 0, lodZero = 0;
  double lodSum = 0, seconds = 0;
  RayCounters counters;
  Totals& operator+=(const Totals& o) {
    hits += o.hits, secondaryRays += o.secondaryRays, lodZero += o.lodZero;
    lodSum += o.lodSum, seconds += o.seconds;
    counters += o.counters;
    return *this;
  }
};

// What both schedules share: the camera, the integrator, the per-pixel sums.
struct Film {
  const Scene& scene;
  const TraceBackend& backend;
  const RenderOptions& opts;
  PinholeCamera cam;
  RayCone camCone;
  IntegratorSettings settings;
  std::vector<std::vector<DisplacedTriangle>> triangles;  // smooth normals: every mesh's
  AOVs& aov;

  void normals(const Ray& r, const Hit& h, vec3& ngf, vec3& ns) const {
    shadingNormals(scene, triangles, opts.normals, r, h, ngf, ns);
  }

  // Samples [k0, k1) of a list of pixels (sample k: sample k % spp of pixel
  // pixels[k / spp], or of pixel k / spp when `pixels` is empty): traced, their values
  // and camera counters added to sum[k / spp] and work[k / spp], in sample order; sample
  // 0's depth and shading normal into the AOVs.
  void trace(const std::vector<size_t>& pixels, size_t k0, size_t k1, vec3* sum, RayCounters* work,
             Totals& t) const {
    const size_t spp = size_t(opts.spp), nb = k1 - k0;
    SampleBatch b;
    b.camera.resize(nb);
    b.rng.resize(nb);
    for (size_t j = 0; j < nb; ++j) {
      const size_t slot = (k0 + j) / spp, px = pixels.empty() ? slot : pixels[slot];
      Ray& r = b.camera[j];
      r = cameraSample(cam, opts.size.x, opts.seed, px, int((k0 + j) % spp), b.rng[j]);
      // Under --lod cone, a camera ray's λ from its cone; every ray of its path keeps it.
      if (scene.lodCone) r.lod = backend.coneLod(r, camCone, scene.lodBias);
      t.lodSum += std::max(r.lod, 0.0f), t.lodZero += r.lod <= 0.0f;
    }
    integrate(backend, settings, [this](const Ray& r, const Hit& h, vec3& ngf, vec3& ns) { normals(r, h, ngf, ns); },
              b);
    for (size_t j = 0; j < nb; ++j) {
      const size_t k = k0 + j, slot = k / spp, px = pixels.empty() ? slot : pixels[slot];
      sum[slot] += b.value[j];
      work[slot] += b.work[j];
      if (k % spp == 0 && b.hit[j].valid()) {
        aov.depth[px] = b.hit[j].t;
        aov.normal[px] = b.normal[j];
      }
    }
    t.hits += b.hits, t.secondaryRays += b.secondaryRays, t.seconds += b.seconds;
    t.counters += b.counters;
  }

  // Pixel px's colour (the mean of its samples, no filter) and its camera rays' counters
  // (means over the samples).
  void finish(size_t px, const vec3& sum, const RayCounters& work) const {
    const float inv = 1.0f / float(opts.spp);
    aov.color.pixels[px] = sum / float(opts.spp);
    aov.steps[px] = float(work.steps()) * inv;
    aov.rangeQueries[px] = float(work.rangeQueries) * inv;
    aov.inversions[px] = float(work.inversions) * inv;
    aov.cellsMarched[px] = float(work.cellsMarched) * inv;
  }
};

// 16x16 tiles in parallel (TBB), each in batches of kTileBatchSamples; a tile not yet
// started when Ctrl-C comes is skipped.
void renderTiles(const Film& film, RenderResult& res) {
  const RenderOptions& opts = film.opts;
  const int W = opts.size.x, H = opts.size.y;
  std::mutex totalsMutex;
  Totals total;
  std::atomic<int64_t> pixelsDone{0};
  tbb::parallel_for(tbb::blocked_range2d<int>(0, H, 16, 0, W, 16), [&](const auto& tile) {
    if (opts.interrupt && opts.interrupt->load(std::memory_order_relaxed)) return;
    std::vector<size_t> pixels;
    for (int y = tile.rows().begin(); y < tile.rows().end(); ++y)
      for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) pixels.push_back(size_t(y) * size_t(W) + size_t(x));
    std::vector<vec3> sum(pixels.size(), vec3(0.0f));
    std::vector<RayCounters> work(pixels.size());
    Totals t;
    const size_t ns = pixels.size() * size_t(opts.spp);
    for (size_t k = 0; k < ns; k += kTileBatchSamples)
      film.trace(pixels, k, std::min(ns, k + kTileBatchSamples), sum.data(), work.data(), t);
    for (size_t i = 0; i < pixels.size(); ++i) film.finish(pixels[i], sum[i], work[i]);
    if (opts.progress) opts.progress->add(int64_t(pixels.size()));
    {
      std::lock_guard<std::mutex> lock(totalsMutex);
      total += t;
    }
    pixelsDone += int64_t(pixels.size());
  });
  res.pixelsDone = pixelsDone;
  res.primaryRays = res.pixelsDone * opts.spp;
  res.secondaryRays = total.secondaryRays, res.hits = total.hits, res.counters = total.counters;
  res.cameraLodSum = total.lodSum, res.cameraLodZero = total.lodZero;
}

// The image's samples in order (sample k: pixel k / spp, sample k % spp), in bands, one
// after the other; Ctrl-C is taken between bands: the pixels whose samples were all
// traced are kept. Each sample's value depends on its own stream only, so the image does
// not depend on the banding.
void renderBands(const Film& film, RenderResult& res) {
  const RenderOptions& opts = film.opts;
  const size_t spp = size_t(opts.spp), npx = size_t(opts.size.x) * size_t(opts.size.y), ns = npx * spp;
  checkBandsFit(opts);
  const size_t band = bandSamples(opts);
  std::vector<vec3> pixelSum(npx, vec3(0.0f));  // the samples' values, summed in order
  std::vector<RayCounters> pixelWork(npx);       // the camera rays' counters
  Totals total;
  size_t done = 0;
  while (done < ns) {
    if (opts.interrupt && opts.interrupt->load()) {
      res.partial = true;
      break;
    }
    const size_t next = std::min(ns, done + band);
    film.trace({}, done, next, pixelSum.data(), pixelWork.data(), total);
    if (opts.progress) opts.progress->add(int64_t(next / spp) - int64_t(done / spp));
    done = next;
  }
  res.pixelsDone = int64_t(done / spp);
  for (size_t px = 0; px < size_t(res.pixelsDone); ++px) film.finish(px, pixelSum[px], pixelWork[px]);
  // The rest stays black, without depth or normal.
  for (size_t px = size_t(res.pixelsDone); px < npx; ++px) film.aov.depth[px] = kInfinity, film.aov.normal[px] = vec3(0.0f);
  res.primaryRays = int64_t(done);
  res.secondaryRays = total.secondaryRays, res.hits = total.hits, res.counters = total.counters;
  res.cameraLodSum = total.lodSum, res.cameraLodZero = total.lodZero;
  res.seconds = total.seconds;
  res.tracingOnly = true;
}

}  // namespace

void checkBandsFit(const RenderOptions& opts) {
  const size_t npx = size_t(std::max(opts.size.x, 0)) * size_t(std::max(opts.size.y, 0));
  const size_t band = std::min(bandSamples(opts), kMinBandSamples);
  checkFits("--device vulkan", "rendering on Vulkan", npx * kBytesPerPixel + band * kBytesPerSample,
            "choose a smaller --size",
            fmt::format("{} pixels at {} bytes and at least {} samples in flight at {} bytes", npx, kBytesPerPixel,
                        band, kBytesPerSample));
}

RenderResult render(const Scene& scene, const TraceBackend& backend, const RenderOptions& opts) {
  if (opts.size.x <= 0 || opts.size.y <= 0) fail("render", "image size must be positive");
  if (opts.spp <= 0) fail("--spp", "must be >= 1, got {}", opts.spp);
  RenderResult res;
  res.aov.allocate(opts.size);
  const PinholeCamera cam(scene.camera, opts.size);
  Film film{scene, backend, opts, cam, RayCone{0.0f, cam.pixelSpread()}, integratorSettings(scene, opts), {}, res.aov};
  if (opts.normals == ShadingNormals::Smooth)
    for (const SceneMesh& sm : scene.meshes) {
      std::vector<DisplacedTriangle>& tris = film.triangles.emplace_back(sm.mesh.triangles.size());
      for (size_t i = 0; i < tris.size(); ++i) tris[i] = sm.mesh.triangle(i);
    }
  std::unique_ptr<tbb::global_control> limit;
  if (opts.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, opts.threads);
  const auto start = std::chrono::steady_clock::now();
  if (backend.concurrent()) {
    renderTiles(film, res);
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    res.partial = res.pixelsDone < int64_t(opts.size.x) * opts.size.y;
  } else {
    renderBands(film, res);
  }
  return res;
}

TraceResult traceRays(const TraceBackend& backend, const std::vector<Ray>& rays, int threads,
                      const std::atomic<bool>* interrupt, std::vector<RayCounters>* perRay) {
  // In batches, so that Ctrl-C is answered within one batch and a device's staging
  // memory stays bounded; each ray's answer does not depend on its batch.
  constexpr size_t kBatch = size_t(1) << 18;
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  TraceResult res;
  res.hits.resize(rays.size());
  std::vector<RayCounters> batchWork;
  if (perRay) perRay->assign(rays.size(), RayCounters{});
  for (size_t b = 0; b < rays.size(); b += kBatch) {
    if (interrupt && interrupt->load()) break;
    const size_t n = std::min(kBatch, rays.size() - b);
    std::span<RayCounters> work;
    if (perRay) {
      work = std::span<RayCounters>(*perRay).subspan(b, n);
    } else {
      batchWork.assign(n, RayCounters{});
      work = batchWork;
    }
    res.seconds += backend.traceHits(RayKind::Camera, std::span<const Ray>(rays).subspan(b, n),
                                     std::span<Hit>(res.hits).subspan(b, n), work);
    for (const RayCounters& c : work) res.counters += c;
  }
  res.interrupted = interrupt && interrupt->load();
  for (const Hit& h : res.hits) res.found += h.valid();
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
  ImagePixels img{W, H, C, true, px.data(), {std::begin(names), std::end(names)}, 3};
  writeImagePixels(img, path, "AOVs");
}

}  // namespace oblong
