// The Vulkan ray tracing path (docs/vulkan.md; docs/design.md §4 "Run the canonical configuration on
// Vulkan ray tracing"): the scene's upload records (records.h, built by the CPU's own
// code) on the device runner (runner.h): one AABB per bounding prism (the CPU's
// Intersector::bounds), triangles for undisplaced meshes, and the traversal in an
// intersection shader. Same rays in, same hits out as EmbreeScene::intersect
// (docs/vulkan.md has the layouts and the parity numbers).
#pragma once

#include "core/memory.h"
#include "core/scene.h"
#include "render/accel_options.h"
#include "render/cone_lod.h"
#include "render/far_rays.h"
#include "render/trace_backend.h"
#include "render/vulkan/records.h"

#include <memory>
#include <string>
#include <vector>

namespace oblong::vk {

class Runner;

// The Vulkan trace backend (render/trace_backend.h): one batch at a time (one queue).
class VulkanScene : public TraceBackend {
 public:
  // Throws oblong::Error with one line when no Vulkan device supports ray tracing, when
  // the configuration is not the canonical one (rmip + newton + midpoint2d, no
  // baseline), or when the scene does not fit the device's limits.
  VulkanScene(const Scene& scene, const AccelOptions& opts);
  ~VulkanScene();
  VulkanScene(const VulkanScene&) = delete;
  VulkanScene& operator=(const VulkanScene&) = delete;

  // First hit of every ray (Vulkan needs tmin >= 0: a negative tmin is an error);
  // per-ray traversal work into *counters when given. Seconds of the dispatches only.
  // anyHit: occlusion rays, the traversal stops at the first prism or triangle that
  // reports a hit (valid() then means occluded; t, mesh and uv are of that hit).
  std::vector<Hit> trace(const std::vector<Ray>& rays, std::vector<RayCounters>* counters = nullptr,
                         double* seconds = nullptr, bool anyHit = false) const;

  // TraceBackend: trace() into the caller's buffers.
  double traceHits(RayKind kind, std::span<const Ray> rays, std::span<Hit> hits,
                   std::span<RayCounters> counters) const override;
  double traceOcclusion(RayKind kind, std::span<const Ray> rays, std::span<uint8_t> blocked,
                        std::span<RayCounters> counters) const override;
  bool concurrent() const override { return false; }
  // The CPU's rule (ConeLod) for a camera ray's λ, as EmbreeScene::coneLod.
  float coneLod(const Ray& r, const RayCone& c, float bias) const override {
    return cone_ ? cone_->lod(r, c, bias) : 0.0f;
  }

  std::string deviceName() const;   // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string driverInfo() const;   // e.g. "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"
  std::string geometryName() const override { return geometryName_; }
  MemoryReport memory() const override;
  double buildSeconds() const override { return buildSeconds_; }
  size_t baseTriangles() const override { return baseTriangles_; }
  nlohmann::json describe() const override { return describe_; }
  nlohmann::json device() const override;
  std::string deviceText() const override;

 private:
  // trace() on n rays into hits and, when not null, counters (n each).
  double traceInto(const Ray* rays, size_t n, Hit* hits, RayCounters* counters, bool anyHit) const;

  std::unique_ptr<Runner> run_;
  std::unique_ptr<ConeLod> cone_;  // under a level of detail per ray only
  SceneReach reach_;  // render/far_rays.h
  nlohmann::json describe_;
  std::string geometryName_;
  double buildSeconds_ = 0;
  size_t baseTriangles_ = 0;
};

}  // namespace oblong::vk
