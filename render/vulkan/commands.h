// `--device vulkan` for oblong trace and oblong render, and oblong bake
// (apps/oblong.cpp calls these after it has read the scene and the strategy
// flags). Rendering, tracing and the summaries are the CPU's (render/renderer.h,
// render/report.h), on the Vulkan trace backend. Without the Vulkan target (CMake option
// OBLONG_VULKAN off, or Vulkan / glslc not installed), the stubs in commands_stub.cpp
// fail with one line saying so.
#pragma once

#include "core/scene.h"
#include "render/accel_options.h"
#include "render/trace_backend.h"

#include <memory>
#include <string>
#include <vector>

namespace oblong::vk {

// The scene on Vulkan (VulkanScene, render/vulkan/vulkan_scene.h). Throws oblong::Error
// (one line) when there is no device with ray tracing or the configuration is not the
// canonical one.
std::unique_ptr<TraceBackend> makeScene(const Scene& scene, const AccelOptions& opts);

// `oblong bake`: the scene's upload records, camera, image size, lights and albedos,
// and the rays when given, into one baked file (bake_file.h); prints one summary line.
int bakeCommand(const Scene& scene, const AccelOptions& opts, ivec2 image, const std::vector<Ray>& rays,
                const std::string& out, const std::string& version);

}  // namespace oblong::vk
