// `--device vulkan` for oblong trace and oblong render, and oblong bake (see commands.h).
#include "render/vulkan/commands.h"

#include "core/error.h"
#include "render/output.h"
#include "render/renderer.h"
#include "render/vulkan/bake_file.h"
#include "render/vulkan/vulkan_scene.h"

#include <fmt/core.h>

namespace oblong::vk {

std::unique_ptr<TraceBackend> makeScene(const Scene& scene, const AccelOptions& opts) {
  return std::make_unique<VulkanScene>(scene, opts);
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
