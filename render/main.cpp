// oblong: command-line front end.
//   oblong render [SCENE.json] -o out.png [--size WxH] [--threads N] [--stats out.json]
//   oblong info   [SCENE.json] [--range NAME]
// Without a scene file, the built-in default scene is used (no data files needed).
// Every bad input ends with one line "oblong: FILE: problem" and exit status 1.
#include "core/error.h"
#include "core/procedural.h"
#include "core/scene.h"
#include "core/stats.h"
#include "render/embree_scene.h"
#include "render/renderer.h"
#include "strategies/range_query.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <regex>

using namespace oblong;

namespace {

Scene sceneFrom(const std::string& path) { return path.empty() ? defaultScene() : loadScene(path); }

ivec2 parseSize(const std::string& s) {
  std::smatch m;
  static const std::regex re(R"((\d{1,5})x(\d{1,5}))");
  if (!std::regex_match(s, m, re)) fail("--size", "expected WxH with positive integers, got '{}'", s);
  const ivec2 v(std::stoi(m[1]), std::stoi(m[2]));
  if (v.x <= 0 || v.y <= 0) fail("--size", "expected positive sizes, got '{}'", s);
  return v;
}

std::string human(size_t bytes) {
  if (bytes >= (size_t(1) << 30)) return fmt::format("{:.2f} GiB", bytes / double(1 << 30));
  if (bytes >= (size_t(1) << 20)) return fmt::format("{:.2f} MiB", bytes / double(1 << 20));
  if (bytes >= 1024) return fmt::format("{:.1f} KiB", bytes / 1024.0);
  return fmt::format("{} B", bytes);
}

// The scene's range-query strategy built for each displaced mesh, sized by what its
// triangles can ask (DESIGN invariant 4).
std::vector<std::unique_ptr<RangeQuery>> buildRangeQueries(const Scene& scene, const std::string& name) {
  std::vector<std::unique_ptr<RangeQuery>> out;
  for (const SceneMesh& sm : scene.meshes) {
    if (!sm.displacement) continue;
    std::vector<Rect> boxes;
    for (size_t i = 0; i < sm.mesh.triangles.size(); ++i) boxes.push_back(sm.mesh.triangle(i).uvBox);
    RangeQueryContext ctx{*sm.displacement, QueryNeeds::forRects(*sm.displacement, boxes)};
    ParamSet params(name == scene.range.name ? scene.range.params : nlohmann::json::object(), scene.range.where);
    out.push_back(createRangeQuery(name, params, ctx));
  }
  return out;
}

int runRender(const std::string& scenePath, const std::string& out, const std::string& size, int threads,
              const std::string& statsPath) {
  Scene scene = sceneFrom(scenePath);
  RenderOptions opts;
  opts.size = size.empty() ? scene.imageSize : parseSize(size);
  opts.threads = threads;
  if (threads < 0) fail("--threads", "must be >= 0, got {}", threads);
  Stats::reset();
  EmbreeScene accel(scene);
  RenderResult res = renderDirect(scene, accel, opts);
  writeImage(res.image, out);
  const MemoryReport mem = accel.memory();
  const double rays = double(res.primaryRays + res.shadowRays);
  fmt::print("oblong render: {} -> {}\n", scene.path, out);
  fmt::print("  geometry : pre-tessellated (baseline), {} base triangles, {} micro-triangles, built in {:.2f} s\n",
             accel.baseTriangles(), accel.microTriangles(), accel.buildSeconds());
  for (const auto& m : mem) fmt::print("  memory   : {:<24} {}\n", m.name, human(m.bytes));
  fmt::print("  summary  : {}x{}, {:.3f} s, {:.2f} Mrays/s ({} primary + {} shadow rays, {:.1f}% hit), memory {}\n",
             opts.size.x, opts.size.y, res.seconds, rays / res.seconds * 1e-6, res.primaryRays, res.shadowRays,
             100.0 * res.hits / std::max<int64_t>(1, res.primaryRays), human(totalBytes(mem)));
  if (!statsPath.empty()) {
    nlohmann::json j;
    j["scene"] = scene.path;
    j["geometry"] = "tessellated";
    j["image"] = {{"width", opts.size.x}, {"height", opts.size.y}, {"file", out}};
    j["threads"] = threads;
    j["seconds"] = {{"build", accel.buildSeconds()}, {"render", res.seconds}};
    j["rays"] = {{"primary", res.primaryRays}, {"shadow", res.shadowRays}, {"hits", res.hits}};
    j["mrays_per_second"] = rays / res.seconds * 1e-6;
    for (const auto& m : mem) j["memory"][m.name] = m.bytes;
    j["counters"] = Stats::snapshot();
    std::ofstream f(statsPath);
    if (!f) fail(statsPath, "cannot write statistics");
    f << j.dump(2) << "\n";
  }
  return 0;
}

int runInfo(const std::string& scenePath, const std::string& range) {
  Scene scene = sceneFrom(scenePath);
  const std::string name = range.empty() ? scene.range.name : range;
  fmt::print("scene {}\n", scene.path);
  size_t displaced = 0;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const SceneMesh& sm = scene.meshes[i];
    fmt::print("  mesh {} '{}': {} vertices, {} triangles, {}\n", i, sm.mesh.name, sm.mesh.positions.size(),
               sm.mesh.triangles.size(), sm.displacement ? "displaced" : "plain (Embree triangles)");
    if (sm.displacement) {
      ++displaced;
      const Displacement& d = *sm.displacement;
      fmt::print("    map {} ({}x{}), scale {}, bias {}, tiling ({}, {}), {}\n", d.map->name(), d.map->width(),
                 d.map->height(), d.scale, d.bias, d.tiling.x, d.tiling.y, human(d.map->bytes()));
    }
  }
  auto rqs = buildRangeQueries(scene, name);
  size_t k = 0;
  for (const auto& rq : rqs) {
    const QueryNeeds& n = rq->needs();
    fmt::print("  range query '{}' for displaced mesh {}: needs extents {}x{} samples, wrap {}\n", rq->name(), k++,
               n.maxExtentX, n.maxExtentY, n.wrap ? "yes" : "no");
    for (const auto& m : rq->memory()) fmt::print("    {:<28} {}\n", m.name, human(m.bytes));
  }
  if (displaced == 0) fmt::print("  no displaced mesh: no range query built\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"oblong: ray tracing displaced triangle meshes without tessellation"};
  app.require_subcommand(1);
  std::string scenePath, out = "oblong.png", size, statsPath, range;
  int threads = 0;

  auto* render = app.add_subcommand("render", "render a scene (default: the built-in scene)");
  render->add_option("scene", scenePath, "scene file (JSON); omit for the built-in default scene");
  render->add_option("-o,--output", out, "output image (.png, .exr, ...)");
  render->add_option("--size", size, "image size WxH (default: the scene's)");
  render->add_option("--threads", threads, "worker threads (0: all cores)");
  render->add_option("--stats", statsPath, "write configuration, timings, counters and memory as JSON");

  auto* info = app.add_subcommand("info", "what the scene needs and what is built for it");
  info->add_option("scene", scenePath, "scene file (JSON); omit for the built-in default scene");
  info->add_option("--range", range, "range-query strategy (default: the scene's)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (*render) return runRender(scenePath, out, size, threads, statsPath);
    if (*info) return runInfo(scenePath, range);
  } catch (const Error& e) {
    fmt::print(stderr, "oblong: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "oblong: internal error: {}\n", e.what());
    return 2;
  }
  return 0;
}
