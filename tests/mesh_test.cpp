#include "core/error.h"
#include "core/mesh.h"
#include "core/procedural.h"
#include "test_util.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include <filesystem>
#include <fstream>
#include <cstring>
#include <map>
#include <set>
#include <tuple>

#include <sys/stat.h>

using namespace oblong;
using Catch::Matchers::Contains;

namespace {

std::string writeFile(const std::string& name, const std::string& text) {
  const std::string p = (test::scratchDir("mesh") / name).string();
  std::ofstream(p) << text;
  return p;
}

// Two faces meeting at the edge (0,0,0)-(0,1,0): A in the plane z=0 (cross product
// (0,0,1), area 1/2), B in the plane x=0 (cross product (-2,0,0), area 1). At the
// shared vertices the area-weighted normal is (-2,0,1)/sqrt(5); an angle-weighted or
// unweighted average would give (-1,0,1)/sqrt(2) (both corner angles are 90 degrees).
// B's copies of the shared vertices have their own uvs: a uv seam.
const char* kTent =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 2\n"
    "vt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nvt 0.5 0.9\nvt 0.9 0.5\n"
    "f 1/1 2/2 3/3\nf 3/5 1/4 4/6\n";

bool near(const vec3& a, const vec3& b, float eps = 1e-6f) { return glm::length(a - b) <= eps; }

// Vertex v in the world, as a float (the file's coordinates for these small meshes:
// `positions` are in the mesh's frame, centred on its box).
vec3 at(const Mesh& m, size_t v) { return vec3(m.world(v)); }

}  // namespace

TEST_CASE("OBJ with uvs and normals: positions, uvs, triangles, normals normalised", "[mesh][unit]") {
  // A unit quad of two triangles; the file's normals have length 2.
  const auto path = writeFile("quad.obj",
                              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                              "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 2\n"
                              "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n");
  const Mesh m = loadMesh(path, {glm::mat4(1.0f), true});
  CHECK(m.name == path);
  REQUIRE(m.positions.size() == 4);
  REQUIRE(m.normals.size() == 4);
  REQUIRE(m.uvs.size() == 4);
  REQUIRE(m.triangles.size() == 2);
  for (size_t v = 0; v < 4; ++v) {
    INFO("vertex " << v);
    CHECK(near(m.normals[v], vec3(0, 0, 1)));
    CHECK(m.uvs[v] == vec2(at(m, v).x, at(m, v).y));  // uv = xy for this quad
  }
  // Both triangles keep their winding (normal +z) and cover the quad.
  float area = 0;
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const DisplacedTriangle t = m.triangle(i);
    CHECK(near(t.faceNormal, vec3(0, 0, 1)));
    CHECK(t.uvArea2 > 0);
    area += t.area;
    for (int k = 0; k < 3; ++k) {
      CHECK(t.p[k] == m.positions[m.triangles[i][k]]);
      CHECK(t.n[k] == m.normals[m.triangles[i][k]]);
      CHECK(t.t[k] == m.uvs[m.triangles[i][k]]);
    }
  }
  CHECK(area == Approx(1.0f));
  CHECK(m.inputTriangle == std::vector<uint32_t>{0, 1});
  CHECK(m.bytes() == 4 * sizeof(vec3) * 2 + 4 * sizeof(vec2) + 2 * sizeof(glm::uvec3) + 2 * sizeof(uint32_t));
}

TEST_CASE("ASCII PLY with uvs: quads are triangulated", "[mesh][unit]") {
  const auto path = writeFile("quad.ply",
                              "ply\nformat ascii 1.0\nelement vertex 4\n"
                              "property float x\nproperty float y\nproperty float z\n"
                              "property float s\nproperty float t\n"
                              "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                              "0 0 0 0 0\n2 0 0 1 0\n2 2 0 1 1\n0 2 0 0 1\n4 0 1 2 3\n");
  const Mesh m = loadMesh(path, {glm::mat4(1.0f), true});
  REQUIRE(m.triangles.size() == 2);
  REQUIRE(m.positions.size() == 4);
  REQUIRE(m.hasUVs());
  for (size_t v = 0; v < 4; ++v) {
    CHECK(m.uvs[v] == vec2(at(m, v).x / 2, at(m, v).y / 2));
    CHECK(near(m.normals[v], vec3(0, 0, 1)));  // computed: the file has none
  }
}

TEST_CASE("smooth normals are area-weighted, unit, and shared across uv seams", "[mesh][unit]") {
  const auto path = writeFile("tent.obj", kTent);
  const Mesh m = loadMesh(path, {glm::mat4(1.0f), true});
  REQUIRE(m.triangles.size() == 2);
  // The shared positions are split by their uvs: 6 vertices, 4 positions.
  REQUIRE(m.positions.size() == 6);
  const vec3 shared = glm::normalize(vec3(-2, 0, 1));
  std::map<std::tuple<float, float, float>, vec3> byPosition;
  for (size_t v = 0; v < m.positions.size(); ++v) {
    const vec3 p = at(m, v), n = m.normals[v];
    INFO("vertex " << v << " at " << p.x << " " << p.y << " " << p.z);
    CHECK(glm::length(n) == Approx(1.0f).epsilon(1e-6));
    if (p == vec3(1, 0, 0)) CHECK(near(n, vec3(0, 0, 1)));
    else if (p == vec3(0, 0, 2)) CHECK(near(n, vec3(-1, 0, 0)));
    else CHECK(near(n, shared));
    // Seam copies get bit-identical normals (needed for watertight displacement).
    auto [it, fresh] = byPosition.try_emplace({p.x, p.y, p.z}, n);
    if (!fresh) CHECK(it->second == n);
  }
  CHECK(byPosition.size() == 4);

  // computeSmoothNormals on its own gives the same.
  Mesh copy = m;
  computeSmoothNormals(copy);
  CHECK(copy.normals == m.normals);
}

TEST_CASE("zero normals in the file are replaced by smooth normals", "[mesh][unit]") {
  const auto path = writeFile("zeronormal.obj",
                              "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 0 0 3\n"
                              "f 1//1 2//2 3//1\n");
  const Mesh m = loadMesh(path);
  REQUIRE(m.normals.size() == 3);
  for (const vec3& n : m.normals) CHECK(near(n, vec3(0, 0, 1)));
  CHECK_FALSE(m.hasUVs());
  CHECK(m.triangle(0).t[1] == vec2(0.0f));  // no uvs: t = 0
}

TEST_CASE("several objects in one file are concatenated", "[mesh][unit]") {
  const auto path = writeFile("two.obj",
                              "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                              "o b\nv 5 0 0\nv 6 0 0\nv 5 1 0\nv 6 1 0\nf 4 5 6\nf 5 7 6\n");
  const Mesh m = loadMesh(path);
  REQUIRE(m.triangles.size() == 3);
  REQUIRE(m.positions.size() == 7);
  AABB box;
  for (const auto& f : m.triangles)
    for (int k = 0; k < 3; ++k) {
      REQUIRE(f[k] < m.positions.size());
      box.extend(at(m, f[k]));
    }
  CHECK(box.lo == vec3(0, 0, 0));
  CHECK(box.hi == vec3(6, 1, 0));
}

TEST_CASE("transforms move positions and normals (inverse transpose)", "[mesh][unit]") {
  const auto path = writeFile("tent_t.obj", kTent);
  const Mesh base = loadMesh(path);
  // Non-uniform scale: the normal (-2,0,1) becomes (-1,0,1) under the inverse transpose.
  const glm::mat4 T = glm::translate(glm::mat4(1.0f), vec3(1, 2, 3)) * glm::scale(glm::mat4(1.0f), vec3(2, 1, 1));
  const Mesh m = loadMesh(path, {T, false});
  REQUIRE(m.positions.size() == base.positions.size());
  // The translation is the frame's, not the positions': the origin is the translation
  // plus the linear part's image of the untransformed mesh's centre.
  CHECK(m.origin == dvec3(1, 2, 3) + dvec3(glm::mat3(T) * vec3(base.origin)));
  for (size_t v = 0; v < m.positions.size(); ++v) {
    const vec3 p = at(base, v), q = base.positions[v];
    CHECK(m.positions[v] == vec3(2 * q.x, q.y, q.z));
    CHECK(near(vec3(m.world(v)), vec3(2 * p.x + 1, p.y + 2, p.z + 3)));
    if (near(base.normals[v], glm::normalize(vec3(-2, 0, 1))))
      CHECK(near(m.normals[v], glm::normalize(vec3(-1, 0, 1))));
    CHECK(glm::length(m.normals[v]) == Approx(1.0f));
  }
  // The area-weighted normal commutes with affine maps: recomputing gives the same.
  Mesh again = m;
  computeSmoothNormals(again);
  for (size_t v = 0; v < m.normals.size(); ++v) CHECK(near(again.normals[v], m.normals[v], 1e-5f));

  // A mirror keeps the winding consistent with the vertex normals.
  Mesh mirrored = base;
  transformMesh(mirrored, glm::scale(glm::mat4(1.0f), vec3(-1, 1, 1)));
  for (size_t i = 0; i < mirrored.triangles.size(); ++i) {
    const DisplacedTriangle t = mirrored.triangle(i);
    for (int k = 0; k < 3; ++k) CHECK(glm::dot(t.faceNormal, t.n[k]) > 0.0f);
  }
  Mesh flat = base;
  CHECK_THROWS_WITH(transformMesh(flat, glm::scale(glm::mat4(1.0f), vec3(1, 0, 1))), Contains("singular"));
}

TEST_CASE("bad meshes give one-line errors naming the file", "[mesh][unit]") {
  SECTION("missing file") {
    const std::string path = (test::scratchDir("mesh") / "does_not_exist.obj").string();
    CHECK_THROWS_MATCHES(loadMesh(path), Error, Catch::Matchers::Message(path + ": file not found"));
  }
  SECTION("garbage file") {
    const auto path = writeFile("garbage.ply", "this is not a mesh\n\x01\x02\x03");
    CHECK_THROWS_WITH(loadMesh(path), Contains(path + ": cannot load mesh"));
  }
  SECTION("PLY header without end_header: an error, not assimp's endless loop") {
    for (const std::string text : {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
                                   "PLY\nformat ascii 1.0\nend_headerX\n", "\r\nply\ncomment end_header\n"}) {
      const auto path = writeFile("noend.ply", text);
      CHECK_THROWS_WITH(loadMesh(path), Contains(path + ": cannot load mesh (PLY header without an end_header"));
    }
    // A well-formed header (CRLF, indented end_header) still loads.
    const auto ok = writeFile("crlf.ply",
                              "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\nproperty float y\r\n"
                              "property float z\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\n"
                              "  end_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n");
    CHECK(loadMesh(ok).triangles.size() == 1);
  }
  SECTION("no triangles (lines only)") {
    const auto path = writeFile("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
    CHECK_THROWS_WITH(loadMesh(path), Contains(path + ": ") && Contains("no triangles"));
  }
  SECTION("no uvs when displacement needs them") {
    const auto path = writeFile("nouv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_NOTHROW(loadMesh(path));
    CHECK_THROWS_MATCHES(loadMesh(path, {glm::mat4(1.0f), true}), Error,
                         Catch::Matchers::Message(path + ": mesh has no texture coordinates (needed for displacement)"));
  }
  SECTION("normals that cancel (two-sided sheet sharing vertices)") {
    const auto path = writeFile("cancel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                              "f 1/1 2/2 3/3\nf 1/1 3/3 2/2\n");
    // To be displaced: the normal is the displacement's direction, so it is an error.
    CHECK_THROWS_WITH(loadMesh(path, {glm::mat4(1.0f), true}), Contains(path + ": ") && Contains("zero normal"));
    // A plain mesh: the normal only shades; each vertex takes its largest triangle's.
    MeshLoadOptions plain;
    plain.warn = false;
    const Mesh m = loadMesh(path, plain);
    for (const vec3& n : m.normals) CHECK(std::abs(glm::length(n) - 1.0f) < 1e-6f);
  }
  SECTION("non-finite positions") {
    const auto path = writeFile("inf.ply",
                                "ply\nformat ascii 1.0\nelement vertex 3\n"
                                "property float x\nproperty float y\nproperty float z\n"
                                "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1e39 0 0\n0 1 0\n3 0 1 2\n");
    CHECK_THROWS_WITH(loadMesh(path), Contains(path + ": ") && Contains("non-finite"));
  }
}

TEST_CASE("the glmark2 asteroid loads (low: uvs for the height map, high: the reference)", "[mesh][unit]") {
  // The build's copy of glmark2-data's models (tests/test_data.cmake).
  const std::string low = OBLONG_TEST_DATA "/glmark2/models/asteroid-low.3ds";
  const std::string high = OBLONG_TEST_DATA "/glmark2/models/asteroid-high.3ds";
  REQUIRE(std::filesystem::exists(low));
  REQUIRE(std::filesystem::exists(high));
  const Mesh m = loadMesh(low, {glm::mat4(1.0f), true});
  CHECK(m.triangles.size() == 480);
  CHECK(m.positions.size() == 262);  // 242 distinct positions, 20 split at uv seams
  REQUIRE(m.hasUVs());
  AABB box;
  for (size_t v = 0; v < m.positions.size(); ++v) box.extend(at(m, v));
  CHECK(box.lo.x == Approx(-1.2756f).margin(1e-3));
  CHECK(box.hi.x == Approx(1.1518f).margin(1e-3));
  CHECK(box.lo.y == Approx(-0.8847f).margin(1e-3));
  CHECK(box.hi.z == Approx(0.9475f).margin(1e-3));
  for (const vec3& n : m.normals) CHECK(glm::length(n) == Approx(1.0f).epsilon(1e-5));
  for (const vec2& t : m.uvs) CHECK((t.x >= 0 && t.x <= 1 && t.y >= 0 && t.y <= 1));
  size_t displaceable = 0;
  for (size_t i = 0; i < m.triangles.size(); ++i) displaceable += m.triangle(i).prepare();
  CHECK(displaceable == m.triangles.size());

  const Mesh h = loadMesh(high);
  CHECK(h.triangles.size() == 48000);
  CHECK(h.positions.size() == 24002);
  CHECK_FALSE(h.hasUVs());
}

TEST_CASE("degenerate triangles are skipped with a warning, not an error", "[mesh][bad_input][unit]") {
  // Triangle 1 repeats a vertex, triangle 2 has three collinear vertices, triangle 3 has
  // a zero-area uv triangle (all uvs equal): skipped only when the mesh is displaced.
  const auto path = writeFile("degenerate.obj",
                              "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 1 1 0\n"
                              "vt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\n"
                              "f 1/1 2/2 3/3\nf 1/1 2/2 2/2\nf 1/1 2/2 4/1\nf 2/4 4/4 5/4\n");
  const Mesh plain = loadMesh(path, {glm::mat4(1.0f), false, false});
  CHECK(plain.triangles.size() == 2);  // triangles 0 and 3
  CHECK(plain.skippedTriangles == 2);
  const Mesh displaced = loadMesh(path, {glm::mat4(1.0f), true, false});
  CHECK(displaced.triangles.size() == 1);
  CHECK(displaced.skippedTriangles == 3);
  for (size_t i = 0; i < displaced.triangles.size(); ++i) CHECK(displaced.triangle(i).prepare());
  // The vertex used only by degenerate triangles (x = 2) still gets a unit normal.
  for (const vec3& n : displaced.normals) CHECK(glm::length(n) == Approx(1.0f));
}

TEST_CASE("a mesh whose triangles are all degenerate is an error", "[mesh][bad_input][unit]") {
  const auto path = writeFile("alldegenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n");
  CHECK_THROWS_MATCHES(loadMesh(path, {glm::mat4(1.0f), false, false}), Error,
                       Catch::Matchers::Message(path + ": all 2 triangles are degenerate (zero area: 2)"));
  // Zero uv area everywhere: fine undisplaced, an error displaced.
  const auto flatUV = writeFile("flatuv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 1\nvt 2 2\nf 1/1 2/2 3/3\n");
  CHECK(loadMesh(flatUV).triangles.size() == 1);
  CHECK_THROWS_WITH(loadMesh(flatUV, {glm::mat4(1.0f), true, false}),
                    Contains(flatUV + ": all 1 triangles are degenerate (zero area: 0, zero uv area: 1)"));
  // A transform so small that every area underflows to zero.
  const auto tiny = writeFile("tiny.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  CHECK_THROWS_WITH(loadMesh(tiny, {glm::scale(glm::mat4(1.0f), vec3(1e-25f, 1, 1)), false, false}),
                    Contains(tiny + ": all 1 triangles are degenerate (zero area: 1)"));
}

TEST_CASE("normals that cancel inside a displaced triangle are an error", "[mesh][bad_input][unit]") {
  // Opposite vertex normals: N(b) vanishes on the edge between them, so N/|N| (the
  // displacement direction) is undefined. Fine for a plain mesh.
  const auto path = writeFile("cancelinside.obj",
                              "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\n"
                              "f 1/1/1 2/2/2 3/3/1\n");
  CHECK_NOTHROW(loadMesh(path));
  CHECK_THROWS_WITH(loadMesh(path, {glm::mat4(1.0f), true, false}),
                    Contains(path + ": triangle 0: its vertex normals cancel"));
}

TEST_CASE("coordinates whose triangle areas overflow are an error", "[mesh][bad_input][unit]") {
  const auto path = writeFile("huge.obj", "v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n");
  CHECK_THROWS_WITH(loadMesh(path), Contains(path + ": triangle 0: its area overflows"));
}

TEST_CASE("finishMesh checks generated meshes like loaded ones", "[mesh][bad_input][unit]") {
  Mesh m;
  m.name = "<test>";
  CHECK_THROWS_WITH(finishMesh(m, {}), Contains("<test>: mesh has no triangles"));
  m.positions = {vec3(0), vec3(1, 0, 0), vec3(0, 1, 0)};
  m.normals = {vec3(0), vec3(0), vec3(0)};
  m.triangles = {{0, 1, 5}};
  CHECK_THROWS_WITH(finishMesh(m, {}), Contains("triangle uses vertex 5 of 3"));
  m.triangles = {{0, 1, 2}};
  CHECK_THROWS_WITH(finishMesh(m, {glm::mat4(1.0f), true, false}), Contains("no texture coordinates"));
  finishMesh(m, {});
  for (const vec3& n : m.normals) CHECK(n == vec3(0, 0, 1));  // smooth normals filled in
}

TEST_CASE("procedural plane and sphere: outward normals, seams bit-identical, nothing degenerate", "[mesh][unit]") {
  const Mesh plane = planeMesh(vec2(3, 2), ivec2(3, 4), vec2(0.1f, 0.2f), vec2(0.9f, 0.7f));
  CHECK(plane.triangles.size() == 24);
  for (size_t i = 0; i < plane.triangles.size(); ++i) {
    DisplacedTriangle T = plane.triangle(i);
    REQUIRE(T.prepare());
    CHECK(T.faceNormal == vec3(0, 1, 0));
    CHECK(T.uvArea2 != 0.0f);
  }
  // Corners: exact positions and uvs.
  CHECK(plane.positions.front() == vec3(-1.5f, 0, -1));
  CHECK(plane.positions.back() == vec3(1.5f, 0, 1));
  CHECK(plane.uvs.front() == vec2(0.1f, 0.2f));
  CHECK(plane.uvs.back() == vec2(0.9f, 0.7f));

  for (const ivec2 seg : {ivec2(3, 2), ivec2(64, 32), ivec2(7, 5)}) {
    const Mesh s = sphereMesh(1.5f, seg.x, seg.y);
    INFO(seg.x << "x" << seg.y);
    CHECK(s.triangles.size() == size_t(2 * seg.x * (seg.y - 1)));
    double area = 0;
    for (size_t i = 0; i < s.triangles.size(); ++i) {
      DisplacedTriangle T = s.triangle(i);
      REQUIRE(T.prepare());
      area += T.area;
      // Outward: the geometric normal agrees with the vertex normals and points away
      // from the centre; uv triangles keep one orientation (no mirrored charts).
      for (int k = 0; k < 3; ++k) CHECK(glm::dot(T.faceNormal, T.n[k]) > 0.0f);
      CHECK(glm::dot(T.faceNormal, (T.p[0] + T.p[1] + T.p[2]) / 3.0f) > 0.0f);
      CHECK(T.uvArea2 < 0.0f);  // same sign for every triangle
    }
    if (seg.x == 64) CHECK(area == Approx(4 * 3.14159265 * 1.5 * 1.5).epsilon(0.01));
    // Same position => bit-identical normal (watertight displacement needs it).
    std::map<std::tuple<float, float, float>, vec3> byPosition;
    for (size_t v = 0; v < s.positions.size(); ++v) {
      CHECK(glm::length(s.normals[v]) == Approx(1.0f).epsilon(1e-6));
      const vec3 p = s.positions[v];
      auto [it, fresh] = byPosition.try_emplace({p.x, p.y, p.z}, s.normals[v]);
      if (!fresh) CHECK(it->second == s.normals[v]);
    }
    // Distinct positions: (nv-1) rings of nu, and the two poles.
    CHECK(byPosition.size() == size_t(seg.x * (seg.y - 1) + 2));
  }
  // Seen from outside at +x (u = 0), u increases to the right (towards -z) and v
  // downwards: the map is not mirrored.
  const Mesh s = sphereMesh(1.0f, 8, 4);
  for (size_t v = 0; v < s.positions.size(); ++v) {
    if (s.uvs[v] == vec2(0.125f, 0.5f)) CHECK(s.positions[v].z < 0.0f);
    if (s.uvs[v] == vec2(0.0f, 0.25f)) CHECK(s.positions[v].y > 0.0f);
  }
}

namespace {

std::string bytesOf(const void* p, size_t n) { return std::string(static_cast<const char*>(p), n); }

// The quad of the uv tests: positions and uvs, two triangles (0,1,2), (0,2,3).
const vec3 kQuadP[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
const vec2 kQuadT[4] = {{0.25f, 0.05f}, {0.75f, 0.05f}, {0.75f, 0.5f}, {0.125f, 0.875f}};

// glTF 2.0 of the quad: POSITION, TEXCOORD_0 and indices in one buffer, embedded as a
// base64 data URI (.gltf) or as the binary chunk (.glb).
std::string quadBuffer() {
  std::string b = bytesOf(kQuadP, sizeof kQuadP) + bytesOf(kQuadT, sizeof kQuadT);
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  return b + bytesOf(idx, sizeof idx);
}
std::string quadGltfJson(const std::string& bufferUri) {
  const size_t n = quadBuffer().size();
  return fmt::format(R"({{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
    "nodes": [{{"mesh": 0}}],
    "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2}}]}}],
    "buffers": [{{"byteLength": {}{}}}],
    "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
                    {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
                    {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}],
    "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                    "min": [0, 0, 0], "max": [1, 1, 0]}},
                  {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
                  {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}})",
                     n, bufferUri.empty() ? "" : R"(, "uri": ")" + bufferUri + "\"");
}
std::string quadGlb() {
  std::string json = quadGltfJson(""), bin = quadBuffer();
  while (json.size() % 4) json += ' ';
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](uint32_t v) { return bytesOf(&v, 4); };
  const std::string body = u32(uint32_t(json.size())) + "JSON" + json + u32(uint32_t(bin.size())) + "BIN" +
                           std::string(1, '\0') + bin;
  return "glTF" + u32(2) + u32(uint32_t(12 + body.size())) + body;
}

std::map<std::tuple<float, float, float>, vec2> uvByPosition(const Mesh& m) {
  std::map<std::tuple<float, float, float>, vec2> r;
  for (size_t v = 0; v < m.positions.size(); ++v) r[{at(m, v).x, at(m, v).y, at(m, v).z}] = m.uvs[v];
  return r;
}

}  // namespace

TEST_CASE("uvs come out as the file stores them: OBJ, PLY, glTF and GLB agree", "[mesh][unit]") {
  // assimp flips glTF's v (v' = 1 - v) and keeps OBJ's and PLY's; loadMesh undoes the flip.
  std::string obj, ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                         "property float z\nproperty float s\nproperty float t\nelement face 2\n"
                         "property list uchar int vertex_indices\nend_header\n";
  for (int k = 0; k < 4; ++k) {
    obj += fmt::format("v {} {} {}\nvt {} {}\n", kQuadP[k].x, kQuadP[k].y, kQuadP[k].z, kQuadT[k].x, kQuadT[k].y);
    ply += fmt::format("{} {} {} {} {}\n", kQuadP[k].x, kQuadP[k].y, kQuadP[k].z, kQuadT[k].x, kQuadT[k].y);
  }
  obj += "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  ply += "3 0 1 2\n3 0 2 3\n";
  const auto fromObj = uvByPosition(loadMesh(writeFile("uvquad.obj", obj), {glm::mat4(1.0f), true}));
  const auto fromPly = uvByPosition(loadMesh(writeFile("uvquad.ply", ply), {glm::mat4(1.0f), true}));
  const auto fromGltf = uvByPosition(loadMesh(
      writeFile("uvquad.gltf", quadGltfJson("data:application/octet-stream;base64," + test::base64(quadBuffer()))),
      {glm::mat4(1.0f), true}));
  const auto fromGlb = uvByPosition(loadMesh(writeFile("uvquad.glb", quadGlb()), {glm::mat4(1.0f), true}));
  REQUIRE(fromObj.size() == 4);
  for (int k = 0; k < 4; ++k) {
    INFO("vertex " << k);
    const std::tuple<float, float, float> p{kQuadP[k].x, kQuadP[k].y, kQuadP[k].z};
    CHECK(fromObj.at(p) == kQuadT[k]);  // bit-identical, v = 0.05 included
    CHECK(fromPly.at(p) == kQuadT[k]);
    CHECK(fromGltf.at(p) == kQuadT[k]);
    CHECK(fromGlb.at(p) == kQuadT[k]);
  }
}

TEST_CASE("normals \"smooth\": per-face normals of split vertices become one normal per position", "[mesh][unit]") {
  // A unit cube exported flat: 6 face normals, each corner split into three vertices.
  std::string obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                    "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n";
  const int faces[6][4] = {{1, 4, 3, 2}, {5, 6, 7, 8}, {1, 2, 6, 5}, {4, 8, 7, 3}, {1, 5, 8, 4}, {2, 3, 7, 6}};
  for (int f = 0; f < 6; ++f)
    obj += fmt::format("f {}/1/{} {}/2/{} {}/3/{} {}/4/{}\n", faces[f][0], f + 1, faces[f][1], f + 1, faces[f][2],
                       f + 1, faces[f][3], f + 1);
  const auto path = writeFile("flatcube.obj", obj);
  const Mesh file = loadMesh(path, {glm::mat4(1.0f), true});
  MeshLoadOptions smooth{glm::mat4(1.0f), true};
  smooth.smoothNormals = true;
  const Mesh s = loadMesh(path, smooth);
  REQUIRE(file.positions.size() == 24);
  REQUIRE(s.positions.size() == 24);
  std::map<std::tuple<float, float, float>, std::vector<vec3>> fileNormals, smoothNormals;
  for (size_t v = 0; v < 24; ++v) {
    const vec3 p = at(s, v);
    fileNormals[{at(file, v).x, at(file, v).y, at(file, v).z}].push_back(file.normals[v]);
    smoothNormals[{p.x, p.y, p.z}].push_back(s.normals[v]);
    CHECK(glm::length(s.normals[v]) == Approx(1.0f));
    CHECK(glm::dot(s.normals[v], glm::normalize(p - vec3(0.5f))) > 0.9f);  // outwards, between the three faces
  }
  REQUIRE(smoothNormals.size() == 8);
  for (const auto& [p, ns] : smoothNormals) {
    REQUIRE(ns.size() == 3);
    CHECK(ns[0] == ns[1]);  // bit-identical: the displaced copies meet
    CHECK(ns[1] == ns[2]);
  }
  for (const auto& [p, ns] : fileNormals) CHECK(ns[0] != ns[1]);  // the file's: three directions
}

TEST_CASE("truncated PLY files are refused, never read past their end", "[mesh][bad_input][unit]") {
  // Binary: every cut of a valid file (assimp read past the end and crashed, even one byte
  // short) gives one error line; the whole file loads.
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nproperty float s\nproperty float t\nelement face 2\n"
                    "property list uchar int vertex_indices\nend_header\n";
  const size_t header = bin.size();
  const float v[4][5] = {{0, 0, 0, 0, 0}, {1, 0, 0, 1, 0}, {1, 1, 0, 1, 1}, {0, 1, 0, 0, 1}};
  bin += bytesOf(v, sizeof v);
  for (const int32_t f : {0, 1, 2, 0, 2, 3}) {
    if (bin.size() == header + sizeof v || bin.size() == header + sizeof v + 13) bin += '\3';
    bin += bytesOf(&f, 4);
  }
  const auto good = writeFile("good_bin.ply", bin);
  CHECK(loadMesh(good, {glm::mat4(1.0f), true}).triangles.size() == 2);
  for (size_t n = bin.size() - 1; n >= header; --n) {
    const auto cut = writeFile("cut_bin.ply", bin.substr(0, n));
    INFO(n << " of " << bin.size() << " bytes");
    CHECK_THROWS_WITH(loadMesh(cut, {glm::mat4(1.0f), true}),
                      Contains(cut + ": cannot load mesh (PLY header declares ") && Contains(" but the file "));
  }
  CHECK_THROWS_WITH(loadMesh(writeFile("cut_bin.ply", bin.substr(0, bin.size() - 1))),
                    Contains("cannot load mesh (PLY header declares 2 face elements but the file ends after 1 of them"));
  CHECK_THROWS_WITH(loadMesh(writeFile("cut_bin.ply", bin.substr(0, header + 40))),
                    Contains("cannot load mesh (PLY header declares 4 vertex elements of 20 bytes but the file holds "
                             "only 40 bytes for them)"));

  // ASCII: a missing last line, a line cut short (assimp loaded a partial mesh).
  const std::string ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                            "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
  CHECK(loadMesh(writeFile("good_ascii.ply", ascii)).triangles.size() == 2);
  const std::string noLast = ascii.substr(0, ascii.size() - 8), shortLine = ascii.substr(0, ascii.size() - 5);
  CHECK_THROWS_WITH(loadMesh(writeFile("cut_ascii.ply", noLast)),
                    Contains("cannot load mesh (PLY header declares 2 face elements but the file ends after 1 of them)"));
  CHECK_THROWS_WITH(loadMesh(writeFile("cut_ascii.ply", shortLine)),
                    Contains("cannot load mesh (PLY face 1 (line 15): list count '3' is more than the 1 values after "
                             "it)"));
  CHECK_THROWS_WITH(loadMesh(writeFile("cut_ascii.ply", ascii.substr(0, ascii.find("0 1 0")))),
                    Contains("cannot load mesh (PLY header declares 4 vertex elements but the file ends after 3 of them)"));
}

TEST_CASE("a PLY header claiming more than the file holds is refused before assimp allocates", "[mesh][bad_input][unit]") {
  // assimp allocated 3.5 GiB for the first and tried 48 GB for the second.
  for (const char* count : {"300000000", "4000000000"}) {
    std::string h = fmt::format("ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n"
                                "property float y\nproperty float z\nelement face 1\n"
                                "property list uchar int vertex_indices\nend_header\n",
                                count);
    const size_t data = 200 - h.size();
    const auto path = writeFile("claims.ply", h + std::string(data, '\0'));
    CHECK_THROWS_MATCHES(loadMesh(path), Error,
                         Catch::Matchers::Message(fmt::format("{}: cannot load mesh (PLY header declares {} vertex "
                                                              "elements of 12 bytes but the file holds only {} bytes "
                                                              "for them)",
                                                              path, count, data)));
    const auto ascii = writeFile("claims_ascii.ply", "ply\nformat ascii 1.0\nelement vertex " + std::string(count) +
                                                         "\nproperty float x\nend_header\n0\n1\n");
    CHECK_THROWS_WITH(loadMesh(ascii), Contains("PLY header declares " + std::string(count) +
                                                " vertex elements but the file ends after 2 of them"));
  }
  // A list whose count says more than the file holds, or a negative count.
  const std::string head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list char int vertex_indices\nend_header\n";
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const int32_t f[3] = {0, 1, 2};
  CHECK_THROWS_WITH(loadMesh(writeFile("negcount.ply", head + bytesOf(v, 36) + "\xff" + bytesOf(f, 12))),
                    Contains("cannot load mesh (PLY face 0: its list count is negative or not a count)"));
  CHECK_THROWS_WITH(loadMesh(writeFile("bigcount.ply", head + bytesOf(v, 36) + "\x7f" + bytesOf(f, 12))),
                    Contains("(entry 0's list of 127 needs 508 bytes, the file holds 12 more)"));
  CHECK(loadMesh(writeFile("count3.ply", head + bytesOf(v, 36) + "\x03" + bytesOf(f, 12))).triangles.size() == 1);
}

TEST_CASE("PLY headers assimp would misread are refused, and its quirks are worked around", "[mesh][bad_input][unit]") {
  const std::string vertex = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
  const std::string data = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  // A comment among the properties ends assimp's property list (y and z would be lost).
  const auto comment = writeFile("comment.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                                "comment here\nproperty float y\nproperty float z\n" +
                                                    face + "end_header\n" + data);
  CHECK_THROWS_WITH(loadMesh(comment), Contains("cannot load mesh (assimp 5.2 would misread this PLY header: its list "
                                                "of the properties of element 'vertex' ends at a comment line)"));
  // A comment between elements is fine.
  CHECK(loadMesh(writeFile("comment_ok.ply", "ply\nformat ascii 1.0\ncomment a\n" + vertex + "comment b\n" + face +
                                                 "end_header\n" + data))
            .triangles.size() == 1);
  // An element assimp does not know before the vertices: it reads its count as 0.
  const auto camera = writeFile("camera.ply", "ply\nformat ascii 1.0\nelement camera 1\nproperty float view_px\n" +
                                                  vertex + face + "end_header\n7\n" + data);
  CHECK_THROWS_WITH(loadMesh(camera), Contains("it reads the count of element 'camera' as 0, not 1"));
  // ... after them it is ignored, as it should be.
  CHECK(loadMesh(writeFile("camera_last.ply", "ply\nformat ascii 1.0\n" + vertex + face +
                                                  "element camera 1\nproperty float view_px\nend_header\n" + data +
                                                  "7\n"))
            .triangles.size() == 1);
  // end_header as the last line, without a line end: assimp parses that line again
  // over older text forever (found by fuzzing the PLY checks; the input verbatim).
  CHECK_THROWS_WITH(loadMesh(writeFile("eof_end.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                                      "property float x\np0operty float y\nproperty float z\n"
                                                      "elent face 1\nproperty list uchar int vertex_indices\n"
                                                      "end_header")),
                    Contains("cannot load mesh (PLY header without an end_header line as assimp reads lines"));
  // The same with the magic in mixed case, which assimp accepts too (the fuzzer again).
  CHECK_THROWS_WITH(loadMesh(writeFile("eof_end_case.ply", "pLy\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                                           "property float x\np0operty float y\nproperty float z\n"
                                                           "elent face 1\nproperIIIIist uchar int vertex_indices\n"
                                                           "end_header")),
                    Contains("cannot load mesh (PLY header without an end_header line as assimp reads lines"));
  // A property type assimp does not know.
  CHECK_THROWS_WITH(loadMesh(writeFile("int64.ply", "ply\nformat ascii 1.0\n" + vertex +
                                                        "property int64 id\n" + face + "end_header\n" + data)),
                    Contains("cannot load mesh (PLY property type 'int64' of element 'vertex' is not one assimp reads)"));
  // Not a number where the header wants an integer.
  CHECK_THROWS_WITH(loadMesh(writeFile("notint.ply", "ply\nformat ascii 1.0\n" + vertex + face + "end_header\n" +
                                                         "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n")),
                    Contains("cannot load mesh (PLY face 0 (line 13): '1.5' is not a number of its type)"));

  // Binary data whose first byte is '\n': assimp drops it (it expects "end_header\r\n")
  // and would read every value one byte off. x = 0x3F80000A (1.0000012f) starts with it.
  const std::string head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const uint32_t x0 = 0x3F80000Au;
  float v[9] = {0, 0, 0, 3, 0, 0, 1, 1, 0};
  std::memcpy(&v[0], &x0, 4);
  const int32_t f[3] = {0, 1, 2};
  const Mesh lf = loadMesh(writeFile("lf_first.ply", head + bytesOf(v, 36) + "\x03" + bytesOf(f, 12)));
  REQUIRE(lf.triangles.size() == 1);
  std::set<std::tuple<float, float, float>> got, want;
  for (size_t k = 0; k < lf.positions.size(); ++k) got.insert({at(lf, k).x, at(lf, k).y, at(lf, k).z});
  for (int k = 0; k < 3; ++k) want.insert({v[3 * k], v[3 * k + 1], v[3 * k + 2]});
  CHECK(got == want);

  // ASCII without a line end after the last line: assimp parses it over the previous
  // line's text, here turning index 2 into 25. It gets a copy that ends in one.
  const Mesh noEol = loadMesh(writeFile("no_eol.ply", "ply\nformat ascii 1.0\n" + vertex + face +
                                                          "end_header\n0 0 0\n1 0 0\n0.5 1.25 0\n3 0 1 2"));
  REQUIRE(noEol.triangles.size() == 1);
  CHECK(noEol.positions.size() == 3);
}

TEST_CASE("positions beyond the coordinate limit after the transform are an error", "[mesh][bad_input][unit]") {
  const auto far = writeFile("far.obj", "v 2e12 0 0\nv 2e12 1 0\nv 2e12 0 1\nf 1 2 3\n");
  CHECK_THROWS_WITH(loadMesh(far), Contains(far + ": vertex 0 at (") &&
                                        Contains(") lies beyond the supported coordinate range (|x|, |y|, |z| <= 2^40 = "
                                                 "1.1e+12)"));
  const auto near1 = writeFile("near1.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  CHECK_NOTHROW(loadMesh(near1, {glm::translate(glm::mat4(1.0f), vec3(0, 0, 1e12f))}));
  CHECK_THROWS_WITH(loadMesh(near1, {glm::translate(glm::mat4(1.0f), vec3(0, 0, 2e12f))}),
                    Contains("after the transform lies beyond the supported coordinate range"));
}

TEST_CASE("inputTriangle maps triangles back to the numbering of the warning line", "[mesh][unit]") {
  const auto path = writeFile("map_degenerate.obj",
                              "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 0 0 1\n"
                              "f 1 2 3\nf 1 2 4\nf 1 2 5\nf 2 2 3\nf 2 4 3\n");
  const Mesh m = loadMesh(path, {glm::mat4(1.0f), false, false});
  REQUIRE(m.triangles.size() == 3);
  CHECK(m.inputTriangle == std::vector<uint32_t>{0, 2, 4});
  CHECK(m.bytes() == m.positions.size() * 2 * sizeof(vec3) + 3 * sizeof(glm::uvec3) + 3 * sizeof(uint32_t));
}

TEST_CASE("a mesh far from the origin gets its own frame: same positions wherever it sits", "[mesh][unit]") {
  const auto path = writeFile("tent_far.obj", kTent);
  const Mesh base = loadMesh(path);
  for (const double d : {1e2, 1e4, 1e6}) {
    CAPTURE(d);
    const vec3 t(float(d), float(-d), float(d));
    const Mesh m = loadMesh(path, {glm::translate(glm::mat4(1.0f), t), false});
    CHECK(m.origin == dvec3(t) + base.origin);
    CHECK(m.positions == base.positions);  // bit for bit
    for (size_t v = 0; v < m.positions.size(); ++v) CHECK(m.world(v) == dvec3(t) + base.world(v));
  }
  // A mesh whose own coordinates lie far away is recentred: the origin moves to its box
  // centre (in double), the world positions stay, and the positions are the ones the
  // mesh has anywhere else.
  Mesh far = base;
  for (vec3& p : far.positions) p += vec3(3e5f, 0.0f, -7e5f);
  const Mesh kept = far;
  recentreMesh(far);
  CHECK(far.origin == base.origin + dvec3(3e5, 0.0, -7e5));
  CHECK(far.positions == base.positions);
  float extent = 0;
  for (size_t v = 0; v < far.positions.size(); ++v) {
    CHECK(far.world(v) == kept.world(v));
    extent = std::max({extent, std::abs(far.positions[v].x), std::abs(far.positions[v].z)});
  }
  CHECK(extent < 10.0f);
  Mesh near0 = base;
  recentreMesh(near0);  // already recentred: unchanged
  CHECK(near0.origin == base.origin);
  CHECK(near0.positions == base.positions);
}

TEST_CASE("the frame's origin is the box centre in double: the same mesh authored anywhere gets the same positions",
          "[mesh][translation][unit]") {
  // The tent at the origin, and written into its file at offsets that keep its
  // coordinates floats (non-powers of two; the second is far, the third not a float
  // grid point of the old power-of-two rule).
  const Mesh base = loadMesh(writeFile("tent_cov.obj", kTent));
  CHECK(base.origin == dvec3(0.5, 0.5, 1.0));  // the box [0,1]x[0,1]x[0,2]'s centre
  for (const vec3 t : {vec3(100, 0, 0), vec3(12345.678f, -271.828f, 0.5f), vec3(-3.3f, 6.6f, 1e6f)}) {
    CAPTURE(t.x, t.y, t.z);
    std::string obj;
    for (const vec3& p : {vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 2)}) {
      REQUIRE(dvec3(p + t) == dvec3(p) + dvec3(t));  // the moved file is the mesh moved exactly
      obj += fmt::format("v {} {} {}\n", p.x + t.x, p.y + t.y, p.z + t.z);
    }
    obj += std::string(kTent).substr(std::string(kTent).find("vt"));
    const Mesh m = loadMesh(writeFile("tent_cov_moved.obj", obj));
    CHECK(m.origin == base.origin + dvec3(t));
    CHECK(m.positions == base.positions);  // bit for bit
  }
  // A mesh symmetric about the world's origin keeps its positions, bit for bit.
  const Mesh sym = loadMesh(writeFile("sym.obj", "v -1 -0.3 -2\nv 1 -0.3 2\nv -1 0.3 2\nv 1 0.3 -2\nf 1 2 3\nf 1 4 2\n"));
  CHECK(sym.origin == dvec3(0.0));
  CHECK(sym.positions == std::vector<vec3>{vec3(-1, -0.3f, -2), vec3(1, -0.3f, 2), vec3(-1, 0.3f, 2), vec3(1, 0.3f, -2)});
  // The centre is not rounded to a float: 2^24 + 1 is none.
  const Mesh odd = loadMesh(writeFile("odd.obj", "v 16777216 0 0\nv 16777218 0 0\nv 16777216 1 0\nf 1 2 3\n"));
  CHECK(odd.origin == dvec3(16777217.0, 0.5, 0.0));
  CHECK(odd.positions == std::vector<vec3>{vec3(-1, -0.5f, 0), vec3(1, -0.5f, 0), vec3(-1, 0.5f, 0)});
}

namespace {

// The quad's glTF with its mesh at the end of a chain of `levels` nodes; `extra` is
// appended to the node list (more nodes, or a node that closes a cycle).
std::string chainGltfJson(int levels, const std::string& extra = "") {
  std::string nodes;
  for (int k = 0; k + 1 < levels; ++k) nodes += fmt::format(R"({{"children": [{}]}}, )", k + 1);
  nodes += R"({"mesh": 0})" + extra;
  std::string json = quadGltfJson("data:application/octet-stream;base64," + test::base64(quadBuffer()));
  const std::string one = R"("nodes": [{"mesh": 0}])";
  json.replace(json.find(one), one.size(), R"("nodes": [)" + nodes + "]");
  return json;
}

// COLLADA of one triangle instanced at the end of `levels` nested <node> elements.
std::string chainDae(int levels) {
  std::string s =
      R"(<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<library_geometries><geometry id="g"><mesh>
<source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>
<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="s">)";
  for (int k = 0; k < levels; ++k) s += "<node>";
  s += R"(<instance_geometry url="#g"/>)";
  for (int k = 0; k < levels; ++k) s += "</node>";
  return s + R"(</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#s"/></scene></COLLADA>
)";
}

std::string glbOf(std::string json, const std::string& binChunk) {
  while (json.size() % 4) json += ' ';
  auto u32 = [](uint32_t v) { return bytesOf(&v, 4); };
  const std::string body = u32(uint32_t(json.size())) + "JSON" + json + binChunk;
  return "glTF" + u32(2) + u32(uint32_t(12 + body.size())) + body;
}

}  // namespace

TEST_CASE("node hierarchies deeper than 1000 levels are refused before assimp recurses into them",
          "[mesh][bad_input]") {
  // 20 000 levels overflowed assimp's recursion (exit 139); 1000 load.
  CHECK(loadMesh(writeFile("chain1000.gltf", chainGltfJson(1000))).triangles.size() == 2);
  const auto gltf = writeFile("chain20000.gltf", chainGltfJson(20000));
  CHECK_THROWS_MATCHES(loadMesh(gltf), Error,
                       Catch::Matchers::Message(gltf + ": cannot load mesh (glTF nodes (from node 0) nested 20000 "
                                                       "levels deep; at most 1000 are supported, as assimp reads each "
                                                       "level recursively)"));
  const auto glb = writeFile("chain20000.glb", glbOf(chainGltfJson(20000), ""));
  CHECK_THROWS_WITH(loadMesh(glb), Contains(glb + ": cannot load mesh (glTF nodes (from node 0) nested 20000 levels"));
  // A node among its own descendants would recurse forever.
  const auto cycle = writeFile("cycle.gltf", chainGltfJson(3, R"(, {"children": [4]}, {"children": [3]})"));
  CHECK_THROWS_WITH(loadMesh(cycle), Contains(cycle + ": cannot load mesh (glTF node 3 is among its own descendants)"));
  // Nested JSON arrays (RapidJSON parses them recursively).
  std::string deepJson = chainGltfJson(1);
  deepJson.insert(deepJson.rfind('}'), R"(, "extras": )" + std::string(5000, '[') + std::string(5000, ']'));
  const auto arrays = writeFile("arrays.gltf", deepJson);
  CHECK_THROWS_WITH(loadMesh(arrays), Contains(arrays + ": cannot load mesh (glTF JSON arrays and objects nested 5001 "
                                                        "levels deep"));

  CHECK(loadMesh(writeFile("chain1000.dae", chainDae(1000))).triangles.size() == 1);
  const auto dae = writeFile("chain20000.dae", chainDae(20000));
  CHECK_THROWS_MATCHES(loadMesh(dae), Error,
                       Catch::Matchers::Message(dae + ": cannot load mesh (XML <node> elements nested 20000 levels "
                                                      "deep; at most 1000 are supported, as assimp reads each level "
                                                      "recursively)"));
}

TEST_CASE("every file a mesh pulls in must be a regular file: a FIFO is refused before it is opened", "[mesh][bad_input][unit]") {
  const auto dir = test::scratchDir("mesh");
  const std::string fifo = (dir / "pulled.fifo").string();
  if (!std::filesystem::exists(fifo)) REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  // Both blocked forever in assimp's fopen.
  const auto obj = writeFile("fifo_mtl.obj", "mtllib pulled.fifo\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
  CHECK_THROWS_MATCHES(loadMesh(obj), Error, Catch::Matchers::Message(obj + ": " + fifo + ": not a regular file"));
  const auto gltf = writeFile("fifo_buffer.gltf", quadGltfJson("pulled.fifo"));
  CHECK_THROWS_MATCHES(loadMesh(gltf), Error, Catch::Matchers::Message(gltf + ": " + fifo + ": not a regular file"));
  // A missing material library is still only a warning of assimp's; a regular buffer file loads.
  CHECK(loadMesh(writeFile("missing_mtl.obj", "mtllib nosuch.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"))
            .triangles.size() == 1);
  std::ofstream(dir / "quad.bin", std::ios::binary) << quadBuffer();
  CHECK(loadMesh(writeFile("file_buffer.gltf", quadGltfJson("quad.bin"))).triangles.size() == 2);
}

TEST_CASE("GLB chunk lengths beyond the end of the file are refused before assimp allocates them",
          "[mesh][bad_input][unit]") {
  // A JSON chunk claiming 0x7FFFFFF0 bytes made assimp allocate 2.2 GB (17 s) before it failed.
  std::string glb = quadGlb();
  const uint32_t lie = 0x7FFFFFF0;
  glb.replace(12, 4, bytesOf(&lie, 4));
  const auto json = writeFile("lying_json.glb", glb);
  CHECK_THROWS_MATCHES(loadMesh(json), Error,
                       Catch::Matchers::Message(fmt::format("{}: cannot load mesh (GLB chunk 'JSON' at byte 12 claims "
                                                            "2147483632 bytes, the file has {} after its header)",
                                                            json, glb.size() - 20)));
  // The binary chunk, after the JSON.
  glb = quadGlb();
  uint32_t jsonLength;
  std::memcpy(&jsonLength, glb.data() + 12, 4);
  const size_t bin = 20 + jsonLength;
  glb.replace(bin, 4, bytesOf(&lie, 4));
  const auto body = writeFile("lying_bin.glb", glb);
  CHECK_THROWS_WITH(loadMesh(body), Contains(fmt::format("{}: cannot load mesh (GLB chunk 'BIN?' at byte {} claims "
                                                         "2147483632 bytes",
                                                         body, bin)));
  // The header's total length.
  glb = quadGlb();
  glb.replace(8, 4, bytesOf(&lie, 4));
  const auto total = writeFile("lying_total.glb", glb);
  CHECK_THROWS_WITH(loadMesh(total), Contains(total + ": cannot load mesh (GLB header claims 2147483632 bytes"));
}
