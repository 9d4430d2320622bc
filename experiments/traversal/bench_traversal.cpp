// Traversal speed (experiments/traversal/README.md): primary rays on a scene, single thread, for the
// canonical configuration (rmip + newton + midpoint2d), TFDM (the `tfdm` baseline,
// docs/tfdm.md), the RMIP driver with TFDM's mipmap and quad-tree splits (minmax_mipmap +
// quadtree, no inversion, marching scale 1: an ablation) and the pre-tessellated Embree
// scene, side by side in one run. Counters: Mrays/s (per core), steps per ray (boxes + marched cells,
// as the RMIP paper counts them), acceleration-structure memory (MB).
//
// `secondary/...`: path-traced bounce rays from the canonical configuration's camera
// hits (cosine-distributed, spawned as the renderer spawns them). A third family, `grazing/...` (grazing_rays.h: within 0.5-6 degrees of the base
// surface, aimed into the shell; --grazing N rays, default 20000, 0 for none), with the
// canonical configuration at marching scales 1 and 2 beside the others.
//
//   ./build/bench_traversal [--scene scenes/asteroid.json] [--size 256x192] [--grazing N]
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//       --benchmark_out=out.json --benchmark_out_format=json
//   /usr/bin/python3 experiments/traversal/summarize.py out.json
//   ./build/bench_traversal --scene S --grazing N --write-grazing FILE.bin
//       writes the grazing family as a ray file for `oblong trace --rays` and exits
//       (experiments/table1 traces it with every configuration).
//
// Build with -DOBLONG_STATS=OFF for timings (the per-ray RayCounters stay: they are
// plain integer increments on the ray's own struct).
#include "core/procedural.h"
#include "core/scene.h"
#include "render/camera.h"
#include "core/error.h"
#include "render/embree_scene.h"
#include "render/rays_io.h"
#include "render/sampling.h"
#include "tests/fixtures/grazing_rays.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <cstring>
#include <map>
#include <memory>

using namespace oblong;

namespace {

std::string gScene;  // empty: the built-in default scene
ivec2 gSize{256, 192};
int gGrazing = 20000;

const Scene& scene() {
  static Scene s = gScene.empty() ? defaultScene() : loadScene(gScene);
  return s;
}

const std::vector<Ray>& primaryRays() {
  static std::vector<Ray> rays = [] {
    PinholeCamera cam(scene().camera, gSize);
    std::vector<Ray> r;
    for (int y = 0; y < gSize.y; ++y)
      for (int x = 0; x < gSize.x; ++x) r.push_back(cam.generate(x + 0.5f, y + 0.5f));
    return r;
  }();
  return rays;
}

const EmbreeScene& accelByName(const std::string& name);

// Path-traced bounce rays: from the canonical configuration's first hits of the camera
// rays, a cosine-distributed direction about the facing geometric normal, spawned as the
// renderer spawns them (render/sampling.h). Incoherent, starting on the surface.
const std::vector<Ray>& secondaryRays() {
  static std::vector<Ray> rays = [] {
    const EmbreeScene& a = accelByName("canonical");
    std::vector<Ray> out;
    Rng rng(11, 0);
    for (const Ray& r : primaryRays()) {
      const Hit h = a.intersect(r);
      if (!h.valid()) continue;
      const vec3 ng = glm::dot(h.ng, r.d) > 0 ? -h.ng : h.ng;
      const vec3 d = cosineSample(ng, rng);
      if (glm::dot(d, ng) <= 0) continue;
      out.push_back(Ray{spawnOrigin(r.at(h.t), ng, d), d, 0.0f, kInfinity});
    }
    return out;
  }();
  return rays;
}

const std::vector<Ray>& grazing() {
  static std::vector<Ray> rays = grazingRays(scene(), gGrazing);
  return rays;
}

struct Config {
  std::string name;
  AccelOptions opts;
};

std::vector<Config> configs() {
  std::vector<Config> c;
  AccelOptions canonical;  // defaults: rmip + newton + midpoint2d, inversion on
  c.push_back({"canonical", canonical});
  // The canonical configuration at lower RMIP resolutions (paper Table 1's low / normal
  // / high columns: the RMIP's memory against its bounds' tightness on small queries).
  for (int res : {512, 256, 128}) {
    AccelOptions o;
    o.traversal.rangeParams = {{"resolution", res}};
    c.push_back({"canonical_res" + std::to_string(res), o});
  }
  AccelOptions tfdm;
  tfdm.traversal.baseline = "tfdm";
  c.push_back({"tfdm", tfdm});
  AccelOptions driver;
  driver.traversal.range = "minmax_mipmap";
  driver.traversal.splitter = "quadtree";
  driver.traversal.inversionInTraversal = false;
  driver.traversal.marchingScale = 1.0f;
  c.push_back({"driver_mipmap", driver});
  for (float ms : {1.0f, 2.0f, 8.0f}) {  // the marching scale against grazing rays
    AccelOptions o;
    o.traversal.marchingScale = ms;
    c.push_back({fmt::format("canonical_march{}", ms), o});
  }
  AccelOptions tess;
  tess.traversal.baseline = "tessellated";
  c.push_back({"tessellated", tess});
  return c;
}

const EmbreeScene& accel(const Config& c) {
  static std::map<std::string, std::unique_ptr<EmbreeScene>> cache;
  auto& p = cache[c.name];
  if (!p) p = std::make_unique<EmbreeScene>(scene(), c.opts);
  return *p;
}

const EmbreeScene& accelByName(const std::string& name) {
  for (const Config& c : configs())
    if (c.name == name) return accel(c);
  throw Error("bench_traversal: no configuration " + name);
}

void trace(benchmark::State& state, const Config& c, const std::vector<Ray>& (*family)()) {
  // A configuration that does not fit (the pre-tessellation of a paper-scale scene) is
  // reported as skipped with the builder's one-line reason.
  const EmbreeScene* ap = nullptr;
  try {
    ap = &accel(c);
  } catch (const Error& e) {
    state.SkipWithError(e.what());
    for (auto _ : state) {}
    return;
  }
  const EmbreeScene& a = *ap;
  const std::vector<Ray>& rays = family();
  RayCounters counters;
  int64_t hits = 0, passes = 0;
  for (auto _ : state) {
    counters = RayCounters{};
    hits = 0;
    for (const Ray& r : rays) {
      const Hit h = a.intersect(r, &counters);
      hits += h.valid();
      benchmark::DoNotOptimize(h);
    }
    ++passes;
  }
  const double n = double(rays.size());
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
  state.counters["Mrays/s"] = benchmark::Counter(n * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["steps/ray"] = double(counters.steps()) / n;
  state.counters["boxes/ray"] = double(counters.boxes) / n;
  state.counters["cells/ray"] = double(counters.cellsMarched) / n;
  state.counters["inversions/ray"] = double(counters.inversions) / n;
  state.counters["prisms/ray"] = double(counters.prisms) / n;
  state.counters["hit%"] = 100.0 * double(hits) / n;
  state.counters["MB"] = double(totalBytes(a.memory())) / 1e6;
  state.counters["build_s"] = a.buildSeconds();
}

}  // namespace

int main(int argc, char** argv) {
  // Our own flags first; the rest go to Google Benchmark.
  std::vector<char*> rest{argv[0]};
  const char* writeGrazing = nullptr;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--scene") && i + 1 < argc) gScene = argv[++i];
    else if (!std::strcmp(argv[i], "--grazing") && i + 1 < argc) gGrazing = std::max(0, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--write-grazing") && i + 1 < argc) writeGrazing = argv[++i];
    else if (!std::strcmp(argv[i], "--size") && i + 1 < argc) {
      if (std::sscanf(argv[++i], "%dx%d", &gSize.x, &gSize.y) != 2 || gSize.x <= 0 || gSize.y <= 0) {
        eprint("bench_traversal: --size: expected WxH, got '{}'\n", argv[i]);
        return 1;
      }
    } else rest.push_back(argv[i]);
  }
  int n = int(rest.size());
  try {
    scene();
    if (writeGrazing) {
      writeRays(writeGrazing, grazing());
      return 0;
    }
  } catch (const std::exception& e) {
    eprint("bench_traversal: {}\n", e.what());
    return 1;
  }
  const std::pair<const char*, const std::vector<Ray>& (*)()> families[] = {
      {"primary", primaryRays}, {"secondary", secondaryRays}, {"grazing", grazing}};
  for (const auto& [family, rays] : families)
    for (const Config& c : configs()) {
      if (!std::strcmp(family, "grazing") && gGrazing == 0) continue;
      benchmark::RegisterBenchmark((std::string(family) + "/" + c.name).c_str(),
                                   [c, rays = rays](benchmark::State& s) { trace(s, c, rays); })
          ->Unit(benchmark::kMillisecond)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
