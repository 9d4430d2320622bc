// `oblong export` (render/mesh_export.h): the PLY file holds the pre-tessellation
// baseline's triangles with its float vertices, so that the file's triangles trace
// exactly as `--baseline tessellated` on the original scene, also loaded back through a
// scene file; the uv differences that remain are checked against their causes.
#include "core/error.h"
#include "core/microgeometry.h"
#include "core/scene.h"
#include "render/embree_scene.h"
#include "render/mesh_export.h"
#include "test_util.h"

#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <array>
#include <map>
#include <random>
#include <vector>

using namespace oblong;

namespace {

namespace fs = std::filesystem;

// A displaced plane and a displaced sphere over a plain ground quad. Every coordinate of
// every vertex, displaced or not, lies in [4, 8): oblong's loader puts a mesh's frame at
// the centre of its box and rounds each position once into it (core/mesh.h,
// recentreMesh); within one binade that rounding is exact, so the re-imported mesh has
// the exported floats bit for bit (see docs/export.md).
std::string writeScene(const fs::path& dir) {
  std::vector<float> v(32 * 32);
  for (int j = 0; j < 32; ++j)
    for (int i = 0; i < 32; ++i)
      v[size_t(j * 32 + i)] = 0.5f + 0.5f * std::sin(0.7f * float(i)) * std::cos(0.45f * float(j) + 0.3f);
  test::writeGray((dir / "map.png").string(), 32, 32, v, OIIO::TypeDesc::UINT16);
  const fs::path p = dir / "scene.json";
  std::ofstream(p) << R"({"meshes": [
    {"shape": {"type": "plane", "size": 2, "segments": [3, 2]}, "transform": {"translate": [6, 5, 6]},
     "displacement": {"map": "map.png", "scale": 0.3, "tiling": [1.5, 1]}},
    {"shape": {"type": "plane", "size": 3.5, "uv": [0, 0, 2, 2]}, "transform": {"translate": [6, 4.5, 6]}},
    {"shape": {"type": "sphere", "radius": 0.8, "segments": [12, 8]}, "transform": {"translate": [6.5, 6.2, 6]},
     "displacement": {"map": "map.png", "scale": 0.1, "bias": -0.5}}]})";
  return p.string();
}

// Rays from all around the scene's middle towards points inside its box.
std::vector<Ray> raysAround(size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Ray> rays;
  const vec3 centre(6.0f, 5.5f, 6.0f);
  for (size_t i = 0; i < n; ++i) {
    const float z = 2.0f * u(rng) - 1.0f, a = 6.2831853f * u(rng), s = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const vec3 o = centre + 4.0f * vec3(s * std::cos(a), z, s * std::sin(a));
    const vec3 target(5.0f + 2.5f * u(rng), 4.5f + 2.5f * u(rng), 4.8f + 2.4f * u(rng));
    Ray r;
    r.o = o;
    r.d = target - o;
    rays.push_back(r);
  }
  return rays;
}

template <typename T>
bool sameBits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

struct Agreement {
  size_t rays = 0, hits = 0, differ = 0;
  size_t flaggedUV = 0;  // hits whose uv differs only through a flagged triangle's uvs
  std::string first;     // the first ray that differs
};

// Every ray: the same hit or miss, t, uv and geometric normal bit for bit. `flagged`, per
// triangle of b's mesh 0: its vertex uvs are not a's; a hit on it may differ in uv by at
// most assimp's tolerance for joining vertices (1e-5 per coordinate), nothing else.
Agreement compare(const EmbreeScene& a, const EmbreeScene& b, const std::vector<Ray>& rays,
                  const std::vector<uint8_t>& flagged = {}) {
  Agreement g;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit x = a.intersect(rays[i]), y = b.intersect(rays[i]);
    ++g.rays;
    g.hits += x.valid();
    const bool geometry = x.valid() == y.valid() && (!x.valid() || (sameBits(x.t, y.t) && sameBits(x.ng, y.ng)));
    if (geometry && (!x.valid() || sameBits(x.uv, y.uv))) continue;
    if (geometry && !flagged.empty() && flagged[size_t(y.prim)] &&
        glm::all(glm::lessThanEqual(glm::abs(x.uv - y.uv), vec2(1e-5f)))) {
      ++g.flaggedUV;
      continue;
    }
    if (g.differ++ == 0)
      g.first = fmt::format("ray {}: t {:.9g} vs {:.9g}, uv ({:.9g}, {:.9g}) vs ({:.9g}, {:.9g}), mesh/prim {}/{} vs {}/{}",
                            i, x.t, y.t, x.uv.x, x.uv.y, y.uv.x, y.uv.y, x.mesh, x.prim, y.mesh, y.prim);
  }
  return g;
}

// An export's vertex records: x y z u v, 3 per triangle.
std::vector<float> exportedVertices(const fs::path& ply) {
  const std::string text = test::slurp(ply);
  const size_t at = text.find("end_header\n") + 11;
  const size_t n = std::stoul(text.substr(text.find("element vertex ") + 15));
  REQUIRE(text.size() >= at + n * 5 * sizeof(float));
  std::vector<float> v(5 * n);
  std::memcpy(v.data(), text.data() + at, v.size() * sizeof(float));
  return v;
}

// The file's triangles as they are, in the world's frame: one plain mesh per mesh of the
// scene (`split`, as the scene's meshes are Embree geometries of their own), or one.
Scene sceneOfRecords(const std::vector<float>& v, const ExportPlan& plan, bool split) {
  Scene s;
  s.path = "<records>";
  size_t at = 0;
  for (size_t pi = 0; pi < plan.parts.size(); ++pi) {
    const size_t n = split ? plan.parts[pi].triangles : plan.triangles;
    Mesh m;
    m.name = "<records>";
    for (size_t i = 15 * at; i < 15 * (at + n); i += 5) {
      m.positions.emplace_back(v[i], v[i + 1], v[i + 2]);
      m.uvs.emplace_back(v[i + 3], v[i + 4]);
      m.normals.emplace_back(0.0f, 1.0f, 0.0f);
    }
    for (uint32_t k = 0; 3 * k < m.positions.size(); ++k) m.triangles.emplace_back(3 * k, 3 * k + 1, 3 * k + 2);
    at += n;
    s.meshes.push_back(SceneMesh{std::move(m), std::nullopt});
    if (!split) break;
  }
  return s;
}

// The file's records with the uvs the pre-tessellated baseline gives them: it shares one
// vertex among a base triangle's micro-triangles by position (in the mesh's frame) and
// keeps the uv of its first occurrence, while the file has each micro-triangle's own
// (the oracle's). Where the micro-geometry computed a shared point's uv an ulp apart for
// two micro-triangles, the two differ; `changed` counts those vertices.
std::vector<float> withSharedUVs(const Scene& scene, const ExportPlan& plan, std::vector<float> v, size_t& changed) {
  changed = 0;
  size_t rec = 0;
  for (const ExportPlan::Part& part : plan.parts) {
    const SceneMesh& sm = scene.meshes[size_t(part.mesh)];
    if (!part.displaced) {
      rec += part.triangles;
      continue;
    }
    for (size_t ti = 0; ti < sm.mesh.triangles.size(); ++ti) {
      std::map<std::array<uint32_t, 3>, vec2> first;
      forEachMicroTriangle(sm.mesh.triangle(ti), *sm.displacement, [&](const MicroTriangle& m) {
        for (int c = 0; c < 3; ++c) {
          std::array<uint32_t, 3> key;
          std::memcpy(key.data(), &m.v[c].p, sizeof key);
          const vec2 uv = first.emplace(key, m.v[c].uv).first->second;
          float* e = &v[15 * rec + 5 * c];
          if (!sameBits(vec2(e[3], e[4]), uv)) e[3] = uv.x, e[4] = uv.y, ++changed;
        }
        ++rec;
      });
    }
  }
  return v;
}

// Per triangle: whether any of its vertex uvs differs between two sets of records.
std::vector<uint8_t> uvsDiffer(const std::vector<float>& a, const std::vector<float>& b) {
  std::vector<uint8_t> out(a.size() / 15, 0);
  for (size_t i = 0; i < a.size(); ++i)
    if (i % 5 >= 3 && !sameBits(a[i], b[i])) out[i / 15] = 1;
  return out;
}

// The export of `scene` written to DIR/NAME.ply and loaded back through a scene file
// (assimp, core/mesh.cpp).
Scene reimport(const Scene& scene, const fs::path& dir, const std::string& name) {
  const ExportPlan plan = planExport(scene);
  const fs::path ply = dir / (name + ".ply");
  REQUIRE(writeExport(scene, plan, ply.string()));
  // The header and three vertices and one face per triangle, nothing else.
  CHECK(fs::file_size(ply) == exportHeader(scene, plan).size() + plan.triangles * ExportPlan::kBytesPerTriangle);
  const fs::path json = dir / (name + ".json");
  std::ofstream(json) << R"({"meshes": [{"file": ")" << ply.filename().string() << R"("}]})";
  return loadScene(json.string());
}

}  // namespace

TEST_CASE("export: the exported triangles trace as --baseline tessellated, bit for bit", "[export][tessellated][unit]") {
  const fs::path dir = test::scratchDir("export_reimport");
  Scene scene = loadScene(writeScene(dir));
  const std::vector<Ray> rays = raysAround(20000);
  for (const std::optional<float> lod : {std::optional<float>(), std::optional<float>(1.5f)}) {
    INFO("lod " << (lod ? *lod : -1.0f));
    setLod(scene, lod, "test");
    const ExportPlan plan = planExport(scene);
    const EmbreeScene tess(scene, AccelOptions::withBaseline(kTessellatedBaseline));
    // The same micro-triangles as the baseline builds, and the plain quad's two.
    CHECK(plan.microTriangles == tess.microTriangles());
    CHECK(plan.plainTriangles == 2);
    CHECK(plan.displacedMeshes == 2);
    const std::string name = lod ? "lod" : "full";
    const Scene back = reimport(scene, dir, name);
    const std::vector<float> v = exportedVertices(dir / (name + ".ply"));
    REQUIRE(v.size() == 15 * plan.triangles);

    // The file's records with the baseline's shared uvs, one geometry per mesh as in the
    // scene: every hit the baseline's, bit for bit (t, uv, normal).
    size_t shared = 0;
    const std::vector<float> tessUV = withSharedUVs(scene, plan, v, shared);
    const Agreement records = compare(tess, EmbreeScene(sceneOfRecords(tessUV, plan, true), AccelOptions{}), rays);
    INFO(records.first);
    CHECK(records.hits > rays.size() / 3);
    CHECK(records.differ == 0);
    // The file's own uvs, all in one geometry: hits on a triangle whose uvs the sharing
    // changed differ in uv by about an ulp, nothing else does.
    const Agreement own =
        compare(tess, EmbreeScene(sceneOfRecords(v, plan, false), AccelOptions{}), rays, uvsDiffer(v, tessUV));
    INFO(own.first);
    INFO(fmt::format("{} of {} vertex uvs shared by the baseline; {} of {} hits differ in uv through them", shared,
                     3 * plan.triangles, own.flaggedUV, own.hits));
    CHECK(own.differ == 0);

    // Through a scene file: the loader skips the zero-area micro-triangles (which Embree
    // never hits), keeps every position bit for bit (the frame's rounding is exact in
    // this scene), and joins vertices (assimp's JoinIdenticalVertices) that share a
    // position and whose uvs differ by less than its tolerance (1e-5): a vertex whose uv
    // two micro-triangles computed an ulp apart gets one of them, as in the baseline but
    // not always the same one.
    REQUIRE(back.meshes.size() == 1);
    const Mesh& m = back.meshes[0].mesh;
    CHECK(m.triangles.size() + m.skippedTriangles == plan.triangles);
    size_t moved = 0;
    std::vector<uint8_t> joined(m.triangles.size(), 0);
    for (size_t k = 0; k < m.triangles.size(); ++k)
      for (int c = 0; c < 3; ++c) {
        const float* e = &tessUV[15 * m.inputTriangle[k] + 5 * c];
        const uint32_t i = m.triangles[k][c];
        moved += !sameBits(worldFloat(m, m.positions[i]), vec3(e[0], e[1], e[2]));
        joined[k] |= !sameBits(m.uvs[i], vec2(e[3], e[4]));
      }
    CHECK(moved == 0);
    const Agreement loaded = compare(tess, EmbreeScene(back, AccelOptions{}), rays, joined);
    INFO(loaded.first);
    INFO(fmt::format("loaded back: {} of {} hits differ in uv through joined vertices", loaded.flaggedUV, loaded.hits));
    CHECK(loaded.hits == records.hits);
    CHECK(loaded.differ == 0);
  }
}

TEST_CASE("export: counts, header and refusals", "[export][unit]") {
  const fs::path dir = test::scratchDir("export_plan");
  const Scene scene = loadScene(writeScene(dir));
  const ExportPlan plan = planExport(scene);
  REQUIRE(plan.parts.size() == 3);
  CHECK(plan.parts[1].triangles == 2);
  CHECK(plan.triangles == plan.microTriangles + plan.plainTriangles);
  const std::string h = exportHeader(scene, plan);
  CHECK(h.rfind("ply\nformat binary_little_endian 1.0\n", 0) == 0);
  CHECK(h.find(fmt::format("element vertex {}\n", 3 * plan.triangles)) != std::string::npos);
  CHECK(h.find(fmt::format("element face {}\n", plan.triangles)) != std::string::npos);
  CHECK(h.find("property list uchar uint vertex_indices\nend_header\n") != std::string::npos);
  // More vertices than uint32 indices address: a plane tiled far beyond any file.
  const fs::path big = dir / "big.json";
  std::ofstream(big) << R"({"meshes": [{"shape": {"type": "plane"},
    "displacement": {"map": "map.png", "scale": 0.1, "tiling": 2048}}]})";
  const Scene s = loadScene(big.string());
  const ExportPlan p = planExport(s);
  CHECK(p.vertices() > UINT32_MAX);
  try {
    checkExportFits(s, p, (dir / "big.ply").string());
    FAIL("not refused");
  } catch (const Error& e) {
    const std::string m = e.what();
    INFO(m);
    CHECK(m.rfind(big.string() + ": the export needs ", 0) == 0);
    CHECK(m.find("uint32 indices") != std::string::npos);
    CHECK(m.find("try --lod ") != std::string::npos);
    CHECK(m.find('\n') == std::string::npos);
  }
}
