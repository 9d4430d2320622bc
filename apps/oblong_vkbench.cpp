// oblong_vkbench: a baked scene (`oblong bake`, bake_file.h) traced on Vulkan by the
// canonical traversal's shaders, with GPU time per pass from timestamp queries. Links
// only the Vulkan loader and the C/C++ runtime, so it runs on a GPU machine without
// oblong's other libraries (docs/vulkan.md, "On a GPU").
//   oblong_vkbench SCENE.oblg [--rays N] [--size WxH] [--spp S] [--integrator primary|path]
//                  [--repeat K] [--seed S] [--out stats.json] [--hits hits.csv] [--rays-out rays.bin]
//   oblong_vkbench SCENE.oblg [--size WxH] [--spp S] --rays-out rays.bin --no-trace   (the rays only)
//   oblong_vkbench --checksum HITS.csv   (the hit checksum of a hits file, e.g. `oblong trace`'s)
//   oblong_vkbench --pipeline-stats [--spirv DIR] [--out pipelines.json]
//                  (the driver's statistics of both pipelines: registers, binary size, ...)
// The hit checksum is checksum64 of the hits CSV of the camera rays, byte for byte the
// file `oblong trace` writes for the same rays (render/rays_io.h), so the CPU's and the
// GPU's answers compare by one number.
#include "core/error.h"
#include "render/camera.h"
#include "render/integrator.h"
#include "render/sampling.h"
#include "render/trace_backend.h"
#include "render/vulkan/bake_file.h"
#include "render/vulkan/runner.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

using namespace oblong;
using namespace oblong::vk;
using namespace oblong::vkgpu;

namespace {

// The hits CSV of render/rays_io.cpp writeHits (%.9g round-trips a float).
std::string hitsCsv(const std::vector<Hit>& hits) {
  std::string text = "t,mesh,prim,u,v\n";
  for (const Hit& h : hits) {
    if (!h.valid()) {
      text += "inf,,,,\n";
      continue;
    }
    fmt::format_to(std::back_inserter(text), "{:.9g},{},{},{:.9g},{:.9g}\n", h.t, h.mesh, h.prim, h.uv.x, h.uv.y);
  }
  return text;
}

// The same hits, bit for bit (t, mesh, triangle, uv, normal).
bool sameHits(const std::vector<Hit>& a, const std::vector<Hit>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    const Hit &x = a[i], &y = b[i];
    if (x.mesh != y.mesh || x.prim != y.prim || std::memcmp(&x.t, &y.t, sizeof x.t) != 0 ||
        std::memcmp(&x.uv, &y.uv, sizeof x.uv) != 0 || std::memcmp(&x.ng, &y.ng, sizeof x.ng) != 0)
      return false;
  }
  return true;
}

std::string hex(uint64_t v) { return fmt::format("{:016x}", v); }

void writeFile(const std::string& path, const void* data, size_t bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) fail(path, "cannot open for writing");
  f.write(static_cast<const char*>(data), std::streamsize(bytes));
  f.close();
  if (!f) fail(path, "write failed");
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

RayGpu toGpu(const Ray& r) { return {r.o, r.d, r.tmin, r.tmax, r.lod, 0.0f}; }
Ray fromGpu(const RayGpu& r) { return Ray{r.o, r.d, r.tmin, r.tmax, r.lod}; }

// One kind of dispatch (camera, shadow, bounce): rays and seconds summed per repeat.
struct Pass {
  std::string name;
  std::vector<int64_t> rays;
  std::vector<double> gpu, wall;
};

// The runner as a trace backend (render/trace_backend.h), so that the paths are those of
// `oblong render`'s integrator (render/integrator.h); every dispatch is timed into its
// pass (the ray kind) and repeat. Rays are traced as given (no far-origin move: a baked
// scene's camera is near it).
class Bench final : public TraceBackend {
 public:
  Bench(Runner& run, std::string geometry, uint64_t baseTriangles, double buildSeconds)
      : run_(run), geometry_(std::move(geometry)), baseTriangles_(baseTriangles), buildSeconds_(buildSeconds) {}
  int repeat = 0;  // current repeat
  const std::vector<Pass>& passes() const { return passes_; }

  double traceHits(RayKind kind, std::span<const Ray> rays, std::span<Hit> hits,
                   std::span<RayCounters> counters) const override {
    double seconds = 0;
    const std::vector<HitGpu> hg = dispatch(kind, rays, counters, false, seconds);
    for (size_t i = 0; i < rays.size(); ++i) {
      hits[i] = Hit{};
      if (hg[i].mesh < 0) continue;
      hits[i].t = hg[i].t, hits[i].mesh = hg[i].mesh, hits[i].prim = hg[i].prim;
      hits[i].uv = vec2(hg[i].u, hg[i].v), hits[i].ng = hg[i].ng;
    }
    return seconds;
  }
  double traceOcclusion(RayKind kind, std::span<const Ray> rays, std::span<uint8_t> blocked,
                        std::span<RayCounters> counters) const override {
    double seconds = 0;
    const std::vector<HitGpu> hg = dispatch(kind, rays, counters, true, seconds);
    for (size_t i = 0; i < rays.size(); ++i) blocked[i] = hg[i].mesh >= 0 ? 1 : 0;
    return seconds;
  }
  bool concurrent() const override { return false; }
  std::string geometryName() const override { return geometry_; }
  size_t baseTriangles() const override { return size_t(baseTriangles_); }
  double buildSeconds() const override { return buildSeconds_; }
  MemoryReport memory() const override {
    MemoryReport r;
    for (const auto& [name, bytes] : run_.memory()) r.push_back({name, bytes});
    return r;
  }
  nlohmann::json device() const override {
    return {{"api", "vulkan"}, {"name", run_.deviceName()}, {"driver", run_.driverInfo()}};
  }

 private:
  // One dispatch, timed into its pass; seconds: the GPU's (timestamps), else the wall's.
  std::vector<HitGpu> dispatch(RayKind kind, std::span<const Ray> rays, std::span<RayCounters> counters, bool anyHit,
                               double& seconds) const {
    std::vector<RayGpu> gpu(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) gpu[i] = toGpu(rays[i]);
    std::vector<HitGpu> hits(rays.size());
    std::vector<CountersGpu> cg(counters.empty() ? 0 : rays.size());
    double wall = 0, gpuSeconds = 0;
    run_.trace(gpu.data(), gpu.size(), hits.data(), cg.empty() ? nullptr : cg.data(), anyHit, &wall, &gpuSeconds);
    for (size_t i = 0; i < cg.size(); ++i) {
      RayCounters& c = counters[i];
      c = RayCounters{};
      c.prisms = cg[i].prisms, c.boxes = cg[i].boxes, c.rangeQueries = cg[i].rangeQueries;
      c.inversions = cg[i].inversions, c.cellsMarched = cg[i].cellsMarched, c.microTriangles = cg[i].microTriangles;
    }
    const std::string pass = rayKindName(kind);
    auto it = std::find_if(passes_.begin(), passes_.end(), [&](const Pass& p) { return p.name == pass; });
    if (it == passes_.end()) it = passes_.insert(passes_.end(), Pass{pass, {}, {}, {}});
    const size_t r = size_t(repeat);
    it->rays.resize(r + 1, 0), it->gpu.resize(r + 1, 0), it->wall.resize(r + 1, 0);
    it->rays[r] += int64_t(rays.size());
    it->gpu[r] += gpuSeconds;
    it->wall[r] += wall;
    seconds = gpuSeconds >= 0 ? gpuSeconds : wall;
    return hits;
  }

  Runner& run_;
  std::string geometry_;
  uint64_t baseTriangles_;
  double buildSeconds_;
  mutable std::vector<Pass> passes_;  // the dispatches so far (trace calls are const)
};

// --pipeline-stats: the driver's statistics of both pipelines (runner.h), printed and as JSON.
int pipelineStats(const std::string& spirvDir, const std::string& out) {
  const PipelineStatistics P = pipelineStatistics(spirvDir);
  const std::string source = spirvDir.empty() ? "this build's SPIR-V" : spirvDir;
  nlohmann::json j;
  j["device"] = {{"api", "vulkan"}, {"name", P.device}, {"driver", P.driver}};
  j["spirv"] = spirvDir.empty() ? "built in" : spirvDir;
  j["supported"] = P.supported;
  j["programs"] = nlohmann::json::array();
  fmt::print("oblong_vkbench: pipeline statistics of {} on {} ({}){}\n", source, P.device, P.driver,
             P.supported ? ""
                         : ": the device does not report them (no VK_KHR_pipeline_executable_properties); "
                           "both pipelines were created");
  for (const PipelineProgram& prog : P.programs) {
    nlohmann::json pj = {{"method", prog.method}, {"stage", prog.stage}, {"executables", nlohmann::json::array()}};
    for (const PipelineExecutable& e : prog.executables) {
      nlohmann::json ej = {{"name", e.name}, {"description", e.description}, {"stages", e.stages},
                           {"subgroup_size", e.subgroupSize}, {"statistics", nlohmann::json::array()}};
      std::string line;
      for (const PipelineStatistic& st : e.statistics) {
        ej["statistics"].push_back({{"name", st.name}, {"value", st.value}, {"description", st.description}});
        line += fmt::format("{}{} {:.6g}", line.empty() ? "" : ", ", st.name, st.value);
      }
      pj["executables"].push_back(std::move(ej));
      fmt::print("{} ({}): {} [{}]: {}\n", prog.method, prog.stage, e.name, e.stages,
                 line.empty() ? "no statistics" : line);
    }
    j["programs"].push_back(std::move(pj));
  }
  if (!out.empty()) {
    const std::string text = j.dump(2) + "\n";
    writeFile(out, text.data(), text.size());
  }
  return 0;
}

struct Options {
  std::string file, out, hitsOut, raysOut, checksumOf, size, integrator = "primary", spirvDir;
  bool pipelineStats = false;
  int64_t rays = 0;
  int spp = 1, repeat = 3;
  uint64_t seed = 0;
  bool noTrace = false;
};

int run(const Options& o) {
  if (o.pipelineStats) {
    if (!o.file.empty()) fail("--pipeline-stats", "takes no scene (got '{}')", o.file);
    return pipelineStats(o.spirvDir, o.out);
  }
  if (!o.spirvDir.empty()) fail("--spirv", "only applies with --pipeline-stats");
  if (!o.checksumOf.empty()) {
    std::ifstream f(o.checksumOf, std::ios::binary);
    if (!f) fail(o.checksumOf, "cannot open hits file");
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    fmt::print("{}\n", hex(checksum64(text.data(), text.size())));
    return 0;
  }
  if (o.file.empty()) fail("command line", "a baked scene (.oblg) is required");
  if (o.spp < 1) fail("--spp", "must be >= 1, got {}", o.spp);
  if (o.repeat < 1) fail("--repeat", "must be >= 1, got {}", o.repeat);
  if (o.rays < 0) fail("--rays", "must be >= 0, got {}", o.rays);
  const auto t0 = std::chrono::steady_clock::now();
  BakedScene S = readBake(o.file);
  const double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Camera rays (oblong render's: render/integrator.h, cameraSample), or the baked ray
  // list (ray k with the stream of pixel k's sample 0).
  std::vector<Ray> camera;
  std::vector<Rng> rngs;
  ivec2 image = S.image;
  const bool useBaked = !S.rays.empty() && o.rays == 0 && o.size.empty();
  if (useBaked) {
    for (size_t k = 0; k < S.rays.size(); ++k) {
      camera.push_back(fromGpu(S.rays[k]));
      rngs.emplace_back(pixelSeed(o.seed, k), 0);
    }
    image = ivec2(0);
  } else {
    if (!o.size.empty()) {
      int w = 0, h = 0;
      char x = 0, rest = 0;
      std::istringstream in(o.size);
      if (!(in >> w >> x >> h) || x != 'x' || in >> rest || w <= 0 || h <= 0 || int64_t(w) * h > (int64_t(1) << 26))
        fail("--size", "expected WxH with positive integers, at most 2^26 pixels, got '{}'", o.size);
      image = ivec2(w, h);
    }
    int64_t n = int64_t(image.x) * image.y * o.spp;
    if (o.rays > 0) {  // an image of the baked aspect with at least N samples; the first N
      n = o.rays;
      const double pixels = std::ceil(double(n) / o.spp), aspect = double(image.x) / image.y;
      image.y = std::max(1, int(std::lround(std::sqrt(pixels / aspect))));
      image.x = std::max(1, int(std::ceil(pixels / image.y)));
    }
    const PinholeCamera cam(S.camera, image);
    camera.resize(size_t(n));
    rngs.resize(size_t(n));
    for (int64_t k = 0; k < n; ++k)
      camera[size_t(k)] = cameraSample(cam, image.x, o.seed, size_t(k / o.spp), int(k % o.spp), rngs[size_t(k)]);
  }
  if (!o.raysOut.empty()) {  // rays_io.h's .bin: 8 float32 a ray
    std::vector<float> bin;
    bin.reserve(camera.size() * 8);
    for (const Ray& r : camera) bin.insert(bin.end(), {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax});
    writeFile(o.raysOut, bin.data(), bin.size() * sizeof(float));
  }
  if (o.noTrace) {
    if (o.raysOut.empty()) fail("--no-trace", "only applies with --rays-out");
    return 0;
  }

  const auto t1 = std::chrono::steady_clock::now();
  const std::string geometry = S.records.geometryName;
  const uint64_t baseTriangles = S.records.baseTriangles;
  Runner runner(std::move(S.records));
  const double buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  eprint("oblong_vkbench: {} on {} ({}): {} base triangles, {} camera rays, built in {:.2f} s\n", o.file,
             runner.deviceName(), runner.driverInfo(), baseTriangles, camera.size(), buildSeconds);

  // `oblong render`'s integrator with micro-triangle normals (the renderer's default):
  // primary traces the camera rays only; path adds per bounce one shadow pass (one ray
  // per light at every vertex) and one bounce pass. The first repeat counts the work.
  IntegratorSettings set;
  set.integrator = o.integrator == "path" ? Integrator::Path : Integrator::Primary;
  set.maxDepth = S.maxDepth;
  set.sky = S.sky;
  set.lights = S.lights;
  set.albedo = S.albedo;
  Bench B(runner, geometry, baseTriangles, buildSeconds);
  std::vector<Hit> first;
  RayCounters counters;
  bool deterministic = true;
  vec3 radiance(0.0f);
  for (B.repeat = 0; B.repeat < o.repeat; ++B.repeat) {
    SampleBatch batch;
    batch.camera = camera;
    batch.rng = rngs;
    set.counters = B.repeat == 0;
    integrate(B, set, microNormals, batch);
    if (set.integrator == Integrator::Path) {
      radiance = vec3(0.0f);
      for (const vec3& v : batch.value) radiance += v;
      radiance /= float(std::max<size_t>(batch.value.size(), 1));
    }
    if (B.repeat == 0) {
      first = std::move(batch.hit);
      for (const RayCounters& c : batch.work) counters += c;
    } else {
      deterministic = deterministic && sameHits(first, batch.hit);
    }
  }
  const std::string csv = hitsCsv(first);
  const std::string checksum = hex(checksum64(csv.data(), csv.size()));
  if (!o.hitsOut.empty()) writeFile(o.hitsOut, csv.data(), csv.size());
  int64_t found = 0;
  for (const Hit& h : first) found += h.valid();

  nlohmann::json j;
  j["file"] = o.file;
  j["scene"] = S.scene;
  j["baked_by"] = S.version;
  j["geometry"] = geometry;
  j["base_triangles"] = baseTriangles;
  j["device"] = B.device();
  addMemoryJson(j, B.memory());
  j["integrator"] = o.integrator;
  j["camera_rays"] = {{"count", camera.size()}, {"source", useBaked ? "baked ray list" : "camera"},
                      {"width", image.x}, {"height", image.y}, {"spp", useBaked ? 1 : o.spp}, {"seed", o.seed}};
  j["repeat"] = o.repeat;
  j["seconds"] = {{"load", loadSeconds}, {"build", buildSeconds}};
  // Per pass and in total: GPU seconds (timestamps; -1: none) and wall seconds per repeat.
  std::vector<double> gpuTotal(size_t(o.repeat), 0), wallTotal(size_t(o.repeat), 0);
  int64_t raysPerRepeat = 0;
  for (const Pass& p : B.passes()) {
    j["passes"][p.name] = {{"rays", p.rays.front()}, {"gpu_seconds", p.gpu}, {"wall_seconds", p.wall},
                           {"mrays_per_second_gpu", double(p.rays.front()) / std::max(median(p.gpu), 1e-12) * 1e-6}};
    raysPerRepeat += p.rays.front();
    for (int r = 0; r < o.repeat; ++r) gpuTotal[size_t(r)] += p.gpu[size_t(r)], wallTotal[size_t(r)] += p.wall[size_t(r)];
  }
  const bool timestamps = !B.passes().empty() && B.passes().front().gpu.front() >= 0;
  const double gpuMedian = median(gpuTotal), wallMedian = median(wallTotal);
  j["rays_per_repeat"] = raysPerRepeat;
  j["gpu_seconds_median"] = timestamps ? gpuMedian : -1.0;
  j["wall_seconds_median"] = wallMedian;
  j["mrays_per_second"] = {
      {"gpu_median", timestamps ? double(raysPerRepeat) / std::max(gpuMedian, 1e-12) * 1e-6 : -1.0},
      {"gpu_best", timestamps ? double(raysPerRepeat) /
                                    std::max(*std::min_element(gpuTotal.begin(), gpuTotal.end()), 1e-12) * 1e-6
                              : -1.0},
      {"wall_median", double(raysPerRepeat) / std::max(wallMedian, 1e-12) * 1e-6}};
  j["hits"] = found;
  j["hit_checksum"] = checksum;
  j["deterministic"] = deterministic;
  if (o.integrator == "path") j["mean_radiance"] = {radiance.x, radiance.y, radiance.z};
  j["camera_ray_counters"] = countersJson(counters, int64_t(camera.size()));
  if (!o.out.empty()) {
    const std::string text = j.dump(2) + "\n";
    writeFile(o.out, text.data(), text.size());
  }
  fmt::print("oblong_vkbench: {} {} rays x {}: {:.3f} ms GPU (median), {:.4g} Mrays/s GPU, {:.4g} Mrays/s wall, "
             "{} camera hits, hit checksum {}{}\n",
             o.integrator, raysPerRepeat, o.repeat, gpuMedian * 1e3, j["mrays_per_second"]["gpu_median"].get<double>(),
             j["mrays_per_second"]["wall_median"].get<double>(), found, checksum,
             deterministic ? "" : " (repeats differ!)");
  return deterministic ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"oblong_vkbench: a baked scene (oblong bake) on Vulkan ray tracing, timed per pass"};
  Options o;
  app.add_option("scene", o.file, "baked scene (.oblg)");
  app.add_option("--rays", o.rays, "camera rays: the first N samples of an image of the baked aspect (0: the baked "
                                   "image, or the baked ray list)");
  app.add_option("--size", o.size, "camera image WxH (default: the baked one)");
  app.add_option("--spp", o.spp, "samples per pixel (sample 0 through the centre, the others jittered)");
  app.add_option("--integrator", o.integrator, "primary (camera rays) | path (shadow and bounce rays too)")
      ->check(CLI::IsMember({"primary", "path"}));
  app.add_option("--repeat", o.repeat, "times every pass is traced (the median is reported)");
  app.add_option("--seed", o.seed, "random seed of the jittered samples and the paths");
  app.add_option("--out", o.out, "statistics JSON");
  app.add_option("--hits", o.hitsOut, "the camera rays' hits as CSV (as `oblong trace -o` writes them)");
  app.add_option("--rays-out", o.raysOut, "the camera rays as .bin (8 float32 a ray: `oblong trace --rays`)");
  app.add_flag("--no-trace", o.noTrace, "write --rays-out and exit (no Vulkan device needed)");
  app.add_option("--checksum", o.checksumOf, "print the hit checksum of a hits CSV and exit");
  app.add_flag("--pipeline-stats", o.pipelineStats,
               "print (and with --out write) the driver's statistics of both pipelines and exit");
  app.add_option("--spirv", o.spirvDir, "with --pipeline-stats: the stages' NAME.spv from this folder (another "
                                        "build's shaders) instead of the built-in ones");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::string what = e.what();
    for (char& c : what)
      if (c == '\n' || c == '\r') c = ' ';
    eprint("oblong_vkbench: command line: {} (--help lists the options)\n", what);
    return 1;
  }
  try {
    return run(o);
  } catch (const Error& e) {
    eprint("oblong_vkbench: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    eprint("oblong_vkbench: internal error: {}\n", e.what());
    return 2;
  }
}
