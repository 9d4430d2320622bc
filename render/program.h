// What the programs share: the command line (apps/oblong.cpp) and the Python
// module (python/) load a scene, choose its strategies by name, build a device's
// trace backend and check a render's options through these, so that both accept the same
// input and fail with the same one-line messages (oblong::Error, naming the command
// line's flag: "--range: unknown strategy 'x' (known: ...)").
#pragma once

#include "core/asset_scene.h"
#include "core/scene.h"
#include "render/accel_options.h"
#include "render/renderer.h"
#include "render/trace_backend.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace oblong {

// The scene file at `path`, or the built-in default scene for an empty path; a mesh file
// (by its extension, core/asset_scene.h) is read as a mesh with its material, which
// `asset` (--displacement, --scale, --bias, --tiling) may replace. Those flags with a
// scene file or the built-in scene are an error.
Scene sceneFrom(const std::string& path, const AssetFlags& asset = {});

// "WxH" (--size), at most kMaxImagePixels; a seed, a decimal integer in [0, 2^64) (--seed).
ivec2 parseSize(const std::string& s);
uint64_t parseSeed(const std::string& s);

// The strategy flags of render, trace, bake and info; unset ones keep the scene's choice.
struct StrategyFlags {
  std::string range, inverter, splitter, baseline;
  std::optional<double> marchingScale, step;
  std::optional<bool> inversionInTraversal;
  std::string lod;  // empty: the scene's
  std::optional<float> lodBias;

  // --lod moves the scene's displaced meshes to that level of detail (from their
  // full-resolution maps), before anything is built for them.
  // `perRay`: "" where a λ per ray can be traced (render), else why not.
  void applyLod(Scene& scene, const std::string& perRay = "") const;
  // Whether applyLod changes the scene; else it only runs checkLod.
  bool changesLod() const { return !lod.empty() || lodBias.has_value(); }
  // What applyLod checks last: a λ per ray only where it can be traced; a warning for
  // each map whose levels stop short of the scene's λ.
  void checkLod(const Scene& scene, const std::string& perRay = "") const;
  // The scene's strategies with the flags' choices over them.
  AccelOptions resolve(const Scene& scene) const;
};

// Prisms that lost their projection bounds are traversed box-only, much slower: says so
// on stderr.
void warnBoxOnly(const Scene& scene, const TraceBackend& backend);

// The trace backend of --device `device` ("cpu": Embree, "vulkan"). `render`: the
// options of the render it is built for, whose host memory is checked first on a device
// that renders in bands (checkBandsFit).
std::unique_ptr<TraceBackend> makeBackend(const Scene& scene, const AccelOptions& accel, const std::string& device,
                                          const RenderOptions* render = nullptr);

// The flags of `oblong render` that set its RenderOptions, as given.
struct RenderFlags {
  std::string size, integrator = "path", normals = "micro", seed = "0";
  int threads = 0, spp = 1, maxDepth = 5;
  // The options they set, checked (before the scene is loaded); the size stays the
  // default until sizeFor.
  RenderOptions options() const;
  // The image size (--size, else the scene's) into `opts`; throws oblong::Error when
  // the per-pixel buffers would not fit: colour, depth, normal and the four counters,
  // and `copyBytesPerPixel` more for what is made of them (files, arrays).
  void sizeFor(const Scene& scene, RenderOptions& opts, size_t copyBytesPerPixel) const;
};

}  // namespace oblong
