// A small direct-lighting renderer over an EmbreeScene: one primary ray per pixel
// sample, Lambert shading with shadow rays to the scene's lights, multi-threaded over
// image tiles with TBB. Deterministic: the result does not depend on the thread count.
#pragma once

#include "render/embree_scene.h"
#include "render/image.h"

namespace oblong {

struct RenderOptions {
  ivec2 size{640, 480};
  int threads = 0;  // 0: all cores
};

struct RenderResult {
  Image image{1, 1};
  double seconds = 0;
  int64_t primaryRays = 0, shadowRays = 0, hits = 0;
};

RenderResult renderDirect(const Scene& scene, const EmbreeScene& accel, const RenderOptions& opts);

}  // namespace oblong
