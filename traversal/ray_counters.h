// Per-ray traversal work, as every intersector and both devices count it, and its
// `--stats` JSON. A header of its own (no other oblong header) so that programs without
// the CPU libraries (oblong_vkbench) share it.
#pragma once

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>

namespace oblong {

// Per-ray work counters (summed over the prisms a ray visits).
struct RayCounters {
  int64_t boxes = 0;          // ray/box tests of uv-rectangle bounds
  int64_t rangeQueries = 0;   // RangeQuery::query calls
  int64_t inversions = 0;     // Inverter calls
  int64_t cellsMarched = 0;   // grid cells visited by texel marching
  int64_t microTriangles = 0; // ray/micro-triangle tests
  int64_t prisms = 0;         // prisms entered
  // Traversal steps as the RMIP paper counts them (Fig. 9): boxes + marched cells.
  int64_t steps() const { return boxes + cellsMarched; }
  RayCounters& operator+=(const RayCounters& o) {
    boxes += o.boxes, rangeQueries += o.rangeQueries, inversions += o.inversions;
    cellsMarched += o.cellsMarched, microTriangles += o.microTriangles, prisms += o.prisms;
    return *this;
  }
};

// The counters as `--stats` JSON writes them (CPU and Vulkan alike), with the mean steps
// over `rays`.
inline nlohmann::json countersJson(const RayCounters& c, int64_t rays) {
  return {{"boxes", c.boxes},
          {"range_queries", c.rangeQueries},
          {"inversions", c.inversions},
          {"cells_marched", c.cellsMarched},
          {"micro_triangles", c.microTriangles},
          {"prisms", c.prisms},
          {"steps", c.steps()},
          {"steps_per_ray", double(c.steps()) / double(std::max<int64_t>(1, rays))}};
}

}  // namespace oblong
