// The programs' shared steps (program.h).
#include "render/program.h"

#include "core/error.h"
#include "core/lod.h"
#include "core/memory.h"
#include "core/procedural.h"
#include "render/embree_scene.h"
#include "render/vulkan/commands.h"

#include <fmt/core.h>

#include <charconv>
#include <cmath>
#include <limits>
#include <regex>

namespace oblong {

namespace {

constexpr double kMaxFloat = std::numeric_limits<float>::max();

void warnLodClamped(const Scene& scene) {
  if (!scene.lod) return;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const auto& d = scene.meshes[i].displacement;
    if (!d || d->lod >= *scene.lod) continue;
    const HeightMap& m = d->level0 ? *d->level0 : *d->map;
    eprint("oblong: warning: {}: meshes[{}]: map {} ({}x{}) has levels of detail up to {}: traced at {}, not {}\n",
           scene.path, i, m.name(), m.width(), m.height(), lodLevels(m), d->lod, *scene.lod);
  }
}

}  // namespace

Scene sceneFrom(const std::string& path, const AssetFlags& asset) {
  if (!path.empty() && isAssetPath(path)) return loadAsset(path, asset);
  if (asset.any()) {
    const char* flag = !asset.displacement.empty() ? "--displacement"
                       : asset.scale              ? "--scale"
                       : asset.bias               ? "--bias"
                                                  : "--tiling";
    fail(flag, "applies to a mesh file given instead of a scene ({})",
         path.empty() ? std::string("the built-in scene has its own") : path + " is a scene file: set it there");
  }
  return path.empty() ? defaultScene() : loadScene(path);
}

ivec2 parseSize(const std::string& s) {
  std::smatch m;
  static const std::regex re(R"((\d+)x(\d+))");
  if (!std::regex_match(s, m, re)) fail("--size", "expected WxH with positive integers, got '{}'", s);
  // Each side saturated past 2^31 (any such side is too large anyway).
  const auto side = [](const std::string& d) {
    return d.size() > 10 ? int64_t(1) << 31 : std::min<int64_t>(std::stoll(d), int64_t(1) << 31);
  };
  const int64_t w = side(m[1]), h = side(m[2]);
  if (w <= 0 || h <= 0) fail("--size", "expected positive sizes, got '{}'", s);
  if (w * h > kMaxImagePixels)
    fail("--size", "{} pixels is more than the supported 2^26 (8192x8192), as in a scene's image block",
         excerpt(s, 40));
  return ivec2(int(w), int(h));
}

uint64_t parseSeed(const std::string& s) {
  uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || s[0] == '-' || s[0] == '+' || ec != std::errc() || end != s.data() + s.size())
    fail("--seed", "expected an integer in [0, 2^64), got '{}'", s);
  return v;
}

void StrategyFlags::applyLod(Scene& scene, const std::string& perRay) const {
  if (lod == "cone") {
    setLodCone(scene);
  } else if (!lod.empty()) {
    std::optional<float> l;
    if (lod != "off") {
      float v = 0.0f;
      const auto [end, ec] = std::from_chars(lod.data(), lod.data() + lod.size(), v);
      if (ec != std::errc() || end != lod.data() + lod.size() || !std::isfinite(v) || v < 0.0f)
        fail("--lod", "must be off, cone or a level of detail >= 0 (a number), got '{}'", lod);
      l = v;
    }
    setLod(scene, l, "--lod");
  }
  if (lodBias) {
    if (!scene.lodCone) fail("--lod-bias", "applies to --lod cone only (a λ per ray)");
    if (!std::isfinite(*lodBias) || std::abs(*lodBias) > 64.0f)
      fail("--lod-bias", "must be a number of levels in [-64, 64], got {}", *lodBias);
    scene.lodBias = *lodBias;
  }
  checkLod(scene, perRay);
}

void StrategyFlags::checkLod(const Scene& scene, const std::string& perRay) const {
  if (scene.lodCone && !perRay.empty())
    fail(lod == "cone" ? std::string("--lod") : scene.path + ": strategies.lod",
         "cone (a λ per ray from its ray cone): {}; use render, or a fixed level of detail", perRay);
  warnLodClamped(scene);
}

AccelOptions StrategyFlags::resolve(const Scene& scene) const {
  AccelOptions o;
  o.traversal = traversalConfigOf(scene);
  TraversalConfig& c = o.traversal;
  // A flag naming another strategy than the scene's drops the scene's parameters for it.
  auto pick = [&c](std::string& name, nlohmann::json& params, const std::string& value, const char* slot,
                   const char* flag) {
    if (value.empty() || value == name) return;
    name = value;
    params = nlohmann::json::object();
    c.flags[slot] = flag;
  };
  pick(c.range, c.rangeParams, range, "strategies.range", "--range");
  pick(c.inverter, c.inverterParams, inverter, "strategies.inverter", "--inverter");
  pick(c.splitter, c.splitterParams, splitter, "strategies.splitter", "--splitter");
  if (marchingScale) {
    if (!(*marchingScale >= kMinMarchingScale) || !(*marchingScale <= kMaxFloat))
      fail("--marching-scale",
           "must be a number of texels >= {} (smaller only multiplies the work) and <= {:g} (a float), got {:g}",
           kMinMarchingScale, kMaxFloat, *marchingScale);
    c.marchingScale = float(*marchingScale);
  }
  if (inversionInTraversal) c.inversionInTraversal = *inversionInTraversal;
  // A --baseline other than the scene's drops the scene's parameters for it.
  if (!baseline.empty() && baseline != c.baseline) {
    c.baseline = baseline;
    c.baselineParams = nlohmann::json::object();
    c.flags["strategies.baseline"] = "--baseline";
  }
  if (step) {
    if (!(*step > 0) || !(*step <= kMaxFloat))
      fail("--step", "must be a number > 0 and at most {:g} (a float), got {:g}", kMaxFloat, *step);
    if (c.baseline != "fixedstep") fail("--step", "only applies to --baseline fixedstep");
    c.fixedStep = float(*step);
    c.baselineParams.erase("step");
  }
  return o;
}

void warnBoxOnly(const Scene& scene, const TraceBackend& backend) {
  const auto* accel = dynamic_cast<const EmbreeScene*>(&backend);
  if (!accel) return;  // the counts are the CPU scene's
  for (const auto& p : accel->prismCounts()) {
    const size_t boxOnly = p.built - p.wellPosed;
    if (boxOnly == 0) continue;
    eprint(
        "oblong: warning: {}: meshes[{}]: {} of {} prisms are box-only (no projection bounds: the normals "
        "converge within the displacement, or the triangle is too thin or too far from its mesh's centre "
        "for its size), which makes them much slower to trace\n",
        scene.path, p.mesh, boxOnly, p.built);
  }
}

std::unique_ptr<TraceBackend> makeBackend(const Scene& scene, const AccelOptions& accel, const std::string& device,
                                          const RenderOptions* render) {
  if (device == "vulkan") {
    if (render) checkBandsFit(*render);
    return vk::makeScene(scene, accel);
  }
  if (device != "cpu") fail("--device", "{} not in {{cpu,vulkan}}", device);
  return std::make_unique<EmbreeScene>(scene, accel);
}

RenderOptions RenderFlags::options() const {
  if (threads < 0) fail("--threads", "must be >= 0, got {}", threads);
  if (spp <= 0) fail("--spp", "must be >= 1, got {}", spp);
  if (maxDepth <= 0) fail("--max-depth", "must be >= 1, got {}", maxDepth);
  RenderOptions opts;
  if (!size.empty()) opts.size = parseSize(size);
  opts.threads = threads;
  opts.spp = spp;
  opts.maxDepth = maxDepth;
  opts.seed = parseSeed(seed);
  opts.integrator = parseIntegrator(integrator);
  opts.normals = parseShadingNormals(normals);
  return opts;
}

void RenderFlags::sizeFor(const Scene& scene, RenderOptions& opts, size_t copyBytesPerPixel) const {
  if (size.empty()) opts.size = scene.imageSize;
  // The renderer's own buffers: colour, depth, normal and four counters per pixel.
  const size_t perPixel = 44 + copyBytesPerPixel;
  const size_t px = size_t(opts.size.x) * size_t(opts.size.y);
  checkFits(size.empty() ? scene.path : std::string("--size"), "rendering at this size", px * perPixel,
            "choose a smaller --size", fmt::format("{}x{} pixels, {} bytes each", opts.size.x, opts.size.y, perPixel));
}

}  // namespace oblong
