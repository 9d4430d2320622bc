// The pre-tessellation baseline's micro-triangles (`--baseline tessellated`): their
// count and memory before they are built, and their construction, one base triangle's
// patch at a time. EmbreeScene builds and traces them (render/embree_scene.cpp);
// `oblong export` writes the same triangles (render/mesh_export.h); `oblong info`
// reports the estimate. Free of Embree: only the BVH's size per triangle is Embree's,
// as measured.
#pragma once

#include "core/heightmap.h"
#include "core/mesh.h"

#include <cstddef>
#include <vector>

namespace oblong {

// The pre-tessellation baseline's name (TraversalConfig::baseline): registered in
// BaselineRegistry as built by the scene (render/embree_scene.cpp), so it is listed and
// chosen like every baseline; EmbreeScene builds it instead of user geometry.
inline constexpr const char* kTessellatedBaseline = "tessellated";

// The pre-tessellation baseline's size for one displaced mesh, computed before it is
// built (EmbreeScene refuses a scene whose micro-triangles would not fit in memory).
struct TessellationEstimate {
  // Embree's BVH over the micro-triangles (RTC_SCENE_FLAG_ROBUST, default quality),
  // measured on grids of 2-134 M triangles: 54-64 bytes per triangle after the build,
  // 84-98 in all (RSS) at the peak of the build (docs/range_query.md, "Memory").
  static constexpr size_t kBvhBytesPerTriangle = 64;
  static constexpr size_t kBvhBuildBytesPerTriangle = 100;

  size_t microTriangles = 0;  // exact: what the baseline builds
  size_t vertices = 0;        // shared vertices, an upper bound (Euler's formula per patch)
  size_t tableBytes = 0;      // the patches' vertex tables, all of them
  size_t largestTable = 0;    // and the largest one
  size_t geometryBytes() const {  // vertices + padding, uvs, indices, base prims, as stored
    return (vertices + 1) * sizeof(vec4) + vertices * sizeof(vec2) + microTriangles * (sizeof(glm::uvec3) + 4);
  }
  size_t bvhBytes() const { return microTriangles * kBvhBytesPerTriangle; }
  size_t patchBytes() const { return vertices * (sizeof(vec4) + sizeof(vec2)) + microTriangles * sizeof(glm::uvec3); }
};
TessellationEstimate estimateTessellation(const Mesh& mesh, const Displacement& d);
// The micro-triangles the pre-tessellation baseline builds for each triangle of the mesh
// (forEachMicroTriangle's, counted without building them; 0 for a skipped triangle).
std::vector<size_t> microTriangleCounts(const Mesh& mesh, const Displacement& d);
// A point of a mesh's frame in world floats: origin + p summed in double, rounded once
// (plain meshes' vertices as Embree traces them, and `oblong export`'s positions; the
// pre-tessellated micro-triangles are traced in the mesh's frame instead).
inline vec3 worldFloat(const Mesh& mesh, const vec3& p) { return vec3(mesh.origin + dvec3(p)); }
// Bytes held at the peak of building these meshes' tessellations and their BVH
// (patches with their vertex tables, the concatenated buffers, Embree's build).
size_t tessellationPeakBytes(const std::vector<TessellationEstimate>& meshes, size_t threads);

// Micro-triangles of one base triangle with its vertices shared (exact position match).
struct TessellationPatch {
  std::vector<vec4> vertices;
  std::vector<vec2> uvs;
  std::vector<glm::uvec3> indices;
};

// Sizes of one base triangle's patch: micro-triangles exactly as forEachMicroTriangle
// emits them, shared vertices bounded by Euler's formula.
struct TessellationPatchSize {
  size_t triangles = 0, vertices = 0;
};

// Each triangle's patch size (in parallel), their sum for the mesh, and one patch built
// from its size (no regrowth, so the build's peak is what was estimated).
std::vector<TessellationPatchSize> tessellationPatchSizes(const Mesh& mesh, const Displacement& d);
TessellationEstimate summarizeTessellation(const std::vector<TessellationPatchSize>& sizes);
TessellationPatch tessellatePatch(const DisplacedTriangle& T, const Displacement& d,
                                  const TessellationPatchSize& size);

}  // namespace oblong
