// What a scene is built with on any device: the traversal's configuration, from the scene
// file and the flags. Free of Embree, so that the Vulkan path and the programs name it
// without the CPU backend's header (render/embree_scene.h).
#pragma once

#include "core/scene.h"
#include "traversal/intersector.h"

#include <string>

namespace oblong {

struct AccelOptions {
  TraversalConfig traversal;  // strategies for the displaced meshes, or a baseline
  // The default strategies with a baseline instead, e.g. withBaseline("tessellated").
  static AccelOptions withBaseline(const std::string& name) {
    AccelOptions o;
    o.traversal.baseline = name;
    return o;
  }
};

// The traversal configuration a scene file asks for (its "strategies" block).
TraversalConfig traversalConfigOf(const Scene& scene);

}  // namespace oblong
