// `--device vulkan` for oblong trace and oblong render (see commands.h).
#include "render/vulkan/commands.h"

#include "core/error.h"
#include "core/stats.h"
#include "render/output.h"
#include "render/rays_io.h"
#include "render/vulkan/bake_file.h"
#include "render/renderer.h"
#include "render/vulkan/vulkan_scene.h"

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <filesystem>


namespace oblong::vk {

namespace {

nlohmann::json deviceJson(const VulkanScene& vs) {
  nlohmann::json j = {{"api", "vulkan"}, {"name", vs.deviceName()}, {"driver", vs.driverInfo()}};
  for (const auto& m : vs.memory()) j["memory"][m.name] = m.bytes;
  j["memory_total"] = totalBytes(vs.memory());
  return j;
}

void writeJson(const std::string& path, const nlohmann::json& j) { writeTextOutput(path, j.dump(2) + "\n"); }

}  // namespace

int traceCommand(const Scene& scene, const AccelOptions& opts, const std::vector<Ray>& rays,
                 const std::string& raysPath, const std::string& out, const std::string& statsPath,
                 const std::atomic<bool>* interrupt) {
  VulkanScene vs(scene, opts);
  // In batches, so that Ctrl-C is answered within one batch and the host's staging
  // memory stays bounded; each ray's answer does not depend on its batch.
  constexpr size_t kBatch = size_t(1) << 18;
  std::vector<Hit> hits;
  std::vector<RayCounters> perRay;
  hits.reserve(rays.size());
  perRay.reserve(rays.size());
  double seconds = 0;
  for (size_t b = 0; b < rays.size(); b += kBatch) {
    if (interrupt && interrupt->load()) {
      eprint("oblong: interrupted: no hits written (a hits file holds every ray or none)\n");
      return 130;
    }
    const std::vector<Ray> batch(rays.begin() + ptrdiff_t(b), rays.begin() + ptrdiff_t(std::min(rays.size(), b + kBatch)));
    std::vector<RayCounters> counters;
    double s = 0;
    const std::vector<Hit> h = vs.trace(batch, &counters, &s);
    hits.insert(hits.end(), h.begin(), h.end());
    perRay.insert(perRay.end(), counters.begin(), counters.end());
    seconds += s;
  }
  if (interrupt && interrupt->load()) {
    eprint("oblong: interrupted: no hits written (a hits file holds every ray or none)\n");
    return 130;
  }
  writeHits(out, hits);
  RayCounters total;
  size_t found = 0;
  for (size_t i = 0; i < rays.size(); ++i) total += perRay[i], found += hits[i].valid();
  const double mrays = double(rays.size()) / std::max(seconds, 1e-9) * 1e-6;
  fmt::print("oblong trace: {} rays -> {}: {} hits, {} on Vulkan ({}, {}), {:.3f} s, {:.2f} Mrays/s, {:.1f} steps/ray\n",
             rays.size(), out, found, vs.geometryName(), vs.deviceName(), vs.driverInfo(), seconds, mrays,
             double(total.steps()) / double(std::max<size_t>(1, rays.size())));
  if (!statsPath.empty()) {
    nlohmann::json j;
    j["scene"] = scene.path;
    j["rays"] = {{"file", raysPath}, {"count", rays.size()}, {"hits", found}};
    j["geometry"] = vs.geometryName();
    j["device"] = deviceJson(vs);
    j["seconds"] = {{"build", vs.buildSeconds()}, {"trace", seconds}};
    j["mrays_per_second"] = mrays;
    j["ray_counters"] = countersJson(total, int64_t(rays.size()));
    writeJson(statsPath, j);
  }
  return 0;
}

int renderCommand(const Scene& scene, const AccelOptions& opts, const RenderOptions& ro, const std::string& out,
                  const std::string& aovs, const std::string& heatmap, const std::string& statsPath) {
  checkBandsFit(ro);
  VulkanScene vs(scene, opts);
  if (ro.progress)
    ro.progress->phase(fmt::format("rendering {}x{} at {} spp on Vulkan", ro.size.x, ro.size.y, ro.spp),
                       int64_t(ro.size.x) * ro.size.y);
  const RenderResult res = render(scene, vs, ro);
  if (ro.progress) ro.progress->clear();
  if (res.partial) eprint("oblong: interrupted: writing the {} of {} pixels rendered (the rest is black)\n",
                          res.pixelsDone, int64_t(ro.size.x) * ro.size.y);
  writeImage(res.aov.color, out);
  if (!aovs.empty()) writeAOVs(res.aov, aovs);
  if (!heatmap.empty()) writeHeatMap(res.aov, heatmap);
  const double rays = double(res.primaryRays + res.secondaryRays);
  const double mrays = rays / std::max(res.seconds, 1e-9) * 1e-6;
  fmt::print("oblong render: {} -> {}\n", scene.path, out);
  fmt::print("  device   : Vulkan, {} ({})\n", vs.deviceName(), vs.driverInfo());
  fmt::print("  geometry : {}, {} base triangles, built in {:.2f} s\n", vs.geometryName(), vs.baseTriangles(),
             vs.buildSeconds());
  for (const auto& m : vs.memory()) fmt::print("  memory   : {:<24} {} B\n", m.name, m.bytes);
  double meanPrimarySteps = 0;
  for (float st : res.aov.steps) meanPrimarySteps += st;
  meanPrimarySteps /= double(std::max<size_t>(1, res.aov.steps.size()));
  fmt::print("  summary  : {}x{} {} spp {}, {:.3f} s tracing, {:.2f} Mrays/s ({} camera + {} secondary rays, {:.1f}% "
             "hit), {:.1f} steps/camera ray, {:.1f} steps/ray\n",
             ro.size.x, ro.size.y, ro.spp, integratorName(ro.integrator), res.seconds, mrays, res.primaryRays,
             res.secondaryRays, 100.0 * double(res.hits) / double(std::max<int64_t>(1, res.primaryRays)),
             meanPrimarySteps, double(res.counters.steps()) / std::max(1.0, rays));
  if (!statsPath.empty()) {
    nlohmann::json j;
    j["scene"] = scene.path;
    j["geometry"] = vs.geometryName();
    j["device"] = deviceJson(vs);
    j["image"] = {{"width", ro.size.x}, {"height", ro.size.y}, {"file", out}};
    j["integrator"] = integratorName(ro.integrator);
    j["normals"] = shadingNormalsName(ro.normals);
    j["spp"] = ro.spp;
    j["seed"] = ro.seed;
    j["seconds"] = {{"build", vs.buildSeconds()}, {"render", res.seconds}};
    j["partial"] = res.partial;
    j["pixels"] = {{"rendered", res.pixelsDone}, {"total", int64_t(ro.size.x) * ro.size.y}};
    j["rays"] = {{"primary", res.primaryRays}, {"secondary", res.secondaryRays}, {"hits", res.hits}};
    j["mrays_per_second"] = mrays;
    j["steps_per_camera_ray"] = meanPrimarySteps;
    if (scene.lodCone && res.primaryRays > 0)
      j["lod_per_ray"] = {{"bias", scene.lodBias},
                          {"camera_mean", res.cameraLodSum / double(res.primaryRays)},
                          {"camera_at_0", double(res.cameraLodZero) / double(res.primaryRays)}};
    j["ray_counters"] = countersJson(res.counters, res.primaryRays + res.secondaryRays);
    writeJson(statsPath, j);
  }
  return res.partial ? 130 : 0;
}

int bakeCommand(const Scene& scene, const AccelOptions& opts, ivec2 image, const std::vector<Ray>& rays,
                const std::string& out, const std::string& version) {
  BakedScene b;
  b.records = buildRecords(scene, opts);
  b.scene = scene.path;
  b.version = version;
  b.camera = scene.camera;
  b.image = image;
  b.lights = scene.lights;
  for (const SceneMesh& sm : scene.meshes) b.albedo.push_back(sm.albedo);
  const RenderOptions defaults;  // the renderer's sky and path length
  b.sky = defaults.sky;
  b.maxDepth = defaults.maxDepth;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!(rays[i].tmin >= 0.0f)) fail("--rays", "ray {}: tmin = {} < 0 (Vulkan needs tmin >= 0)", i, rays[i].tmin);
    b.rays.push_back({rays[i].o, rays[i].d, rays[i].tmin, rays[i].tmax, rays[i].lod, 0.0f});
  }
  uint64_t bytes = 0;
  // Through a temporary file renamed into place: a failed write leaves no truncated
  // file and keeps an earlier one.
  writeOutput(out, [&](const std::string& tmp) { bytes = writeBake(tmp, b, out); });
  fmt::print("oblong bake: {} -> {}: {} meshes, {} base triangles, {}, {:.1f} MiB (camera {}x{}{})\n", scene.path,
             out, scene.meshes.size(), b.records.baseTriangles, b.records.geometryName, double(bytes) / (1 << 20),
             image.x, image.y, rays.empty() ? "" : fmt::format(", {} rays", rays.size()));
  return 0;
}

}  // namespace oblong::vk
