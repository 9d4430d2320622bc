// Intersector: the per-mesh interface between Embree's user geometry and a traversal
// (docs/design.md §2). One Intersector serves one displaced mesh: it bounds every displaced
// triangle (its prism) and finds the first hit of a ray with one triangle's
// micro-geometry. The Embree callback is one indirect call per ray/prism pair.
#pragma once

#include "core/kernels/constants.h"

#include "core/heightmap.h"
#include "core/math.h"
#include "core/memory.h"
#include "core/params.h"
#include "core/registry.h"
#include "core/triangle.h"
#include "strategies/range_query.h"
#include "traversal/ray_counters.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>

#include <memory>
#include <map>
#include <string>
#include <vector>

namespace oblong {

struct TriangleHit {
  float t = kInfinity;
  vec2 uv{0.0f};  // texture coordinates of the hit (before tiling)
  vec3 ng{0.0f};  // unit geometric normal of the hit micro-triangle
};

// Fixed steps far below a texel only multiply the inversions (kMinMarchingScale, in
// core/scene.h, bounds the traversal's work the same way).
constexpr float kMinFixedStepTexels = 1.0f / 64.0f;  // of the smallest texel's world size

// The strategy choice for the displaced meshes of a scene (names as on the CLI).
struct TraversalConfig {
  std::string range = "rmip";          // RangeQuery name
  std::string inverter = "newton";     // Inverter name
  std::string splitter = "midpoint2d"; // Splitter name
  float marchingScale = 4.0f;          // texels: rectangles at most this size are marched
  bool inversionInTraversal = true;    // invert box intervals to tighten rectangles (Fig. 12)
  // Entries of the per-ray, per-prism stack the traversal may use, 2..OBLONG_TRAV_STACK:
  // a push beyond it marches (or tests cell by cell) instead, on the CPU and the GPU alike.
  // A bound on a shader's local memory to study, and how the tests reach the overflow
  // branch, which the full depth never meets.
  int stackDepth = OBLONG_TRAV_STACK_DEFAULT;
  // "" (the traversal above) or a registered baseline (BaselineRegistry below):
  // "bruteforce" (every micro-triangle of the prism's triangle: the oracle), "tfdm"
  // (Thonat et al. 2021's quad-tree traversal), "fixedstep" (PDM-style constant-step
  // marching, approximate), "tessellated" (registered by render/embree_scene.cpp,
  // StrategyTraits::builtByScene: not an Intersector, EmbreeScene builds it).
  std::string baseline;
  // A level of detail per ray (Ray::lod; docs/lod.md): one intersector per level of the
  // map, each blending toward the next with the ray's fraction (createIntersector).
  bool lodPerRay = false;
  float fixedStep = 0.0f;  // world-space step of "fixedstep" (0: one texel's world size)
  nlohmann::json baselineParams = nlohmann::json::object();  // the baseline's own parameters
  // Strategy parameters by strategy (JSON objects), e.g. rmip: {"resolution": 0.5}.
  nlohmann::json rangeParams = nlohmann::json::object();
  nlohmann::json inverterParams = nlohmann::json::object();
  nlohmann::json splitterParams = nlohmann::json::object();
  // The scene file the choices come from ("" when built in code): errors about unknown
  // names and parameters name it.
  std::string source;
  // Slots ("strategies.range", ...) whose choice a command-line flag made, with the flag:
  // errors about them name the flag, not the scene file.
  std::map<std::string, std::string> flags;
  std::string where(const std::string& slot) const {
    if (const auto f = flags.find(slot); f != flags.end()) return f->second;
    return source.empty() ? slot : source + ": " + slot;
  }
};

class Intersector {
 public:
  virtual ~Intersector() = default;
  virtual std::string name() const = 0;  // e.g. "rmip+newton+midpoint2d"
  virtual size_t size() const = 0;       // number of triangles (Embree primitives)
  // Conservative world bounds of triangle `prim`'s bounding prism; empty for triangles
  // that cannot be displaced (skipped with a warning at build time).
  virtual AABB bounds(uint32_t prim) const = 0;
  // First hit of r with triangle `prim`'s micro-geometry in [r.tmin, r.tmax]
  // (r.tmax is the closest hit found so far: prune against it). Adds to c.
  virtual bool intersect(const Ray& r, uint32_t prim, TriangleHit& hit, RayCounters& c) const = 0;
  virtual MemoryReport memory() const = 0;
  // What was built and how it runs, for --stats and `oblong info`: the strategies with
  // their resolved parameters, the code path, the traversal options.
  virtual nlohmann::json describe() const { return {{"name", name()}}; }
  // The displacement map's samples in `changed` (inclusive, may wrap) were edited:
  // refresh the structures they affect, so that the intersector equals one built on the
  // edited map. Reports the triangles whose bounds() may have changed (the caller refits
  // its BVH over them) and the seconds spent. Intersectors without an incremental update
  // throw oblong::Error.
  struct Update {
    std::vector<uint32_t> triangles;
    double structureSeconds = 0, prismSeconds = 0;
  };
  virtual Update update(const SampleRange& changed);
};

// Baselines are registered like strategies (core/registry.h), one line in their .cpp:
//     OBLONG_REGISTER_BASELINE("tfdm", makeTfdm, StrategyTraits{...});
// StrategyTraits::approximate marks a baseline that is not exact by design (fixedstep):
// the conformance suites run every other one against the oracle. A layer above may
// register a baseline its scene builds instead of an Intersector
// (StrategyTraits::builtByScene: `tessellated`, render/embree_scene.cpp).
// Padding of a prism's box traced in the world at `origin` + box (a mesh's frame):
// Embree's ray/box test for user geometry and GPU implementations' box tests are not
// robust (t = lo·(1/d) − o·(1/d) in float, off by about |o|·2^-24 along each axis).
// 2^-22 of the box's world magnitude covers rays starting within about twice that
// magnitude.
inline double framePad(const AABB& local, const dvec3& origin) {
  double m = 0;
  for (int a = 0; a < 3; ++a)
    m = std::max({m, std::abs(double(local.lo[a]) + origin[a]), std::abs(double(local.hi[a]) + origin[a])});
  return m * 0x1p-22;
}

struct BaselineContext {
  const TraversalConfig& config;
  std::vector<DisplacedTriangle>* triangles;  // the factory takes them (moves from them)
  const Displacement& disp;
};
using BaselineRegistry = Registry<Intersector, BaselineContext>;
#define OBLONG_REGISTER_BASELINE(name, ...) OBLONG_REGISTER(::oblong::BaselineRegistry, name, __VA_ARGS__)

// Builds the intersector for one displaced mesh: its triangles (DisplacedTriangle,
// prepared) and its displacement. Unknown names / unused parameters throw oblong::Error.
std::unique_ptr<Intersector> createIntersector(const TraversalConfig& cfg,
                                               std::vector<DisplacedTriangle> triangles,
                                               const Displacement& disp);

}  // namespace oblong
