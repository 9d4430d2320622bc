// `oblong info`: what a scene needs and what is built for it, per mesh (the range
// query's layout and bytes, the level of detail, the prisms, the memory), as JSON (the
// Python module's scene.info()) and as the text the command line prints from it.
#pragma once

#include "core/scene.h"
#include "traversal/intersector.h"

#include <nlohmann/json.hpp>

#include <string>

namespace oblong {

// Builds, per displaced mesh, what the renderer would build under `config` (once each,
// then freed) and describes it:
//   {"scene": path, "meshes": [{"name", "vertices", "triangles", "displaced", ...}],
//    "displaced_meshes", "total_bytes", "peak_memory"}
// A plain mesh has "bytes"; a displaced one "map", "scale", "bias", "tiling", "needs",
// "lod", and either "tessellation" (a baseline the scene builds), "traversal" (the
// intersector's describe()) with "prisms", "per_ray" (a level of detail per ray) or
// "baseline", then "memory" (bytes per structure) and "memory_total".
nlohmann::json sceneInfo(const Scene& scene, const TraversalConfig& config);

// The lines `oblong info` prints for sceneInfo's JSON.
std::string sceneInfoText(const nlohmann::json& info);

}  // namespace oblong
