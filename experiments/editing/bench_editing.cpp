// Interactive editing (PDM, Hoetzlein 2025, §7.3 / Table 2): an 8192^2 map on a plane,
// a sequence of 256^2 brush strokes applied through HeightMap::set, each followed by
// EmbreeScene::update (range query, prisms, BVH refit) and a re-render of the region
// around the stroke. Configurations share the one edited map: rmip (default: pairs,
// 16-bit), rmip 32-bit, minmax_mipmap 16- and 32-bit, and the fixedstep baseline (no
// range query; its prisms' heights are brute force over the triangle's samples). Some
// strokes also build each configuration from scratch on the edited map (the "full
// rebuild": range query + prisms + BVH), whose image must equal the updated scene's.
//
//   ./build/bench_editing [--strokes 16] [--side 8192] [--brush 256] [--grid 64]
//       [--image 128] [--rebuild-every 4] [--border] [--csv experiments/editing/results.csv]
//
// One row per stroke and configuration in the CSV; a summary (median / max) on stdout.
#include "core/error.h"
#include "core/procedural.h"
#include "core/scene.h"
#include "render/camera.h"
#include "render/embree_scene.h"
#include "render/renderer.h"
#include "tests/fixtures/relief_map.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

using namespace oblong;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

using bench::reliefMap;

float quantize16(float v) { return float(std::round(double(std::clamp(v, 0.0f, 1.0f)) * 65535.0) / 65535.0); }

struct Config {
  std::string label, range, params, baseline;
};

AccelOptions optionsFor(const Scene& base, const Config& c) {
  Scene s = base;  // cheap enough: only the options are read
  s.range.name = c.range;
  s.range.params = nlohmann::json::parse(c.params);
  s.baseline.name = c.baseline;
  return AccelOptions{traversalConfigOf(s)};
}

// Same hits pixel by pixel: depth and shading normal bit for bit.
bool sameImage(const RenderResult& a, const RenderResult& b) {
  return a.hits == b.hits && a.aov.depth.size() == b.aov.depth.size() &&
         std::memcmp(a.aov.depth.data(), b.aov.depth.data(), a.aov.depth.size() * sizeof(float)) == 0 &&
         std::memcmp(a.aov.normal.data(), b.aov.normal.data(), a.aov.normal.size() * sizeof(vec3)) == 0;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
double maxOf(const std::vector<double>& v) { return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end()); }

}  // namespace

int main(int argc, char** argv) try {
  int strokes = 16, side = 8192, brush = 256, grid = 64, image = 128, rebuildEvery = 4;
  bool border = false;  // the last stroke crosses the map's corner (edits that wrap)
  std::string csvPath = "experiments/editing/results.csv";
  for (int i = 1; i < argc; ++i) {
    auto next = [&] {
      if (i + 1 >= argc) throw Error(fmt::format("{} needs a value", argv[i]));
      return std::string(argv[++i]);
    };
    const std::string a = argv[i];
    if (a == "--strokes") strokes = std::stoi(next());
    else if (a == "--side") side = std::stoi(next());
    else if (a == "--brush") brush = std::stoi(next());
    else if (a == "--grid") grid = std::stoi(next());
    else if (a == "--image") image = std::stoi(next());
    else if (a == "--rebuild-every") rebuildEvery = std::max(1, std::stoi(next()));
    else if (a == "--csv") csvPath = next();
    else if (a == "--border") border = true;
    else throw Error("unknown argument " + a);
  }

  auto t0 = Clock::now();
  const std::shared_ptr<HeightMap> map = reliefMap(side);
  fmt::print("map {}x{} generated in {:.0f} ms\n", side, side, msSince(t0));

  // An 8 x 8 plane, uvs [0,1]^2: a texel is 8/side wide, the relief 0.05 tall.
  const float extent = 8.0f, scale = 0.05f;
  Scene scene;
  scene.path = "<bench_editing>";
  SceneMesh plane;
  plane.mesh = planeMesh(vec2(extent), ivec2(grid));
  plane.displacement = Displacement{map, scale, 0.0f, vec2(1.0f)};
  scene.meshes.push_back(std::move(plane));
  scene.imageSize = ivec2(image);

  const std::vector<Config> configs = {
      {"rmip", "rmip", "{}", ""},  // the default: pairs layout, 16-bit
      {"rmip_32", "rmip", R"({"bits":32})", ""},
      {"minmax_mipmap_16", "minmax_mipmap", R"({"bits":16})", ""},
      {"minmax_mipmap_32", "minmax_mipmap", R"({"bits":32})", ""},
      {"fixedstep", "rmip", "{}", "fixedstep"},  // the range choice is unused by the baseline
  };
  std::vector<std::unique_ptr<EmbreeScene>> scenes;
  for (const Config& c : configs) {
    t0 = Clock::now();
    scenes.push_back(std::make_unique<EmbreeScene>(scene, optionsFor(scene, c)));
    const MemoryReport mem = scenes.back()->memory();
    size_t bytes = 0;
    for (const auto& e : mem) bytes += e.bytes;
    fmt::print("built {:<17} in {:7.1f} ms ({:.1f} MiB of structures, prisms and BVH)\n", c.label, msSince(t0),
               double(bytes) / (1 << 20));
  }

  RenderOptions ro;
  ro.size = ivec2(image);
  ro.spp = 1;
  ro.integrator = Integrator::Primary;

  FILE* csv = std::fopen(csvPath.c_str(), "w");
  if (!csv) throw Error("cannot write " + csvPath);
  std::fprintf(csv,
               "stroke,x0,y0,config,texture_ms,structure_ms,structure_rep_min_ms,prism_ms,bvh_ms,update_ms,prisms_updated,render_ms,"
               "hits,rebuild_ms,rebuild_render_ms,image_equal\n");

  std::mt19937 rng(2025);
  std::uniform_int_distribution<int> pos(0, side - brush);
  std::uniform_real_distribution<float> amp(-0.35f, 0.35f);
  const float R = 0.5f * brush;
  std::map<std::string, std::vector<double>> col;  // "config/field" -> per-stroke values
  int equalChecked = 0, equalFailed = 0;
  const auto runStart = Clock::now();
  for (int k = 0; k < strokes; ++k) {
    int x0 = pos(rng), y0 = pos(rng);
    if (border && k == strokes - 1) x0 = y0 = side - brush / 2;
    const float a = amp(rng);
    // The stroke: a smooth bump (raised cosine of the distance to the brush centre),
    // clamped to [0,1] and kept on the 16-bit grid, written texel by texel.
    t0 = Clock::now();
    for (int j = y0; j < y0 + brush; ++j)
      for (int i = x0; i < x0 + brush; ++i) {
        const float dx = (i + 0.5f - x0 - R) / R, dy = (j + 0.5f - y0 - R) / R;
        const float r = std::sqrt(dx * dx + dy * dy);
        if (r >= 1.0f) continue;
        const float w = 0.5f + 0.5f * std::cos(float(M_PI) * r);
        map->set(i, j, quantize16(map->at(i, j) + a * w));
      }
    const double textureMs = msSince(t0);
    const SampleRange changed{x0, y0, x0 + brush - 1, y0 + brush - 1};

    // The camera looks down at 45 degrees on the stroke's centre from 0.64 away: the
    // view is about twice the brush wide.
    const float u = (x0 + R) / side, v = (y0 + R) / side;
    const vec3 c(extent * (u - 0.5f), 0.0f, extent * (v - 0.5f));
    const float dist = 2.0f * brush * extent / side * 1.25f;
    scene.camera = Camera{c + vec3(0.0f, dist, dist) / std::sqrt(2.0f), c, vec3(0, 1, 0), 40.0f};

    const bool rebuild = k % rebuildEvery == 0 || k == strokes - 1;
    for (size_t ci = 0; ci < configs.size(); ++ci) {
      const Config& cf = configs[ci];
      t0 = Clock::now();
      const EmbreeScene::UpdateTimes ut = scenes[ci]->update(0, changed);
      const double updateMs = msSince(t0);
      // The same update again on the unchanged map (it is idempotent: equal to a full
      // build): the best of three separates the cost from the load of the shared machine
      // (caches are warm, so it is a lower bound).
      double structureRepMs = kInf;
      for (int rep = 0; rep < 3; ++rep)
        structureRepMs = std::min(structureRepMs, scenes[ci]->update(0, changed).structureSeconds * 1e3);
      const RenderResult img = render(scene, *scenes[ci], ro);
      double rebuildMs = std::nan(""), rebuildRenderMs = std::nan("");
      int equal = -1;
      if (rebuild) {
        t0 = Clock::now();
        const EmbreeScene fresh(scene, optionsFor(scene, cf));
        rebuildMs = msSince(t0);
        const RenderResult freshImg = render(scene, fresh, ro);
        rebuildRenderMs = freshImg.seconds * 1e3;
        equal = sameImage(img, freshImg);
        ++equalChecked, equalFailed += !equal;
        fmt::print("stroke {:2} {:<17} updated image {} the fresh build's ({} hits of {} pixels)\n", k, cf.label,
                   equal ? "equals" : "DIFFERS FROM", img.hits, image * image);
      }
      const std::string p = cf.label + "/";
      col[p + "structure"].push_back(ut.structureSeconds * 1e3);
      col[p + "structure_rep"].push_back(structureRepMs);
      col[p + "prism"].push_back(ut.prismSeconds * 1e3);
      col[p + "bvh"].push_back(ut.bvhSeconds * 1e3);
      col[p + "update"].push_back(updateMs);
      col[p + "prisms"].push_back(double(ut.triangles));
      col[p + "render"].push_back(img.seconds * 1e3);
      if (rebuild) col[p + "rebuild"].push_back(rebuildMs);
      std::fprintf(csv, "%d,%d,%d,%s,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%zu,%.3f,%lld,%.2f,%.3f,%s\n", k, x0, y0,
                   cf.label.c_str(), textureMs, ut.structureSeconds * 1e3, structureRepMs, ut.prismSeconds * 1e3,
                   ut.bvhSeconds * 1e3, updateMs, ut.triangles, img.seconds * 1e3, (long long)img.hits, rebuildMs,
                   rebuildRenderMs, equal < 0 ? "" : (equal ? "1" : "0"));
    }
    col["texture"].push_back(textureMs);
    std::fflush(csv);
  }
  std::fclose(csv);

  fmt::print("\n{} strokes of {}^2 texels on a {}^2 map, plane of {} triangles, {}x{} primary rays, 1 spp "
             "({:.1f} s)\n",
             strokes, brush, side, 2 * grid * grid, image, image, std::chrono::duration<double>(Clock::now() - runStart).count());
  fmt::print("texture update (writing the texels): median {:.3f} ms, max {:.3f} ms\n", median(col["texture"]),
             maxOf(col["texture"]));
  fmt::print("{:<17} {:>17} {:>17} {:>17} {:>17} {:>17} {:>10} {:>17} {:>17}\n", "config [ms]", "structure med/max",
             "repeat best med/max", "prisms med/max", "bvh refit med/max", "update med/max", "prisms", "render med/max", "rebuild med/max");
  for (const Config& cf : configs) {
    const std::string p = cf.label + "/";
    auto mm = [&](const char* f) { return fmt::format("{:8.3f}/{:8.3f}", median(col[p + f]), maxOf(col[p + f])); };
    fmt::print("{:<17} {:>17} {:>17} {:>17} {:>17} {:>17} {:>10.0f} {:>17} {:>17}\n", cf.label, mm("structure"),
               mm("structure_rep"), mm("prism"),
               mm("bvh"), mm("update"), median(col[p + "prisms"]), mm("render"), mm("rebuild"));
  }
  const double rmipMax = maxOf(col["rmip/structure"]);
  fmt::print("target: rmip structure update of a {}^2 stroke <= 5 ms: {} (median {:.3f} ms, max {:.3f} ms)\n", brush,
             rmipMax <= 5.0 ? "holds" : (median(col["rmip/structure"]) <= 5.0 ? "holds at the median, not the max" : "NOT met"),
             median(col["rmip/structure"]), rmipMax);
  fmt::print("        rmip structure update repeated on the unchanged map, best of 3: median {:.3f} ms, max {:.3f} ms\n",
             median(col["rmip/structure_rep"]), maxOf(col["rmip/structure_rep"]));
  fmt::print("images: updated == fresh build on {} of {} checks\n", equalChecked - equalFailed, equalChecked);
  return equalFailed == 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_editing: %s\n", e.what());
  return 2;
}
