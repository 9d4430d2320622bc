// The scene handed to Embree. Undisplaced meshes are native Embree triangles;
// displaced meshes are, for now, the pre-tessellation baseline (DESIGN §2): every
// micro-triangle built explicitly and traced by Embree. It is the memory-heavy
// reference the tessellation-free traversals are compared against.
#pragma once

#include "core/memory.h"
#include "core/scene.h"

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

class EmbreeScene {
 public:
  explicit EmbreeScene(const Scene& scene);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  Hit intersect(const Ray& r) const;
  bool occluded(const Ray& r) const;

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
  };
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<std::unique_ptr<Geometry>> geoms_;  // indexed by Embree geometry id
  std::shared_ptr<std::atomic<int64_t>> embreeBytes_;
  size_t microTriangles_ = 0, baseTriangles_ = 0;
  double buildSeconds_ = 0;
};

}  // namespace oblong
