// The trace backend: what the renderer (render/integrator.h), `oblong trace` and the
// statistics writer (the command line, apps/oblong.cpp) need of a device's scene. Batches of rays in, the
// closest hits (or whether each ray is blocked) and each ray's traversal work out; and
// what was built: its geometry, describe(), memory, the device. Implemented by
// EmbreeScene (render/embree_scene.h, the CPU), vk::VulkanScene
// (render/vulkan/vulkan_scene.h) and oblong_vkbench's adapter over the Vulkan runner.
//
// Header-only and free of the CPU libraries (Embree, TBB, OpenImageIO), so that
// oblong_vkbench, which links only the Vulkan loader, implements it and runs the same
// integrator (docs/architecture.md, "Layers"; docs/vulkan.md, "On a GPU").
#pragma once

#include "core/math.h"
#include "core/memory.h"
#include "traversal/ray_counters.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace oblong {

struct Hit {
  float t = kInfinity;
  int mesh = -1;  // index in Scene::meshes
  int prim = -1;  // base triangle index in that mesh as loaded
  vec2 uv{0.0f};  // texture coordinates of the hit (before tiling)
  vec3 ng{0.0f};  // unit geometric normal of the hit (micro-)triangle
  bool valid() const { return mesh >= 0; }
};

// What a batch of rays is for. Every kind is traced alike; the kind names the pass for
// timings (oblong_vkbench times camera, shadow and bounce rays apart).
enum class RayKind { Camera, Shadow, Ambient, Bounce };
inline const char* rayKindName(RayKind k) {
  switch (k) {
    case RayKind::Camera: return "camera";
    case RayKind::Shadow: return "shadow";
    case RayKind::Ambient: return "ambient";
    case RayKind::Bounce: return "bounce";
  }
  return "?";
}

// A ray cone (Akenine-Möller et al., "Texture Level of Detail Strategies for Real-Time
// Ray Tracing", Ray Tracing Gems 2019, ch. 20): the footprint's width at the ray's
// origin and its spread angle; at distance t it is width + spread·t wide.
struct RayCone {
  float width = 0.0f, spread = 0.0f;
  RayCone at(float t) const { return {width + spread * t, spread}; }
};

class TraceBackend {
 public:
  virtual ~TraceBackend() = default;

  // The closest hit of every ray. `counters` is empty or holds one entry per ray, set to
  // that ray's traversal work. Returns the seconds the tracing took (the device's own
  // time where it measures it: a GPU's dispatches; else the wall clock of the call).
  virtual double traceHits(RayKind kind, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayCounters> counters) const = 0;
  // Whether anything lies on each ray within [tmin, tmax]: blocked[i] = 1 or 0.
  virtual double traceOcclusion(RayKind kind, std::span<const Ray> rays, std::span<uint8_t> blocked,
                                std::span<RayCounters> counters) const = 0;
  // Whether the two calls above may run from several threads at once (Embree: yes; one
  // GPU queue: no). The renderer renders tiles in parallel on a concurrent backend and
  // large bands of samples one after the other on the others (render/renderer.cpp).
  virtual bool concurrent() const = 0;
  // The level of detail of a camera ray with cone c under `--lod cone` (ConeLod,
  // render/cone_lod.h); 0 for a scene built without a level of detail per ray.
  virtual float coneLod(const Ray&, const RayCone&, float /*bias*/) const { return 0.0f; }

  // What was built, for the summary and `--stats` (the command line, apps/oblong.cpp).
  virtual std::string geometryName() const = 0;  // "rmip+newton+midpoint2d", "tessellated", ...
  virtual size_t baseTriangles() const = 0;
  virtual double buildSeconds() const = 0;
  // The summary's geometry line (before "built in ...").
  virtual std::string geometryText() const {
    return fmt::format("{}, {} base triangles", geometryName(), baseTriangles());
  }
  // Intersector::describe() of each displaced mesh traced by the traversal ("mesh": its
  // index), for `--stats` "traversal".
  virtual nlohmann::json describe() const { return nlohmann::json::array(); }
  // Bytes per structure (docs/render.md, "--stats out.json": `memory`).
  virtual MemoryReport memory() const = 0;
  // `--stats` "device": {"api": ..., and what the device says of itself}.
  virtual nlohmann::json device() const = 0;
  // The console's device line ("Vulkan, NAME (DRIVER)"); empty on the CPU (no line).
  virtual std::string deviceText() const { return {}; }
  // Whether the traversal runs in this process, so that the statistics registry
  // (core/stats.h, `--stats` "counters") counts its work.
  virtual bool hostStatistics() const { return false; }
};

// The one convention for memory in every statistics file (`oblong --stats`,
// oblong_vkbench --out): "memory", bytes per structure as integers, and "memory_total",
// their sum. The console prints the same numbers in binary units (KiB, MiB, ...).
inline void addMemoryJson(nlohmann::json& j, const MemoryReport& m) {
  j["memory"] = nlohmann::json::object();
  for (const MemoryItem& item : m) j["memory"][item.name] = item.bytes;
  j["memory_total"] = totalBytes(m);
}

}  // namespace oblong
