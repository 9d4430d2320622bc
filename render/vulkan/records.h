// Everything the Vulkan path uploads, as plain arrays in the GPU layouts of core/kernels/device_records.h:
// built from a Scene by buildRecords (records.cpp, which needs the CPU libraries), read
// and written as one baked file by bake_file.h, and consumed by the device runner
// (runner.h), which needs nothing but the Vulkan loader. `oblong --device vulkan`,
// `oblong bake` and `oblong_vkbench` share these records and the runner.
#pragma once

#include "core/kernels/device_records.h"

#include <nlohmann/json_fwd.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace oblong {
// Declared only: the runner and the baked file use the records without the CPU libraries.
struct Scene;
struct AccelOptions;
}  // namespace oblong

namespace oblong::vk {

// One prism's box in VkAabbPositionsKHR's layout (NaN min x: inactive).
struct AabbGpu {
  float lo[3], hi[3];
};

struct GpuRecords {
  std::vector<vkgpu::TriGpu> tris;        // displaced triangles, all meshes
  std::vector<vkgpu::MeshGpu> meshes;     // one per scene mesh (chunkShift set by the runner)
  std::vector<uint32_t> meshTriangles;    // base triangles per mesh (bottom-level sizes)
  std::vector<uint32_t> meshVertices;     // vertices per mesh (plain meshes: maxVertex + 1)
  std::vector<float> texels;              // height maps, raw texels, row-major
  std::vector<uint32_t> rmipData;         // RMIP words of every mesh
  std::vector<glm::ivec4> rmipLayers;     // RMIP layer tables of every mesh
  std::vector<uint32_t> plainIndex;       // plain meshes: 3 indices a triangle
  std::vector<glm::vec2> plainUV;         // plain meshes: uv per vertex
  std::vector<float> plainPos;            // plain meshes: xyz per vertex
  std::vector<AabbGpu> aabbs;             // one per displaced triangle (prism bounds)
  std::string geometryName;               // "rmip+newton+midpoint2d"
  uint64_t baseTriangles = 0;
  uint64_t triBytes = 0, rmipBytes = 0, texelBytes = 0;  // memory report
};

// The records of every mesh, built with the CPU's own code (createIntersector). Throws
// oblong::Error with one line when the configuration is not the canonical one
// (rmip + newton + midpoint2d, no baseline) or the maps exceed the 32-bit offsets.
// `describe`, when given, gets each displaced mesh's Intersector::describe() ("mesh":
// its index), as EmbreeScene::describe() gives them.
GpuRecords buildRecords(const Scene& scene, const AccelOptions& opts, nlohmann::json* describe = nullptr);

}  // namespace oblong::vk
