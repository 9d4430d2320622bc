// VulkanScene: buildRecords (records.cpp) on the device runner (runner.cpp), with the
// CPU's Ray / Hit / RayCounters at the interface.
#include "render/vulkan/vulkan_scene.h"

#include "render/vulkan/runner.h"

#include <fmt/format.h>

#include <chrono>

namespace oblong::vk {

using namespace vkgpu;

VulkanScene::VulkanScene(const Scene& scene, const AccelOptions& opts) {
  const auto start = std::chrono::steady_clock::now();
  GpuRecords records = buildRecords(scene, opts, &describe_);
  reach_ = sceneReach(scene);
  if (opts.traversal.lodPerRay) cone_ = std::make_unique<ConeLod>(scene);
  geometryName_ = records.geometryName;
  baseTriangles_ = size_t(records.baseTriangles);
  run_ = std::make_unique<Runner>(std::move(records));
  buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

VulkanScene::~VulkanScene() = default;

std::string VulkanScene::deviceName() const { return run_->deviceName(); }
std::string VulkanScene::driverInfo() const { return run_->driverInfo(); }
MemoryReport VulkanScene::memory() const {
  MemoryReport r;
  for (const auto& [name, bytes] : run_->memory()) r.push_back({name, bytes});
  return r;
}
nlohmann::json VulkanScene::device() const {
  return {{"api", "vulkan"}, {"name", deviceName()}, {"driver", driverInfo()}};
}
std::string VulkanScene::deviceText() const { return fmt::format("Vulkan, {} ({})", deviceName(), driverInfo()); }

std::vector<Hit> VulkanScene::trace(const std::vector<Ray>& rays, std::vector<RayCounters>* counters,
                                    double* seconds, bool anyHit) const {
  std::vector<Hit> out(rays.size());
  if (counters) counters->assign(rays.size(), RayCounters{});
  const double s = traceInto(rays.data(), rays.size(), out.data(), counters ? counters->data() : nullptr, anyHit);
  if (seconds) *seconds = s;
  return out;
}

double VulkanScene::traceHits(RayKind, std::span<const Ray> rays, std::span<Hit> hits,
                              std::span<RayCounters> counters) const {
  return traceInto(rays.data(), rays.size(), hits.data(), counters.empty() ? nullptr : counters.data(), false);
}

double VulkanScene::traceOcclusion(RayKind, std::span<const Ray> rays, std::span<uint8_t> blocked,
                                   std::span<RayCounters> counters) const {
  std::vector<Hit> hits(rays.size());
  const double s =
      traceInto(rays.data(), rays.size(), hits.data(), counters.empty() ? nullptr : counters.data(), true);
  for (size_t i = 0; i < rays.size(); ++i) blocked[i] = hits[i].valid() ? 1 : 0;
  return s;
}

double VulkanScene::traceInto(const Ray* rays, size_t n, Hit* out, RayCounters* counters, bool anyHit) const {
  std::vector<HitGpu> hg(n);
  std::vector<CountersGpu> cg(counters ? n : 0);
  std::vector<RayGpu> gpu(n);
  // Far origins moved to the scene as EmbreeScene moves them (render/far_rays.h); a ray
  // that cannot reach the scene is traced empty (tmin = tmax = 0, far from every surface).
  std::vector<NearRay> near(n);
  for (size_t i = 0; i < n; ++i) {
    near[i] = nearScene(rays[i], reach_);
    const Ray& r = near[i].ray;
    gpu[i] = near[i].misses ? RayGpu{r.o, r.d, 0.0f, 0.0f, r.lod, 0.0f} : RayGpu{r.o, r.d, r.tmin, r.tmax, r.lod, 0.0f};
  }
  double seconds = 0;
  run_->trace(gpu.data(), n, hg.data(), counters ? cg.data() : nullptr, anyHit, &seconds);
  for (size_t i = 0; i < n; ++i) {
    out[i] = Hit{};
    if (hg[i].mesh >= 0) {
      out[i].t = unshift(hg[i].t, near[i].shift);
      out[i].mesh = hg[i].mesh;
      out[i].prim = hg[i].prim;
      out[i].uv = vec2(hg[i].u, hg[i].v);
      out[i].ng = hg[i].ng;
    }
    if (counters) {
      RayCounters& c = counters[i];
      c = RayCounters{};
      c.prisms = cg[i].prisms, c.boxes = cg[i].boxes, c.rangeQueries = cg[i].rangeQueries;
      c.inversions = cg[i].inversions, c.cellsMarched = cg[i].cellsMarched, c.microTriangles = cg[i].microTriangles;
    }
  }
  return seconds;
}

}  // namespace oblong::vk
