// `--device vulkan` for oblong trace and oblong render, and oblong bake (render/apps/oblong.cpp calls these
// after it has read the scene, the strategy flags and the rays). Without the Vulkan
// target (CMake option OBLONG_VULKAN off, or Vulkan / glslc not installed), the stubs
// in commands_stub.cpp fail with one line saying so.
#pragma once

#include "core/scene.h"
#include "render/embree_scene.h"
#include "render/renderer.h"

#include <atomic>
#include <string>
#include <vector>

namespace oblong::vk {

// Writes the hits CSV (render/rays_io.h format) and prints one summary line; returns
// the exit status. Throws oblong::Error (one line) on any problem.
int traceCommand(const Scene& scene, const AccelOptions& opts, const std::vector<Ray>& rays,
                 const std::string& raysPath, const std::string& out, const std::string& statsPath,
                 const std::atomic<bool>* interrupt = nullptr);

// Renders (any integrator, render() of render/renderer.h); writes the image and the
// optional AOVs / heat map / stats. Interrupted (RenderOptions::interrupt) between
// bands of samples: writes what was rendered, marked partial, and returns 130.
int renderCommand(const Scene& scene, const AccelOptions& opts, const RenderOptions& ro, const std::string& out,
                  const std::string& aovs, const std::string& heatmap, const std::string& statsPath);

// `oblong bake`: the scene's upload records, camera, image size, lights and albedos,
// and the rays when given, into one baked file (bake_file.h); prints one summary line.
int bakeCommand(const Scene& scene, const AccelOptions& opts, ivec2 image, const std::vector<Ray>& rays,
                const std::string& out, const std::string& version);

}  // namespace oblong::vk
