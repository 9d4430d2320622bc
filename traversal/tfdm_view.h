// The "tfdm" baseline's view for the GPU: what traversal/tfdm.cpp exposes of its
// structure, so that the Vulkan records (render/vulkan/records.cpp) upload it without
// the driver's header (traversal/traversal.h) or the baseline's implementation.
#pragma once

#include "core/math.h"
#include "traversal/intersector.h"
#include "traversal/traversal_mesh.h"

#include <cstdint>
#include <vector>

namespace oblong {

// What the Vulkan path uploads of the "tfdm" baseline (traversal/tfdm.cpp): its
// per-triangle constants and its min-max pyramid as stored, level by level (bits 16: one
// word of conservative codes per node, decoded with `base` + code · `step`; bits 32: the
// float [min, max], two words). `folds`: nodes above the stored levels are unions of at
// most 64 stored nodes; when false the CPU answers them with a minmax_mipmap range query,
// which the shaders do not have.
struct TfdmView {
  const TraversalMesh* mesh = nullptr;
  int bits = 16;
  float base = 0.0f, step = 0.0f;
  std::vector<ivec2> dims;                   // level L: dims[L].x × dims[L].y nodes
  std::vector<const uint32_t*> words;        // level L's words, row-major
  bool folds = true;
  int topLevel = 0;                          // the highest root level
  bool worldBoxes = false;                   // the `boxes: "world"` ablation
};
class TfdmIntersector : public Intersector {
 public:
  virtual TfdmView view() const = 0;
};

}  // namespace oblong
