// oblong: command-line front end.
//   oblong render [SCENE.json] -o out.png [--size WxH] [--spp N] [--integrator primary|ao|path] [--seed S]
//                 [--normals micro|smooth] [--threads N] [--aovs out.exr] [--heatmap steps.png]
//                 [--stats out.json] [strategy flags]
//   oblong trace  [SCENE.json] --rays RAYS.csv|.bin -o HITS.csv [--stats out.json] [strategy flags]
//   oblong info   [SCENE.json] [--range NAME] | --strategies [--json]
//   oblong bake   [SCENE.json] -o SCENE.oblg [--size WxH] [--rays RAYS] [strategy flags]
// Strategy flags (override the scene's "strategies" block): --range, --inverter,
// --splitter, --marching-scale, --inversion-in-traversal, --baseline, --step.
// Without a scene file, the built-in default scene is used (no data files needed).
// Every bad input ends with one line "oblong: FILE: problem" and exit status 1; every
// output path is checked before any work. Ctrl-C during `render` finishes the tiles in
// flight, writes what was rendered (marked partial in --stats) and exits with 130.
#include "oblong_version.h"

#include "core/error.h"
#include "core/lod.h"
#include "core/memory.h"
#include "core/procedural.h"
#include "core/scene.h"
#include "core/stats.h"
#include "render/embree_scene.h"
#include "render/image.h"
#include "render/output.h"
#include "render/progress.h"
#include "render/rays_io.h"
#include "render/renderer.h"
#include "render/report.h"
#include "traversal/strategy_catalog.h"
#include "traversal/traversal.h"
#include "render/vulkan/commands.h"
#include "strategies/range_query.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <bit>
#include <charconv>
#include <chrono>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <system_error>
#include <limits>
#include <optional>
#include <regex>

using namespace oblong;

namespace {

Scene sceneFrom(const std::string& path) { return path.empty() ? defaultScene() : loadScene(path); }

// The files a loaded scene was read from (scene, meshes, maps), as (what, path) pairs
// for checkNotInputs; the procedural ones ("<...>") have no file.
std::vector<std::pair<std::string, std::string>> sceneInputs(const std::string& scenePath, const Scene& scene) {
  std::vector<std::pair<std::string, std::string>> in;
  if (!scenePath.empty()) in.emplace_back("scene", scenePath);
  for (const SceneMesh& sm : scene.meshes) {
    if (!sm.mesh.name.empty() && sm.mesh.name[0] != '<') in.emplace_back("mesh", sm.mesh.name);
    if (!sm.displacement) continue;
    for (const HeightMap* m : {sm.displacement->map.get(), sm.displacement->level0.get()})
      if (m && !m->name().empty() && m->name()[0] != '<') in.emplace_back("displacement map", m->name());
  }
  return in;
}

// --device of render and trace: "cpu" (Embree) or "vulkan" (render/vulkan/commands.h).
std::string deviceFlag = "cpu";

ivec2 parseSize(const std::string& s) {
  std::smatch m;
  static const std::regex re(R"((\d{1,5})x(\d{1,5}))");
  if (!std::regex_match(s, m, re)) fail("--size", "expected WxH with positive integers, got '{}'", s);
  const ivec2 v(std::stoi(m[1]), std::stoi(m[2]));
  if (v.x <= 0 || v.y <= 0) fail("--size", "expected positive sizes, got '{}'", s);
  if (int64_t(v.x) * v.y > kMaxImagePixels)
    fail("--size", "{}x{} pixels is more than the supported 2^26 (8192x8192), as in a scene's image block", v.x, v.y);
  return v;
}

// A seed is a decimal integer in [0, 2^64): no sign, no wrap-around.
uint64_t parseSeed(const std::string& s) {
  uint64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || s[0] == '-' || s[0] == '+' || ec != std::errc() || end != s.data() + s.size())
    fail("--seed", "expected an integer in [0, 2^64), got '{}'", s);
  return v;
}

// Set by Ctrl-C; a second Ctrl-C kills at once (SA_RESETHAND).
std::atomic<bool> gInterrupted{false};
extern "C" void onInterrupt(int) { gInterrupted.store(true); }
void catchInterrupt() {
  struct sigaction sa {};
  sa.sa_handler = onInterrupt;
  sa.sa_flags = SA_RESETHAND;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
}
constexpr int kInterruptedStatus = 130;  // 128 + SIGINT, as shells report it

// Strategy flags shared by render and trace; unset flags keep the scene's choice.
constexpr double kMaxFloat = std::numeric_limits<float>::max();

struct StrategyFlags {
  std::string range, inverter, splitter, baseline;
  std::optional<double> marchingScale, step;
  std::optional<bool> inversionInTraversal;
  std::string lod;  // empty: the scene's
  std::optional<float> lodBias;

  void add(CLI::App* app) {
    app->add_option("--lod", lod,
                    "level of detail: off | cone (a λ per ray from its ray cone; render only) | a number >= 0, "
                    "clamped to each map's last level (docs/lod.md; default: the scene's, off)");
    app->add_option("--lod-bias", lodBias, "levels added to each ray's λ under --lod cone (default: the scene's, 0)");
    app->add_option("--range", range, "RangeQuery: " + strategyChoices(StrategyKind::Range));
    app->add_option("--inverter", inverter, "Inverter: " + strategyChoices(StrategyKind::Inverter));
    app->add_option("--splitter", splitter, "Splitter: " + strategyChoices(StrategyKind::Splitter));
    app->add_option("--marching-scale", marchingScale,
                    "rectangles of at most this many texels are marched (>= 1/64; default: the scene's, 4)");
    app->add_option("--inversion-in-traversal", inversionInTraversal, "invert box intervals (true | false)");
    std::string choices;
    for (const std::string& n : baselineNames()) choices += (choices.empty() ? "" : " | ") + n;
    app->add_option("--baseline", baseline, choices + " (instead of the traversal)")
        ->check(CLI::IsMember(baselineNames()));
    app->add_option("--step", step,
                    "world-space step of --baseline fixedstep (default: one texel; at least 1/64 of the smallest "
                    "texel's world size)");
  }

  // --lod moves the scene's displaced meshes to that level of detail (from their
  // full-resolution maps), before anything is built for them.
  // `perRay`: "" where a λ per ray can be traced (render), else why not.
  void applyLod(Scene& scene, const std::string& perRay = "") const {
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
    if (scene.lodCone && !perRay.empty())
      fail(lod == "cone" ? std::string("--lod") : scene.path + ": strategies.lod",
           "cone (a λ per ray from its ray cone): {}; use render, or a fixed level of detail", perRay);
    warnLodClamped(scene);
  }

  static void warnLodClamped(const Scene& scene) {
    if (!scene.lod) return;
    for (size_t i = 0; i < scene.meshes.size(); ++i) {
      const auto& d = scene.meshes[i].displacement;
      if (!d || d->lod >= *scene.lod) continue;
      const HeightMap& m = d->level0 ? *d->level0 : *d->map;
      eprint("oblong: warning: {}: meshes[{}]: map {} ({}x{}) has levels of detail up to {}: traced at {}, not {}\n",
                 scene.path, i, m.name(), m.width(), m.height(), lodLevels(m), d->lod, *scene.lod);
    }
  }

  AccelOptions resolve(const Scene& scene) const {
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
};

void writeJson(const std::string& path, const nlohmann::json& j) { writeTextOutput(path, j.dump(2) + "\n"); }

// Prisms that lost their projection bounds are traversed box-only, much slower; say so.
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

struct RenderFlags {
  std::string out = "oblong.png", size, statsPath, aovs, heatmap, integrator = "path", normals = "micro";
  std::string seed = "0", progress = "auto";
  int threads = 0, spp = 1, maxDepth = 5;
  bool quiet = false, defaultOut = true;
};

int runRender(const std::string& scenePath, const RenderFlags& f, const StrategyFlags& flags) {
  // Everything the command line decides is checked before the scene is loaded.
  if (f.threads < 0) fail("--threads", "must be >= 0, got {}", f.threads);
  if (f.spp <= 0) fail("--spp", "must be >= 1, got {}", f.spp);
  if (f.maxDepth <= 0) fail("--max-depth", "must be >= 1, got {}", f.maxDepth);
  RenderOptions opts;
  if (!f.size.empty()) opts.size = parseSize(f.size);
  opts.threads = f.threads;
  opts.spp = f.spp;
  opts.maxDepth = f.maxDepth;
  opts.seed = parseSeed(f.seed);
  opts.integrator = parseIntegrator(f.integrator);
  opts.normals = parseShadingNormals(f.normals);
  const ProgressMode asked = parseProgressMode(f.progress);  // checked even under -q
  const ProgressMode mode = f.quiet ? ProgressMode::Never : asked;
  checkImageOutput(f.out, "image");
  if (!f.aovs.empty()) {
    checkImageOutput(f.aovs, "AOVs");
    std::string ext = std::filesystem::path(f.aovs).extension().string();
    for (char& c : ext) c = char(std::tolower((unsigned char)c));
    if (ext != ".exr") fail(f.aovs, "AOVs are written as one multi-channel EXR: use a .exr name");
  }
  if (!f.heatmap.empty()) checkImageOutput(f.heatmap, "heat map");
  if (!f.statsPath.empty()) checkOutputPath(f.statsPath, "statistics");
  const std::vector<std::pair<std::string, std::string>> outputs = {
      {"-o", f.out}, {"--aovs", f.aovs}, {"--heatmap", f.heatmap}, {"--stats", f.statsPath}};
  checkDistinctOutputs(outputs);
  checkNotInputs(outputs, {{"scene", scenePath}});

  Progress progress(mode);
  progress.phase("loading " + (scenePath.empty() ? std::string("the built-in scene") : scenePath));
  Scene scene = sceneFrom(scenePath);
  checkNotInputs(outputs, sceneInputs(scenePath, scene));
  flags.applyLod(scene);
  const double loadSeconds = progress.elapsed();
  const AccelOptions accelOpts = flags.resolve(scene);
  if (f.size.empty()) opts.size = scene.imageSize;
  {
    // Colour, depth, normal and four counters per pixel; the AOV file and the heat map
    // are encoded from copies.
    const size_t perPixel = 44 + (f.aovs.empty() ? 3 : 44) + (f.heatmap.empty() ? 0 : 15);
    const size_t px = size_t(opts.size.x) * size_t(opts.size.y);
    checkFits(f.size.empty() ? scene.path : std::string("--size"), "rendering at this size", px * perPixel,
              "choose a smaller --size", fmt::format("{}x{} pixels, {} bytes each", opts.size.x, opts.size.y, perPixel));
  }
  opts.progress = &progress;
  opts.interrupt = &gInterrupted;
  Stats::reset();
  std::unique_ptr<TraceBackend> backend;
  if (deviceFlag == "vulkan") {
    checkBandsFit(opts);
    progress.phase("building on Vulkan");
    backend = vk::makeScene(scene, accelOpts);
  } else {
    const std::string& baseline = accelOpts.traversal.baseline;
    progress.phase("building the acceleration structures" + (baseline.empty() ? "" : " (--baseline " + baseline + ")"));
    backend = std::make_unique<EmbreeScene>(scene, accelOpts);
  }
  progress.clear();
  warnBoxOnly(scene, *backend);
  if (gInterrupted) {
    eprint("oblong: interrupted before rendering: nothing written\n");
    return kInterruptedStatus;
  }
  progress.phase(fmt::format("rendering {}x{} at {} spp{}", opts.size.x, opts.size.y, opts.spp,
                             deviceFlag == "vulkan" ? " on Vulkan" : ""),
                 int64_t(opts.size.x) * opts.size.y);
  const RenderResult res = render(scene, *backend, opts);
  progress.phase("writing " + f.out);
  writeImage(res.aov.color, f.out);
  if (!f.aovs.empty()) writeAOVs(res.aov, f.aovs);
  if (!f.heatmap.empty()) writeHeatMap(res.aov, f.heatmap);
  progress.clear();
  const RenderReport report{scene, accelOpts, *backend, opts, res, f.out, f.heatmap, f.defaultOut};
  printRenderSummary(report);
  if (!f.statsPath.empty())
    writeJson(f.statsPath, renderStats(report, {OBLONG_VERSION, f.threads, loadSeconds, progress.elapsed()}));
  return res.partial ? kInterruptedStatus : 0;
}

// `oblong bake`: the Vulkan path's upload records and ray generation in one file for
// oblong_vkbench (render/vulkan/bake_file.h).
int runBake(const std::string& scenePath, const std::string& out, const std::string& size,
            const std::string& raysPath, const StrategyFlags& flags) {
  checkOutputPath(out, "baked scene");
  checkNotInputs({{"-o", out}}, {{"scene", scenePath}, {"--rays", raysPath}});
  Scene scene = sceneFrom(scenePath);
  checkNotInputs({{"-o", out}}, sceneInputs(scenePath, scene));
  flags.applyLod(scene, "bake's rays carry no ray cones");
  const AccelOptions accelOpts = flags.resolve(scene);
  const ivec2 image = size.empty() ? scene.imageSize : parseSize(size);
  const std::vector<Ray> rays = raysPath.empty() ? std::vector<Ray>() : readRays(raysPath);
  return vk::bakeCommand(scene, accelOpts, image, rays, out, OBLONG_VERSION);
}

int runTrace(const std::string& scenePath, const std::string& raysPath, const std::string& out, bool defaultOut,
             int threads, const std::string& statsPath, const StrategyFlags& flags) {
  if (threads < 0) fail("--threads", "must be >= 0, got {}", threads);
  checkOutputPath(out, "hits");
  if (!statsPath.empty()) checkOutputPath(statsPath, "statistics");
  const std::vector<std::pair<std::string, std::string>> outputs = {{"-o", out}, {"--stats", statsPath}};
  checkDistinctOutputs(outputs);
  checkNotInputs(outputs, {{"scene", scenePath}, {"--rays", raysPath}});
  const auto start = std::chrono::steady_clock::now();
  Scene scene = sceneFrom(scenePath);
  checkNotInputs(outputs, sceneInputs(scenePath, scene));
  flags.applyLod(scene, "a rays file carries no ray cones");
  const AccelOptions accelOpts = flags.resolve(scene);
  const std::vector<Ray> rays = readRays(raysPath);
  const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Stats::reset();
  const std::unique_ptr<TraceBackend> backend =
      deviceFlag == "vulkan" ? vk::makeScene(scene, accelOpts) : std::make_unique<EmbreeScene>(scene, accelOpts);
  warnBoxOnly(scene, *backend);
  const TraceResult res = traceRays(*backend, rays, threads, &gInterrupted);
  // A hits file must hold every ray's answer: an interrupted trace writes none.
  if (res.interrupted) {
    eprint("oblong: interrupted: no hits written (a hits file holds every ray or none)\n");
    return kInterruptedStatus;
  }
  writeHits(out, res.hits);
  const TraceReport report{scene, accelOpts, *backend, res, raysPath, out, defaultOut};
  printTraceSummary(report);
  if (!statsPath.empty())
    writeJson(statsPath,
              traceStats(report, {OBLONG_VERSION, threads, loadSeconds,
                                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}));
  return 0;
}

// One value of a describe() JSON for `oblong info`: byte counts (keys ending in
// "bytes") in human units, arrays as [a, b, ...].
std::string infoValue(const std::string& key, const nlohmann::json& v) {
  const bool bytes = key.size() >= 5 && key.compare(key.size() - 5, 5, "bytes") == 0;
  if (v.is_array()) {
    std::string s;
    for (const auto& e : v) s += (s.empty() ? "" : ", ") + infoValue(key, e);
    return "[" + s + "]";
  }
  if (bytes && v.is_number_unsigned()) return memoryText(v.get<size_t>());
  return v.is_string() ? v.get<std::string>() : v.dump();
}

// What the traversal built for one displaced mesh (docs/design.md invariant 4), from its
// describe(): the range query's layout and bytes, the strategies' resolved parameters,
// the code path.
void printTraversal(const nlohmann::json& d) {
  const nlohmann::json& rq = d.at("range");
  fmt::print("      built    : {} ({}), {}\n", rq.at("exact").get<bool>() ? "exact bounds" : "conservative bounds",
             infoValue("params", rq.at("params")), memoryText(rq.at("bytes").get<size_t>()));
  if (rq.contains("layout"))
    for (const auto& [k, v] : rq.at("layout").items()) {
      if (k == "stores_wrap" || k == "wrap_bytes") continue;
      // A table (array of arrays): one line per row.
      if (v.is_array() && !v.empty() && v[0].is_array() && v[0].size() > 2) {
        for (size_t r = 0; r < v.size(); ++r) {
          std::string row;
          for (const auto& e : v[r]) row += fmt::format("{:>11}", infoValue(k, e));
          fmt::print("      {:<20}: {:>3} {}\n", r == 0 ? k : "", r, row);
        }
        continue;
      }
      fmt::print("      {:<20}: {}\n", k, infoValue(k, v));
    }
  if (rq.contains("layout") && rq.at("layout").value("stores_wrap", false) &&
      rq.at("layout").value("layout", "") == "pairs")
    fmt::print("      wrap     : blocks wrapping around the map border filled with the wrapped pixels (no extra bytes)\n");
  else if (rq.contains("layout") && rq.at("layout").value("stores_wrap", false))
    fmt::print("      wrap     : corners wrapping around the map border stored{}\n",
               rq.at("layout").contains("wrap_bytes")
                   ? ": " + infoValue("wrap_bytes", rq.at("layout").at("wrap_bytes")) + " of it"
                   : std::string());
  else
    fmt::print("      wrap     : none stored (queries crossing the border are split, or wrap addressing)\n");
  fmt::print("    traversal: {} path; inverter {} {}; splitter {} {}; marching scale {}, inversion in traversal {}\n",
             d.at("path").get<std::string>(), d.at("inverter").at("name").get<std::string>(),
             infoValue("", d.at("inverter").at("params")), d.at("splitter").at("name").get<std::string>(),
             infoValue("", d.at("splitter").at("params")), d.at("marching_scale").get<float>(),
             d.at("inversion_in_traversal").get<bool>() ? "on" : "off");
}

// `oblong info --strategies`: every registered strategy (what the experiments read).
int runStrategies(bool json) {
  const nlohmann::json j = strategiesJson();
  if (json) {
    fmt::print("{}\n", j.dump(2));
    return 0;
  }
  for (const char* kind : {"range", "inverter", "splitter"}) {
    fmt::print("{}:\n", kind);
    for (const auto& e : j.at(kind))
      fmt::print("  {:<14} {}{}\n", e.at("name").get<std::string>(), e.at("summary").get<std::string>(),
                 e.at("slow_reference").get<bool>() ? " [slow reference]" : "");
  }
  fmt::print("baselines:\n");
  for (const auto& e : j.at("baselines"))
    fmt::print("  {:<14} {}{}\n", e.at("name").get<std::string>(), e.at("summary").get<std::string>(),
               e.at("approximate").get<bool>() ? " [approximate]" : "");
  return 0;
}

int runInfo(const std::string& scenePath, const std::string& range, const std::string& lod) {
  Scene scene = sceneFrom(scenePath);
  StrategyFlags flags;
  flags.range = range;
  flags.lod = lod;
  flags.applyLod(scene);
  const TraversalConfig cfg = flags.resolve(scene).traversal;
  fmt::print("scene {}\n", scene.path);
  size_t displaced = 0, total = 0;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const SceneMesh& sm = scene.meshes[i];
    fmt::print("  mesh {} '{}': {} vertices, {} triangles, {}\n", i, sm.mesh.name, sm.mesh.positions.size(),
               sm.mesh.triangles.size(), sm.displacement ? "displaced" : "plain (Embree triangles)");
    if (!sm.displacement) {
      fmt::print("    built    : no range query, no prisms ({})\n", memoryText(sm.mesh.bytes()));
      continue;
    }
    const Displacement& d = *sm.displacement;
    fmt::print("    map {} ({}x{}), scale {}, bias {}, tiling ({}, {}), {}\n", d.map->name(), d.map->width(),
               d.map->height(), d.scale, d.bias, d.tiling.x, d.tiling.y, memoryText(d.map->bytes()));
    // What the traversal builds: the range query sized by the triangles' uv boxes
    // (as createIntersector does) and one prism per displaceable triangle.
    std::vector<DisplacedTriangle> tris(sm.mesh.triangles.size());
    std::vector<Rect> boxes;
    for (size_t t = 0; t < tris.size(); ++t) {
      tris[t] = sm.mesh.triangle(t);
      if (tris[t].uvArea2 != 0.0f) boxes.push_back(tris[t].uvBox);
    }
    const QueryNeeds needs = QueryNeeds::forRects(d, boxes);
    const bool tiled = d.tiling != vec2(1.0f);
    fmt::print("    needs    : range queries up to {}x{} samples; wrapping queries {}\n", needs.maxExtentX,
               needs.maxExtentY,
               !needs.wrap ? "no" : tiled ? "yes (the map is tiled)" : "yes (triangles' cells cross the map border)");
    if (scene.lodCone)
      fmt::print("    LoD      : cone (a λ per ray, bias {}): levels 0 .. {} built, one intersector each (docs/lod.md)\n",
                 scene.lodBias, lodLevels(*d.map));
    else if (!d.level0)
      fmt::print("    LoD      : off, no levels built ({} levels possible for this map, docs/lod.md)\n",
                 lodLevels(*d.map));
    else
      fmt::print("    LoD      : lod {}: level {} grid ({}x{} samples, {}) at the heights of lod {}; the {}x{} "
                 "full-resolution map kept\n",
                 d.lod, int(std::floor(d.lod)), d.map->width(), d.map->height(), memoryText(d.map->bytes()), d.lod,
                 d.level0->width(), d.level0->height());
    if (!cfg.baseline.empty() && BaselineRegistry::instance().has(cfg.baseline) &&
        BaselineRegistry::instance().traits(cfg.baseline).builtByScene) {
      // No intersector: the scene builds the micro-triangles (EmbreeScene's estimate).
      const TessellationEstimate e = estimateTessellation(sm.mesh, d);
      fmt::print("    baseline '{}': no range query; {} micro-triangles: {} of vertices, uvs and indices, about {} "
                 "of Embree BVH\n",
                 cfg.baseline, e.microTriangles, memoryText(e.geometryBytes()), memoryText(e.bvhBytes()));
      total += e.geometryBytes();
      ++displaced;
      continue;
    }
    // Built once, as the renderer builds it; what is shown is that structure.
    const auto is = createIntersector(cfg, tris, d);
    if (const auto* t = dynamic_cast<const TraversalIntersectorBase*>(is.get())) {
      fmt::print("    range query '{}' for displaced mesh {}:\n", t->rangeQuery().name(), displaced);
      printTraversal(t->describe());
      size_t prisms = 0, wellPosed = 0;
      for (const PrismParams& pp : t->mesh().params) prisms += pp.valid, wellPosed += pp.valid && pp.wellPosed;
      fmt::print("    prisms   : {} built ({} well-posed, {} box-only), {} skipped (not displaceable)\n", prisms,
                 wellPosed, prisms - wellPosed, tris.size() - prisms);
    } else if (is->describe().contains("lod")) {
      const nlohmann::json j = is->describe();
      fmt::print("    per ray  : '{}' on each of {} levels: a range structure per level, prisms per level\n",
                 j.at("name").get<std::string>(), j.at("lod").at("levels").get<int>());
    } else {
      fmt::print("    baseline '{}': no range query\n", is->name());
    }
    const MemoryReport mem = is->memory();
    std::string parts;
    for (const auto& m : mem) parts += fmt::format("{}{} {}", parts.empty() ? "" : ", ", m.name, memoryText(m.bytes));
    fmt::print("    built    : {} = {}\n", parts, memoryText(totalBytes(mem)));
    total += totalBytes(mem);
    ++displaced;
  }
  if (displaced == 0) fmt::print("  no displaced mesh: no range query built\n");
  else
    fmt::print("  total    : {} built for {} displaced mesh{} (plus Embree's BVH, reported by oblong render)\n",
               memoryText(total), displaced, displaced == 1 ? "" : "es");
  fmt::print("  peak     : {} of process memory (each structure above built once)\n", memoryText(peakMemoryBytes()));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"oblong: ray tracing displaced triangle meshes without tessellation"};
  app.require_subcommand(1);
  // --help shows every option's default (subcommands copy these option defaults).
  app.option_defaults()->always_capture_default();
  std::string scenePath, statsPath, range, raysPath, hitsPath = "hits.csv", lodFlag;
  int threads = 0;
  StrategyFlags flags;
  RenderFlags rf;

  auto* render = app.add_subcommand("render", "render a scene (default: the built-in scene)");
  render->add_option("scene", scenePath, "scene file (JSON); omit for the built-in default scene");
  auto* renderOut = render->add_option("-o,--output", rf.out, "output image (.png, .exr, .tif, .hdr, .pfm, ...)");
  render->add_option("--size", rf.size, "image size WxH, at most 2^26 pixels (default: the scene's)");
  render->add_option("--threads", rf.threads, "worker threads (0: all cores)");
  render->add_option("--spp", rf.spp, "samples per pixel");
  render->add_option("--integrator", rf.integrator, "primary | ao | path");
  render->add_option("--max-depth", rf.maxDepth, "path: longest path (vertices)");
  render->add_option("--normals", rf.normals,
                     "shading normals: micro (the micro-triangle's) | smooth (PDM paper §5.1)");
  render->add_option("--seed", rf.seed, "random seed in [0, 2^64) (same seed, same image, any thread count)");
  render->add_option("--aovs", rf.aovs, "multi-channel EXR: colour, depth, normal, per-pixel counters");
  render->add_option("--heatmap", rf.heatmap, "false-colour log-scale heat map of traversal steps (PNG)");
  render->add_flag("-q,--quiet", rf.quiet, "no progress display (same as --progress never)");
  render->add_option("--progress", rf.progress,
                     "phases, elapsed time and ETA on stderr: auto (on a terminal) | always (also plain lines to a "
                     "file or pipe) | never");
  render->add_option("--stats", rf.statsPath, "write configuration, timings, counters and memory as JSON");
  flags.add(render);
  render->add_option("--device", deviceFlag, "cpu (Embree) | vulkan (ray tracing pipeline, docs/vulkan.md)")
      ->check(CLI::IsMember({"cpu", "vulkan"}));

  auto* trace = app.add_subcommand("trace", "first hit of every ray of a ray file");
  trace->add_option("scene", scenePath, "scene file (JSON); omit for the built-in default scene");
  trace->add_option("--rays", raysPath, "rays: CSV (ox,oy,oz,dx,dy,dz,tmin,tmax) or .bin (8 float32 per ray)")
      ->required();
  auto* traceOut = trace->add_option("-o,--output", hitsPath,
                                     "hits: CSV (t,mesh,prim,u,v; t in units of |d|, u,v texture coordinates)");
  trace->add_option("--threads", threads, "worker threads (0: all cores)");
  trace->add_option("--stats", statsPath, "write configuration, timings, counters and memory as JSON");
  flags.add(trace);
  trace->add_option("--device", deviceFlag, "cpu (Embree) | vulkan (ray tracing pipeline, docs/vulkan.md)")
      ->check(CLI::IsMember({"cpu", "vulkan"}));

  auto* bake = app.add_subcommand("bake", "write what the Vulkan path uploads into one file for oblong_vkbench");
  std::string bakeOut, bakeSize;
  bake->add_option("scene", scenePath, "scene file (JSON); omit for the built-in default scene");
  bake->add_option("-o,--output", bakeOut, "baked scene (.oblg, docs/vulkan.md)")->required();
  bake->add_option("--size", bakeSize, "camera rays' image size WxH (default: the scene's)");
  bake->add_option("--rays", raysPath, "also store this ray file (CSV or .bin, as for trace)");
  flags.add(bake);

  auto* info = app.add_subcommand("info", "what the scene needs and what is built for it");
  info->add_option("scene", scenePath, "scene file (JSON); omit for the built-in default scene");
  info->add_option("--range", range, "range-query strategy (default: the scene's)");
  info->add_option("--lod", lodFlag, "level of detail: off | a number >= 0 (default: the scene's)");
  bool listStrategies = false, infoJson = false;
  info->add_flag("--strategies", listStrategies, "list the registered strategies (what --range etc. accept)");
  info->add_flag("--json", infoJson, "with --strategies: as JSON (read by the experiments)");

  // CLI11 says "A subcommand is required" for a misspelt one.
  bool known = false;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    known = known || (argc > 1 && sub->get_name() == argv[1]);
  if (argc > 1 && argv[1][0] != '-' && !known) {
    eprint("oblong: command line: unknown command '{}' (render, trace, info or bake; oblong --help lists them)\n",
           argv[1]);
    return 1;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    // One line and exit status 1, as for any other bad input.
    std::string what = e.what();
    for (char& c : what)
      if (c == '\n' || c == '\r') c = ' ';
    while (!what.empty() && what.back() == ' ') what.pop_back();
    eprint("oblong: command line: {} (oblong --help lists the options)\n", what);
    return 1;
  }
  int status = 0;
  try {
    // An empty value is never the default: `--lod ''` or `info ''` is a mistake (a
    // variable that was not set), not a request for the scene's choice.
    for (const CLI::App* sub : app.get_subcommands())
      for (const CLI::Option* o : sub->get_options())
        if (o->count() > 0 && o->get_type_size_min() > 0)
          for (const std::string& v : o->results())
            if (v.empty())
              fail(o->get_name(), "{}",
                   o->get_name() == "scene" ? "empty file name (omit it for the built-in scene)" : "empty value");
    // Ctrl-C keeps what was rendered (render) or writes nothing (trace), on both devices.
    if (*render || *trace) catchInterrupt();
    rf.defaultOut = renderOut->count() == 0;
    if (*render) status = runRender(scenePath, rf, flags);
    else if (*trace) status = runTrace(scenePath, raysPath, hitsPath, traceOut->count() == 0, threads, statsPath, flags);
    else if (*bake) status = runBake(scenePath, bakeOut, bakeSize, raysPath, flags);
    else if (*info && listStrategies) status = runStrategies(infoJson);
    else if (*info && infoJson) fail("--json", "only applies to --strategies");
    else if (*info) status = runInfo(scenePath, range, lodFlag);
  } catch (const Error& e) {
    eprint("oblong: {}\n", e.what());
    return 1;
  } catch (const std::system_error& e) {
    // fmt::print throws this when standard output is closed or full.
    if (std::ferror(stdout) && !dynamic_cast<const std::filesystem::filesystem_error*>(&e)) {
      eprint("oblong: standard output: write failed ({})\n", e.code().message());
      return 1;
    }
    eprint("oblong: internal error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    eprint("oblong: internal error: {}\n", e.what());
    return 2;
  }
  // What was printed must have reached standard output (`info > /dev/full`).
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    eprint("oblong: standard output: write failed ({})\n", std::strerror(errno));
    return 1;
  }
  return status;
}
