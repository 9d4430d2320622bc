// oblong: command-line front end.
// SCENE is a scene file (JSON) or a mesh file with its material (docs/assets.md), whose
// displacement --displacement, --scale, --bias and --tiling set.
//   oblong render [SCENE.json] -o out.png [--size WxH] [--spp N] [--integrator primary|ao|path] [--seed S]
//                 [--normals micro|smooth] [--threads N] [--aovs out.exr] [--heatmap steps.png]
//                 [--heatmap-max N] [--stats out.json] [-q] [strategy flags]
//   oblong trace  [SCENE.json] --rays RAYS.csv|.bin -o HITS.csv|.bin [--stats out.json] [-q] [strategy flags]
//   oblong info   [SCENE.json] [--range NAME] | --strategies [--json]
//   oblong bake   [SCENE.json] -o SCENE.oblg [--size WxH] [--rays RAYS] [strategy flags]
//   oblong export [SCENE.json] -o MESH.ply [--lod off|λ]
//   oblong compare A B [-o ERROR.png|.exr] [--max E] [--json]   (B the reference)
//   oblong --version
// -q (render, trace): nothing on standard output; warnings and errors still go to stderr.
// Strategy flags (override the scene's "strategies" block): --range, --inverter,
// --splitter, --marching-scale, --inversion-in-traversal, --baseline, --step.
// Without a scene file, the built-in default scene is used (no data files needed).
// Loading, the strategy flags, the device's backend and the render options are
// render/program.h's, shared with the Python module (python/).
// Every bad input ends with one line "oblong: FILE: problem" and exit status 1; every
// output path is checked before any work. Ctrl-C during `render` finishes the tiles in
// flight, writes what was rendered (marked partial in --stats) and exits with 130.
#include "oblong_version.h"

#include "core/error.h"
#include "core/memory.h"
#include "core/scene.h"
#include "core/stats.h"
#include "render/figures.h"
#include "render/image.h"
#include "render/mesh_export.h"
#include "render/output.h"
#include "render/program.h"
#include "render/progress.h"
#include "render/rays_io.h"
#include "render/renderer.h"
#include "render/report.h"
#include "render/scene_info.h"
#include "traversal/intersector.h"
#include "traversal/strategy_catalog.h"
#include "render/vulkan/commands.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <cerrno>
#include <csignal>

#include <sys/stat.h>
#include <unistd.h>
#include <cstring>
#include <system_error>
#include <optional>

using namespace oblong;

namespace {

// The files a loaded scene was read from (scene, meshes and the files they pull in such
// as an OBJ's .mtl or a glTF's .bin, maps), as (what, path) pairs
// for checkNotInputs; the procedural ones ("<...>") have no file.
std::vector<std::pair<std::string, std::string>> sceneInputs(const std::string& scenePath, const Scene& scene) {
  std::vector<std::pair<std::string, std::string>> in;
  if (!scenePath.empty()) in.emplace_back("scene", scenePath);
  for (const SceneMesh& sm : scene.meshes) {
    if (!sm.mesh.name.empty() && sm.mesh.name[0] != '<') in.emplace_back("mesh", sm.mesh.name);
    for (const std::string& f : sm.mesh.files) in.emplace_back("file of mesh " + sm.mesh.name, f);
    if (!sm.displacement) continue;
    for (const HeightMap* m : {sm.displacement->map.get(), sm.displacement->level0.get()})
      if (m && !m->name().empty() && m->name()[0] != '<') in.emplace_back("displacement map", m->name());
  }
  return in;
}

// An output named as standard output (-o /dev/stdout) gets the real standard output to
// itself and the summaries go to stderr: printed to stdout they would mix into the bytes
// written (or, with stdout redirected to a file, overwrite its start).
void claimStandardOutput(std::string& path) {
  if (path.rfind("/dev/", 0) != 0 && path.rfind("/proc/", 0) != 0) return;
  struct stat a {}, b {};
  if (::stat(path.c_str(), &a) != 0 || ::fstat(1, &b) != 0 || a.st_dev != b.st_dev || a.st_ino != b.st_ino) return;
  const int fd = ::dup(1);
  if (fd < 0) return;
  std::fflush(stdout);
  ::dup2(2, 1);
  path = fmt::format("/proc/self/fd/{}", fd);
}

// --device of render and trace: "cpu" (Embree) or "vulkan" (render/vulkan/commands.h).
std::string deviceFlag = "cpu";

// --displacement, --scale, --bias, --tiling: a mesh file's displacement (docs/assets.md).
AssetFlags assetFlags;
void addAssetFlags(CLI::App* app) {
  app->add_option("--displacement", assetFlags.displacement,
                  "with a mesh file: its height map (replaces the material's; docs/assets.md)");
  app->add_option("--scale", assetFlags.scale, "with a mesh file: heights h = scale * (H + bias) (default: the "
                                               "material's, else 1)");
  app->add_option("--bias", assetFlags.bias, "with a mesh file: added to the map's H before --scale (default: the "
                                             "material's, else 0)");
  app->add_option("--tiling", assetFlags.tiling, "with a mesh file: T or TU,TV, uv multiplied before the map lookup "
                                                 "(default: the material's, else 1)");
}
const char* kSceneHelp = "scene file (JSON) or mesh file (.obj, .gltf, .glb, .ply, ...: docs/assets.md); omit for "
                         "the built-in default scene";

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

// The strategy flags (render/program.h) on a subcommand.
void addStrategyFlags(CLI::App* app, StrategyFlags& f) {
  app->add_option("--lod", f.lod,
                  "level of detail: off | cone (a λ per ray from its ray cone; render only) | a number >= 0, "
                  "clamped to each map's last level (docs/lod.md; default: the scene's, off)");
  app->add_option("--range", f.range, "RangeQuery: " + strategyChoices(StrategyKind::Range));
  app->add_option("--inverter", f.inverter, "Inverter: " + strategyChoices(StrategyKind::Inverter));
  app->add_option("--splitter", f.splitter, "Splitter: " + strategyChoices(StrategyKind::Splitter));
  app->add_option("--marching-scale", f.marchingScale,
                  "rectangles of at most this many texels are marched (>= 1/64; default: the scene's, 4)");
  app->add_option("--inversion-in-traversal", f.inversionInTraversal, "invert box intervals (true | false)");
  std::string choices;
  for (const std::string& n : baselineNames()) choices += (choices.empty() ? "" : " | ") + n;
  app->add_option("--baseline", f.baseline, choices + " (instead of the traversal)")
      ->check(CLI::IsMember(baselineNames()));
  app->add_option("--step", f.step,
                  "world-space step of --baseline fixedstep (default: one texel; at least 1/64 of the smallest "
                  "texel's world size)");
}

void writeJson(const std::string& path, const nlohmann::json& j) { writeTextOutput(path, j.dump(2) + "\n"); }

// A heat map in which no pixel took a traversal step is black but for its colour bar:
// one warning line says so and why, instead of a silently black image.
void warnEmptyHeatMap(const Scene& scene, const AccelOptions& accel, const RenderResult& res, const std::string& path) {
  for (float st : res.aov.steps)
    if (st > 0) return;
  bool displaced = false;
  for (const SceneMesh& sm : scene.meshes) displaced = displaced || sm.displacement.has_value();
  const std::string& baseline = accel.traversal.baseline;
  const BaselineRegistry& reg = BaselineRegistry::instance();
  std::string why = "no camera ray reached a displaced mesh";
  if (!displaced) why = "the scene has no displaced mesh; undisplaced meshes are plain triangles";
  else if (!baseline.empty() && reg.has(baseline) && reg.traits(baseline).builtByScene)
    why = "--baseline " + baseline + " traces plain triangles";
  eprint("oblong: warning: --heatmap {}: no camera ray took a traversal step ({}): the map is black\n", path, why);
}

// render's outputs and display; its options are RenderFlags (render/program.h).
struct RenderOutputs {
  std::string out = "oblong.png", statsPath, aovs, heatmap, progress = "auto";
  float heatmapMax = 0;  // 0: each map to its own maximum
  bool quiet = false, defaultOut = true, heatmapMaxGiven = false;
};

// A colour bar without its numbers still shows the colours; the scale is in the summary.
void warnUnlabelled(const FalseColourResult& r, const std::string& flag, const std::string& path) {
  if (!r.labelled)
    eprint("oblong: warning: {} {}: no font for the colour bar's numbers (DejaVu Sans: Debian's fonts-dejavu-core): "
           "the bar has none\n",
           flag, path);
}

int runRender(const std::string& scenePath, const RenderFlags& rf, const RenderOutputs& f, const StrategyFlags& flags) {
  // Everything the command line decides is checked before the scene is loaded.
  RenderOptions opts = rf.options();
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
  if (f.heatmapMaxGiven) {
    if (f.heatmap.empty()) fail("--heatmap-max", "applies to a heat map: give --heatmap too");
    if (!(f.heatmapMax > 0) || !std::isfinite(f.heatmapMax))
      fail("--heatmap-max", "must be a number of steps > 0, got {}", f.heatmapMax);
  }
  if (!f.statsPath.empty()) checkOutputPath(f.statsPath, "statistics");
  const std::vector<std::pair<std::string, std::string>> outputs = {
      {"-o", f.out}, {"--aovs", f.aovs}, {"--heatmap", f.heatmap}, {"--stats", f.statsPath}};
  checkDistinctOutputs(outputs);
  checkNotInputs(outputs, {{"scene", scenePath}});

  Progress progress(mode);
  progress.phase("loading " + (scenePath.empty() ? std::string("the built-in scene") : scenePath));
  Scene scene = sceneFrom(scenePath, assetFlags);
  checkNotInputs(outputs, sceneInputs(scenePath, scene));
  flags.applyLod(scene);
  const double loadSeconds = progress.elapsed();
  const AccelOptions accelOpts = flags.resolve(scene);
  // The AOV file and the heat map are encoded from copies.
  rf.sizeFor(scene, opts, (f.aovs.empty() ? 3 : 44) + (f.heatmap.empty() ? 0 : 15));
  opts.progress = &progress;
  opts.interrupt = &gInterrupted;
  Stats::reset();
  if (deviceFlag == "vulkan") {
    progress.phase("building on Vulkan");
  } else {
    const std::string& baseline = accelOpts.traversal.baseline;
    progress.phase("building the acceleration structures" + (baseline.empty() ? "" : " (--baseline " + baseline + ")"));
  }
  const std::unique_ptr<TraceBackend> backend = makeBackend(scene, accelOpts, deviceFlag, &opts);
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
  const HeatMapScale heat = heatMapScale(res.aov, f.heatmapMax);
  FalseColourResult heatWritten;
  if (!f.heatmap.empty()) heatWritten = writeHeatMap(res.aov, f.heatmap, heat);
  progress.clear();
  if (!f.heatmap.empty()) warnEmptyHeatMap(scene, accelOpts, res, f.heatmap);
  if (!f.heatmap.empty()) warnUnlabelled(heatWritten, "--heatmap", f.heatmap);
  const RenderReport report{scene, accelOpts, *backend, opts, res, f.out, f.heatmap, f.defaultOut, heat,
                            heatWritten};
  if (!f.quiet) printRenderSummary(report);
  // The summary's `partial` line, as a warning, when there is no summary.
  if (f.quiet && res.partial)
    eprint("oblong: warning: interrupted: {} of {} pixels rendered into {} (the rest is black)\n", res.pixelsDone,
           int64_t(opts.size.x) * opts.size.y, f.out);
  if (!f.statsPath.empty())
    writeJson(f.statsPath, renderStats(report, {OBLONG_VERSION, rf.threads, loadSeconds, progress.elapsed()}));
  return res.partial ? kInterruptedStatus : 0;
}

// `oblong bake`: the Vulkan path's upload records and ray generation in one file for
// oblong_vkbench (render/vulkan/bake_file.h).
int runBake(const std::string& scenePath, const std::string& out, const std::string& size,
            const std::string& raysPath, const StrategyFlags& flags) {
  checkOutputPath(out, "baked scene");
  checkNotInputs({{"-o", out}}, {{"scene", scenePath}, {"--rays", raysPath}});
  Scene scene = sceneFrom(scenePath, assetFlags);
  checkNotInputs({{"-o", out}}, sceneInputs(scenePath, scene));
  flags.applyLod(scene, "bake's rays carry no ray cones");
  const AccelOptions accelOpts = flags.resolve(scene);
  const ivec2 image = size.empty() ? scene.imageSize : parseSize(size);
  const std::vector<Ray> rays = raysPath.empty() ? std::vector<Ray>() : readRays(raysPath);
  return vk::bakeCommand(scene, accelOpts, image, rays, out, OBLONG_VERSION);
}

int runTrace(const std::string& scenePath, const std::string& raysPath, const std::string& out, bool defaultOut,
             int threads, const std::string& statsPath, bool quiet, const StrategyFlags& flags) {
  if (threads < 0) fail("--threads", "must be >= 0, got {}", threads);
  checkOutputPath(out, "hits");
  if (!statsPath.empty()) checkOutputPath(statsPath, "statistics");
  const std::vector<std::pair<std::string, std::string>> outputs = {{"-o", out}, {"--stats", statsPath}};
  checkDistinctOutputs(outputs);
  checkNotInputs(outputs, {{"scene", scenePath}, {"--rays", raysPath}});
  // More rays than memory holds are refused before the scene loads or a ray is read.
  checkTraceFits(raysPath, out);
  const auto start = std::chrono::steady_clock::now();
  Scene scene = sceneFrom(scenePath, assetFlags);
  checkNotInputs(outputs, sceneInputs(scenePath, scene));
  flags.applyLod(scene, "a rays file carries no ray cones");
  const AccelOptions accelOpts = flags.resolve(scene);
  const std::vector<Ray> rays = readRays(raysPath);
  const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Stats::reset();
  const std::unique_ptr<TraceBackend> backend = makeBackend(scene, accelOpts, deviceFlag);
  warnBoxOnly(scene, *backend);
  const TraceResult res = traceRays(*backend, rays, threads, &gInterrupted);
  // A hits file must hold every ray's answer: an interrupted trace writes none.
  if (res.interrupted) {
    eprint("oblong: interrupted: no hits written (a hits file holds every ray or none)\n");
    return kInterruptedStatus;
  }
  writeHits(out, res.hits);
  const TraceReport report{scene, accelOpts, *backend, res, raysPath, out, defaultOut};
  if (!quiet) printTraceSummary(report);
  if (!statsPath.empty())
    writeJson(statsPath,
              traceStats(report, {OBLONG_VERSION, threads, loadSeconds,
                                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}));
  return 0;
}

// `oblong export`: the surface the pre-tessellation baseline traces, as one PLY file
// (render/mesh_export.h), refused before anything is written when it would not fit.
int runExport(const std::string& scenePath, const std::string& out, const std::string& lod) {
  checkOutputPath(out, "export");
  std::string ext = std::filesystem::path(out).extension().string();
  for (char& c : ext) c = char(std::tolower((unsigned char)c));
  // A device (/dev/stdout) takes the bytes whatever its name.
  if (ext != ".ply" && !writtenThrough(out))
    fail(out, "the export is a binary PLY file: use a .ply name");
  checkNotInputs({{"-o", out}}, {{"scene", scenePath}});
  const auto start = std::chrono::steady_clock::now();
  Scene scene = sceneFrom(scenePath, assetFlags);
  checkNotInputs({{"-o", out}}, sceneInputs(scenePath, scene));
  StrategyFlags flags;
  flags.lod = lod;
  flags.applyLod(scene, "an export holds one surface");
  const ExportPlan plan = planExport(scene);
  checkExportFits(scene, plan, out);
  ExportMerged merged;
  if (!writeExport(scene, plan, out, &gInterrupted, &merged)) {
    eprint("oblong: interrupted: nothing written\n");
    return kInterruptedStatus;
  }
  if (const std::string w = exportMergedWarning(out, plan, merged); !w.empty()) eprint("oblong: {}\n", w);
  // The levels the meshes are at (each map's own, clamped to its last level).
  std::string levels;
  if (scene.lod) {
    std::vector<float> l;
    for (const SceneMesh& sm : scene.meshes)
      if (sm.displacement && std::find(l.begin(), l.end(), sm.displacement->lod) == l.end())
        l.push_back(sm.displacement->lod);
    for (const float x : l) levels += fmt::format("{}{:g}", levels.empty() ? " at level of detail " : ", ", x);
  }
  fmt::print("oblong export: {} -> {}: {} micro-triangles of {} displaced mesh{}{}, {} triangles of {} plain "
             "mesh{}, {} vertices, {}, {:.3f} s\n",
             scene.path, out, plan.microTriangles, plan.displacedMeshes, plan.displacedMeshes == 1 ? "" : "es",
             levels, plan.plainTriangles,
             plan.plainMeshes, plan.plainMeshes == 1 ? "" : "es", plan.vertices(),
             humanBytes(exportHeader(scene, plan).size() + plan.bodyBytes()),
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return 0;
}

// `oblong compare A B`: relMSE and PSNR of A against the reference B (render/figures.h) and
// an error image: false colour with a numbered bar (8-bit formats) or each pixel's relative
// squared error as grey (EXR, TIFF, HDR, PFM: the values themselves).
int runCompare(const std::string& a, const std::string& b, const std::string& out, float max, bool maxGiven,
               bool json) {
  // The scale spans three decades below --max, all normal floats.
  if (maxGiven && !(max >= 1e-30f && std::isfinite(max)))
    fail("--max", "must be an error between 1e-30 and {:g}, got {:g}", std::numeric_limits<float>::max(), max);
  if (maxGiven && out.empty()) fail("--max", "applies to the error image: give -o too");
  if (!out.empty()) {
    checkImageOutput(out, "error image");
    checkNotInputs({{"-o", out}}, {{"image", a}, {"reference", b}});
  }
  const Comparison c = compareImages(a, b);
  std::string ext = std::filesystem::path(out).extension().string();
  for (char& ch : ext) ch = char(std::tolower((unsigned char)ch));
  const bool data = ext == ".exr" || ext == ".tif" || ext == ".tiff" || ext == ".hdr" || ext == ".pfm";
  ColourScale scale;
  scale.kind = ColourScale::Kind::Decades;
  scale.decades = 3;
  scale.max = maxGiven ? max : std::max(c.maxPerPixel, 1e-12f);
  scale.captions = {"relative squared error (a-b)^2/(b^2+0.01), log scale", "relative squared error, log scale",
                    "rel. sq. error, log"};
  int64_t above = 0;
  for (float v : c.perPixel) above += v > scale.max;
  FalseColourResult written;
  if (!out.empty() && data) {
    Image img(c.width, c.height);
    for (size_t i = 0; i < c.perPixel.size(); ++i) img.pixels[i] = vec3(c.perPixel[i]);
    writeImage(img, out);
  } else if (!out.empty()) {
    written = writeFalseColour(c.perPixel, c.width, c.height, scale, out);
  }
  const double scaleLo = scale.max * std::pow(10.0, -scale.decades);
  if (json) {
    nlohmann::json j;
    j["image"] = a;
    j["reference"] = b;
    j["width"] = c.width;
    j["height"] = c.height;
    j["relmse"] = c.relMSE;
    j["mse"] = c.mse;
    j["psnr_db"] = std::isfinite(c.psnr) ? nlohmann::json(c.psnr) : nlohmann::json("inf");
    j["max_pixel_error"] = c.maxPerPixel;
    j["definitions"] = {{"relmse", "mean over pixels and RGB of (a-b)^2/(b^2+0.01), b the reference, linear values"},
                        {"psnr_db", "10 log10(1/MSE), peak 1"}};
    if (!out.empty())
      j["error_image"] = data ? nlohmann::json{{"file", out}, {"values", "per-pixel relative squared error"}}
                              : nlohmann::json{{"file", out}, {"scale", "log"}, {"min", scaleLo},
                                               {"max", scale.max}, {"fixed", maxGiven}, {"pixels_above", above}};
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("oblong compare: {} against the reference {}, {}x{}\n", a, b, c.width, c.height);
    fmt::print("  relMSE   : {:.6g} (mean over pixels and RGB of (a-b)^2/(b^2+0.01), linear values)\n", c.relMSE);
    fmt::print("  PSNR     : {} (10 log10(1/MSE), peak 1; MSE {:.6g})\n",
               std::isfinite(c.psnr) ? fmt::format("{:.2f} dB", c.psnr) : std::string("inf, identical images"), c.mse);
    if (!out.empty() && data)
      fmt::print("  error    : {}, each pixel's relative squared error (mean over RGB), grey\n", out);
    else if (!out.empty())
      fmt::print("  error    : {}, relative squared error per pixel, log scale, colour bar {:.2g} .. {:.2g}{}\n", out,
                 scaleLo, scale.max,
                 maxGiven ? fmt::format(" (--max; the image's largest {:.2g}, {} pixel{} above the scale)",
                                        c.maxPerPixel, above, above == 1 ? "" : "s")
                          : std::string());
  }
  warnUnlabelled(written, "-o", out);
  return 0;
}

// `oblong info --strategies`: every registered strategy (what the experiments read).
int runStrategies(bool json) {
  const nlohmann::json j = strategiesJson();
  if (json) {
    fmt::print("{}\n", j.dump(2));
    return 0;
  }
  // [cpu] or [cpu, vulkan]: the devices it runs on.
  const auto devices = [](const nlohmann::json& e) {
    return fmt::format("[{}]", fmt::join(e.at("devices").get<std::vector<std::string>>(), ", "));
  };
  for (const char* kind : {"range", "inverter", "splitter"}) {
    fmt::print("{}:\n", kind);
    for (const auto& e : j.at(kind))
      fmt::print("  {:<14} {:<13} {}{}\n", e.at("name").get<std::string>(), devices(e), e.at("summary").get<std::string>(),
                 e.at("slow_reference").get<bool>() ? " [slow reference]" : "");
  }
  fmt::print("baselines:\n");
  for (const auto& e : j.at("baselines"))
    fmt::print("  {:<14} {:<13} {}{}\n", e.at("name").get<std::string>(), devices(e), e.at("summary").get<std::string>(),
               e.at("approximate").get<bool>() ? " [approximate]" : "");
  fmt::print("on vulkan: {}\n", j.at("vulkan").get<std::string>());
  return 0;
}

int runInfo(const std::string& scenePath, const std::string& range, const std::string& lod) {
  Scene scene = sceneFrom(scenePath, assetFlags);
  StrategyFlags flags;
  flags.range = range;
  flags.lod = lod;
  flags.applyLod(scene);
  fmt::print("{}", sceneInfoText(sceneInfo(scene, flags.resolve(scene).traversal)));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Past a file size limit (ulimit -f) a write then fails with EFBIG, which every writer
  // reports as one line, instead of SIGXFSZ ending the process mid-write.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"oblong: ray tracing displaced triangle meshes without tessellation"};
  app.require_subcommand(1);
  // The release number (CMake's project version, CITATION.cff's) and `git describe` of
  // the source tree, as --stats records it.
  app.set_version_flag("--version", fmt::format("oblong {} ({})", OBLONG_VERSION_NUMBER, OBLONG_VERSION),
                       "print the version and exit");
  // --help shows every option's default (subcommands copy these option defaults).
  app.option_defaults()->always_capture_default();
  std::string scenePath, statsPath, range, raysPath, hitsPath = "hits.csv", lodFlag;
  int threads = 0;
  StrategyFlags flags;
  RenderFlags rf;
  RenderOutputs ro;

  auto* render = app.add_subcommand("render", "render a scene (default: the built-in scene)");
  render->add_option("scene", scenePath, kSceneHelp);
  auto* renderOut = render->add_option("-o,--output", ro.out, "output image (.png, .exr, .tif, .hdr, .pfm, ...)");
  render->add_option("--size", rf.size, "image size WxH, at most 2^26 pixels (default: the scene's)");
  render->add_option("--threads", rf.threads, "worker threads (0: all cores)");
  render->add_option("--spp", rf.spp, "samples per pixel");
  render->add_option("--integrator", rf.integrator, "primary | ao | path");
  render->add_option("--max-depth", rf.maxDepth, "path: longest path (vertices)");
  render->add_option("--normals", rf.normals,
                     "shading normals: micro (the micro-triangle's) | smooth (PDM paper §5.1)");
  render->add_option("--seed", rf.seed, "random seed in [0, 2^64) (same seed, same image, any thread count)");
  render->add_option("--aovs", ro.aovs, "multi-channel EXR: colour, depth, normal, per-pixel counters");
  render->add_option("--heatmap", ro.heatmap,
                     "false-colour log-scale heat map of traversal steps per camera ray, numbered colour bar (PNG)");
  auto* heatmapMax = render->add_option(
      "--heatmap-max", ro.heatmapMax,
      "top of the heat map's scale in steps, the same for every run given it (default: the image's maximum)");
  render->add_flag("-q,--quiet", ro.quiet,
                   "print nothing but warnings and errors (stderr): no summary, no progress display");
  render->add_option("--progress", ro.progress,
                     "phases, elapsed time and ETA on stderr: auto (on a terminal) | always (also plain lines to a "
                     "file or pipe) | never");
  render->add_option("--stats", ro.statsPath, "write configuration, timings, counters and memory as JSON");
  addStrategyFlags(render, flags);
  addAssetFlags(render);
  // Only render traces a λ per ray (--lod cone), so only render has its bias.
  render->add_option("--lod-bias", flags.lodBias,
                     "levels added to each ray's λ under --lod cone (default: the scene's, 0)");
  render->add_option("--device", deviceFlag, "cpu (Embree) | vulkan (ray tracing pipeline, docs/vulkan.md)")
      ->check(CLI::IsMember({"cpu", "vulkan"}));

  auto* trace = app.add_subcommand("trace", "first hit of every ray of a ray file");
  trace->add_option("scene", scenePath, kSceneHelp);
  trace->add_option("--rays", raysPath, "rays: CSV (ox,oy,oz,dx,dy,dz,tmin,tmax) or .bin (8 float32 per ray)")
      ->required();
  auto* traceOut = trace->add_option("-o,--output", hitsPath,
                                     "hits: CSV (t,mesh,prim,u,v; t in units of |d|, u,v texture coordinates) or "
                                     ".bin (t float32, mesh, prim int32, u, v float32 per ray)");
  trace->add_option("--threads", threads, "worker threads (0: all cores)");
  trace->add_option("--stats", statsPath, "write configuration, timings, counters and memory as JSON");
  bool traceQuiet = false;
  trace->add_flag("-q,--quiet", traceQuiet, "print nothing but warnings and errors (stderr): no summary");
  addStrategyFlags(trace, flags);
  addAssetFlags(trace);
  trace->add_option("--device", deviceFlag, "cpu (Embree) | vulkan (ray tracing pipeline, docs/vulkan.md)")
      ->check(CLI::IsMember({"cpu", "vulkan"}));

  auto* bake = app.add_subcommand("bake", "write what the Vulkan path uploads into one file for oblong_vkbench");
  std::string bakeOut, bakeSize;
  bake->add_option("scene", scenePath, kSceneHelp);
  bake->add_option("-o,--output", bakeOut, "baked scene (.oblg, docs/vulkan.md)")->required();
  bake->add_option("--size", bakeSize, "camera rays' image size WxH (default: the scene's)");
  bake->add_option("--rays", raysPath, "also store this ray file (CSV or .bin, as for trace)");
  addStrategyFlags(bake, flags);
  addAssetFlags(bake);

  auto* exportCmd = app.add_subcommand(
      "export", "write the displaced micro-geometry and the plain meshes as one PLY file (world coordinates)");
  std::string exportOut;
  exportCmd->add_option("scene", scenePath, kSceneHelp);
  exportCmd->add_option("-o,--output", exportOut,
                        "binary little-endian PLY: float x y z u v per vertex, 3 vertices per triangle")
      ->required();
  exportCmd->add_option("--lod", lodFlag, "level of detail: off | a number >= 0 (default: the scene's)");
  addAssetFlags(exportCmd);

  auto* compare = app.add_subcommand("compare", "relMSE and PSNR of an image against a reference, and an error image");
  std::string compareA, compareB, compareOut;
  float compareMax = 0;
  bool compareJson = false;
  compare->add_option("image", compareA, "the image to measure (EXR, PNG, ...: what OpenImageIO reads)")->required();
  compare->add_option("reference", compareB, "the reference image, of the same size")->required();
  compare->add_option("-o,--output", compareOut,
                      "error image: false colour with a numbered bar (.png, ...) or the per-pixel values (.exr, "
                      ".tif, .hdr, .pfm)");
  auto* compareMaxOpt = compare->add_option(
      "--max", compareMax, "top of the error image's colour scale, the same for every run given it (default: the "
                           "image's largest per-pixel error)");
  compare->add_flag("--json", compareJson, "print the numbers as JSON");

  auto* info = app.add_subcommand("info", "what the scene needs and what is built for it");
  info->add_option("scene", scenePath, kSceneHelp);
  info->add_option("--range", range, "range-query strategy (default: the scene's)");
  info->add_option("--lod", lodFlag, "level of detail: off | a number >= 0 (default: the scene's)");
  addAssetFlags(info);
  bool listStrategies = false, infoJson = false;
  info->add_flag("--strategies", listStrategies, "list the registered strategies (what --range etc. accept)");
  info->add_flag("--json", infoJson, "with --strategies: as JSON (read by the experiments)");

  // CLI11 says "A subcommand is required" for a misspelt one.
  bool known = false;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    known = known || (argc > 1 && sub->get_name() == argv[1]);
  if (argc > 1 && argv[1][0] != '-' && !known) {
    eprint("oblong: command line: unknown command '{}' (render, trace, info, bake, export or compare; oblong --help "
           "lists them)\n",
           argv[1]);
    return 1;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
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
    for (std::string* out : {&ro.out, &ro.statsPath, &ro.aovs, &ro.heatmap, &hitsPath, &statsPath, &bakeOut,
                             &exportOut, &compareOut})
      claimStandardOutput(*out);
    // Ctrl-C keeps what was rendered (render) or writes nothing (trace, export).
    if (*render || *trace || *exportCmd) catchInterrupt();
    ro.defaultOut = renderOut->count() == 0;
    ro.heatmapMaxGiven = heatmapMax->count() > 0;
    if (*render) status = runRender(scenePath, rf, ro, flags);
    else if (*trace)
      status = runTrace(scenePath, raysPath, hitsPath, traceOut->count() == 0, threads, statsPath, traceQuiet, flags);
    else if (*bake) status = runBake(scenePath, bakeOut, bakeSize, raysPath, flags);
    else if (*exportCmd) status = runExport(scenePath, exportOut, lodFlag);
    else if (*compare)
      status = runCompare(compareA, compareB, compareOut, compareMax, compareMaxOpt->count() > 0, compareJson);
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
