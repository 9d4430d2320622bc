// Mesh files as scenes (docs/assets.md): an OBJ+MTL, a .gltf and a .glb written here,
// each traced by the oblong binary against the JSON scene that says the same thing
// (identical hits); bad input gives one line naming the file; unused material keys are
// named in a warning.
#include "core/asset_scene.h"
#include "core/error.h"
#include "test_util.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

namespace {

namespace fs = std::filesystem;
using oblong::test::CliRun;
using oblong::test::runOblongCli;
using Catch::Matchers::Contains;

fs::path dir() { return oblong::test::scratchDir("assets"); }

std::string write(const std::string& name, const std::string& text) {
  const fs::path p = dir() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p.string();
}

// A 16x16 height map with a pattern in both directions (so a flipped or tiled lookup
// would differ), as an 8-bit PNG or a float EXR.
std::string heightMap(const std::string& name, OIIO::TypeDesc type) {
  std::vector<float> v(16 * 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      v[size_t(y * 16 + x)] = 0.5f + 0.25f * std::sin(0.7f * float(x)) + 0.2f * std::cos(0.45f * float(y)) * (y < 8 ? 1.0f : 0.3f);
  const std::string p = (dir() / name).string();
  oblong::test::writeGray(p, 16, 16, v, type);
  return p;
}

// The quad [-1, 1]² at z = 0 facing +z, uv (0, 0) at its lower left corner.
const float kP[4][3] = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
const float kN[4][3] = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
const float kT[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};

std::string quadObj(const std::string& mtllib, const std::string& usemtl) {
  std::string s = mtllib.empty() ? "" : "mtllib " + mtllib + "\n";
  for (const auto& p : kP) s += fmt::format("v {} {} {}\n", p[0], p[1], p[2]);
  for (const auto& t : kT) s += fmt::format("vt {} {}\n", t[0], t[1]);
  s += "vn 0 0 1\n";
  s += usemtl.empty() ? "" : "usemtl " + usemtl + "\n";
  return s + "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n";
}

std::string bytes(const void* p, size_t n) { return std::string(static_cast<const char*>(p), n); }

std::string quadBuffer() {
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  return bytes(kP, sizeof kP) + bytes(kN, sizeof kN) + bytes(kT, sizeof kT) + bytes(idx, sizeof idx);
}

// glTF 2.0 of the quad with one material; `bufferUri` empty: the GLB's binary chunk.
nlohmann::json quadGltf(const nlohmann::json& material, const std::string& bufferUri) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "extensionsUsed": ["KHR_materials_displacement"],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                "material": 0}]}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 96, "byteLength": 32}, {"buffer": 0, "byteOffset": 128, "byteLength": 12}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                  {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                  {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    "textures": [{"source": 0}], "images": [{"uri": "height.exr"}]})");
  j["materials"] = nlohmann::json::array({material});
  j["buffers"] = nlohmann::json::array({{{"byteLength", quadBuffer().size()}}});
  if (!bufferUri.empty()) j["buffers"][0]["uri"] = bufferUri;
  return j;
}

std::string glbOf(const nlohmann::json& j) {
  std::string json = j.dump(), bin = quadBuffer();
  while (json.size() % 4) json += ' ';
  while (bin.size() % 4) bin += '\0';
  auto u32 = [](uint32_t v) { return bytes(&v, 4); };
  const std::string body = u32(uint32_t(json.size())) + "JSON" + json + u32(uint32_t(bin.size())) + "BIN" +
                           std::string(1, '\0') + bin;
  return "glTF" + u32(2) + u32(uint32_t(12 + body.size())) + body;
}

// A grid of slanted rays over the quad, from z = 3 down.
std::string rays() {
  std::string s = "ox,oy,oz,dx,dy,dz,tmin,tmax\n";
  for (int i = 0; i < 24; ++i)
    for (int j = 0; j < 24; ++j)
      s += fmt::format("{},{},3,0.07,-0.04,-1,0,inf\n", -1.1 + 2.2 * i / 23.0, -1.1 + 2.2 * j / 23.0);
  return write("rays.csv", s);
}

// `oblong trace SCENE` with the extra arguments; the hits file's text.
std::string trace(const std::string& scene, const std::string& extra = "") {
  const std::string hits = (dir() / (fs::path(scene).filename().string() + ".hits.csv")).string();
  const CliRun r = runOblongCli("trace " + scene + " " + extra + " --rays " + rays() + " -o " + hits + " -q");
  INFO(r.err);
  REQUIRE(r.status == 0);
  return oblong::test::slurp(hits);
}

// The hits are those of a displaced surface: most rays hit, at different t.
void requireDisplacedHits(const std::string& hits) {
  std::istringstream in(hits);
  std::set<std::string> ts;
  size_t hit = 0;
  for (std::string line; std::getline(in, line);)
    if (line != "t,mesh,prim,u,v" && line.rfind("inf", 0) != 0) ++hit, ts.insert(line.substr(0, line.find(',')));
  CHECK(hit > 300);
  CHECK(ts.size() > 100);
}

std::string jsonScene(const std::string& name, const nlohmann::json& mesh) {
  return write(name, nlohmann::json{{"meshes", nlohmann::json::array({mesh})}}.dump(2));
}

// One error line naming what is given, exit status 1.
void oneError(const CliRun& r, std::initializer_list<std::string> parts) {
  INFO(r.err);
  CHECK(r.status == 1);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.rfind("oblong: ", 0) == 0);
  for (const std::string& p : parts) CHECK_THAT(r.err, Contains(p));
}

}  // namespace

TEST_CASE("an OBJ with its MTL's disp -mm and -s traces as the JSON scene that says the same", "[assets][cli]") {
  heightMap("height.png", OIIO::TypeDesc::UINT8);
  write("rock.mtl",
        "# a material\nnewmtl rock\nNs 10\nKa 0 0 0\nKd 0.6 0.5 0.4\nmap_Kd albedo.png\n"
        "disp -mm -0.1 0.3 -s 2 3 height.png\nbump -bm 0.5 height.png\nillum 2\n");
  const std::string obj = write("rock.obj", quadObj("rock.mtl", "rock"));
  const double base = -0.1, gain = 0.3;
  const std::string json = jsonScene(
      "rock.json", {{"file", "rock.obj"},
                    {"albedo", {0.6, 0.5, 0.4}},
                    {"displacement",
                     {{"map", "height.png"}, {"scale", gain}, {"bias", base / gain}, {"tiling", {2, 3}}, {"flip_v", true}}}});
  const std::string fromObj = trace(obj), fromJson = trace(json);
  CHECK(fromObj == fromJson);
  requireDisplacedHits(fromObj);

  // The scene is the JSON scene's (and its albedo the MTL's Kd).
  const oblong::Scene s = oblong::loadAsset(obj);
  REQUIRE(s.meshes.size() == 1);
  REQUIRE(s.meshes[0].displacement);
  CHECK(s.meshes[0].displacement->scale == float(gain));
  CHECK(s.meshes[0].displacement->bias == float(base / gain));
  CHECK(s.meshes[0].displacement->tiling == oblong::vec2(2.0f, 3.0f));
  CHECK(s.meshes[0].albedo == oblong::vec3(0.6f, 0.5f, 0.4f));

  // Every key oblong does not use is named, bump and map_Kd with why.
  const CliRun info = runOblongCli("info " + obj);
  INFO(info.err);
  CHECK(info.status == 0);
  CHECK_THAT(info.err, Contains("rock.mtl: material 'rock': not used by oblong: Ns, Ka, map_Kd (oblong's albedo is a "
                                "constant: Kd), bump (bump and normal maps are not used"));
  CHECK_THAT(info.err, Contains("illum"));
}

TEST_CASE("a bare mesh with --displacement --scale --bias --tiling traces as the JSON scene", "[assets][cli]") {
  heightMap("height.png", OIIO::TypeDesc::UINT8);
  const std::string obj = write("bare.obj", quadObj("", ""));
  const std::string json = jsonScene(
      "bare.json", {{"file", "bare.obj"},
                    {"displacement", {{"map", "height.png"}, {"scale", 0.25}, {"bias", -0.5}, {"tiling", {2, 1.5}}, {"flip_v", true}}}});
  const std::string map = (dir() / "height.png").string();
  const std::string fromFlags = trace(obj, "--displacement " + map + " --scale 0.25 --bias -0.5 --tiling 2,1.5");
  CHECK(fromFlags == trace(json));
  requireDisplacedHits(fromFlags);

  // The flags override the material's values one by one.
  write("over.mtl", "newmtl m\ndisp -mm 0.4 2 -s 5 5 height.png\n");
  const std::string over = write("over.obj", quadObj("over.mtl", "m"));
  CHECK(trace(over, "--scale 0.25 --bias -0.5 --tiling 2,1.5") == fromFlags);

  // A bare mesh renders (camera and light framed on it).
  const std::string png = (dir() / "bare.png").string();
  const CliRun r = runOblongCli("render " + obj + " --displacement " + map + " --scale 0.3 --size 32x24 --threads 2 -q -o " + png);
  INFO(r.err);
  CHECK(r.status == 0);
  CHECK(r.err.empty());
  CHECK(fs::file_size(png) > 0);
}

TEST_CASE("glTF and GLB with KHR_materials_displacement trace as the JSON scene that says the same", "[assets][cli]") {
  heightMap("height.exr", OIIO::TypeDesc::FLOAT);
  const nlohmann::json material = {
      {"name", "ground"},
      {"pbrMetallicRoughness", {{"baseColorFactor", {0.3, 0.6, 0.2, 1.0}}, {"metallicFactor", 0.0}}},
      {"normalTexture", {{"index", 0}}},
      {"extensions",
       {{"KHR_materials_displacement",
         {{"displacementGeometryTexture", {{"index", 0}, {"texCoord", 0}}},
          {"displacementGeometryFactor", 0.4},
          {"displacementGeometryOffset", -0.2}}}}}};
  const std::string gltf = write(
      "ground.gltf", quadGltf(material, "data:application/octet-stream;base64," + oblong::test::base64(quadBuffer())).dump(2));
  const std::string glb = write("ground.glb", glbOf(quadGltf(material, "")));
  const double factor = 0.4, offset = -0.2;
  for (const std::string& file : {gltf, glb}) {
    INFO(file);
    const std::string json = jsonScene(
        fs::path(file).filename().string() + ".json",
        {{"file", fs::path(file).filename().string()},
         {"albedo", {0.3, 0.6, 0.2}},
         {"displacement", {{"map", "height.exr"}, {"scale", factor}, {"bias", offset / factor}, {"flip_v", false}}}});
    const std::string fromFile = trace(file);
    CHECK(fromFile == trace(json));
    requireDisplacedHits(fromFile);
    const CliRun info = runOblongCli("info " + file);
    INFO(info.err);
    CHECK(info.status == 0);
    CHECK_THAT(info.err, Contains("materials[0] 'ground': not used by oblong: normalTexture (oblong shades the displaced "
                                  "geometry), pbrMetallicRoughness.metallicFactor"));
  }
}

TEST_CASE("bad mesh-file input gives one error line naming the file", "[assets][cli][bad_input]") {
  heightMap("height.png", OIIO::TypeDesc::UINT8);
  const std::string png = (dir() / "x.png").string();

  write("nomap.mtl", "newmtl m\ndisp -mm 0 0.2 missing.png\n");
  const std::string nomap = write("nomap.obj", quadObj("nomap.mtl", "m"));
  oneError(runOblongCli("render " + nomap + " -o " + png), {"nomap.mtl: line 2: disp: ", "missing.png: file not found"});

  write("badmm.mtl", "newmtl m\nKd 0.5 0.5 0.5\ndisp -mm 0.2 height.png\n");
  const std::string badmm = write("badmm.obj", quadObj("badmm.mtl", "m"));
  oneError(runOblongCli("info " + badmm), {"badmm.mtl: line 3: disp: -mm needs two numbers (base gain)"});

  write("badkd.mtl", "newmtl m\nKd 0.5 x 0.5\n");
  oneError(runOblongCli("info " + write("badkd.obj", quadObj("badkd.mtl", "m"))), {"badkd.mtl: line 2: Kd: expected"});

  write("bright.mtl", "newmtl m\nKd 1.5 0.5 0.5\n");
  oneError(runOblongCli("info " + write("bright.obj", quadObj("bright.mtl", "m"))),
           {"bright.mtl: line 2: Kd: components must lie in [0, 1]"});

  write("offset.mtl", "newmtl m\ndisp -o 0.5 0 height.png\n");
  oneError(runOblongCli("info " + write("offset.obj", quadObj("offset.mtl", "m"))),
           {"offset.mtl: line 2: disp: -o (a texture offset) is not supported"});

  nlohmann::json material = {
      {"extensions", {{"KHR_materials_displacement", {{"displacementGeometryTexture", {{"index", 3}}}}}}}};
  const std::string range = write("range.gltf", quadGltf(material, "data:application/octet-stream;base64," +
                                                                       oblong::test::base64(quadBuffer()))
                                                          .dump());
  oneError(runOblongCli("info " + range),
           {"range.gltf: materials[0].extensions.KHR_materials_displacement.displacementGeometryTexture.index: 3 out of "
            "range (the file has 1 textures)"});
  nlohmann::json embedded = quadGltf(material, "");
  embedded["materials"][0]["extensions"]["KHR_materials_displacement"]["displacementGeometryTexture"]["index"] = 0;
  embedded["images"][0] = {{"bufferView", 0}, {"mimeType", "image/png"}};
  oneError(runOblongCli("info " + write("embedded.glb", glbOf(embedded))),
           {"embedded.glb: images[0]: an image inside the file (bufferView) is not supported"});
  // A uri that is not a string is named as such (it was reported as a bufferView image).
  nlohmann::json numberUri = embedded;
  numberUri["images"][0] = {{"uri", 5}};
  oneError(runOblongCli("info " + write("uri5.glb", glbOf(numberUri))),
           {"uri5.glb: images[0].uri: must be a file name (a string), got 5"});
  // An offset beyond a float's range (it became infinite and was reported as 'got null').
  nlohmann::json farOffset = embedded;
  farOffset["images"][0] = {{"uri", "height.png"}};
  auto& khr = farOffset["materials"][0]["extensions"]["KHR_materials_displacement"];
  khr["displacementGeometryOffset"] = 1e300;
  oneError(runOblongCli("info " + write("offset.glb", glbOf(farOffset))),
           {"offset.glb: ", "displacementGeometryOffset: 1e+300 is beyond a float's range"});
  khr["displacementGeometryOffset"] = 1e38;
  khr["displacementGeometryFactor"] = 1e-30;
  oneError(runOblongCli("info " + write("ratio.glb", glbOf(farOffset))),
           {"ratio.glb: ", "displacementGeometryOffset / displacementGeometryFactor = 1e+68 is beyond a float's range"});

  nlohmann::json red = quadGltf({{"pbrMetallicRoughness", {{"baseColorFactor", {2, 0, 0, 1}}}}}, "");
  oneError(runOblongCli("info " + write("red.glb", glbOf(red))),
           {"red.glb: materials[0].pbrMetallicRoughness.baseColorFactor: components must lie in [0, 1]"});
  oneError(runOblongCli("info " + write("broken.gltf", "{\"asset\": ")), {"broken.gltf: malformed glTF JSON"});
  write("huge.mtl", "newmtl m\ndisp -s 1e300 1 height.png\n");
  oneError(runOblongCli("info " + write("huge.obj", quadObj("huge.mtl", "m"))),
           {"huge.mtl: line 2: disp -s [0]: must be a finite number"});
  // Below a float's smallest normal: it became 0 and read "must not be zero" or "got [0, 1]".
  write("tiny.mtl", "newmtl m\ndisp -mm 0 1e-300 height.png\n");
  oneError(runOblongCli("info " + write("tiny.obj", quadObj("tiny.mtl", "m"))),
           {"tiny.mtl: line 2: disp -mm: 1e-300 is too small for a float: give 0 or a magnitude of at least"});
  write("tinys.mtl", "newmtl m\ndisp -s 1e-300 1 height.png\n");
  oneError(runOblongCli("info " + write("tinys.obj", quadObj("tinys.mtl", "m"))),
           {"tinys.mtl: line 2: disp -s [0]: 1e-300 is too small for a float"});

  const std::string bare = write("bare2.obj", quadObj("", ""));
  oneError(runOblongCli("info " + bare + " --scale 2"), {"--scale: ", "bare2.obj has no displacement map"});
  oneError(runOblongCli("info " + bare + " --displacement " + (dir() / "height.png").string() + " --scale 0"),
           {"--scale: must be a non-zero finite number"});
  oneError(runOblongCli("info " + bare + " --displacement " + (dir() / "height.png").string() + " --tiling 2,0"),
           {"--tiling: expected T or TU,TV (positive numbers), got '2,0'"});
  oneError(runOblongCli("info " + bare + " --displacement " + (dir() / "nothere.png").string()),
           {"--displacement: ", "nothere.png: file not found"});
  const std::string scene = jsonScene("plain.json", {{"file", "bare2.obj"}});
  oneError(runOblongCli("info " + scene + " --displacement " + (dir() / "height.png").string()),
           {"--displacement: applies to a mesh file given instead of a scene", "plain.json is a scene file"});
  oneError(runOblongCli("info " + (dir() / "absent.obj").string()), {"absent.obj: file not found"});
}

TEST_CASE("a glTF's buffer is an input no output names, an empty image uri and two materials of one name are named",
          "[assets][cli][bad_input]") {
  heightMap("height.png", OIIO::TypeDesc::UINT8);
  nlohmann::json material = {
      {"name", "m"},
      {"extensions",
       {{"KHR_materials_displacement",
         {{"displacementGeometryTexture", {{"index", 0}}}, {"displacementGeometryFactor", 0.2}}}}}};
  nlohmann::json j = quadGltf(material, "g.bin");
  j["images"][0]["uri"] = "height.png";
  const std::string gltf = write("g.gltf", j.dump()), bin = write("g.bin", quadBuffer());
  write("g.csv", "ox,oy,oz,dx,dy,dz,tmin,tmax\n0,0,3,0,0,-1,0,inf\n");
  // Every output naming the buffer is refused and the buffer kept (it was overwritten).
  const std::string d = dir().string() + "/";
  for (const std::string& args : {"render " + gltf + " --size 8x8 -q -o " + d + "g.png --stats " + bin,
                                  "trace " + gltf + " --rays " + d + "g.csv -o " + bin, "bake " + gltf + " -o " + bin}) {
    INFO(args);
    oneError(runOblongCli(args), {"names an input of this command", "g.bin"});
    std::ifstream in(bin, std::ios::binary);
    CHECK(std::string(std::istreambuf_iterator<char>(in), {}) == quadBuffer());
  }
  // An empty uri dropped the displacement without a word.
  nlohmann::json empty = j;
  empty["images"][0]["uri"] = "";
  oneError(runOblongCli("info " + write("empty.gltf", empty.dump())),
           {"empty.gltf: images[0].uri: is empty: give the displacement map's file name"});
  // Two materials named alike but different: the one not used is named as "another".
  nlohmann::json two = j;
  two["materials"].push_back(material);
  two["materials"][1]["extensions"]["KHR_materials_displacement"]["displacementGeometryFactor"] = 0.5;
  two["meshes"][0]["primitives"].push_back(two["meshes"][0]["primitives"][0]);
  two["meshes"][0]["primitives"][1]["material"] = 1;
  const CliRun info = runOblongCli("info " + write("two.gltf", two.dump()));
  INFO(info.err);
  CHECK(info.status == 0);
  CHECK_THAT(info.err, Contains("two.gltf: oblong applies one material to a whole mesh file: 'm'; not used: another 'm'"));
}

TEST_CASE("a mesh file is told from a scene file by its extension", "[assets]") {
  CHECK(oblong::isAssetPath("a/b.obj"));
  CHECK(oblong::isAssetPath("b.GLB"));
  CHECK(oblong::isAssetPath("b.gltf"));
  CHECK(oblong::isAssetPath("b.ply"));
  CHECK_FALSE(oblong::isAssetPath("scene.json"));
  CHECK_FALSE(oblong::isAssetPath("scene"));
  CHECK_FALSE(oblong::isAssetPath("scene.txt"));
}

TEST_CASE("what a mesh file's materials say and oblong does not use is named in a warning", "[assets][cli]") {
  heightMap("height.png", OIIO::TypeDesc::UINT8);
  // A missing .mtl: the mesh loads without it, one warning.
  const CliRun nolib = runOblongCli("info " + write("nolib.obj", quadObj("nolib.mtl", "m")));
  INFO(nolib.err);
  CHECK(nolib.status == 0);
  CHECK_THAT(nolib.err, Contains("nolib.obj: mtllib ") && Contains("nolib.mtl: file not found; its materials are not used"));
  CHECK(std::count(nolib.err.begin(), nolib.err.end(), '\n') == 1);

  // An undefined material.
  write("few.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
  const CliRun undefined = runOblongCli("info " + write("few.obj", quadObj("few.mtl", "b")));
  CHECK(undefined.status == 0);
  CHECK_THAT(undefined.err, Contains("few.obj: usemtl b: no such material in"));

  // Two materials that differ: the displaced one is applied, the other named.
  write("two.mtl", "newmtl plain\nKd 0.2 0.2 0.2\nnewmtl bumpy\nKd 0.5 0.5 0.5\ndisp -mm 0 0.1 height.png\n");
  std::string obj = quadObj("two.mtl", "plain");
  obj.insert(obj.rfind("f 1/1/1 3/3/1"), "usemtl bumpy\n");
  const std::string two = write("two.obj", obj);
  const CliRun both = runOblongCli("info " + two);
  INFO(both.err);
  CHECK(both.status == 0);
  CHECK_THAT(both.err, Contains("two.obj: oblong applies one material to a whole mesh file: 'bumpy'; not used: 'plain'"));
  const oblong::Scene s = oblong::loadAsset(two);
  REQUIRE(s.meshes[0].displacement);
  CHECK(s.meshes[0].albedo == oblong::vec3(0.5f));

  // A glTF sampler that clamps, and an extension oblong does not read.
  const nlohmann::json material = {
      {"extensions",
       {{"KHR_materials_displacement", {{"displacementGeometryTexture", {{"index", 0}}}}},
        {"KHR_materials_clearcoat", {{"clearcoatFactor", 1}}}}}};
  heightMap("height.exr", OIIO::TypeDesc::FLOAT);
  nlohmann::json j = quadGltf(material, "data:application/octet-stream;base64," + oblong::test::base64(quadBuffer()));
  j["textures"][0]["sampler"] = 0;
  j["samplers"] = nlohmann::json::array({{{"wrapS", 33071}}});
  const CliRun gltf = runOblongCli("info " + write("clamp.gltf", j.dump()));
  INFO(gltf.err);
  CHECK(gltf.status == 0);
  CHECK_THAT(gltf.err, Contains("extensions.KHR_materials_clearcoat") &&
                           Contains("samplers[0].wrapS 33071 (oblong repeats the map)"));
}
