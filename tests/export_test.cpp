// `oblong export` (render/mesh_export.h): the PLY file holds the pre-tessellation
// baseline's triangles with its float vertices, so that the file's triangles trace
// exactly as `--baseline tessellated` on the original scene, also loaded back through a
// scene file; the uv differences that remain are checked against their causes.
#include "core/asset_scene.h"
#include "core/error.h"
#include "core/microgeometry.h"
#include "core/scene.h"
#include "render/embree_scene.h"
#include "render/mesh_export.h"
#include "test_util.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <algorithm>
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

// The baseline traces its micro-triangles in each mesh's frame; the file holds them in
// world floats, each vertex rounded once. Same hit or miss, mesh and t within the
// conformance tests' tolerance against Embree (1e-5 relative, divided by the hit's |cos|).
Agreement compareNear(const EmbreeScene& a, const EmbreeScene& b, const std::vector<Ray>& rays, float diag) {
  Agreement g;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit x = a.intersect(rays[i]), y = b.intersect(rays[i]);
    ++g.rays;
    g.hits += x.valid();
    bool ok = x.valid() == y.valid();
    if (ok && x.valid()) {
      const float tol = 1e-5f * std::max(std::abs(x.t), 1e-2f * diag) /
                        std::max(std::abs(glm::dot(x.ng, glm::normalize(rays[i].d))), 1e-3f);
      ok = std::abs(x.t - y.t) <= tol && x.mesh == y.mesh;
    }
    if (!ok && g.differ++ == 0)
      g.first = fmt::format("ray {}: t {:.9g} vs {:.9g}, mesh {} vs {}", i, x.t, y.t, x.mesh, y.mesh);
  }
  return g;
}

TEST_CASE("export: the exported triangles are the baseline's in world floats and load back bit for bit", "[export][tessellated][unit]") {
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
    // Each micro-vertex is the oracle's, its frame's origin added in double and rounded once.
    size_t rec = 0, notWorld = 0;
    for (const ExportPlan::Part& part : plan.parts) {
      const SceneMesh& sm = scene.meshes[size_t(part.mesh)];
      if (!part.displaced) {
        rec += part.triangles;
        continue;
      }
      for (size_t ti = 0; ti < sm.mesh.triangles.size(); ++ti)
        forEachMicroTriangle(sm.mesh.triangle(ti), *sm.displacement, [&](const MicroTriangle& m) {
          for (int c = 0; c < 3; ++c) {
            const float* e = &v[15 * rec + 5 * size_t(c)];
            notWorld += !sameBits(worldFloat(sm.mesh, m.v[c].p), vec3(e[0], e[1], e[2]));
          }
          ++rec;
        });
    }
    CHECK(notWorld == 0);

    // The file's records with the baseline's shared uvs, one geometry per mesh as in the
    // scene: every hit the baseline's, t within the rounding to world floats.
    size_t shared = 0;
    const std::vector<float> tessUV = withSharedUVs(scene, plan, v, shared);
    const EmbreeScene records(sceneOfRecords(tessUV, plan, true), AccelOptions{});
    const float diag = glm::length(vec3(3.5f));
    const Agreement near = compareNear(tess, records, rays, diag);
    INFO(near.first);
    CHECK(near.hits > rays.size() / 3);
    // A ray grazing a silhouette within that rounding (2.4e-7 here) may hit on one side
    // only: 1 of the 20 000 at λ = 1.5, none at full resolution.
    CHECK(near.differ <= 2);
    // The file's own uvs, all in one geometry: hits on a triangle whose uvs the sharing
    // changed differ in uv by about an ulp, nothing else does.
    const Agreement own = compare(records, EmbreeScene(sceneOfRecords(v, plan, false), AccelOptions{}), rays,
                                  uvsDiffer(v, tessUV));
    INFO(own.first);
    INFO(fmt::format("{} of {} vertex uvs shared by the baseline; {} of {} hits differ in uv through them", shared,
                     3 * plan.triangles, own.flaggedUV, own.hits));
    CHECK(own.differ == 0);

    // Through a scene file: the loader skips the zero-area micro-triangles (which Embree
    // never hits), keeps every position bit for bit (the frame's rounding is exact in
    // this scene), and joins vertices (assimp's JoinIdenticalVertices) that share a
    // position and whose uvs differ by less than its tolerance (1e-5): a vertex whose uv
    // two micro-triangles computed an ulp apart gets one of them, as in the baseline but
    // not always the same one. So it traces as the records, bit for bit.
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
    const Agreement loaded = compare(records, EmbreeScene(back, AccelOptions{}), rays, joined);
    INFO(loaded.first);
    INFO(fmt::format("loaded back: {} of {} hits differ in uv through joined vertices", loaded.flaggedUV, loaded.hits));
    CHECK(loaded.hits == near.hits);
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

namespace {

// A 256² map with detail in both directions (8-bit levels are enough here).
void writeDetailMap(const fs::path& png, int w, int h) {
  std::vector<float> v(size_t(w) * size_t(h));
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i)
      v[size_t(j * w + i)] = 0.5f + 0.25f * std::sin(0.7f * float(i)) + 0.2f * std::cos(0.45f * float(j));
  test::writeGray(png.string(), w, h, v, OIIO::TypeDesc::UINT8);
}

// The depth AOV of a render (inf where the camera ray missed).
std::vector<float> depthOf(const fs::path& exr) {
  auto in = OIIO::ImageInput::open(exr.string());
  REQUIRE(in);
  const OIIO::ImageSpec spec = in->spec();
  const int z = spec.channelindex("Z");
  REQUIRE(z >= 0);
  std::vector<float> all(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
  REQUIRE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data()));
  std::vector<float> out(size_t(spec.width) * size_t(spec.height));
  for (size_t p = 0; p < out.size(); ++p) out[p] = all[p * size_t(spec.nchannels) + size_t(z)];
  return out;
}

// Renders `sceneA` and the export's scene `sceneB` (each a render command's scene and
// flags) with the primary integrator at `size` and checks that they hit the same pixels
// at depths within 1e-5 relative (the traversal works in the mesh's frame, the export in
// world floats: ulps apart). Returns the second render's stderr.
std::string checkRendersAlike(const fs::path& dir, const std::string& tag, const std::string& sceneA,
                              const std::string& sceneB, const std::string& size) {
  const std::string common = " --size " + size + " --integrator primary -q";
  const test::CliRun a = test::runOblongCli("render " + sceneA + common + " -o " + (dir / (tag + "_a.png")).string() +
                                            " --aovs " + (dir / (tag + "_a.exr")).string());
  INFO(a.err);
  REQUIRE(a.status == 0);
  const test::CliRun b = test::runOblongCli("render " + sceneB + common + " -o " + (dir / (tag + "_b.png")).string() +
                                            " --aovs " + (dir / (tag + "_b.exr")).string());
  INFO(b.err);
  REQUIRE(b.status == 0);
  const std::vector<float> za = depthOf(dir / (tag + "_a.exr")), zb = depthOf(dir / (tag + "_b.exr"));
  REQUIRE(za.size() == zb.size());
  size_t hits = 0, differ = 0;
  for (size_t p = 0; p < za.size(); ++p) {
    const bool ha = std::isfinite(za[p]), hb = std::isfinite(zb[p]);
    hits += ha;
    differ += ha != hb || (ha && std::abs(za[p] - zb[p]) > 1e-5f * za[p]);
  }
  CHECK(hits > za.size() / 8);
  CHECK(differ == 0);
  return b.err;
}

}  // namespace

// Far from the origin float world positions (the file's) are coarser than the
// micro-geometry, which oblong computes in the mesh's frame: a plane 6 wide under a 256²
// map (texels 0.023 wide) at 1e9, where floats are 64 apart, had 2 418 identical vertices
// and no word about it. The export counts the micro-triangles whose distinct vertices the
// floats merge and the command prints one warning line; at the origin nothing merges.
TEST_CASE("export: a plane far from the origin keeps its vertices distinct or warns that floats merge them", "[export][bad_input]") {
  const fs::path dir = test::scratchDir("export_far");
  writeDetailMap(dir / "map.png", 256, 256);
  for (const double shift : {0.0, 1e5, 1e9}) {
    INFO("shift " << shift);
    const std::string name = fmt::format("far{:g}", shift);
    const fs::path json = dir / (name + ".json");
    std::ofstream(json) << fmt::format(
        R"({{"meshes": [{{"shape": {{"type": "plane", "size": 6, "segments": [8, 8]}},
             "transform": {{"translate": [{0}, {0}, {0}]}},
             "displacement": {{"map": "map.png", "scale": 0.1, "bias": -0.5}}}}]}})",
        shift);
    const Scene scene = loadScene(json.string());
    const ExportPlan plan = planExport(scene);
    const fs::path ply = dir / (name + ".ply");
    ExportMerged merged;
    REQUIRE(writeExport(scene, plan, ply.string(), nullptr, &merged));
    // The count is the file's: micro-triangles with two equal float vertices that are
    // distinct in the mesh's frame.
    const std::vector<float> v = exportedVertices(ply);
    REQUIRE(v.size() == 15 * plan.triangles);
    size_t inFile = 0, k = 0;
    const SceneMesh& sm = scene.meshes[0];
    for (size_t ti = 0; ti < sm.mesh.triangles.size(); ++ti)
      forEachMicroTriangle(sm.mesh.triangle(ti), *sm.displacement, [&](const MicroTriangle& m) {
        bool merges = false;
        for (int c = 0; c < 3; ++c) {
          const int d = (c + 1) % 3;
          const float* a = &v[15 * k + 5 * size_t(c)];
          const float* b = &v[15 * k + 5 * size_t(d)];
          merges |= a[0] == b[0] && a[1] == b[1] && a[2] == b[2] && m.v[c].p != m.v[d].p;
        }
        inFile += merges;
        ++k;
      });
    CHECK(k == plan.triangles);
    CHECK(merged.triangles == inFile);
    if (shift == 0.0) CHECK(merged.triangles == 0);
    if (shift == 1e9) CHECK(merged.triangles > 1000);
    // The command: one warning line exactly when something merged, exit 0.
    const test::CliRun r = test::runOblongCli("export " + json.string() + " -o " + (dir / (name + "_cli.ply")).string());
    INFO(r.err);
    CHECK(r.status == 0);
    if (merged.triangles == 0) {
      CHECK(r.err.empty());
    } else {
      CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
      CHECK(r.err.rfind("oblong: warning: " + (dir / (name + "_cli.ply")).string() + ": float world positions merge "
                        "vertices of " + std::to_string(merged.triangles) + " of " + std::to_string(plan.microTriangles),
                        0) == 0);
    }
  }
}

// `oblong export` of an OBJ grid (8×8 quads over [-1, 1]², an MTL `disp` map of 32²)
// loads back and renders as the scene it came from. With a square map every base
// diagonal lies on the texel cells' diagonals, and a grid line passes through every
// vertex of the grid: the half-cells touching a base edge only along it left polygons of
// zero area whose vertices at T's corners were computed twice, an ulp apart, so their fans
// were slivers of opposite winding on both sides of the edge; a vertex used only by two
// of them got a zero normal, and `oblong render out.ply` failed (exit 1). Both diagonal
// directions, each rendered at 40×30 from the mesh file's camera: every pixel's depth the
// same within 1e-5 relative.
TEST_CASE("export: an OBJ grid with an MTL disp map loads back and renders as the scene", "[export][cli][bad_input]") {
  const fs::path dir = test::scratchDir("export_grid");
  writeDetailMap(dir / "height.png", 32, 32);
  std::ofstream(dir / "plane.mtl") << "newmtl m\ndisp -mm 0 0.1 height.png\n";
  for (const bool flipped : {false, true}) {
    INFO("diagonals " << (flipped ? "(i+1,j)-(i,j+1)" : "(i,j)-(i+1,j+1)"));
    const int n = 8;
    std::string obj = "mtllib plane.mtl\n";
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        obj += fmt::format("v {} {} 0\nvt {} {}\n", -1.0 + 2.0 * i / n, -1.0 + 2.0 * j / n, double(i) / n, double(j) / n);
    obj += "vn 0 0 1\nusemtl m\n";
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 2, d = a + n + 1;
        const auto f = [&](int x, int y, int z) { obj += fmt::format("f {0}/{0}/1 {1}/{1}/1 {2}/{2}/1\n", x, y, z); };
        if (flipped) f(a, b, d), f(b, c, d);
        else f(a, b, c), f(a, c, d);
      }
    const std::string tag = flipped ? "flipped" : "plain";
    const fs::path objPath = dir / (tag + ".obj"), ply = dir / (tag + ".ply");
    std::ofstream(objPath) << obj;
    const test::CliRun e = test::runOblongCli("export " + objPath.string() + " -o " + ply.string());
    INFO(e.err);
    REQUIRE(e.status == 0);
    // The export as a scene seen by the mesh file's own camera.
    nlohmann::json scene = assetSceneJson(objPath.string());
    scene["meshes"][0].erase("displacement");
    scene["meshes"][0]["file"] = ply.string();
    const Camera cam = loadAsset(objPath.string()).camera;
    const auto arr = [](const vec3& x) { return nlohmann::json::array({x.x, x.y, x.z}); };
    scene["camera"] = {{"from", arr(cam.from)}, {"to", arr(cam.to)}, {"up", arr(cam.up)}, {"fov", cam.fovY}};
    const fs::path back = dir / (tag + "_back.json");
    std::ofstream(back) << scene.dump();
    const std::string err = checkRendersAlike(dir, tag, objPath.string(), back.string(), "40x30");
    // At most the loader's one line about the zero-area micro-triangles it skipped.
    CHECK(std::count(err.begin(), err.end(), '\n') <= 1);
  }
}

// The shipped scenes (their copies in the build where they name system data) exported at a
// coarse level of detail load back as plain meshes and render as the scene, seen by its
// camera: terrain's export has slivers along the map's border whose normals cancel at a
// vertex, which the loader refused for every mesh (now shaded with a triangle's normal).
TEST_CASE("export: the shipped scenes load back and render as the scene", "[export][cli][bad_input]") {
  const fs::path dir = test::scratchDir("export_suite");
  for (const std::string name : {"asteroid", "sphere", "terrain", "quad_tiled"}) {
    INFO(name);
    const std::string scenePath = test::shippedScene(name + ".json");
    const fs::path ply = dir / (name + ".ply");
    const test::CliRun e = test::runOblongCli("export " + scenePath + " --lod 3 -o " + ply.string());
    INFO(e.err);
    REQUIRE(e.status == 0);
    std::ifstream in(scenePath);
    const nlohmann::json original = nlohmann::json::parse(in, nullptr, true, /*ignore_comments=*/true);
    const nlohmann::json back = {{"meshes", {{{"file", ply.string()}}}}, {"camera", original.at("camera")}};
    const fs::path backPath = dir / (name + "_back.json");
    std::ofstream(backPath) << back.dump();
    checkRendersAlike(dir, name, scenePath + " --lod 3", backPath.string(), "64x48");
  }
}
