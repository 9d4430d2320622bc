// The Vulkan device runner: a headless Vulkan 1.2 device with VK_KHR_ray_tracing_pipeline
// and VK_KHR_acceleration_structure (Mesa's lavapipe on the CPU, or a GPU), the records
// of records.h uploaded, one bottom level of AABB geometry per displaced mesh (one AABB
// per bounding prism), one of triangle geometry per undisplaced mesh, a top level over
// them, the pipeline of shaders/, and dispatches of rays. Needs only the Vulkan loader
// (and header-only fmt), so that oblong_vkbench runs where none of the CPU libraries are.
#pragma once

#include "render/vulkan/records.h"

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace oblong::vk {

struct Device;         // instance, device, queue, pipelines (runner.cpp)
struct SceneOnDevice;  // one scene's buffers, acceleration structures, descriptor set

// Keeps the process's Vulkan device, and the pipelines compiled on it, alive while it
// lives. Runners share one device (and one pipeline per intersection shader) with every
// Runner or DeviceHold alive when they are made; without one, each Runner made after
// the last one died creates the device and compiles the pipeline again (seconds on
// lavapipe). Throws as Runner does when no device supports ray tracing.
class DeviceHold {
 public:
  DeviceHold();
  ~DeviceHold();

 private:
  std::shared_ptr<Device> device_;
};

// The driver's own account of the ray-tracing pipelines (VK_KHR_pipeline_executable_
// properties): per intersection program, each executable the driver compiled (a stage, or
// stages merged) with its statistics as the driver names them (on NVIDIA: registers,
// binary size, local memory, ...). Where the device lacks the extension, supported is
// false and the programs list no executables (their pipelines are still created).
struct PipelineStatistic {
  std::string name, description;
  double value = 0;  // booleans as 0 or 1
};
struct PipelineExecutable {
  std::string name, description;
  std::string stages;  // "intersection", "raygen+miss", ...
  uint32_t subgroupSize = 0;
  std::vector<PipelineStatistic> statistics;
};
struct PipelineProgram {
  std::string method, stage;  // "canonical", "prism.rint"
  std::vector<PipelineExecutable> executables;
};
struct PipelineStatistics {
  std::string device, driver;
  bool supported = false;
  std::vector<PipelineProgram> programs;
};
// Creates a device of its own (with the extension, where the device has it), compiles the
// pipeline of every intersection program with statistics captured and returns them. The
// SPIR-V is the build's, or, where spirvDir is not empty, that folder's STAGE.spv files
// (another commit's shaders, with the same descriptor bindings and push constants).
// Throws oblong::Error with one line as Runner does, or naming an unreadable module.
PipelineStatistics pipelineStatistics(const std::string& spirvDir = "");

class Runner {
 public:
  // Takes the records (the large arrays are freed once on the device), on the process's
  // shared device (DeviceHold). One thread traces at a time per device. Throws
  // oblong::Error with one line when no Vulkan device supports ray tracing or the
  // records do not fit the device's limits.
  explicit Runner(GpuRecords records);
  ~Runner();
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;

  // First hit of n rays (tmin >= 0) into hits[0, n), per-ray work into counters when
  // not null. anyHit: occlusion rays. *seconds: wall time of the dispatches; *gpuSeconds:
  // their GPU time from timestamp queries (-1 when the queue has no timestamps).
  void trace(const vkgpu::RayGpu* rays, size_t n, vkgpu::HitGpu* hits, vkgpu::CountersGpu* counters, bool anyHit,
             double* seconds = nullptr, double* gpuSeconds = nullptr);

  std::string deviceName() const;  // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string driverInfo() const;  // e.g. "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"
  const std::string& geometryName() const { return geometryName_; }
  uint64_t baseTriangles() const { return baseTriangles_; }
  // (name, bytes) of every part on the device: "vulkan/triangles", "vulkan/blas", ...
  const std::vector<std::pair<std::string, size_t>>& memory() const { return memory_; }

 private:
  std::unique_ptr<SceneOnDevice> scene_;
  std::string geometryName_;
  uint64_t baseTriangles_ = 0;
  std::vector<std::pair<std::string, size_t>> memory_;
};

}  // namespace oblong::vk
