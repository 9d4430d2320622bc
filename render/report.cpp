// The summary and statistics writer (report.h).
#include "render/report.h"

#include "core/stats.h"

#include <fmt/core.h>
#include <tbb/info.h>

#include <sys/resource.h>

#include <algorithm>
#include <cmath>

namespace oblong {

size_t peakMemoryBytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return size_t(u.ru_maxrss) * 1024;  // KiB on Linux
}

int threadsUsed(int requested) {
  const int hw = tbb::info::default_concurrency();
  return requested > 0 ? std::min(requested, hw) : hw;
}

namespace {

// The scene's level of detail and, per displaced mesh, the λ it is traced at.
nlohmann::json lodJson(const Scene& scene) {
  if (scene.lodCone) return {{"requested", "cone"}, {"bias", scene.lodBias}};
  if (!scene.lod) return "off";
  nlohmann::json per = nlohmann::json::array();
  for (const SceneMesh& sm : scene.meshes)
    per.push_back(sm.displacement ? nlohmann::json(sm.displacement->lod) : nlohmann::json(nullptr));
  return {{"requested", *scene.lod}, {"per_mesh", per}};
}

// The fields every statistics file has: what was built and run, on which device, with
// its memory; the statistics registry's counters where the traversal ran in this
// process; the run itself.
void commonStats(nlohmann::json& j, const Scene& scene, const AccelOptions& accel, const TraceBackend& backend,
                 const RunInfo& run) {
  j["scene"] = scene.path;
  j["geometry"] = backend.geometryName();
  j["config"] = configJson(accel, scene);
  j["traversal"] = backend.describe();
  j["device"] = backend.device();
  addMemoryJson(j, backend.memory());
  if (backend.hostStatistics()) j["counters"] = Stats::snapshot();
  j["seconds"]["build"] = backend.buildSeconds();
  j["version"] = run.version;
  j["threads"] = {{"requested", run.threadsRequested}, {"used", threadsUsed(run.threadsRequested)}};
  j["seconds"]["load"] = run.loadSeconds;
  j["seconds"]["total"] = run.totalSeconds;
  j["peak_memory"] = peakMemoryBytes();
}

double mraysPerSecond(double rays, double seconds) { return rays / std::max(seconds, 1e-9) * 1e-6; }

// The mean of the steps AOV over the rendered pixels.
double meanCameraSteps(const RenderResult& res) {
  double sum = 0;
  for (float st : res.aov.steps) sum += st;
  return sum / double(std::max<int64_t>(1, res.pixelsDone));
}

}  // namespace

nlohmann::json configJson(const AccelOptions& o, const Scene& scene) {
  const TraversalConfig& c = o.traversal;
  nlohmann::json j;
  const BaselineRegistry& reg = BaselineRegistry::instance();
  if (!c.baseline.empty() && reg.has(c.baseline) && reg.traits(c.baseline).builtByScene) {
    j = {{"baseline", c.baseline}};  // none of the traversal's strategies
  } else {
    j = {{"range", {{"name", c.range}, {"params", c.rangeParams}}},
         {"inverter", {{"name", c.inverter}, {"params", c.inverterParams}}},
         {"splitter", {{"name", c.splitter}, {"params", c.splitterParams}}},
         {"marching_scale", c.marchingScale},
         {"stack_depth", c.stackDepth},
         {"inversion_in_traversal", c.inversionInTraversal}};
    if (!c.baseline.empty()) j["baseline"] = c.baseline;
    if (!c.baselineParams.empty()) j["baseline_params"] = c.baselineParams;
    if (c.baseline == "fixedstep") j["step"] = c.baselineParams.value("step", c.fixedStep);
  }
  j["lod"] = lodJson(scene);
  return j;
}

void printRenderSummary(const RenderReport& r) {
  const RenderResult& res = r.res;
  const RenderOptions& o = r.opts;
  const TraceBackend& b = r.backend;
  const MemoryReport mem = b.memory();
  const double rays = double(res.primaryRays + res.secondaryRays);
  fmt::print("oblong render: {} -> {}{}\n", r.scene.path, r.out, r.defaultOut ? " (the default name; -o chooses)" : "");
  if (const std::string d = b.deviceText(); !d.empty()) fmt::print("  device   : {}\n", d);
  fmt::print("  geometry : {}, built in {:.2f} s\n", b.geometryText(), b.buildSeconds());
  for (const auto& m : mem) fmt::print("  memory   : {:<24} {}\n", m.name, humanBytes(m.bytes));
  fmt::print(
      "  summary  : {}x{} {} spp {}, {:.3f} s{}, {:.2f} Mrays/s ({} camera + {} secondary rays, {:.1f}% hit), "
      "{:.1f} steps/camera ray, {:.1f} steps/ray, {:.1f} prisms/ray, memory {}, peak {}\n",
      o.size.x, o.size.y, o.spp, integratorName(o.integrator), res.seconds, res.tracingOnly ? " tracing" : "",
      mraysPerSecond(rays, res.seconds), res.primaryRays, res.secondaryRays,
      100.0 * double(res.hits) / double(std::max<int64_t>(1, res.primaryRays)), meanCameraSteps(res),
      double(res.counters.steps()) / std::max(1.0, rays), double(res.counters.prisms) / std::max(1.0, rays),
      humanBytes(totalBytes(mem)), humanBytes(peakMemoryBytes()));
  if (res.partial)
    fmt::print("  partial  : interrupted; {} of {} pixels rendered (the rest is black)\n", res.pixelsDone,
               int64_t(o.size.x) * o.size.y);
  if (!r.heatmap.empty()) {
    const HeatMapScale& h = r.heat;
    // As the bar numbers them: steps are means over the samples.
    auto steps = [](float v) { return v == std::round(v) ? fmt::format("{:.0f}", v) : fmt::format("{:.1f}", v); };
    std::string fixed;
    if (h.fixed)
      fixed = fmt::format(" (--heatmap-max; the image's largest {}, {} pixel{} above the scale)", steps(h.imageMax),
                          h.pixelsAbove, h.pixelsAbove == 1 ? "" : "s");
    // The bar is drawn below the image: the file is taller than the render (overlays crop it).
    const std::string bar = r.heatFile.height > r.opts.size.y
                                ? fmt::format(" below the {}x{} image (the file is {}x{})", r.opts.size.x, r.opts.size.y,
                                              r.heatFile.width, r.heatFile.height)
                                : std::string();
    fmt::print("  heat map : {}, steps per camera ray, log scale, colour bar 0 .. {}{}{}\n", r.heatmap,
               steps(h.max), fixed, bar);
  }
}

nlohmann::json renderStats(const RenderReport& r, const RunInfo& run) {
  const RenderResult& res = r.res;
  const RenderOptions& o = r.opts;
  nlohmann::json j;
  commonStats(j, r.scene, r.accel, r.backend, run);
  if (r.scene.lodCone && res.primaryRays > 0)
    j["lod_per_ray"] = {{"camera_mean", res.cameraLodSum / double(res.primaryRays)},
                        {"camera_at_0", double(res.cameraLodZero) / double(res.primaryRays)}};
  j["image"] = {{"width", o.size.x}, {"height", o.size.y}, {"file", r.out}};
  j["integrator"] = integratorName(o.integrator);
  j["normals"] = shadingNormalsName(o.normals);
  j["spp"] = o.spp;
  j["seed"] = o.seed;
  j["seconds"]["render"] = res.seconds;
  j["partial"] = res.partial;
  j["pixels"] = {{"rendered", res.pixelsDone}, {"total", int64_t(o.size.x) * o.size.y}};
  j["rays"] = {{"primary", res.primaryRays}, {"secondary", res.secondaryRays}, {"hits", res.hits}};
  j["mrays_per_second"] = mraysPerSecond(double(res.primaryRays + res.secondaryRays), res.seconds);
  j["steps_per_camera_ray"] = meanCameraSteps(res);
  j["ray_counters"] = countersJson(res.counters, res.primaryRays + res.secondaryRays);
  if (!r.heatmap.empty())
    j["heatmap"] = {{"file", r.heatmap},        {"scale", "log"},
                    {"scale_max", r.heat.max},  {"fixed", r.heat.fixed},
                    {"image_max", r.heat.imageMax}, {"pixels_above", r.heat.pixelsAbove}};
  return j;
}

void printTraceSummary(const TraceReport& r) {
  const TraceBackend& b = r.backend;
  const size_t n = r.res.hits.size();
  const std::string device = b.deviceText();
  fmt::print("oblong trace: {} rays -> {}{}: {} hits, {}{}, {:.3f} s, {:.2f} Mrays/s, {:.1f} steps/ray, memory {}\n", n,
             r.out, r.defaultOut ? " (the default name; -o chooses)" : "", r.res.found, b.geometryName(),
             device.empty() ? "" : " on " + device, r.res.seconds, mraysPerSecond(double(n), r.res.seconds),
             double(r.res.counters.steps()) / double(std::max<size_t>(1, n)), humanBytes(totalBytes(b.memory())));
}

nlohmann::json traceStats(const TraceReport& r, const RunInfo& run) {
  const size_t n = r.res.hits.size();
  nlohmann::json j;
  commonStats(j, r.scene, r.accel, r.backend, run);
  j["rays"] = {{"file", r.raysPath}, {"count", n}, {"hits", r.res.found}};
  j["seconds"]["trace"] = r.res.seconds;
  j["mrays_per_second"] = mraysPerSecond(double(n), r.res.seconds);
  j["ray_counters"] = countersJson(r.res.counters, int64_t(n));
  return j;
}

}  // namespace oblong
