// The scene handed to Embree (DESIGN §2). Undisplaced meshes are native Embree
// triangles. Displaced meshes are either
//   - user geometry over their bounding prisms, intersected by an Intersector (the
//     traversal chosen by name, or the brute-force / fixed-step baselines), or
//   - the pre-tessellation baseline: every micro-triangle built explicitly and traced
//     by Embree (memory-heavy; the practical speed limit and an independent oracle).
#pragma once

#include "core/memory.h"
#include "core/scene.h"
#include "render/intersector.h"

#include <embree3/rtcore.h>

#include <atomic>
#include <memory>
#include <vector>

namespace oblong {

struct Hit {
  float t = kInfinity;
  int mesh = -1;  // index in Scene::meshes
  int prim = -1;  // base triangle index in that mesh as loaded
  vec2 uv{0.0f};  // texture coordinates of the hit (before tiling)
  vec3 ng{0.0f};  // unit geometric normal of the hit (micro-)triangle
  bool valid() const { return mesh >= 0; }
};

struct AccelOptions {
  bool tessellate = false;    // the pre-tessellation baseline instead of an Intersector
  TraversalConfig traversal;  // strategies for the displaced meshes
};

// The traversal configuration a scene file asks for (its "strategies" block).
TraversalConfig traversalConfigOf(const Scene& scene);

class EmbreeScene {
 public:
  EmbreeScene(const Scene& scene, const AccelOptions& opts);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // First hit; per-ray traversal work is added to *counters when given.
  Hit intersect(const Ray& r, RayCounters* counters = nullptr) const;
  bool occluded(const Ray& r, RayCounters* counters = nullptr) const;
  bool tessellated() const { return tessellate_; }
  std::string geometryName() const;

  MemoryReport memory() const;
  size_t microTriangles() const { return microTriangles_; }
  size_t baseTriangles() const { return baseTriangles_; }
  double buildSeconds() const { return buildSeconds_; }

 private:
  struct Geometry {
    int mesh = -1;
    std::vector<vec4> vertices;       // Embree wants 16-byte-readable vertex buffers
    std::vector<glm::uvec3> indices;
    std::vector<vec2> uvs;            // per vertex
    std::vector<uint32_t> basePrim;   // micro-triangle -> base triangle (displaced only)
    std::unique_ptr<Intersector> intersector;  // displaced meshes as user geometry
  };
  void build(const Scene& scene, const AccelOptions& opts);
  void release();

  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<std::unique_ptr<Geometry>> geoms_;  // indexed by Embree geometry id
  std::shared_ptr<std::atomic<int64_t>> embreeBytes_;
  size_t microTriangles_ = 0, baseTriangles_ = 0;
  bool tessellate_ = false;
  std::string traversalName_;
  double buildSeconds_ = 0;
};

}  // namespace oblong
