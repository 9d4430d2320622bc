// The scene handed to Embree (docs/design.md §2). Undisplaced meshes are native Embree
// triangles. Displaced meshes are either
//   - user geometry over their bounding prisms, intersected by an Intersector (the
//     traversal chosen by name, or the brute-force / fixed-step baselines), or
//   - the pre-tessellation baseline (`--baseline tessellated`): every micro-triangle
//     built explicitly and traced by Embree (memory-heavy; the practical speed limit and
//     an independent oracle).
#pragma once

#include "core/memory.h"
#include "core/scene.h"
#include "render/accel_options.h"
#include "render/embree_ray.h"
#include "render/far_rays.h"
#include "render/tessellation.h"
#include "render/trace_backend.h"
#include "traversal/intersector.h"

#include <embree3/rtcore.h>

#include <atomic>
#include <memory>
#include <vector>

namespace oblong {

class ConeLod;  // render/cone_lod.h: the scene owns one under --lod cone

// What a displaced mesh's user-geometry callbacks need: its intersector, which works in
// the mesh's frame (Mesh::origin), and the frame's origin.
struct EmbreeUserGeometry {
  const Intersector* intersector = nullptr;
  dvec3 origin{0.0};
};

// A pre-tessellated mesh: its micro-triangles in the mesh's frame (as the traversal and
// the brute force see them), in an Embree scene of their own that a one-primitive user
// geometry traces with the ray moved into the frame as the traversal moves it. In world
// floats the micro-vertices of a mesh far from the origin would round together.
struct EmbreeFrameScene {
  RTCScene scene = nullptr;
  dvec3 origin{0.0};
  AABB bounds;  // of the micro-triangles, in the frame
};

// The CPU's trace backend (render/trace_backend.h): batches are traced in parallel
// (TBB) and may be traced from several threads at once.
class EmbreeScene : public TraceBackend {
 public:
  EmbreeScene(const Scene& scene, const AccelOptions& opts);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // First hit; per-ray traversal work is added to *counters when given.
  Hit intersect(const Ray& r, RayCounters* counters = nullptr) const;
  bool occluded(const Ray& r, RayCounters* counters = nullptr) const;

  // TraceBackend: intersect / occluded over a batch, in parallel.
  double traceHits(RayKind kind, std::span<const Ray> rays, std::span<Hit> hits,
                   std::span<RayCounters> counters) const override;
  double traceOcclusion(RayKind kind, std::span<const Ray> rays, std::span<uint8_t> blocked,
                        std::span<RayCounters> counters) const override;
  bool concurrent() const override { return true; }
  // The level of detail of a ray with cone c under --lod cone (ConeLod::lod); 0 for a
  // scene built without TraversalConfig::lodPerRay.
  float coneLod(const Ray& r, const RayCone& c, float bias) const override;
  bool tessellated() const { return tessellate_; }
  std::string geometryName() const override;
  std::string geometryText() const override;
  nlohmann::json device() const override;
  bool hostStatistics() const override { return true; }

  MemoryReport memory() const override;
  // Prisms of each displaced mesh traced by the traversal: built, and with projection
  // bounds (the rest are traversed box-only).
  struct PrismCounts {
    int mesh = -1;
    size_t built = 0, wellPosed = 0;
  };
  std::vector<PrismCounts> prismCounts() const;
  // Intersector::describe() of each displaced mesh traced as user geometry ("mesh": its
  // index): the strategies with their resolved parameters and the code path that ran.
  nlohmann::json describe() const override;
  // The map of displaced mesh `mesh` was edited in `changed` (samples, inclusive, may
  // wrap): its intersector updates what the edit reaches, then the BVH is refitted to the
  // new prism bounds. Throws oblong::Error for a pre-tessellated scene or a baseline
  // without an update.
  struct UpdateTimes {
    double structureSeconds = 0, prismSeconds = 0, bvhSeconds = 0;
    size_t triangles = 0;  // prisms recomputed
  };
  UpdateTimes update(int mesh, const SampleRange& changed);
  size_t microTriangles() const { return microTriangles_; }
  size_t baseTriangles() const override { return baseTriangles_; }
  double buildSeconds() const override { return buildSeconds_; }

 private:
  struct Geometry {
    int mesh = -1;
    std::vector<vec4> vertices;       // Embree wants 16-byte-readable vertex buffers
    std::vector<glm::uvec3> indices;
    std::vector<vec2> uvs;            // per vertex
    std::vector<uint32_t> basePrim;   // micro-triangle -> base triangle (displaced only)
    std::unique_ptr<Intersector> intersector;  // displaced meshes as user geometry
    EmbreeUserGeometry user;  // what its callbacks get
    EmbreeFrameScene frame;  // pre-tessellated meshes
  };
  void build(const Scene& scene, const AccelOptions& opts);
  void release();

  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::unique_ptr<ConeLod> cone_;  // under a per-ray level of detail only
  std::vector<std::unique_ptr<Geometry>> geoms_;  // indexed by Embree geometry id
  std::shared_ptr<std::atomic<int64_t>> embreeBytes_;
  size_t microTriangles_ = 0, baseTriangles_ = 0;
  bool tessellate_ = false;
  SceneReach reach_;  // rays starting far outside it are moved to it (render/far_rays.h)
  std::string traversalName_;
  double buildSeconds_ = 0;
};

}  // namespace oblong
