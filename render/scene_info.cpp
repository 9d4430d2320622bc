// `oblong info` (scene_info.h).
#include "render/scene_info.h"

#include "core/lod.h"
#include "render/report.h"
#include "render/tessellation.h"
#include "strategies/range_query.h"
#include "traversal/traversal.h"

#include <fmt/core.h>

#include <cmath>
#include <iterator>

namespace oblong {

namespace {

using nlohmann::json;

template <typename... Args>
void put(std::string& out, fmt::format_string<Args...> f, Args&&... args) {
  fmt::format_to(std::back_inserter(out), f, std::forward<Args>(args)...);
}

// Floats are stored as floats and printed as floats ("0.048", not "0.0480000004").
float f32(const json& v) { return v.get<float>(); }

json describeMesh(const Scene& scene, const SceneMesh& sm, const TraversalConfig& cfg, size_t displacedIndex) {
  json m = {{"name", sm.mesh.name},
            {"vertices", sm.mesh.positions.size()},
            {"triangles", sm.mesh.triangles.size()},
            {"displaced", sm.displacement.has_value()}};
  if (!sm.displacement) {
    m["bytes"] = sm.mesh.bytes();
    return m;
  }
  const Displacement& d = *sm.displacement;
  m["map"] = {{"name", d.map->name()}, {"width", d.map->width()}, {"height", d.map->height()}, {"bytes", d.map->bytes()}};
  m["scale"] = d.scale;
  m["bias"] = d.bias;
  m["tiling"] = {d.tiling.x, d.tiling.y};
  // What the traversal builds: the range query sized by the triangles' uv boxes
  // (as createIntersector does) and one prism per displaceable triangle.
  std::vector<DisplacedTriangle> tris(sm.mesh.triangles.size());
  std::vector<Rect> boxes;
  for (size_t t = 0; t < tris.size(); ++t) {
    tris[t] = sm.mesh.triangle(t);
    if (tris[t].uvArea2 != 0.0f) boxes.push_back(tris[t].uvBox);
  }
  const QueryNeeds needs = QueryNeeds::forRects(d, boxes);
  m["needs"] = {{"max_extent", {needs.maxExtentX, needs.maxExtentY}}, {"wrap", needs.wrap}};
  if (scene.lodCone)
    m["lod"] = {{"mode", "cone"}, {"bias", scene.lodBias}, {"levels", lodLevels(*d.map)}};
  else if (!d.level0)
    m["lod"] = {{"mode", "off"}, {"levels_possible", lodLevels(*d.map)}};
  else
    m["lod"] = {{"mode", "fixed"},
                {"lod", d.lod},
                {"level", int(std::floor(d.lod))},
                {"grid", {d.map->width(), d.map->height()}},
                {"grid_bytes", d.map->bytes()},
                {"full_resolution", {d.level0->width(), d.level0->height()}}};
  if (!cfg.baseline.empty() && BaselineRegistry::instance().has(cfg.baseline) &&
      BaselineRegistry::instance().traits(cfg.baseline).builtByScene) {
    // No intersector: the scene builds the micro-triangles (the pre-tessellation baseline's estimate).
    const TessellationEstimate e = estimateTessellation(sm.mesh, d);
    m["baseline"] = cfg.baseline;
    m["tessellation"] = {
        {"micro_triangles", e.microTriangles}, {"geometry_bytes", e.geometryBytes()}, {"bvh_bytes", e.bvhBytes()}};
    m["memory_total"] = e.geometryBytes();
    return m;
  }
  // Built once, as the renderer builds it; what is shown is that structure.
  const auto is = createIntersector(cfg, tris, d);
  if (const auto* t = dynamic_cast<const TraversalIntersectorBase*>(is.get())) {
    m["range_query"] = t->rangeQuery().name();
    m["displaced_index"] = displacedIndex;
    m["traversal"] = t->describe();
    size_t prisms = 0, wellPosed = 0;
    for (const PrismParams& pp : t->mesh().params) prisms += pp.valid, wellPosed += pp.valid && pp.wellPosed;
    m["prisms"] = {{"built", prisms},
                   {"well_posed", wellPosed},
                   {"box_only", prisms - wellPosed},
                   {"skipped", tris.size() - prisms}};
  } else if (is->describe().contains("lod")) {
    const json j = is->describe();
    m["per_ray"] = {{"name", j.at("name")}, {"levels", j.at("lod").at("levels")}};
  } else {
    m["baseline"] = is->name();
  }
  const MemoryReport mem = is->memory();
  m["memory"] = json::array();
  for (const auto& item : mem) m["memory"].push_back({{"name", item.name}, {"bytes", item.bytes}});
  m["memory_total"] = totalBytes(mem);
  return m;
}

// One value of a describe() JSON: byte counts (keys ending in "bytes") in human units,
// arrays as [a, b, ...].
std::string infoValue(const std::string& key, const json& v) {
  const bool bytes = key.size() >= 5 && key.compare(key.size() - 5, 5, "bytes") == 0;
  if (v.is_array()) {
    std::string s;
    for (const auto& e : v) s += (s.empty() ? "" : ", ") + infoValue(key, e);
    return "[" + s + "]";
  }
  if (bytes && v.is_number_unsigned()) return humanBytes(v.get<size_t>());
  return v.is_string() ? v.get<std::string>() : v.dump();
}

// What the traversal built for one displaced mesh (docs/design.md invariant 4), from its
// describe(): the range query's layout and bytes, the strategies' resolved parameters,
// the code path.
void printTraversal(std::string& out, const json& d) {
  const json& rq = d.at("range");
  put(out, "      built    : {} ({}), {}\n", rq.at("exact").get<bool>() ? "exact bounds" : "conservative bounds",
       infoValue("params", rq.at("params")), humanBytes(rq.at("bytes").get<size_t>()));
  if (rq.contains("layout"))
    for (const auto& [k, v] : rq.at("layout").items()) {
      if (k == "stores_wrap" || k == "wrap_bytes") continue;
      // A table (array of arrays): one line per row.
      if (v.is_array() && !v.empty() && v[0].is_array() && v[0].size() > 2) {
        for (size_t r = 0; r < v.size(); ++r) {
          std::string row;
          for (const auto& e : v[r]) row += fmt::format("{:>11}", infoValue(k, e));
          put(out, "      {:<20}: {:>3} {}\n", r == 0 ? k : "", r, row);
        }
        continue;
      }
      put(out, "      {:<20}: {}\n", k, infoValue(k, v));
    }
  if (rq.contains("layout") && rq.at("layout").value("stores_wrap", false) &&
      rq.at("layout").value("layout", "") == "pairs")
    put(out, "      wrap     : blocks wrapping around the map border filled with the wrapped pixels (no extra bytes)\n");
  else if (rq.contains("layout") && rq.at("layout").value("stores_wrap", false))
    put(out, "      wrap     : corners wrapping around the map border stored{}\n",
         rq.at("layout").contains("wrap_bytes") ? ": " + infoValue("wrap_bytes", rq.at("layout").at("wrap_bytes")) + " of it"
                                                : std::string());
  else
    put(out, "      wrap     : none stored (queries crossing the border are split, or wrap addressing)\n");
  put(out, "    traversal: {} path; inverter {} {}; splitter {} {}; marching scale {}, inversion in traversal {}\n",
       d.at("path").get<std::string>(), d.at("inverter").at("name").get<std::string>(),
       infoValue("", d.at("inverter").at("params")), d.at("splitter").at("name").get<std::string>(),
       infoValue("", d.at("splitter").at("params")), d.at("marching_scale").get<float>(),
       d.at("inversion_in_traversal").get<bool>() ? "on" : "off");
}

}  // namespace

json sceneInfo(const Scene& scene, const TraversalConfig& cfg) {
  json j = {{"scene", scene.path}, {"meshes", json::array()}};
  size_t displaced = 0, total = 0;
  for (const SceneMesh& sm : scene.meshes) {
    json m = describeMesh(scene, sm, cfg, displaced);
    if (m.at("displaced").get<bool>()) {
      total += m.at("memory_total").get<size_t>();
      ++displaced;
    }
    j["meshes"].push_back(std::move(m));
  }
  j["displaced_meshes"] = displaced;
  j["total_bytes"] = total;
  j["peak_memory"] = peakMemoryBytes();
  return j;
}

std::string sceneInfoText(const json& info) {
  std::string out;
  put(out, "scene {}\n", info.at("scene").get<std::string>());
  const json& meshes = info.at("meshes");
  for (size_t i = 0; i < meshes.size(); ++i) {
    const json& m = meshes[i];
    const bool isDisplaced = m.at("displaced").get<bool>();
    put(out, "  mesh {} '{}': {} vertices, {} triangles, {}\n", i, m.at("name").get<std::string>(),
         m.at("vertices").get<size_t>(), m.at("triangles").get<size_t>(),
         isDisplaced ? "displaced" : "plain (Embree triangles)");
    if (!isDisplaced) {
      put(out, "    built    : no range query, no prisms ({})\n", humanBytes(m.at("bytes").get<size_t>()));
      continue;
    }
    const json& map = m.at("map");
    const json& tiling = m.at("tiling");
    put(out, "    map {} ({}x{}), scale {}, bias {}, tiling ({}, {}), {}\n", map.at("name").get<std::string>(),
         map.at("width").get<int>(), map.at("height").get<int>(), f32(m.at("scale")), f32(m.at("bias")), f32(tiling[0]),
         f32(tiling[1]), humanBytes(map.at("bytes").get<size_t>()));
    const json& needs = m.at("needs");
    const bool tiled = f32(tiling[0]) != 1.0f || f32(tiling[1]) != 1.0f;
    put(out, "    needs    : range queries up to {}x{} samples; wrapping queries {}\n", needs.at("max_extent")[0].get<int>(),
         needs.at("max_extent")[1].get<int>(),
         !needs.at("wrap").get<bool>() ? "no"
         : tiled                       ? "yes (the map is tiled)"
                                       : "yes (triangles' cells cross the map border)");
    const json& lod = m.at("lod");
    const std::string mode = lod.at("mode").get<std::string>();
    if (mode == "cone")
      put(out, "    LoD      : cone (a λ per ray, bias {}): levels 0 .. {} built, one intersector each (docs/lod.md)\n",
           f32(lod.at("bias")), lod.at("levels").get<int>());
    else if (mode == "off")
      put(out, "    LoD      : off, no levels built ({} levels possible for this map, docs/lod.md)\n",
           lod.at("levels_possible").get<int>());
    else
      put(out, "    LoD      : lod {}: level {} grid ({}x{} samples, {}) at the heights of lod {}; the {}x{} "
           "full-resolution map kept\n",
           f32(lod.at("lod")), lod.at("level").get<int>(), lod.at("grid")[0].get<int>(), lod.at("grid")[1].get<int>(),
           humanBytes(lod.at("grid_bytes").get<size_t>()), f32(lod.at("lod")),
           lod.at("full_resolution")[0].get<int>(), lod.at("full_resolution")[1].get<int>());
    if (m.contains("tessellation")) {
      const json& e = m.at("tessellation");
      put(out, "    baseline '{}': no range query; {} micro-triangles: {} of vertices, uvs and indices, about {} "
           "of Embree BVH\n",
           m.at("baseline").get<std::string>(), e.at("micro_triangles").get<size_t>(),
           humanBytes(e.at("geometry_bytes").get<size_t>()), humanBytes(e.at("bvh_bytes").get<size_t>()));
      continue;
    }
    if (m.contains("traversal")) {
      put(out, "    range query '{}' for displaced mesh {}:\n", m.at("range_query").get<std::string>(),
           m.at("displaced_index").get<size_t>());
      printTraversal(out, m.at("traversal"));
      const json& p = m.at("prisms");
      put(out, "    prisms   : {} built ({} well-posed, {} box-only), {} skipped (not displaceable)\n",
           p.at("built").get<size_t>(), p.at("well_posed").get<size_t>(), p.at("box_only").get<size_t>(),
           p.at("skipped").get<size_t>());
    } else if (m.contains("per_ray")) {
      put(out, "    per ray  : '{}' on each of {} levels: a range structure per level, prisms per level\n",
           m.at("per_ray").at("name").get<std::string>(), m.at("per_ray").at("levels").get<int>());
    } else {
      put(out, "    baseline '{}': no range query\n", m.at("baseline").get<std::string>());
    }
    std::string parts;
    for (const auto& item : m.at("memory"))
      parts += fmt::format("{}{} {}", parts.empty() ? "" : ", ", item.at("name").get<std::string>(),
                           humanBytes(item.at("bytes").get<size_t>()));
    put(out, "    built    : {} = {}\n", parts, humanBytes(m.at("memory_total").get<size_t>()));
  }
  const size_t displaced = info.at("displaced_meshes").get<size_t>();
  if (displaced == 0) put(out, "  no displaced mesh: no range query built\n");
  else
    put(out, "  total    : {} built for {} displaced mesh{} (plus Embree's BVH, reported by oblong render)\n",
         humanBytes(info.at("total_bytes").get<size_t>()), displaced, displaced == 1 ? "" : "es");
  put(out, "  peak     : {} of process memory (each structure above built once)\n",
       humanBytes(info.at("peak_memory").get<size_t>()));
  return out;
}

}  // namespace oblong
