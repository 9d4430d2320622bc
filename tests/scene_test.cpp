#include "core/error.h"
#include "core/scene.h"
#include "core/triangle.h"
#include "render/accel_options.h"
#include "test_util.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <tuple>

using namespace oblong;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

namespace {

// A scratch folder with a quad with uvs, one without, and a 4x2 8-bit height map.
fs::path sceneDir() {
  const fs::path dir = test::scratchDir("scene");
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "quad.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                     "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  std::ofstream(dir / "nouv.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  test::writeGray((dir / "map.png").string(), 4, 2, {0, 0.2f, 0.4f, 0.6f, 0.8f, 1, 1, 1}, OIIO::TypeDesc::UINT8);
  return dir;
}

std::string writeScene(const fs::path& file, const std::string& text) {
  std::ofstream(file) << text;
  return file.string();
}

const char* kValid = R"({
  // comments are allowed
  "image": {"width": 320, "height": 200},
  "camera": {"from": [0, 1, 4], "to": [0, 0, 0], "up": [0, 1, 0], "fov": 35},
  "lights": [{"type": "directional", "direction": [0, -2, 0], "intensity": 2.5},
             {"type": "point", "position": [1, 2, 3], "intensity": [1, 0.5, 0.25]}],
  "meshes": [
    {"file": "../quad.obj", "albedo": [0.1, 0.2, 0.3],
     "transform": {"scale": 2, "rotate": [90, 0, 0, 1], "translate": [10, 0, 0]},
     "displacement": {"map": "../map.png", "scale": 0.5, "bias": -0.25, "tiling": [2, 3], "flip_v": true}},
    {"file": "../quad.obj", "transform": {"matrix": [2, 0, 0, 1,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]},
     "displacement": {"map": "../sub/../map.png", "flip_v": true, "tiling": 4}},
    {"file": "../quad.obj", "displacement": {"map": "../map.png"}},
    {"file": "../nouv.obj"}
  ],
  "strategies": {"range": {"name": "rmip", "resolution": 64, "lod": false},
                 "inverter": {"name": "cubic"}, "splitter": {"name": "midpoint3d", "depth": 3},
                 "marching_scale": 2.5, "inversion_in_traversal": false, "stack_depth": 16}
})";

bool near(const vec3& a, const vec3& b) { return glm::length(a - b) < 1e-5f; }

}  // namespace

TEST_CASE("a valid scene round trip", "[scene][unit]") {
  const fs::path dir = sceneDir();
  // The scene lives in sub/: every relative path is resolved against sub/, not the cwd.
  const std::string path = writeScene(dir / "sub" / "valid.json", kValid);
  const Scene s = loadScene(path);
  CHECK(s.path == path);
  CHECK(s.imageSize == ivec2(320, 200));
  CHECK(s.camera.from == vec3(0, 1, 4));
  CHECK(s.camera.fovY == 35.0f);

  REQUIRE(s.lights.size() == 2);
  CHECK(s.lights[0].type == Light::Type::Directional);
  CHECK(s.lights[0].direction == vec3(0, -1, 0));  // normalised
  CHECK(s.lights[0].intensity == vec3(2.5f));
  CHECK(s.lights[1].type == Light::Type::Point);
  CHECK(s.lights[1].position == vec3(1, 2, 3));
  CHECK(s.lights[1].intensity == vec3(1, 0.5f, 0.25f));

  REQUIRE(s.meshes.size() == 4);
  const SceneMesh& a = s.meshes[0];
  CHECK(a.mesh.name == (dir / "quad.obj").lexically_normal().string());
  CHECK(a.albedo == vec3(0.1f, 0.2f, 0.3f));
  REQUIRE(a.displacement);
  CHECK(a.displacement->scale == 0.5f);
  CHECK(a.displacement->bias == -0.25f);
  CHECK(a.displacement->tiling == vec2(2, 3));
  REQUIRE(a.displacement->map);
  CHECK(a.displacement->map->width() == 4);
  CHECK(a.displacement->map->height() == 2);
  CHECK(a.displacement->map->atUnchecked(0, 0) == Approx(0.8f).margin(0.5 / 255));  // flipped: last row first
  // Scale 2, then 90 degrees about z, then translate: (1,0,0) -> (2,0,0) -> (0,2,0) -> (10,2,0).
  for (size_t v = 0; v < a.mesh.positions.size(); ++v) {
    const vec3 p(s.meshes[2].mesh.world(v));  // untransformed copy
    CHECK(near(vec3(a.mesh.world(v)), vec3(10 - 2 * p.y, 2 * p.x, 2 * p.z)));
    CHECK(near(a.mesh.normals[v], vec3(0, 0, 1)));
  }
  // Row-major matrix: x' = 2x + 1.
  const SceneMesh& b = s.meshes[1];
  for (size_t v = 0; v < b.mesh.positions.size(); ++v) {
    const vec3 p(s.meshes[2].mesh.world(v));
    CHECK(near(vec3(b.mesh.world(v)), vec3(2 * p.x + 1, p.y, p.z)));
  }
  CHECK(b.displacement->tiling == vec2(4, 4));
  CHECK(b.albedo == vec3(0.7f));  // default

  // Defaults of the third mesh's displacement.
  const Displacement& c = *s.meshes[2].displacement;
  CHECK(c.scale == 1.0f);
  CHECK(c.bias == 0.0f);
  CHECK(c.tiling == vec2(1, 1));
  CHECK(c.map->atUnchecked(0, 0) == 0.0f);  // not flipped

  CHECK_FALSE(s.meshes[3].displacement);
  CHECK_FALSE(s.meshes[3].mesh.hasUVs());  // fine: it is not displaced

  CHECK(s.range.name == "rmip");
  CHECK(s.range.params == nlohmann::json({{"resolution", 64}, {"lod", false}}));
  CHECK(s.range.where == path + ": strategies.range");
  CHECK(s.inverter.name == "cubic");
  CHECK(s.inverter.params.empty());
  CHECK(s.inverter.where == path + ": strategies.inverter");
  CHECK(s.splitter.name == "midpoint3d");
  CHECK(s.splitter.params == nlohmann::json({{"depth", 3}}));
  CHECK(s.splitter.where == path + ": strategies.splitter");
  CHECK(s.marchingScale == 2.5f);
  CHECK_FALSE(s.inversionInTraversal);
  CHECK(s.stackDepth == 16);
}

TEST_CASE("a map used by several meshes is loaded once", "[scene][unit]") {
  const fs::path dir = sceneDir();
  const Scene s = loadScene(writeScene(dir / "sub" / "shared.json", kValid));
  // "../map.png" and "../sub/../map.png" with flip_v: one map; without flip_v: another.
  CHECK(s.meshes[0].displacement->map == s.meshes[1].displacement->map);
  CHECK(s.meshes[0].displacement->map != s.meshes[2].displacement->map);
  CHECK(s.meshes[0].displacement->map.use_count() == 2);  // the two meshes; no cache keeps it
}

TEST_CASE("defaults: a scene with only a mesh", "[scene][unit]") {
  const fs::path dir = sceneDir();
  const std::string path = writeScene(dir / "minimal.json", R"({"meshes": [{"file": "quad.obj"}]})");
  const Scene s = loadScene(path);
  CHECK(s.imageSize == ivec2(640, 480));
  CHECK(s.camera.fovY == 40.0f);
  CHECK(s.lights.empty());
  CHECK(s.range.name == "rmip");
  CHECK(s.range.params.empty());
  CHECK(s.inverter.name == "newton");
  CHECK(s.inverter.params.empty());
  CHECK(s.splitter.name == "midpoint2d");
  CHECK(s.splitter.params.empty());
  CHECK(s.marchingScale == 4.0f);
  CHECK(s.inversionInTraversal);
  CHECK(s.stackDepth == OBLONG_TRAV_STACK_DEFAULT);
  REQUIRE(s.meshes.size() == 1);
  CHECK_FALSE(s.meshes[0].displacement);
  // Only some strategy keys: the others keep their defaults.
  const Scene t = loadScene(writeScene(dir / "partial.json",
                                       R"({"meshes": [{"file": "quad.obj"}], "strategies": {"marching_scale": 8}})"));
  CHECK(t.marchingScale == 8.0f);
  CHECK(t.range.name == "rmip");
  CHECK(t.inverter.name == "newton");
  CHECK(t.splitter.name == "midpoint2d");
}

TEST_CASE("strategies.lod \"cone\" and lod_bias: a lambda per ray, displacements at level 0", "[scene][lod][unit]") {
  const fs::path dir = sceneDir();
  const Scene s = loadScene(writeScene(dir / "cone.json", R"({"meshes": [
    {"shape": {"type": "plane"}, "displacement": {"map": "map.png"}}],
    "strategies": {"lod": "cone", "lod_bias": -1.5}})"));
  CHECK(s.lodCone);
  CHECK(s.lodBias == -1.5f);
  CHECK(!s.lod);
  CHECK(!s.meshes[0].displacement->level0);  // nothing moved: the intersectors build the levels
  CHECK(traversalConfigOf(s).lodPerRay);
}

TEST_CASE("procedural shapes stand in for mesh files", "[scene][unit]") {
  const fs::path dir = sceneDir();
  const Scene s = loadScene(writeScene(dir / "shapes.json", R"({"meshes": [
    {"shape": {"type": "plane", "size": [4, 2], "segments": [3, 2], "uv": [0.25, 0, 0.75, 2]},
     "displacement": {"map": "map.png"}},
    {"shape": {"type": "sphere", "radius": 2, "segments": [8, 4]}, "transform": {"translate": [0, 5, 0]}},
    {"shape": {"type": "torus", "major_radius": 1.5, "minor_radius": 0.5, "segments": 6}},
    {"shape": {"type": "plane"}}
  ]})"));
  REQUIRE(s.meshes.size() == 4);
  const Mesh& plane = s.meshes[0].mesh;
  CHECK(plane.name == "<procedural plane>");
  CHECK(plane.triangles.size() == 2 * 3 * 2);
  AABB box;
  for (const vec3& p : plane.positions) box.extend(p);
  CHECK(box.lo == vec3(-2, 0, -1));
  CHECK(box.hi == vec3(2, 0, 1));
  vec2 uvLo(kInfinity), uvHi(-kInfinity);
  for (const vec2& t : plane.uvs) uvLo = glm::min(uvLo, t), uvHi = glm::max(uvHi, t);
  CHECK(uvLo == vec2(0.25f, 0.0f));
  CHECK(uvHi == vec2(0.75f, 2.0f));
  CHECK(s.meshes[0].displacement);

  const Mesh& sphere = s.meshes[1].mesh;
  CHECK(sphere.triangles.size() == 2 * 8 * 3);
  for (size_t v = 0; v < sphere.positions.size(); ++v)
    CHECK(glm::length(vec3(sphere.world(v)) - vec3(0, 5, 0)) == Approx(2.0f).epsilon(1e-6));
  CHECK(s.meshes[2].mesh.triangles.size() == 2 * 6 * 6);
  CHECK(s.meshes[3].mesh.triangles.size() == 2);
}

TEST_CASE("bad scenes give errors naming the file and the key", "[scene][unit]") {
  const fs::path dir = sceneDir();
  const std::string mesh = R"("meshes": [{"file": "quad.obj"}])";
  const std::string disp = R"({"meshes": [{"file": "quad.obj", "displacement": {"map": "map.png", )";
  struct Case {
    const char* name;
    std::string text;
    std::vector<std::string> expect;  // substrings of the message besides the file name
  } cases[] = {
      {"malformed JSON", R"({"meshes": [})", {"malformed JSON", "parse error"}},
      {"top level not an object", "[1, 2]", {"must be an object"}},
      {"unknown top-level key", "{" + mesh + R"(, "meshs": []})", {"unknown key 'meshs'"}},
      {"unknown mesh key", R"({"meshes": [{"file": "quad.obj", "displacment": {}}]})",
       {"unknown key 'meshes[0].displacment'"}},
      {"unknown key in a later mesh is found first",
       R"({"meshes": [{"file": "missing.obj"}, {"file": "quad.obj", "albedoo": [1,1,1]}]})",
       {"unknown key 'meshes[1].albedoo'"}},
      {"unknown displacement key", disp + R"("scael": 2}}]})", {"unknown key 'meshes[0].displacement.scael'"}},
      {"unknown transform key", R"({"meshes": [{"file": "quad.obj", "transform": {"rotation": [1,0,0,1]}}]})",
       {"unknown key 'meshes[0].transform.rotation'"}},
      {"unknown camera key", "{" + mesh + R"(, "camera": {"fovy": 30}})", {"unknown key 'camera.fovy'"}},
      {"point-light key on a directional light",
       "{" + mesh + R"(, "lights": [{"type": "directional", "direction": [0,-1,0], "position": [0,0,0]}]})",
       {"unknown key 'lights[0].position'"}},
      {"unknown strategy slot", "{" + mesh + R"(, "strategies": {"integrator": {"name": "path"}}})",
       {"unknown key 'strategies.integrator'"}},
      {"inverter without name", "{" + mesh + R"(, "strategies": {"inverter": {"iterations": 4}}})",
       {"strategies.inverter.name", "missing"}},
      {"splitter not an object", "{" + mesh + R"(, "strategies": {"splitter": "midpoint2d"}})",
       {"strategies.splitter", "must be an object"}},
      {"baseline not an object", "{" + mesh + R"(, "strategies": {"baseline": "tfdm"}})",
       {"strategies.baseline", "must be an object"}},
      {"baseline without name", "{" + mesh + R"(, "strategies": {"baseline": {"boxes": "world"}}})",
       {"strategies.baseline.name", "missing"}},
      {"zero marching scale", "{" + mesh + R"(, "strategies": {"marching_scale": 0}})",
       {"strategies.marching_scale", "positive"}},
      {"negative marching scale", "{" + mesh + R"(, "strategies": {"marching_scale": -2}})",
       {"strategies.marching_scale", "positive"}},
      {"marching scale as a string", "{" + mesh + R"(, "strategies": {"marching_scale": "4"}})",
       {"strategies.marching_scale", "must be a number"}},
      {"stack depth too small", "{" + mesh + R"(, "strategies": {"stack_depth": 1}})",
       {"strategies.stack_depth", "integer from 2 to 128"}},
      {"stack depth too large", "{" + mesh + R"(, "strategies": {"stack_depth": 129}})",
       {"strategies.stack_depth", "integer from 2 to 128"}},
      {"stack depth not an integer", "{" + mesh + R"(, "strategies": {"stack_depth": 8.5}})",
       {"strategies.stack_depth", "integer from 2 to 128"}},
      {"inversion flag not a bool", "{" + mesh + R"(, "strategies": {"inversion_in_traversal": 1}})",
       {"strategies.inversion_in_traversal", "true or false"}},
      {"image too large", "{" + mesh + R"(, "image": {"width": 1048576, "height": 1048576}})",
       {"image", "2^26"}},
      {"file and shape", R"({"meshes": [{"file": "quad.obj", "shape": {"type": "plane"}}]})",
       {"meshes[0]", "either 'file' or 'shape'"}},
      {"shape without type", R"({"meshes": [{"shape": {"size": 2}}]})", {"meshes[0].shape.type", "missing"}},
      {"unknown shape", R"({"meshes": [{"shape": {"type": "cube"}}]})", {"meshes[0].shape.type", "cube"}},
      {"sphere key on a plane", R"({"meshes": [{"shape": {"type": "plane", "radius": 2}}]})",
       {"unknown key 'meshes[0].shape.radius'", "plane takes size, segments, uv"}},
      {"negative plane size", R"({"meshes": [{"shape": {"type": "plane", "size": [2, -1]}}]})",
       {"meshes[0].shape.size", "positive"}},
      {"zero sphere radius", R"({"meshes": [{"shape": {"type": "sphere", "radius": 0}}]})",
       {"meshes[0].shape.radius", "positive"}},
      {"too few sphere segments", R"({"meshes": [{"shape": {"type": "sphere", "segments": [2, 8]}}]})",
       {"meshes[0].shape.segments", "at least [3, 2]"}},
      {"fractional segments", R"({"meshes": [{"shape": {"type": "plane", "segments": 2.5}}]})",
       {"meshes[0].shape.segments", "positive integer"}},
      {"huge segments", R"({"meshes": [{"shape": {"type": "plane", "segments": [16384, 16384]}}]})",
       {"meshes[0].shape.segments", "more than the supported"}},
      {"segments beyond int64", R"({"meshes": [{"shape": {"type": "plane", "segments": 18446744073709551615}}]})",
       {"meshes[0].shape.segments", "positive integer"}},
      {"torus radii swapped", R"({"meshes": [{"shape": {"type": "torus", "major_radius": 0.2, "minor_radius": 1}}]})",
       {"meshes[0].shape", "minor_radius < major_radius"}},
      {"inverted plane uv range", R"({"meshes": [{"shape": {"type": "plane", "uv": [1, 0, 0, 1]}}]})",
       {"meshes[0].shape.uv", "u0 < u1"}},
      {"negative tiling", disp + R"("tiling": -2}}]})", {"meshes[0].displacement.tiling", "positive"}},
      {"tiling overflowing the sample grid", disp + R"("tiling": 1e30}}]})",
       {"meshes[0].displacement.tiling", "2^30"}},
      {"heights overflowing a float", disp + R"("scale": 3e38, "bias": 2}}]})",
       {"meshes[0].displacement.scale", "overflow"}},
      {"zero image width", "{" + mesh + R"(, "image": {"width": 0}})", {"image.width", "positive integer"}},
      {"negative image height", "{" + mesh + R"(, "image": {"height": -4}})", {"image.height", "positive integer"}},
      {"fractional image width", "{" + mesh + R"(, "image": {"width": 64.5}})", {"image.width"}},
      {"image width as a string", "{" + mesh + R"(, "image": {"width": "64"}})", {"image.width"}},
      {"image not an object", "{" + mesh + R"(, "image": 64})", {"image: must be an object"}},
      {"fov out of range", "{" + mesh + R"(, "camera": {"fov": 180}})", {"camera.fov", "(0, 180)"}},
      {"fov wrong type", "{" + mesh + R"(, "camera": {"fov": "wide"}})", {"camera.fov", "must be a number"}},
      {"number beyond double", "{" + mesh + R"(, "camera": {"fov": 1e400}})", {"malformed JSON", "1e400"}},
      {"number beyond float", "{" + mesh + R"(, "camera": {"from": [1e39, 0, 0]}})", {"camera.from[0]", "finite"}},
      {"camera from == to", "{" + mesh + R"(, "camera": {"from": [1,1,1], "to": [1,1,1]}})",
       {"camera", "no view direction"}},
      {"up parallel to view", "{" + mesh + R"(, "camera": {"from": [0,5,0], "to": [0,0,0]}})",
       {"camera.up", "parallel"}},
      {"vector of wrong length", "{" + mesh + R"(, "camera": {"from": [0,5]}})", {"camera.from", "3 numbers"}},
      {"vector with a string", "{" + mesh + R"(, "camera": {"to": [0,"a",0]}})", {"camera.to[1]", "number"}},
      {"lights not an array", "{" + mesh + R"(, "lights": {"type": "point"}})", {"lights", "must be an array"}},
      {"unknown light type", "{" + mesh + R"(, "lights": [{"type": "spot"}]})", {"lights[0].type", "spot"}},
      {"light without type", "{" + mesh + R"(, "lights": [{"direction": [0,-1,0]}]})",
       {"lights[0].type", "missing"}},
      {"zero light direction", "{" + mesh + R"(, "lights": [{"type": "directional", "direction": [0,0,0]}]})",
       {"lights[0].direction", "zero"}},
      {"negative intensity", "{" + mesh + R"(, "lights": [{"type": "point", "position": [0,0,0], "intensity": -1}]})",
       {"lights[0].intensity", "negative"}},
      {"point light without position", "{" + mesh + R"(, "lights": [{"type": "point"}]})",
       {"lights[0].position", "missing"}},
      {"no meshes", R"({"camera": {}})", {"meshes", "missing"}},
      {"empty meshes", R"({"meshes": []})", {"meshes", "empty"}},
      {"mesh without file", R"({"meshes": [{"albedo": [1,1,1]}]})", {"meshes[0].file", "missing", "'shape'"}},
      {"mesh file not a string", R"({"meshes": [{"file": 3}]})", {"meshes[0].file", "string"}},
      {"mesh file missing", R"({"meshes": [{"file": "nope.obj"}]})",
       {"meshes[0].file", (dir / "nope.obj").string() + ": file not found"}},
      {"albedo out of range", R"({"meshes": [{"file": "quad.obj", "albedo": [2,0,0]}]})", {"meshes[0].albedo"}},
      {"displacement without map", R"({"meshes": [{"file": "quad.obj", "displacement": {"scale": 1}}]})",
       {"meshes[0].displacement.map", "missing"}},
      {"map file missing", R"({"meshes": [{"file": "quad.obj", "displacement": {"map": "nope.png"}}]})",
       {"meshes[0].displacement.map", (dir / "nope.png").string()}},
      {"zero tiling", disp + R"("tiling": 0}}]})", {"meshes[0].displacement.tiling", "positive"}},
      {"zero tiling in v", disp + R"("tiling": [1, 0]}}]})", {"meshes[0].displacement.tiling"}},
      {"zero displacement scale", disp + R"("scale": 0}}]})", {"meshes[0].displacement.scale"}},
      {"flip_v not a bool", disp + R"("flip_v": "yes"}}]})", {"meshes[0].displacement.flip_v"}},
      {"displaced mesh without uvs", R"({"meshes": [{"file": "nouv.obj", "displacement": {"map": "map.png"}}]})",
       {"meshes[0].file", "no texture coordinates"}},
      {"matrix of 15 numbers", R"({"meshes": [{"file": "quad.obj", "transform": {"matrix": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0]}}]})",
       {"meshes[0].transform.matrix", "16 numbers"}},
      {"projective matrix", R"({"meshes": [{"file": "quad.obj", "transform": {"matrix": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,1,1]}}]})",
       {"meshes[0].transform.matrix", "affine"}},
      {"singular matrix", R"({"meshes": [{"file": "quad.obj", "transform": {"matrix": [1,0,0,0,0,0,0,0,0,0,1,0,0,0,0,1]}}]})",
       {"meshes[0].transform.matrix", "singular"}},
      {"matrix with translate", R"({"meshes": [{"file": "quad.obj", "transform": {"matrix": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1], "translate": [1,0,0]}}]})",
       {"meshes[0].transform.matrix", "combined"}},
      {"zero scale", R"({"meshes": [{"file": "quad.obj", "transform": {"scale": [1,0,1]}}]})",
       {"meshes[0].transform.scale", "zero"}},
      {"zero rotation axis", R"({"meshes": [{"file": "quad.obj", "transform": {"rotate": [30,0,0,0]}}]})",
       {"meshes[0].transform.rotate", "axis"}},
      {"strategy without name", "{" + mesh + R"(, "strategies": {"range": {"resolution": 4}}})",
       {"strategies.range.name", "missing"}},
      {"strategy with empty name", "{" + mesh + R"(, "strategies": {"range": {"name": ""}}})",
       {"strategies.range.name", "non-empty string"}},
      {"strategy name not a string", "{" + mesh + R"(, "strategies": {"range": {"name": 3}}})",
       {"strategies.range.name"}},
      {"duplicate top-level key", "{" + mesh + ", " + mesh + "}", {"duplicate key 'meshes'"}},
      {"duplicate key in a mesh's displacement",
       R"({"meshes": [{"file": "quad.obj"}, {"file": "quad.obj", "displacement": {"map": "map.png", "scale": 1, "scale": 2}}]})",
       {"duplicate key 'meshes[1].displacement.scale'"}},
      {"duplicate key in a light", "{" + mesh + R"(, "lights": [{"type": "point", "position": [0,0,0]},
         {"type": "point", "position": [1,1,1], "intensity": 1, "intensity": 2}]})",
       {"duplicate key 'lights[1].intensity'"}},
      {"duplicate strategy parameter", "{" + mesh + R"(, "strategies": {"range": {"name": "rmip", "resolution": 8, "resolution": 16}}})",
       {"duplicate key 'strategies.range.resolution'"}},
      {"normals neither file nor smooth", R"({"meshes": [{"file": "quad.obj", "normals": "flat"}]})",
       {"meshes[0].normals", "must be \"file\" or \"smooth\", got \"flat\""}},
      {"camera beyond the coordinate range", "{" + mesh + R"(, "camera": {"from": [0, 5e18, 5e18]}})",
       {"camera.from: [0, 5e+18, 5e+18] lies beyond the supported coordinate range"}},
      {"look-at point beyond the coordinate range", "{" + mesh + R"(, "camera": {"to": [2e12, 0, 0]}})",
       {"camera.to", "coordinate range"}},
      {"mesh beyond the coordinate range after the transform",
       R"({"meshes": [{"file": "quad.obj", "transform": {"translate": [0, 0, 3e12]}}]})",
       {"meshes[0].file", "after the transform lies beyond the supported coordinate range"}},
      {"displaced points beyond the coordinate range", disp + R"("scale": 2e12}}]})",
       {"meshes[0].displacement.scale", "displaced points reach 2e+12", "map.png", "scale 2000000000000",
        "beyond the supported coordinate range 2^40"}},
  };
  for (const Case& c : cases) {
    DYNAMIC_SECTION(c.name) {
      const std::string path = writeScene(dir / "bad.json", c.text);
      INFO(c.text);
      try {
        loadScene(path);
        FAIL("no error");
      } catch (const Error& e) {
        const std::string msg = e.what();
        INFO(msg);
        CHECK(msg.rfind(path + ": ", 0) == 0);  // starts with the scene file
        CHECK(msg.find('\n') == std::string::npos);  // one line
        for (const auto& s : c.expect) CHECK_THAT(msg, Contains(s));
      }
    }
  }
}

TEST_CASE("normals: \"smooth\" replaces the file's normals, \"file\" keeps them", "[scene][unit]") {
  const fs::path dir = sceneDir();
  // Two faces at a right angle, each with its own normal: split vertices on the edge.
  std::ofstream(dir / "fold.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                     "vn 0 0 1\nvn 0 1 0\nf 1/1/1 2/2/1 3/3/1\nf 1/1/2 4/3/2 2/2/2\n";
  const Scene s = loadScene(writeScene(dir / "normals.json", R"({"meshes": [
    {"file": "fold.obj", "displacement": {"map": "map.png"}},
    {"file": "fold.obj", "normals": "file", "displacement": {"map": "map.png"}},
    {"file": "fold.obj", "normals": "smooth", "displacement": {"map": "map.png"}}]})"));
  REQUIRE(s.meshes.size() == 3);
  CHECK(s.meshes[0].mesh.normals == s.meshes[1].mesh.normals);  // "file" is the default
  for (int k = 0; k < 2; ++k) {
    const Mesh& m = s.meshes[size_t(k) + 1].mesh;
    std::map<std::tuple<float, float, float>, std::set<std::tuple<float, float, float>>> byPosition;
    for (size_t v = 0; v < m.positions.size(); ++v) {
      const vec3 p(m.world(v));  // the file's coordinates (positions are in the mesh's frame)
      byPosition[{p.x, p.y, p.z}].insert({m.normals[v].x, m.normals[v].y, m.normals[v].z});
    }
    const auto& edge = byPosition.at({0.0f, 0.0f, 0.0f});
    CHECK(edge.size() == (k == 0 ? 2u : 1u));  // the file's two normals, or one shared one
  }
}

TEST_CASE("a map with huge heights is refused naming the map, the scale and the limit", "[scene][unit]") {
  const fs::path dir = sceneDir();
  // A texel of 1e20: its spike overflowed the traversal's float products.
  test::writeGray((dir / "spike.tif").string(), 2, 2, {0, 0, 1e20f, 0}, OIIO::TypeDesc::FLOAT);
  const std::string path =
      writeScene(dir / "spike.json", R"({"meshes": [{"file": "quad.obj", "displacement": {"map": "spike.tif"}}]})");
  CHECK_THROWS_WITH(loadScene(path), Contains(path + ": meshes[0].displacement.scale: displaced points reach 1e+20") &&
                                         Contains((dir / "spike.tif").string() + " with H in [0, 1e+20], scale 1") &&
                                         Contains("beyond the supported coordinate range 2^40 = 1.1e+12"));
  // Within the limit: loads.
  CHECK_NOTHROW(loadScene(writeScene(
      dir / "tall.json", R"({"meshes": [{"file": "quad.obj", "displacement": {"map": "map.png", "scale": 1e12}}]})")));
}

TEST_CASE("missing scene file and non-finite numbers built in code", "[scene][unit]") {
  const fs::path dir = sceneDir();
  const std::string missing = (dir / "nope.json").string();
  CHECK_THROWS_MATCHES(loadScene(missing), Error, Catch::Matchers::Message(missing + ": file not found"));

  nlohmann::json j = nlohmann::json::parse(R"({"meshes": [{"file": "quad.obj"}], "camera": {"fov": 30}})");
  j["camera"]["fov"] = std::nan("");
  const std::string where = (dir / "code.json").string();
  CHECK_THROWS_WITH(parseScene(j, where), Contains(where + ": camera.fov: must be a finite number"));
  j["camera"]["fov"] = 30;
  j["camera"]["from"] = {0.0, INFINITY, 1.0};
  CHECK_THROWS_WITH(parseScene(j, where), Contains(where + ": camera.from[1]"));
}

TEST_CASE("every scene shipped in scenes/ loads with its meshes and maps", "[scene]") {
  // What each scene must contain: meshes (displaced or not), triangles, map sizes.
  struct Expect {
    std::vector<size_t> triangles;
    std::vector<ivec2> maps;  // one per mesh; (0,0) = not displaced
  };
  const std::map<std::string, Expect> expected = {
      {"asteroid.json", {{480}, {{1024, 1024}}}},
      {"asteroid_high.json", {{48000}, {{0, 0}}}},
      {"quad_tiled.json", {{2}, {{256, 256}}}},
      {"sphere.json", {{3968}, {{512, 256}}}},
      {"terrain.json", {{2 * 40 * 34}, {{403, 344}}}},
      {"mixed.json", {{480, 48000, 2}, {{1024, 1024}, {0, 0}, {0, 0}}}},
      // The paper-scale suite (scenes/README.md, "Paper-scale suite").
      {"paper/alien_sphere.json", {{2 * 32 * 15}, {{2048, 2048}}}},
      {"paper/terracotta_roof.json", {{128}, {{2048, 2048}}}},
      {"paper/diving_helmet.json", {{2 * 48 * 27}, {{4096, 4096}}}},
      {"paper/desert_tire.json", {{2 * 96 * 48}, {{4096, 4096}}}},
      {"paper/creature.json", {{2 * 256 * 100}, {{4096, 4096}}}},
  };
  std::set<std::string> seen;
  const fs::path root = fs::path(OBLONG_SOURCE_DIR) / "scenes";
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (entry.path().extension() != ".json") continue;
    const std::string name = fs::relative(entry.path(), root).generic_string();
    INFO(name);
    seen.insert(name);
    if (name == "terrain.json" && !fs::exists(root / "data/jacksboro_fault_dem.png"))
      FAIL("scenes/data/jacksboro_fault_dem.png is missing: the build makes it (target scene_data, scripts/scene_data.sh)");
    if (name.rfind("paper/", 0) == 0 && !fs::exists(root / "data/paper"))
      FAIL("scenes/data/paper/ is missing: the build makes them (target scene_data, scripts/scene_data.sh)");
    // The build's copy of a scene that names Debian's glmark2 data (tests/test_data.cmake):
    // a test reads only what the build or the test makes.
    const std::string file = test::shippedScene(name);
    CHECK(test::slurp(file).find("/usr/share/") == std::string::npos);
    Scene s;
    REQUIRE_NOTHROW(s = loadScene(file));
    CHECK(!s.lights.empty());
    for (const SceneMesh& sm : s.meshes) {
      CHECK(sm.mesh.skippedTriangles == 0);
      if (sm.displacement) {
        REQUIRE(sm.displacement->map);
        CHECK(sm.mesh.hasUVs());
        size_t displaceable = 0;
        for (size_t i = 0; i < sm.mesh.triangles.size(); ++i) displaceable += sm.mesh.triangle(i).prepare();
        CHECK(displaceable == sm.mesh.triangles.size());
      }
    }
    const auto it = expected.find(name);
    if (it == expected.end()) continue;  // a new scene: loading it is the test
    REQUIRE(s.meshes.size() == it->second.triangles.size());
    for (size_t i = 0; i < s.meshes.size(); ++i) {
      INFO("mesh " << i);
      CHECK(s.meshes[i].mesh.triangles.size() == it->second.triangles[i]);
      const ivec2 m = s.meshes[i].displacement
                          ? ivec2(s.meshes[i].displacement->map->width(), s.meshes[i].displacement->map->height())
                          : ivec2(0);
      CHECK(m == it->second.maps[i]);
    }
  }
  for (const auto& [name, e] : expected) CHECK(seen.count(name));
}

TEST_CASE("the sphere scene's map is zero on the polar caps (no cracks at the poles)", "[scene][unit]") {
  const Scene s = loadScene(std::string(OBLONG_SOURCE_DIR) + "/scenes/sphere.json");
  const Displacement& d = *s.meshes[0].displacement;
  const Mesh& m = s.meshes[0].mesh;
  // Every sample a micro-triangle of a pole triangle can use (its uv box snapped
  // outward, plus one sample) has height exactly 0.
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const DisplacedTriangle T = m.triangle(i);
    const bool pole = T.uvBox.lo.y == 0.0f || T.uvBox.hi.y == 1.0f;
    if (!pole) continue;
    const dvec2 lo = d.toSample(T.uvBox.lo), hi = d.toSample(T.uvBox.hi);
    for (int j = int(std::floor(lo.y)) - 1; j <= int(std::ceil(hi.y)) + 1; ++j)
      for (int k = int(std::floor(lo.x)) - 1; k <= int(std::ceil(hi.x)) + 1; ++k) REQUIRE(d.sampleHeight(k, j) == 0.0f);
  }
}
