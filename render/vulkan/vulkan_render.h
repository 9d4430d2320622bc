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
// Samples go in bands (RenderOptions::bandSamples) so that host memory stays bounded;
// Ctrl-C (RenderOptions::interrupt) is taken between bands: the pixels whose samples were
// all traced are kept, the result is marked partial.
RenderResult render(const Scene& scene, VulkanScene& accel, const RenderOptions& opts);

// Throws oblong::Error, before any work, when the host memory render() needs does not fit.
void checkRenderFits(const RenderOptions& opts);

}  // namespace oblong::vk
