// oblong_vkbench: a baked scene (`oblong bake`, bake_file.h) traced on Vulkan by the
// canonical traversal's shaders, with GPU time per pass from timestamp queries. Links
// only the Vulkan loader and the C/C++ runtime, so it runs on a GPU machine without
// oblong's other libraries (docs/vulkan.md, "On a GPU").
//   oblong_vkbench SCENE.oblg [--rays N] [--size WxH] [--spp S] [--integrator primary|path]
//                  [--repeat K] [--seed S] [--out stats.json] [--hits hits.csv] [--rays-out rays.bin]
//   oblong_vkbench SCENE.oblg [--size WxH] [--spp S] --rays-out rays.bin --no-trace   (the rays only)
//   oblong_vkbench --checksum HITS.csv   (the hit checksum of a hits file, e.g. `oblong trace`'s)
// The hit checksum is checksum64 of the hits CSV of the camera rays, byte for byte the
// file `oblong trace` writes for the same rays (render/rays_io.h), so the CPU's and the
// GPU's answers compare by one number.
#include "core/error.h"
#include "render/camera.h"
#include "render/sampling.h"
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
std::string hitsCsv(const std::vector<HitGpu>& hits) {
  std::string text = "t,mesh,prim,u,v\n";
  for (const HitGpu& h : hits) {
    if (h.mesh < 0) {
      text += "inf,,,,\n";
      continue;
    }
    fmt::format_to(std::back_inserter(text), "{:.9g},{},{},{:.9g},{:.9g}\n", h.t, h.mesh, h.prim, h.u, h.v);
  }
  return text;
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

// One kind of dispatch (camera, shadow, bounce): rays and seconds summed per repeat.
struct Pass {
  std::string name;
  std::vector<int64_t> rays;
  std::vector<double> gpu, wall;
};

struct Bench {
  Runner& run;
  int repeat = 0;  // current repeat
  std::vector<Pass> passes;
  std::vector<HitGpu> trace(const std::string& pass, const std::vector<RayGpu>& rays, bool anyHit,
                            std::vector<CountersGpu>* counters = nullptr) {
    std::vector<HitGpu> hits(rays.size());
    if (counters) counters->assign(rays.size(), CountersGpu{});
    double wall = 0, gpu = 0;
    run.trace(rays.data(), rays.size(), hits.data(), counters ? counters->data() : nullptr, anyHit, &wall, &gpu);
    auto it = std::find_if(passes.begin(), passes.end(), [&](const Pass& p) { return p.name == pass; });
    if (it == passes.end()) it = passes.insert(passes.end(), Pass{pass, {}, {}, {}});
    it->rays.resize(size_t(repeat) + 1, 0), it->gpu.resize(size_t(repeat) + 1, 0), it->wall.resize(size_t(repeat) + 1, 0);
    it->rays[size_t(repeat)] += int64_t(rays.size());
    it->gpu[size_t(repeat)] += gpu;
    it->wall[size_t(repeat)] += wall;
    return hits;
  }
};

RayGpu toGpu(const Ray& r) { return {r.o, r.d, r.tmin, r.tmax, r.lod, 0.0f}; }
Ray fromGpu(const RayGpu& r) {
  Ray o;
  o.o = r.o, o.d = r.d, o.tmin = r.tmin, o.tmax = r.tmax;
  return o;
}

// render/vulkan/vulkan_render.cpp's path integrator with micro-triangle normals (the
// renderer's default): direct light by one shadow ray per light at every vertex, cosine
// bounces, Russian roulette from the fourth bounce. Returns the mean radiance.
vec3 tracePaths(Bench& B, const BakedScene& S, const std::vector<RayGpu>& camera, const std::vector<HitGpu>& hits,
                const std::vector<Rng>& rngs) {
  struct Path {
    Rng rng{0, 0};
    vec3 L{0.0f}, beta{1.0f}, pos{0.0f}, geo{0.0f};
    int mesh = -1;
    bool alive = false;
  };
  const size_t ns = camera.size();
  std::vector<Path> paths(ns);
  for (size_t k = 0; k < ns; ++k) {
    Path& p = paths[k];
    p.rng = rngs[k];
    const HitGpu& h = hits[k];
    if (h.mesh < 0) {
      p.L = S.sky;
      continue;
    }
    const Ray r = fromGpu(camera[k]);
    p.pos = r.at(h.t), p.geo = glm::dot(h.ng, r.d) > 0 ? -h.ng : h.ng, p.mesh = h.mesh, p.alive = true;
  }
  std::vector<size_t> owner;
  std::vector<RayGpu> queue;
  for (int depth = 0;; ++depth) {
    struct Shadow {
      size_t path;
      vec3 contribution;
    };
    std::vector<Shadow> shadows;
    queue.clear();
    for (size_t k = 0; k < ns; ++k) {
      const Path& p = paths[k];
      if (!p.alive) continue;
      const vec3 albedo = S.albedo[size_t(p.mesh)];
      for (const Light& light : S.lights) {
        vec3 wi;
        float dist = kInfinity, falloff = 1.0f;
        if (light.type == Light::Type::Directional) {
          wi = -glm::normalize(light.direction);
        } else {
          wi = light.position - p.pos;
          dist = glm::length(wi);
          if (!(dist > 0)) continue;
          wi /= dist;
          falloff = 1.0f / (dist * dist);
        }
        const float cosTheta = glm::dot(p.geo, wi);
        if (cosTheta <= 0) continue;
        shadows.push_back({k, albedo * light.intensity * (cosTheta * falloff / kPi)});
        queue.push_back(toGpu(Ray{p.pos + spawnEps(p.pos) * p.geo, wi, 0.0f, dist * (1.0f - 1e-4f)}));
      }
    }
    if (!queue.empty()) {
      const std::vector<HitGpu> occ = B.trace("shadow", queue, true);
      for (size_t q = 0; q < shadows.size(); ++q)
        if (occ[q].mesh < 0) paths[shadows[q].path].L += paths[shadows[q].path].beta * shadows[q].contribution;
    }
    owner.clear();
    queue.clear();
    for (size_t k = 0; k < ns; ++k) {
      Path& p = paths[k];
      if (!p.alive) continue;
      if (depth + 1 >= S.maxDepth) {
        p.alive = false;
        continue;
      }
      p.beta *= S.albedo[size_t(p.mesh)];
      if (depth >= 3) {
        const float q = std::min(0.95f, std::max({p.beta.x, p.beta.y, p.beta.z}));
        if (p.rng.uniform() >= q) {
          p.alive = false;
          continue;
        }
        p.beta /= q;
      }
      const vec3 d = cosineSample(p.geo, p.rng);
      if (glm::dot(d, p.geo) <= 0) {
        p.alive = false;
        continue;
      }
      owner.push_back(k);
      queue.push_back(toGpu(Ray{spawnOrigin(p.pos, p.geo, d), d, 0.0f, kInfinity}));
    }
    if (queue.empty()) break;
    const std::vector<HitGpu> bh = B.trace("bounce", queue, false);
    for (size_t q = 0; q < queue.size(); ++q) {
      Path& p = paths[owner[q]];
      if (bh[q].mesh < 0) {
        p.L += p.beta * S.sky;
        p.alive = false;
        continue;
      }
      const Ray r = fromGpu(queue[q]);
      p.geo = glm::dot(bh[q].ng, r.d) > 0 ? -bh[q].ng : bh[q].ng;
      p.pos = r.at(bh[q].t);
      p.mesh = bh[q].mesh;
    }
  }
  vec3 mean(0.0f);
  for (const Path& p : paths) mean += p.L;
  return mean / float(std::max<size_t>(ns, 1));
}

struct Options {
  std::string file, out, hitsOut, raysOut, checksumOf, size, integrator = "primary";
  int64_t rays = 0;
  int spp = 1, repeat = 3;
  uint64_t seed = 0;
  bool noTrace = false;
};

int run(const Options& o) {
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

  // Camera rays (vulkan_render.cpp's: sample 0 through the pixel centre, the others
  // jittered by the pixel sample's PCG32), or the baked ray list.
  std::vector<RayGpu> camera;
  std::vector<Rng> rngs;
  ivec2 image = S.image;
  const bool useBaked = !S.rays.empty() && o.rays == 0 && o.size.empty();
  if (useBaked) {
    camera = S.rays;
    for (size_t k = 0; k < camera.size(); ++k) rngs.emplace_back(o.seed * 0x9E3779B97F4A7C15ULL + k, 0);
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
    camera.reserve(size_t(n));
    for (int64_t k = 0; k < n; ++k) {
      const int64_t px = k / o.spp, s = k % o.spp;
      const int x = int(px % image.x), y = int(px / image.x);
      Rng rng(o.seed * 0x9E3779B97F4A7C15ULL + uint64_t(px), uint64_t(s));
      const float jx = s == 0 ? 0.5f : rng.uniform(), jy = s == 0 ? 0.5f : rng.uniform();
      camera.push_back(toGpu(cam.generate(x + jx, y + jy)));
      rngs.push_back(rng);
    }
  }
  if (!o.raysOut.empty()) {  // rays_io.h's .bin: 8 float32 a ray
    std::vector<float> bin;
    bin.reserve(camera.size() * 8);
    for (const RayGpu& r : camera) bin.insert(bin.end(), {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax});
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

  Bench B{runner, 0, {}};
  std::vector<HitGpu> first;
  std::vector<CountersGpu> counters;
  bool deterministic = true;
  vec3 radiance(0.0f);
  for (B.repeat = 0; B.repeat < o.repeat; ++B.repeat) {
    std::vector<HitGpu> hits = B.trace("camera", camera, false, B.repeat == 0 ? &counters : nullptr);
    if (o.integrator == "path") radiance = tracePaths(B, S, camera, hits, rngs);
    if (B.repeat == 0)
      first = std::move(hits);
    else
      deterministic = deterministic && std::memcmp(first.data(), hits.data(), hits.size() * sizeof(HitGpu)) == 0;
  }
  const std::string csv = hitsCsv(first);
  const std::string checksum = hex(checksum64(csv.data(), csv.size()));
  if (!o.hitsOut.empty()) writeFile(o.hitsOut, csv.data(), csv.size());
  int64_t found = 0;
  for (const HitGpu& h : first) found += h.mesh >= 0;

  nlohmann::json j;
  j["file"] = o.file;
  j["scene"] = S.scene;
  j["baked_by"] = S.version;
  j["geometry"] = geometry;
  j["base_triangles"] = baseTriangles;
  j["device"] = {{"api", "vulkan"}, {"name", runner.deviceName()}, {"driver", runner.driverInfo()}};
  for (const auto& [name, bytes] : runner.memory()) j["device"]["memory"][name] = bytes;
  j["integrator"] = o.integrator;
  j["camera_rays"] = {{"count", camera.size()}, {"source", useBaked ? "baked ray list" : "camera"},
                      {"width", image.x}, {"height", image.y}, {"spp", useBaked ? 1 : o.spp}, {"seed", o.seed}};
  j["repeat"] = o.repeat;
  j["seconds"] = {{"load", loadSeconds}, {"build", buildSeconds}};
  // Per pass and in total: GPU seconds (timestamps; -1: none) and wall seconds per repeat.
  std::vector<double> gpuTotal(size_t(o.repeat), 0), wallTotal(size_t(o.repeat), 0);
  int64_t raysPerRepeat = 0;
  for (const Pass& p : B.passes) {
    j["passes"][p.name] = {{"rays", p.rays.front()}, {"gpu_seconds", p.gpu}, {"wall_seconds", p.wall},
                           {"mrays_per_second_gpu", double(p.rays.front()) / std::max(median(p.gpu), 1e-12) * 1e-6}};
    raysPerRepeat += p.rays.front();
    for (int r = 0; r < o.repeat; ++r) gpuTotal[size_t(r)] += p.gpu[size_t(r)], wallTotal[size_t(r)] += p.wall[size_t(r)];
  }
  const bool timestamps = !B.passes.empty() && B.passes.front().gpu.front() >= 0;
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
  CountersGpu sum{};
  for (const CountersGpu& c : counters) {
    sum.prisms += c.prisms, sum.boxes += c.boxes, sum.rangeQueries += c.rangeQueries, sum.inversions += c.inversions;
    sum.cellsMarched += c.cellsMarched, sum.microTriangles += c.microTriangles;
  }
  j["camera_ray_counters"] = {{"prisms", sum.prisms}, {"boxes", sum.boxes}, {"range_queries", sum.rangeQueries},
                              {"inversions", sum.inversions}, {"cells_marched", sum.cellsMarched},
                              {"micro_triangles", sum.microTriangles}};
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
