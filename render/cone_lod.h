// The ray-cone rule of a level of detail per ray (docs/lod.md, "A λ per ray"): a ray's
// footprint where it meets the undisplaced base meshes, in texels of the base triangle
// it meets. The CPU renderer (through EmbreeScene) and the Vulkan renderer share it, so
// both trace every ray at the same λ.
#pragma once

#include "core/scene.h"
#include "render/trace_backend.h"  // RayCone

#include <embree3/rtcore.h>

#include <vector>

namespace oblong {

class ConeLod {
 public:
  // An Embree scene of the displaced meshes' base triangles and each one's texel size
  // in world units. device: where to build it (its memory monitor then counts it); null:
  // a device of its own.
  explicit ConeLod(const Scene& scene, RTCDevice device = nullptr);
  ~ConeLod();
  ConeLod(const ConeLod&) = delete;
  ConeLod& operator=(const ConeLod&) = delete;

  // The level of detail of a ray with cone c: the cone's width where the ray meets the
  // base meshes, over that triangle's texel size, log2, plus bias, clamped to [0, 64];
  // 0 when the ray misses them.
  float lod(const Ray& r, const RayCone& c, float bias) const;

 private:
  RTCDevice device_ = nullptr;  // retained (ours or the caller's), released with the scene
  RTCScene base_ = nullptr;
  std::vector<std::vector<float>> texel_;  // by geometry id, then primitive
};

}  // namespace oblong
