// The baked scene file (`oblong bake SCENE -o scene.oblg`, read by oblong_vkbench):
// everything the Vulkan path uploads (records.h) plus what generates the rays (camera,
// image size, lights and albedos for the path integrator, and optionally a ray list),
// so that a machine with a GPU and none of the CPU libraries can run the traversal.
//
// Layout (little-endian): a 32-byte header
//   char magic[8] = "OBLGBAKE"; u32 version; u32 sections; u64 fileBytes; u64 tableChecksum
// then `sections` entries {char name[16]; u64 offset; u64 bytes; u64 checksum}, then the
// sections' bytes. Checksums are FNV-1a 64 over 8-byte words (checksum64). Section
// "meta" is JSON (format, version, struct sizes, scene, camera, image, lights, ...); the
// others are the arrays of GpuRecords, each stored as byte planes (byte 0 of every
// element, then byte 1, ...: compresses better); the checksums are of the arrays as they
// lie in memory. The version changes with any change of device_records.h's structs or of
// the layout: a file of another version is refused.
#pragma once

#include "core/scene.h"
#include "render/vulkan/records.h"

#include <cstdint>
#include <string>
#include <vector>

namespace oblong::vk {

inline constexpr uint32_t kBakeVersion = 11;  // 11: the boxes' float frame (TriGpu::box); 10: arrays stored as byte planes; 9: tfdm (MeshGpu::method, tfStored); 8: the micro-cells' edges computed by the shaders (core/kernels/microcells.h); 7: MeshGpu::stackDepth; 6: boxes in the texture frame (TriGpu::texAxis, ...)

struct BakedScene {
  GpuRecords records;
  std::string scene;    // path of the scene it was baked from
  std::string version;  // oblong's version that baked it
  Camera camera;
  ivec2 image{640, 480};       // default size of the camera rays
  std::vector<Light> lights;   // path integrator
  std::vector<vec3> albedo;    // per mesh
  vec3 sky{0.12f, 0.14f, 0.18f};
  int maxDepth = 5;
  std::vector<vkgpu::RayGpu> rays;  // optional: a fixed ray list (bake --rays)
};

// FNV-1a 64 over little-endian 8-byte words (the tail zero-padded), then the length.
uint64_t checksum64(const void* data, size_t bytes);

// Throws oblong::Error naming the file on any write error.
// Returns the bytes written; errors name `shown` (the final name) when given.
uint64_t writeBake(const std::string& path, const BakedScene& b, const std::string& shown = "");
// Throws oblong::Error with one line naming the file on a missing, foreign, truncated,
// corrupt or other-version file.
BakedScene readBake(const std::string& path);

}  // namespace oblong::vk
