// The renderer: the integrator (render/integrator.h) over a whole image, on any trace
// backend (render/trace_backend.h), with per-pixel AOVs. Deterministic for a given seed
// whatever the thread count or the batching: each pixel sample draws from its own
// random stream, and its value does not depend on the batch it is traced in.
//
// Two schedules, by what the backend allows (TraceBackend::concurrent):
//   tiles  (EmbreeScene, the CPU) 16x16 image tiles rendered in parallel with TBB, each
//          traced in batches of at most 4096 samples;
//   bands  (VulkanScene, one GPU queue) the image's samples in order, in bands of up to
//          2^18 samples (RenderOptions::bandSamples), one after the other.
// Ctrl-C (RenderOptions::interrupt) is taken between tiles or bands.
//
// Shading normals (--normals): `micro`, the geometric normal of the hit micro-triangle
// (the micro-geometry is flat, docs/design.md §1; shows every texel cell and base edge), or
// `smooth`, the smoothed displaced normal of the PDM paper §5.1 (smoothDisplacedNormal).
// With smooth normals, light and bounce directions below the geometric surface are
// dropped (no light through the surface).
#pragma once

#include "core/scene.h"
#include "core/triangle.h"
#include "render/image.h"
#include "render/integrator.h"
#include "render/progress.h"
#include "render/trace_backend.h"

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

namespace oblong {

enum class ShadingNormals { Micro, Smooth };
ShadingNormals parseShadingNormals(const std::string& name);  // throws oblong::Error
const char* shadingNormalsName(ShadingNormals n);

// The smoothed displaced normal of the PDM paper (Hoetzlein 2025, §5.1 and App. B,
// Eq. 19) at barycentrics (u, v) of T: the normal of S = P + h·N/|N| with the base
// triangle's flat normal P_u × P_v replaced by the interpolated vertex normal scaled to
// the same length (and orientation), h's gradient taken from the bilinear map:
//     N's = |P_u × P_v|·n̂ + h_v·(P_u × n̂) + h_u·(n̂ × P_v),   n̂ = N(u,v)/|N(u,v)|.
// Like the paper, the terms h·∂n̂ are dropped. Without a displacement (d == nullptr): n̂,
// Phong's interpolated normal. Unit length, oriented like P_u × P_v; zero when it cannot
// be formed (degenerate T).
vec3 smoothDisplacedNormal(const DisplacedTriangle& T, const Displacement* d, float u, float v);

// The geometric normal of hit h facing ray r (ngf) and the shading normal (ns, same
// side) of the chosen kind; `triangles` (every mesh's, indexed by Hit::prim) is needed
// for smooth normals only. The renderer's Normals for integrate().
void shadingNormals(const Scene& scene, const std::vector<std::vector<DisplacedTriangle>>& triangles,
                    ShadingNormals kind, const Ray& r, const Hit& h, vec3& ngf, vec3& ns);
// ∇_uv h of the bilinear height h(uv) (docs/design.md §1), inside the cell that holds uv.
vec2 bilinearHeightGradient(const Displacement& d, const vec2& uv);

struct RenderOptions {
  ivec2 size{640, 480};
  int spp = 1;
  int threads = 0;  // 0: all cores
  Integrator integrator = Integrator::Path;
  ShadingNormals normals = ShadingNormals::Micro;
  uint64_t seed = 0;
  int maxDepth = 5;          // path: bounces
  float aoRadius = 0.0f;     // ao: 0 = a quarter of the scene's bounding-box diagonal
  vec3 sky{0.12f, 0.14f, 0.18f};  // path: radiance of rays that leave the scene
  Progress* progress = nullptr;  // advanced per rendered row of a tile
  // Set (by a SIGINT handler) to stop: tiles not yet started are skipped, the ones in
  // flight finish, and the result is marked partial.
  const std::atomic<bool>* interrupt = nullptr;
  // Bands (a backend that is not concurrent, e.g. --device vulkan): camera samples traced
  // per band (0: the default, 2^18); the image does not depend on it.
  size_t bandSamples = 0;
};

// Per-pixel outputs. Counters are the camera rays' traversal work, averaged over the
// pixel's samples (the RMIP paper's Fig. 9 heat maps are of primary rays).
struct AOVs {
  Image color{1, 1};
  std::vector<float> depth;   // t of the first hit (inf: miss), first sample
  std::vector<vec3> normal;   // shading normal of the first hit, first sample (0: miss)
  std::vector<float> steps, rangeQueries, inversions, cellsMarched;
  // Every buffer sized for the image and cleared (depth to inf).
  void allocate(ivec2 size);
};

struct RenderResult {
  AOVs aov;
  // Tiles: the render's wall clock. Bands: the backend's own tracing seconds (a GPU's
  // dispatches, without the host's shading), and tracingOnly is set.
  double seconds = 0;
  bool tracingOnly = false;
  int64_t primaryRays = 0, secondaryRays = 0, hits = 0;  // camera rays, the others, camera rays that hit
  RayCounters counters;  // traversal work of all rays (camera and secondary)
  int64_t pixelsDone = 0;  // < width x height when interrupted (the rest stays black)
  // Under --lod cone: the camera rays' λ from the rule (before each map's clamp), summed,
  // and how many were at 0 (footprint within a texel, or no base mesh met).
  double cameraLodSum = 0;
  int64_t cameraLodZero = 0;
  bool partial = false;
};

// The integrator's settings for this scene and these options.
IntegratorSettings integratorSettings(const Scene& scene, const RenderOptions& opts);

RenderResult render(const Scene& scene, const TraceBackend& backend, const RenderOptions& opts);

// `oblong trace`: the first hit of every ray, in batches of 2^18 rays on any backend;
// Ctrl-C (interrupt) is taken between batches, and then `interrupted` is set and the hits
// are incomplete. threads: as RenderOptions::threads.
struct TraceResult {
  std::vector<Hit> hits;
  RayCounters counters;  // all rays' work
  int64_t found = 0;     // rays that hit
  double seconds = 0;    // the backend's (TraceBackend::traceHits)
  bool interrupted = false;
};
// `perRay`, when given, receives each ray's own work (one entry per ray).
TraceResult traceRays(const TraceBackend& backend, const std::vector<Ray>& rays, int threads = 0,
                      const std::atomic<bool>* interrupt = nullptr, std::vector<RayCounters>* perRay = nullptr);

// Throws oblong::Error, before any work, when the host memory of the bands schedule
// (render() on a backend that is not concurrent) does not fit: the per-pixel sums and
// counters and at least 2^10 samples in flight.
void checkBandsFit(const RenderOptions& opts);

// Colour, depth, normal and the per-pixel counters as one multi-channel EXR.
void writeAOVs(const AOVs& aov, const std::string& path);
// The heat map of steps per pixel is render/figures.h's writeHeatMap.

}  // namespace oblong
