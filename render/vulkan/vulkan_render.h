// `oblong render --device vulkan`: the renderer (render/renderer.h) with every ray traced
// on Vulkan, as a wavefront: all camera rays as one batch, then per bounce one batch of
// shadow rays and one of bounce rays (ao: one batch of occlusion rays). Shading, random
// streams (PCG32 per pixel sample, consumed in the CPU's order), spawning and the AOVs
// are render/renderer.cpp's, so the images match the CPU's.
#pragma once

#include "render/renderer.h"
#include "render/vulkan/vulkan_scene.h"

namespace oblong::vk {

// Same pixels, samples, integrators, AOVs and counters as oblong::render.
RenderResult render(const Scene& scene, VulkanScene& accel, const RenderOptions& opts);

}  // namespace oblong::vk
