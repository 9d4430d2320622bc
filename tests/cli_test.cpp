// Drives the oblong binary as a user would: good runs produce files, bad input gives
// one error line naming the file and a non-zero exit.
#include "render/rays_io.h"
#include "test_util.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <map>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <sys/wait.h>

namespace {

struct Run {
  int status;
  std::string out, err;
};

Run run(const std::string& args) {
  const auto dir = oblong::test::scratchDir("cli");
  const std::string o = (dir / "stdout.txt").string(), e = (dir / "stderr.txt").string();
  const std::string cmd = std::string(OBLONG_BINARY) + " " + args + " >" + o + " 2>" + e;
  const int raw = std::system(cmd.c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(o), slurp(e)};
}

size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }

}  // namespace

TEST_CASE("oblong render writes an image and statistics for the default scene", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_ok");
  const std::string png = (dir / "default.png").string(), stats = (dir / "stats.json").string();
  std::filesystem::remove(png);
  const Run r = run("render --size 64x48 --threads 2 -o " + png + " --stats " + stats);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(std::filesystem::file_size(png) > 100);
  CHECK(r.out.find("Mrays/s") != std::string::npos);
  std::ifstream f(stats);
  const auto j = nlohmann::json::parse(f);
  CHECK(j.at("rays").at("primary") == 64 * 48);
  CHECK(j.at("memory").at("embree/bvh").get<int64_t>() > 0);
  CHECK(j.at("rays").at("hits").get<int64_t>() > 64 * 48 / 4);
  // Which code path ran, with every strategy's resolved parameters (defaults included).
  const auto& t = j.at("traversal").at(0);
  CHECK(t.at("path") == "generic");
  CHECK(t.at("range").at("params").at("layout") == "pairs");
  CHECK(t.at("range").at("params").at("bits") == 16);
  CHECK(t.at("inverter").at("params").at("max_iterations") == 10);
  CHECK(t.at("range").at("layout").at("layers").size() == 2);
}

TEST_CASE("oblong info reports the range-query structures built for the scene", "[cli][rmip][minmax_mipmap][safety_zones]") {
  auto has = [](const std::string& out, const std::string& s) { return out.find(s) != std::string::npos; };
  // Every range query the binary registers (its own list, not one kept here).
  const Run list = run("info --strategies --json");
  REQUIRE(list.status == 0);
  std::vector<std::string> names;
  const nlohmann::json strategies = nlohmann::json::parse(list.out);
  for (const auto& e : strategies.at("range")) names.push_back(e.at("name"));
  REQUIRE(!names.empty());
  for (const std::string& name : names) {
    const Run r = run("info --range " + name);
    INFO(r.out << r.err);
    REQUIRE(r.status == 0);
    CHECK(has(r.out, std::string("range query '") + name + "'"));
    CHECK(has(r.out, "plain (Embree triangles)"));
    // What was built, with bytes (docs/design.md invariant 4): the default torus is tiled (4, 2).
    CHECK(has(r.out, "wrapping queries yes (the map is tiled)"));
    CHECK(has(r.out, "prisms   : 2304 built (2304 well-posed, 0 box-only), 0 skipped"));
    CHECK(has(r.out, "built    : no range query, no prisms"));
    CHECK(has(r.out, "LoD      : off, no levels built (7 levels possible"));
    CHECK(has(r.out, "total    : "));
  }
  // Each strategy's describe(): its layout, resolved parameters and the code path.
  const Run r = run("info --range rmip");
  CHECK(has(r.out, "layers              : [6, 5]"));
  CHECK(has(r.out, "full_pyramid_layers : [9, 9]"));
  // "pairs": layers p, q >= 1, (384 / 2^p) x (256 / 2^q) entries of 4 bytes.
  CHECK(has(r.out, "  1         0 B   96.0 KiB   48.0 KiB   24.0 KiB   12.0 KiB"));
  CHECK(has(r.out, "  5         0 B   6.00 KiB   3.00 KiB   1.50 KiB      768 B"));
  CHECK(has(r.out, "wrap     : blocks wrapping around the map border filled with the wrapped pixels (no extra bytes)"));
  CHECK(has(r.out, R"(({"bits":16,"layout":"pairs","resolution":0}))"));
  const Run c = run(R"(info --range rmip)");
  CHECK(has(c.out, "built    : rmip/layers 349 KiB"));
  CHECK(has(r.out, "traversal: generic path; inverter newton"));
  CHECK(has(run("info --range minmax_mipmap").out, "level_sizes         : [[192, 128], [96, 64], [48, 32], [24, 16], [12, 8], [6, 4]]"));
  CHECK(has(run("info --range safety_zones").out, "deltas              : [1, 2, 4, 8, 16, 32]"));
}

TEST_CASE("oblong info: wrap corners only when some query crosses the map border", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_info");
  std::vector<float> v(16 * 16);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float(i % 7) / 6.0f;
  oblong::test::writeGray((dir / "map.png").string(), 16, 16, v, OIIO::TypeDesc::UINT8);
  auto scene = [&](const std::string& name, const std::string& tiling) {
    const std::string p = (dir / name).string();
    std::ofstream(p) << R"({"meshes": [{"shape": {"type": "plane", "size": 2, "uv": [0.25, 0.25, 0.75, 0.75]},
                             "displacement": {"map": "map.png", "scale": 0.1, "tiling": )" + tiling + "}}]}";
    return p;
  };
  const Run inside = run("info " + scene("inside.json", "1"));
  INFO(inside.out << inside.err);
  REQUIRE(inside.status == 0);
  CHECK(inside.out.find("wrapping queries no") != std::string::npos);
  CHECK(inside.out.find("wrap     : none stored") != std::string::npos);
  const Run tiled = run("info " + scene("tiled.json", "2"));
  INFO(tiled.out << tiled.err);
  REQUIRE(tiled.status == 0);
  CHECK(tiled.out.find("wrapping queries yes (the map is tiled)") != std::string::npos);
  CHECK(tiled.out.find("wrap     : blocks wrapping around the map border filled") != std::string::npos);
  // The "corners" layout stores the wrapping corners as extra entries.
  std::ofstream(dir / "tiled_corners.json")
      << R"({"meshes": [{"shape": {"type": "plane", "size": 2, "uv": [0.25, 0.25, 0.75, 0.75]},
             "displacement": {"map": "map.png", "scale": 0.1, "tiling": 2}}],
             "strategies": {"range": {"name": "rmip", "layout": "corners"}}})";
  const Run corners = run("info " + (dir / "tiled_corners.json").string());
  INFO(corners.out << corners.err);
  CHECK(corners.out.find("wrap     : corners wrapping around the map border stored") != std::string::npos);
  // A scene whose strategies choose the tessellated baseline (built by the scene, no
  // intersector): info says what it builds, the render builds it.
  std::ofstream(dir / "tessellated.json")
      << R"({"meshes": [{"shape": {"type": "plane", "size": 2, "uv": [0.25, 0.25, 0.75, 0.75]},
             "displacement": {"map": "map.png", "scale": 0.1, "tiling": 1}}],
             "strategies": {"baseline": {"name": "tessellated"}}})";
  const Run tess = run("info " + (dir / "tessellated.json").string());
  INFO(tess.out << tess.err);
  CHECK(tess.status == 0);
  CHECK(tess.out.find("baseline 'tessellated': no range query; ") != std::string::npos);
  CHECK(tess.out.find(" micro-triangles") != std::string::npos);
}

TEST_CASE("bad command-line input gives one clear error line", "[cli][bad_input]") {
  const auto dir = oblong::test::scratchDir("cli_bad");
  struct Case {
    std::string args, mustContain;
  };
  const std::string badJson = (dir / "bad.json").string();
  std::ofstream(badJson) << "{ \"meshes\": [ }";
  const std::string unknown = (dir / "unknown.json").string();
  std::ofstream(unknown) << R"({"camera": {"from": [0,0,5], "to": [0,0,0]}, "meshez": []})";
  const Case cases[] = {
      {"render /nonexistent/scene.json -o x.png", "/nonexistent/scene.json"},
      {"render " + badJson + " -o x.png", badJson},
      {"render " + unknown + " -o x.png", "meshez"},
      {"render --size 0x5 -o x.png", "--size"},
      {"render --size banana -o x.png", "--size"},
      {"render --size 8x8 -o /nonexistent/dir/x.png", "/nonexistent/dir/x.png"},
      {"info --range nosuch", "nosuch"},
      {"render --normals bumpy -o x.png", "--normals"},
  };
  for (const auto& c : cases) {
    const Run r = run(c.args);
    INFO(c.args << "\nstdout: " << r.out << "\nstderr: " << r.err);
    CHECK(r.status == 1);
    CHECK(lines(r.err) == 1);
    CHECK(r.err.find(c.mustContain) != std::string::npos);
  }
}

namespace {

std::vector<oblong::Ray> someRays(int n) {
  // Camera-like rays at the default scene (torus at the origin, ground at y = -0.6).
  std::vector<oblong::Ray> rays;
  for (int i = 0; i < n; ++i) {
    const float a = 6.2831853f * float(i) / float(n);
    const oblong::vec3 o(3.0f * std::cos(a), 1.5f, 3.0f * std::sin(a));
    const oblong::vec3 target(0.8f * std::cos(3.0f * a), -0.2f + 0.3f * std::sin(5.0f * a), 0.8f * std::sin(2.0f * a));
    rays.push_back(oblong::Ray{o, glm::normalize(target - o), 0.0f, oblong::kInfinity});
  }
  return rays;
}

}  // namespace

TEST_CASE("oblong trace writes the first hit of every ray, CSV and binary alike", "[cli][trace]") {
  const auto dir = oblong::test::scratchDir("cli_trace");
  const auto rays = someRays(400);
  const std::string csv = (dir / "rays.csv").string(), bin = (dir / "rays.bin").string();
  oblong::writeRays(csv, rays);
  oblong::writeRays(bin, rays);
  const std::string h1 = (dir / "h1.csv").string(), h2 = (dir / "h2.csv").string(),
                    h3 = (dir / "h3.csv").string(), stats = (dir / "trace.json").string();
  Run r = run("trace --rays " + csv + " -o " + h1 + " --stats " + stats);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  r = run("trace --rays " + bin + " -o " + h2);
  REQUIRE(r.status == 0);
  r = run("trace --rays " + csv + " -o " + h3 + " --baseline tessellated");
  REQUIRE(r.status == 0);
  const auto a = oblong::readHits(h1), b = oblong::readHits(h2), c = oblong::readHits(h3);
  REQUIRE(a.size() == rays.size());
  REQUIRE(b.size() == rays.size());
  REQUIRE(c.size() == rays.size());
  size_t hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    INFO("ray " << i);
    CHECK(a[i].valid() == b[i].valid());
    CHECK(a[i].t == b[i].t);  // same rays, same traversal: bit-identical
    REQUIRE(a[i].valid() == c[i].valid());
    if (!a[i].valid()) continue;
    ++hits;
    CHECK(a[i].mesh == c[i].mesh);
    CHECK(std::abs(a[i].t - c[i].t) <= 1e-5f * std::max(1.0f, a[i].t));
    // Modulo 1: a ray in the plane z = 0 hits the torus on its uv seam (u = 0 = 1),
    // where either side's triangle is the first hit.
    auto wrapped = [](float d) { return std::abs(d - std::round(d)); };
    CHECK(wrapped(a[i].uv.x - c[i].uv.x) < 1e-3f);
    CHECK(wrapped(a[i].uv.y - c[i].uv.y) < 1e-3f);
  }
  CHECK(hits > rays.size() / 2);
  std::ifstream f(stats);
  const auto j = nlohmann::json::parse(f);
  CHECK(j.at("rays").at("count") == rays.size());
  CHECK(j.at("config").at("range").at("name") == "rmip");
  CHECK(j.at("ray_counters").at("steps").get<int64_t>() > 0);
  CHECK(j.at("memory_total").get<int64_t>() > 0);
}

TEST_CASE("oblong trace --baseline tfdm matches both oracles, and a scene file can choose it", "[cli][trace][tfdm]") {
  const auto dir = oblong::test::scratchDir("cli_trace_tfdm");
  const auto rays = someRays(300);
  const std::string csv = (dir / "rays.csv").string();
  oblong::writeRays(csv, rays);
  // The default scene (torus and ground) and a tiled torus whose scene file asks for tfdm.
  const std::string scene = (dir / "tfdm_scene.json").string();
  std::ofstream(scene) << R"({"strategies": {"baseline": {"name": "tfdm"}},
    "meshes": [{"shape": {"type": "torus", "segments": [24, 12]},
                "displacement": {"map": ")" OBLONG_SOURCE_DIR R"(/scenes/maps/cobbles_256.png",
                                 "scale": 0.06, "bias": -0.5, "tiling": [3, 2]}}]})";
  for (const std::string& s : {std::string(), scene}) {
    INFO("scene " << (s.empty() ? "<default>" : s));
    const std::string tf = (dir / "tf.csv").string(), bf = (dir / "bf.csv").string(),
                      ts = (dir / "ts.csv").string(), stats = (dir / "tf.json").string();
    const std::string flag = s.empty() ? " --baseline tfdm" : "";  // the scene file chooses it itself
    Run r = run("trace " + s + " --rays " + csv + " -o " + tf + flag + " --stats " + stats);
    INFO(r.out << r.err);
    REQUIRE(r.status == 0);
    REQUIRE(run("trace " + s + " --rays " + csv + " -o " + bf + " --baseline bruteforce").status == 0);
    REQUIRE(run("trace " + s + " --rays " + csv + " -o " + ts + " --baseline tessellated").status == 0);
    const auto a = oblong::readHits(tf), b = oblong::readHits(bf), c = oblong::readHits(ts);
    REQUIRE(a.size() == rays.size());
    REQUIRE(b.size() == rays.size());
    REQUIRE(c.size() == rays.size());
    size_t hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      INFO("ray " << i);
      REQUIRE(a[i].valid() == b[i].valid());
      REQUIRE(a[i].valid() == c[i].valid());
      if (!a[i].valid()) continue;
      ++hits;
      CHECK(a[i].mesh == b[i].mesh);
      CHECK(std::abs(a[i].t - b[i].t) <= 1e-5f * std::max(1.0f, a[i].t));
      CHECK(std::abs(a[i].t - c[i].t) <= 1e-5f * std::max(1.0f, a[i].t));
    }
    CHECK(hits > rays.size() / 4);
    std::ifstream f(stats);
    const auto j = nlohmann::json::parse(f);
    CHECK(j.at("config").at("baseline") == "tfdm");
    CHECK(j.at("memory").contains("tfdm/mipmap"));
    CHECK(j.at("traversal").at(0).at("bits") == 16);  // the paper's TFDM stores 16-bit codes
    const auto& rc = j.at("ray_counters");
    CHECK(rc.at("steps").get<int64_t>() == rc.at("boxes").get<int64_t>() + rc.at("cells_marched").get<int64_t>());
    CHECK(rc.at("cells_marched").get<int64_t>() > 0);
  }
  // Unknown names list what is registered, from the command line and from a scene file.
  Run r = run("trace --rays " + csv + " -o " + (dir / "x.csv").string() + " --baseline tfdmm");
  CHECK(r.status == 1);
  CHECK_THAT(r.err, Catch::Contains("tfdm"));
  const std::string badScene = (dir / "bad_baseline.json").string();
  std::ofstream(badScene) << R"({"strategies": {"baseline": {"name": "tfdmm"}},
    "meshes": [{"shape": {"type": "torus", "segments": [8, 6]},
                "displacement": {"map": ")" OBLONG_SOURCE_DIR R"(/scenes/maps/cobbles_256.png", "scale": 0.05}}]})";
  r = run("trace " + badScene + " --rays " + csv + " -o " + (dir / "y.csv").string());
  CHECK(r.status == 1);
  // The known ones listed, tessellated (registered by render/) among them.
  CHECK_THAT(r.err, Catch::Contains("strategies.baseline") && Catch::Contains("'tfdmm'") &&
                        Catch::Contains("tessellated, tfdm)") && Catch::Contains(badScene));
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  // A bad parameter of the baseline: one line naming the scene and the parameter.
  const std::string badBits = (dir / "bad_bits.json").string();
  std::ofstream(badBits) << R"({"strategies": {"baseline": {"name": "tfdm", "bits": 8}},
    "meshes": [{"shape": {"type": "torus", "segments": [8, 6]},
                "displacement": {"map": ")" OBLONG_SOURCE_DIR R"(/scenes/maps/cobbles_256.png", "scale": 0.05}}]})";
  r = run("trace " + badBits + " --rays " + csv + " -o " + (dir / "z.csv").string());
  CHECK(r.status == 1);
  CHECK(r.err == "oblong: " + badBits + ": strategies.baseline: parameter 'bits' = 8 is not 16 or 32\n");
}

TEST_CASE("oblong trace: bad ray files and flags give one clear error line", "[cli][trace][bad_input]") {
  const auto dir = oblong::test::scratchDir("cli_trace_bad");
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string p = (dir / name).string();
    std::ofstream(p) << text;
    return p;
  };
  const std::string header = "ox,oy,oz,dx,dy,dz,tmin,tmax\n";
  const std::string noHeader = write("noheader.csv", "0,0,5,0,0,-1,0,inf\n");
  const std::string fields = write("fields.csv", header + "0,0,5,0,0,-1,0\n");
  const std::string word = write("word.csv", header + "0,0,five,0,0,-1,0,inf\n");
  const std::string nan = write("nan.csv", header + "0,0,5,0,0,nan,0,inf\n");
  const std::string zero = write("zero.csv", header + "0,0,5,0,0,0,0,inf\n");
  const std::string bin = write("odd.bin", "0123456789");
  const std::string good = write("good.csv", header + "0,0,5,0,0,-1,0,inf\n");
  struct Case {
    std::string args, mustContain;
  };
  const Case cases[] = {
      {"trace --rays /nonexistent/rays.csv", "/nonexistent/rays.csv"},
      {"trace --rays " + noHeader, "header"},
      {"trace --rays " + fields, "line 2"},
      {"trace --rays " + word, "five"},
      {"trace --rays " + nan, "NaN"},
      {"trace --rays " + zero, "zero"},
      {"trace --rays " + bin, "multiple of 32"},
      {"trace --rays " + good + " --range nosuch", "nosuch"},
      {"trace --rays " + good + " --splitter nosuch", "nosuch"},
      {"trace --rays " + good + " --inverter nosuch", "nosuch"},
      {"trace --rays " + good + " --marching-scale -1", "--marching-scale"},
      {"trace --rays " + good + " --step 0.1", "--step"},
  };
  for (const auto& c : cases) {
    const Run r = run(c.args + " -o " + (dir / "hits.csv").string());
    INFO(c.args << "\nstdout: " << r.out << "\nstderr: " << r.err);
    CHECK(r.status == 1);
    CHECK(lines(r.err) == 1);
    CHECK(r.err.find(c.mustContain) != std::string::npos);
  }
}

TEST_CASE("oblong render and info at a fixed level of detail", "[cli][lod]") {
  auto has = [](const std::string& out, const std::string& s) { return out.find(s) != std::string::npos; };
  const auto dir = oblong::test::scratchDir("cli_lod");
  const std::string png = (dir / "lod.png").string(), stats = (dir / "stats.json").string();
  // The default torus' map is 384x256: 7 levels; lod 2.5 traces level 2's 96x64 grid.
  const Run i = run("info --lod 2.5");
  INFO(i.out << i.err);
  REQUIRE(i.status == 0);
  CHECK(has(i.out, "LoD      : lod 2.5: level 2 grid (96x64 samples"));
  CHECK(has(i.out, "the 384x256 full-resolution map kept"));
  const Run r = run("render --size 32x24 --threads 2 --lod 2.5 -o " + png + " --stats " + stats);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  std::ifstream f(stats);
  const auto j = nlohmann::json::parse(f);
  CHECK(j.at("config").at("lod").at("requested") == 2.5);
  CHECK(j.at("config").at("lod").at("per_mesh").at(0) == 2.5);  // the torus
  CHECK(j.at("config").at("lod").at("per_mesh").at(1).is_null());  // the plain ground
  // Beyond the map's last level: one warning line, traced at the last level.
  const Run c = run("render --size 16x12 --threads 2 --lod 12 -o " + png);
  INFO(c.out << c.err);
  CHECK(c.status == 0);
  CHECK(has(c.err, "oblong: warning: <default>: meshes[0]: map <procedural 384x256> (384x256) has levels of detail up "
                   "to 7: traced at 7, not 12\n"));
  // Off by default, and "--lod off" overrides a scene's λ.
  const Run o = run("render --size 16x12 --threads 2 --lod off -o " + png + " --stats " + stats);
  REQUIRE(o.status == 0);
  std::ifstream g(stats);
  CHECK(nlohmann::json::parse(g).at("config").at("lod") == "off");
}

TEST_CASE("oblong render and info with a level of detail per ray", "[cli][lod]") {
  auto has = [](const std::string& out, const std::string& s) { return out.find(s) != std::string::npos; };
  const auto dir = oblong::test::scratchDir("cli_lod_cone");
  const std::string png = (dir / "cone.png").string(), stats = (dir / "stats.json").string();
  const Run i = run("info --lod cone");
  INFO(i.out << i.err);
  REQUIRE(i.status == 0);
  CHECK(has(i.out, "LoD      : cone (a λ per ray, bias 0): levels 0 .. 7 built"));
  CHECK(has(i.out, "per ray  : 'rmip+newton+midpoint2d' on each of 8 levels"));
  const Run r = run("render --size 32x24 --threads 2 --lod cone --lod-bias 1.5 --integrator path --spp 2 -o " + png +
                    " --stats " + stats);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  std::ifstream f(stats);
  const auto j = nlohmann::json::parse(f);
  CHECK(j.at("config").at("lod").at("requested") == "cone");
  CHECK(j.at("config").at("lod").at("bias") == 1.5);
  // Measured at 32x24 (2026-12-02): mean 2.69 over the camera rays, 54 % of them at 0 (they
  // miss the torus' base mesh; the plain ground is not one), so about 5.8 where they meet it
  // (4.3 without the bias: some 20 texels per pixel).
  const double mean = j.at("lod_per_ray").at("camera_mean").get<double>();
  CHECK(mean > 0.5);
  CHECK(mean < 7.0);
  CHECK(j.at("lod_per_ray").at("camera_at_0").get<double>() < 1.0);
}

TEST_CASE("oblong --version prints the version --stats records", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_version");
  const std::string stats = (dir / "stats.json").string();
  const Run v = run("--version");
  INFO(v.out << v.err);
  CHECK(v.status == 0);
  CHECK(v.err.empty());
  REQUIRE(run("render --size 8x6 --threads 1 -q -o " + (dir / "x.png").string() + " --stats " + stats).status == 0);
  std::ifstream f(stats);
  const std::string version = nlohmann::json::parse(f).at("version").get<std::string>();
  CHECK(!version.empty());
  // The release number (CMake's project version, CITATION.cff's) and the commit.
  CHECK_THAT(v.out, Catch::Matches("oblong [0-9]+\\.[0-9]+\\.[0-9]+ \\(" + version + "\\)\n"));
  // Without a command, still one error line.
  const Run none = run("");
  CHECK(none.status == 1);
  CHECK(lines(none.err) == 1);
  CHECK_THAT(none.err, Catch::Contains("A subcommand is required"));
}

TEST_CASE("oblong render and trace -q print nothing but warnings and errors", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_quiet");
  const std::string png = (dir / "q.png").string(), stats = (dir / "q.json").string();
  const std::string csv = (dir / "rays.csv").string(), hits = (dir / "hits.csv").string();
  oblong::writeRays(csv, someRays(50));
  for (const std::string& args : {"render --size 16x12 --threads 1 -o " + png + " --stats " + stats,
                                  "trace --rays " + csv + " -o " + hits + " --stats " + stats}) {
    std::filesystem::remove(stats);
    const Run loud = run(args), quiet = run(args + " -q"), longForm = run(args + " --quiet");
    INFO(args << "\n" << loud.out << loud.err << quiet.out << quiet.err);
    REQUIRE(loud.status == 0);
    CHECK(!loud.out.empty());
    CHECK(quiet.status == 0);
    CHECK(quiet.out.empty());
    CHECK(quiet.err.empty());
    CHECK(longForm.status == 0);
    CHECK(longForm.out.empty());
    CHECK(std::filesystem::exists(stats));  // files are written as without -q
  }
  // Errors still reach stderr under -q.
  const Run bad = run("trace -q --rays " + (dir / "missing.csv").string() + " -o " + hits);
  CHECK(bad.status == 1);
  CHECK(lines(bad.err) == 1);
  CHECK(bad.out.empty());
}

TEST_CASE("oblong trace -o hits.bin writes the binary hits of the CSV", "[cli][trace]") {
  const auto dir = oblong::test::scratchDir("cli_trace_bin");
  // Camera-like rays (hits) and some pointing up, away from the scene (misses).
  auto rays = someRays(300);
  for (int i = 0; i < 20; ++i) rays.push_back(oblong::Ray{oblong::vec3(0.1f * float(i), 2.0f, 0.0f),
                                                          oblong::vec3(0.0f, 1.0f, 0.0f), 0.0f, oblong::kInfinity});
  const std::string bin = (dir / "rays.bin").string(), csv = (dir / "hits.csv").string(),
                    hitsBin = (dir / "hits.bin").string();
  oblong::writeRays(bin, rays);
  Run r = run("trace --rays " + bin + " -o " + csv);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  r = run("trace --rays " + bin + " -o " + hitsBin);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK_THAT(r.out, Catch::Contains("-> " + hitsBin));
  // 20 bytes per ray, not text.
  REQUIRE(std::filesystem::file_size(hitsBin) == 20 * rays.size());
  const std::string bytes = oblong::test::slurp(hitsBin);
  CHECK(bytes.rfind("t,mesh", 0) != 0);
  const auto a = oblong::readHits(csv), b = oblong::readHits(hitsBin);
  REQUIRE(a.size() == rays.size());
  REQUIRE(b.size() == rays.size());
  size_t hit = 0, miss = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    INFO("ray " << i);
    CHECK(a[i].valid() == b[i].valid());
    CHECK(a[i].t == b[i].t);  // %.9g round-trips a float: the same bits
    CHECK(a[i].mesh == b[i].mesh);
    CHECK(a[i].prim == b[i].prim);
    CHECK(a[i].uv == b[i].uv);
    // The record itself: t, mesh, prim, u, v; a miss is inf, -1, -1, 0, 0.
    float t, u, v;
    int32_t mesh, prim;
    std::memcpy(&t, bytes.data() + 20 * i, 4);
    std::memcpy(&mesh, bytes.data() + 20 * i + 4, 4);
    std::memcpy(&prim, bytes.data() + 20 * i + 8, 4);
    std::memcpy(&u, bytes.data() + 20 * i + 12, 4);
    std::memcpy(&v, bytes.data() + 20 * i + 16, 4);
    CHECK(t == a[i].t);
    CHECK(mesh == a[i].mesh);
    CHECK(prim == a[i].prim);
    if (a[i].valid()) {
      ++hit;
      CHECK(u == a[i].uv.x);
      CHECK(v == a[i].uv.y);
    } else {
      ++miss;
      CHECK(t == oblong::kInfinity);
      CHECK(mesh == -1);
      CHECK(prim == -1);
      CHECK(u == 0.0f);
      CHECK(v == 0.0f);
    }
  }
  CHECK(hit > 0);
  CHECK(miss > 0);
  // writeHits then readHits round-trips, and a malformed binary file is one error naming it.
  const std::string again = (dir / "again.bin").string();
  oblong::writeHits(again, b);
  CHECK(oblong::test::slurp(again) == bytes);
  const std::string odd = (dir / "odd.bin").string();
  std::ofstream(odd) << bytes.substr(0, 30);
  CHECK_THROWS_WITH(oblong::readHits(odd), Catch::Contains(odd) && Catch::Contains("multiple of 20"));
  std::string corrupt = bytes.substr(0, 20);
  const int32_t minusTwo = -2;
  std::memcpy(corrupt.data() + 4, &minusTwo, 4);
  const std::string bad = (dir / "bad.bin").string();
  std::ofstream(bad) << corrupt;
  CHECK_THROWS_WITH(oblong::readHits(bad), Catch::Contains(bad) && Catch::Contains("hit 0"));
}

TEST_CASE("oblong render --heatmap with no traversal step warns instead of a silently black map", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_heatmap");
  const std::string png = (dir / "img.png").string(), heat = (dir / "steps.png").string();
  const std::string plain = (dir / "plain.json").string();
  std::ofstream(plain) << R"({"camera": {"from": [0, 2, 3], "to": [0, 0, 0]},
                             "meshes": [{"shape": {"type": "plane", "size": 2}}]})";
  const std::string common = " --size 16x12 --threads 1 --integrator primary -o " + png + " --heatmap " + heat;
  const Run displaced = run("render" + common);
  INFO(displaced.out << displaced.err);
  REQUIRE(displaced.status == 0);
  CHECK(displaced.err.empty());
  const Run undisplaced = run("render " + plain + common);
  INFO(undisplaced.out << undisplaced.err);
  REQUIRE(undisplaced.status == 0);
  CHECK(undisplaced.err == "oblong: warning: --heatmap " + heat +
                               ": no camera ray took a traversal step (the scene has no displaced mesh; undisplaced "
                               "meshes are plain triangles): the map is black\n");
  CHECK(std::filesystem::exists(heat));  // written all the same, as asked
  // Kept under -q; the tessellated baseline counts no steps either.
  const Run tess = run("render" + common + " --baseline tessellated -q");
  INFO(tess.out << tess.err);
  REQUIRE(tess.status == 0);
  CHECK(tess.out.empty());
  CHECK(lines(tess.err) == 1);
  CHECK_THAT(tess.err, Catch::Contains("--baseline tessellated traces plain triangles"));
}

namespace {

// The options `oblong [SUB] --help` lists, each as its names ("-o", "--output").
std::vector<std::vector<std::string>> helpOptions(const std::string& sub) {
  const Run h = run(sub + " --help");
  REQUIRE(h.status == 0);
  std::vector<std::vector<std::string>> opts;
  std::istringstream in(h.out);
  for (std::string line; std::getline(in, line);) {
    const size_t b = line.find_first_not_of(' ');
    if (b == std::string::npos || b == 0 || line[b] != '-') continue;
    std::vector<std::string> names;
    std::string word = line.substr(b, line.find(' ', b) - b);
    for (size_t s = 0; s != std::string::npos;) {
      const size_t c = word.find(',', s);
      names.push_back(word.substr(s, c == std::string::npos ? c : c - s));
      s = c == std::string::npos ? c : c + 1;
    }
    if (names.back() != "--help") opts.push_back(names);
  }
  return opts;
}

// The option names (-x, --xyz) in `text`.
std::vector<std::string> optionWords(const std::string& text) {
  std::vector<std::string> out;
  for (size_t i = 0; i < text.size(); ++i) {
    const bool start = text[i] == '-' && (i == 0 || text[i - 1] == ' ' || text[i - 1] == '[');
    if (!start) continue;
    size_t e = i + 1;
    while (e < text.size() && (std::isalnum((unsigned char)text[e]) || text[e] == '-')) ++e;
    const std::string w = text.substr(i, e - i);
    const size_t letter = w.find_first_not_of('-');
    if (letter != std::string::npos && letter <= 2 && std::isalpha((unsigned char)w[letter])) out.push_back(w);
    i = e;
  }
  return out;
}

}  // namespace

TEST_CASE("the README's usage block lists every option --help lists, and no other", "[cli][docs]") {
  // The indented block under "## Using it": one entry per "./build/oblong ..." line (with
  // its continuation lines) and the "strategy flags:" and "mesh flags:" entries.
  std::istringstream readme(oblong::test::slurp(std::string(OBLONG_SOURCE_DIR) + "/README.md"));
  std::vector<std::string> entries;
  bool inSection = false;
  for (std::string line; std::getline(readme, line);) {
    if (line.rfind("## ", 0) == 0) {
      if (inSection) break;
      inSection = line == "## Using it";
      continue;
    }
    if (!inSection) continue;
    if (!line.empty() && line[0] != ' ') {
      if (!entries.empty()) break;  // the block ended
      continue;
    }
    const size_t b = line.find_first_not_of(' ');
    if (b == std::string::npos) continue;
    const std::string text = line.substr(b);
    if (text.rfind("./build/oblong ", 0) == 0 || text.rfind("strategy flags:", 0) == 0 ||
        text.rfind("mesh flags:", 0) == 0)
      entries.push_back(text);
    else if (!entries.empty())
      entries.back() += " " + text;
  }
  INFO("README usage block:\n" << [&] {
    std::string s;
    for (const auto& e : entries) s += e + "\n";
    return s;
  }());
  std::string strategyFlags, meshFlags;
  for (const auto& e : entries) {
    if (e.rfind("strategy flags:", 0) == 0) strategyFlags = e;
    if (e.rfind("mesh flags:", 0) == 0) meshFlags = e;
  }
  REQUIRE(!strategyFlags.empty());
  REQUIRE(!meshFlags.empty());
  auto usage = [&](const std::string& sub) {
    std::string s;
    for (const auto& e : entries)
      if (e.rfind("./build/oblong " + sub, 0) == 0) s += e.substr(e.find(sub) + sub.size()) + " ";
    if (s.find("[strategy flags]") != std::string::npos) s += strategyFlags.substr(15) + " ";
    if (s.find("[mesh flags]") != std::string::npos) s += meshFlags.substr(11);
    return s;
  };
  // The top level: --version has its line, every command has its entry.
  CHECK(usage("--version").size() > 0);
  for (const char* sub : {"render", "trace", "info", "bake", "export", "compare"}) {
    INFO("oblong " << sub);
    const std::string text = usage(sub);
    REQUIRE(!text.empty());
    const auto opts = helpOptions(sub);
    CHECK(opts.size() > 1);
    const auto words = optionWords(text);
    for (const auto& names : opts) {
      INFO("--help lists " << names.back());
      CHECK(std::any_of(names.begin(), names.end(),
                        [&](const std::string& n) { return std::find(words.begin(), words.end(), n) != words.end(); }));
    }
    for (const std::string& w : words) {
      INFO("the README lists " << w);
      CHECK(std::any_of(opts.begin(), opts.end(),
                        [&](const auto& names) { return std::find(names.begin(), names.end(), w) != names.end(); }));
    }
  }
}

TEST_CASE("oblong export writes a PLY and refuses what it cannot write with one line", "[cli][export]") {
  const auto dir = oblong::test::scratchDir("cli_export");
  std::vector<float> v(16 * 16);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float(i % 5) / 4.0f;
  oblong::test::writeGray((dir / "map.png").string(), 16, 16, v, OIIO::TypeDesc::UINT8);
  const std::string scene = (dir / "scene.json").string(), big = (dir / "big.json").string();
  std::ofstream(scene) << R"({"meshes": [{"shape": {"type": "plane", "size": 2},
                             "displacement": {"map": "map.png", "scale": 0.1}},
                            {"shape": {"type": "plane", "size": 4}, "transform": {"translate": [0, -1, 0]}}]})";
  std::ofstream(big) << R"({"meshes": [{"shape": {"type": "plane"},
                           "displacement": {"map": "map.png", "scale": 0.1, "tiling": 4096}}]})";
  const std::string ply = (dir / "out.ply").string();
  auto has = [](const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; };
  auto oneLine = [](const Run& r, const std::vector<std::string>& words) {
    INFO(r.out << r.err);
    CHECK(r.status == 1);
    CHECK(lines(r.err) == 1);
    CHECK(r.err.rfind("oblong: ", 0) == 0);
    for (const std::string& w : words) CHECK(r.err.find(w) != std::string::npos);
  };
  // The micro-triangles the summary line reports.
  auto microTriangles = [](const std::string& out) {
    std::smatch m;
    REQUIRE(std::regex_search(out, m, std::regex(R"(: (\d+) micro-triangles of 1 displaced mesh)")));
    return std::stoul(m[1]);
  };

  const Run r = run("export " + scene + " -o " + ply);
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(has(r.out, "oblong export: " + scene + " -> " + ply + ": "));
  CHECK(has(r.out, " micro-triangles of 1 displaced mesh, 2 triangles of 1 plain mesh, "));
  const size_t n = microTriangles(r.out) + 2;
  CHECK(n > 2 * 15 * 15);  // at least the 15x15 cells between the 16x16 samples, two each
  // The header, three float x y z u v vertices and one face per triangle, nothing else.
  const std::string text = oblong::test::slurp(ply);
  const size_t body = text.find("end_header\n");
  REQUIRE(body != std::string::npos);
  CHECK(text.size() == body + 11 + n * (3 * 20 + 13));
  CHECK(has(text, "format binary_little_endian 1.0\n"));
  CHECK(has(text, fmt::format("element vertex {}\n", 3 * n)));
  CHECK(has(text, fmt::format("element face {}\n", n)));
  CHECK(has(r.out, fmt::format("{} vertices", 3 * n)));
  // Level 1 of a 16x16 map has 8x8 samples: about a quarter of the micro-triangles.
  const Run lod = run("export " + scene + " --lod 1 -o " + ply);
  INFO(lod.out << lod.err);
  REQUIRE(lod.status == 0);
  CHECK(has(lod.out, " micro-triangles of 1 displaced mesh at level of detail 1, 2 triangles"));
  CHECK(microTriangles(lod.out) < (n - 2) / 3);

  oneLine(run("export " + scene), {"--output is required"});
  oneLine(run("export " + scene + " -o " + (dir / "out.obj").string()), {"out.obj", "use a .ply name"});
  oneLine(run("export " + scene + " --lod cone -o " + ply), {"--lod", "an export holds one surface"});
  oneLine(run("export " + scene + " -o " + scene), {"scene.json", "use a .ply name"});
  // A scene without displaced meshes; its export, loaded as a mesh, is an input of a
  // scene that uses it.
  const std::string plain = (dir / "plain.json").string(), reuse = (dir / "reuse.json").string(),
                    plainPly = (dir / "plain.ply").string();
  std::ofstream(plain) << R"({"meshes": [{"shape": {"type": "plane", "segments": 2}}]})";
  const Run p = run("export " + plain + " -o " + plainPly);
  INFO(p.out << p.err);
  CHECK(p.status == 0);
  CHECK(has(p.out, ": 0 micro-triangles of 0 displaced meshes, 8 triangles of 1 plain mesh, 24 vertices, "));
  std::ofstream(reuse) << R"({"meshes": [{"file": "plain.ply"}]})";
  oneLine(run("export " + reuse + " -o " + plainPly), {"names an input of this command (mesh"});
  oneLine(run("export " + scene + " -o " + (dir / "nosuch" / "x.ply").string()), {"does not exist"});
  // Refused before anything is written: an earlier file stays as it was.
  std::ofstream(ply) << "earlier";
  oneLine(run("export " + big + " -o " + ply), {big + ": the export needs ", "uint32 indices", "try --lod "});
  CHECK(oblong::test::slurp(ply) == "earlier");
  // A device is written through from a copy: a failed write is one line, and the copy
  // is checked against the memory like every structure.
  oneLine(run("export " + scene + " -o /dev/full"), {"/dev/full", "write failed"});
  ::setenv("OBLONG_MEMORY_LIMIT", "1K", 1);
  const Run mem = run("export " + scene + " -o /dev/null");
  ::unsetenv("OBLONG_MEMORY_LIMIT");
  oneLine(mem, {scene + ": writing the export through to /dev/null needs ", "OBLONG_MEMORY_LIMIT"});
}

namespace {

// An image's pixels as 8-bit RGB (what a viewer shows), row-major.
struct Pixels {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
  std::array<uint8_t, 3> at(int x, int y) const {
    const size_t i = (size_t(y) * width + x) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

Pixels readPixels(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  REQUIRE(in);
  Pixels p;
  p.width = in->spec().width, p.height = in->spec().height;
  p.rgb.resize(size_t(p.width) * p.height * 3);
  REQUIRE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, p.rgb.data()));
  return p;
}

std::vector<float> readChannel(const std::string& exr, int channel) {
  auto in = OIIO::ImageInput::open(exr);
  REQUIRE(in);
  const OIIO::ImageSpec spec = in->spec();
  std::vector<float> v(size_t(spec.width) * spec.height);
  REQUIRE(in->read_image(0, 0, channel, channel + 1, OIIO::TypeDesc::FLOAT, v.data()));
  return v;
}

// The colour bar's text rows (below the gradient strip) hold numbers: bright glyph pixels
// on the black background, not one uniform colour.
void checkBarHasText(const Pixels& p, int mapHeight) {
  int bright = 0, black = 0;
  const int strip = std::max(6, std::clamp(p.width / 28, 9, 18));
  for (int y = mapHeight + strip + 4; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x) {
      const auto c = p.at(x, y);
      bright += c[0] > 200 && c[1] > 200 && c[2] > 200;
      black += c[0] == 0 && c[1] == 0 && c[2] == 0;
    }
  CHECK(bright > 20);
  CHECK(black > p.width);
}

}  // namespace

TEST_CASE("oblong render --heatmap-max fixes the heat map's scale, and the colour bar is numbered", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_heatmap_max");
  auto path = [&](const std::string& n) { return (dir / n).string(); };
  const std::string common = " --size 96x64 --threads 2 --integrator primary -q";
  // Two runs with different work per pixel, both on the scale 0 .. 400.
  const Run a = run("render" + common + " -o " + path("a.png") + " --aovs " + path("a.exr") + " --heatmap " +
                    path("ha.png") + " --heatmap-max 400");
  const Run b = run("render" + common + " --marching-scale 1 -o " + path("b.png") + " --aovs " + path("b.exr") +
                    " --heatmap " + path("hb.png") + " --heatmap-max 400 --stats " + path("b.json"));
  const Run own = run("render" + common + " -o " + path("c.png") + " --heatmap " + path("hc.png"));
  INFO(a.err << b.err << own.err);
  REQUIRE(a.status == 0);
  REQUIRE(b.status == 0);
  REQUIRE(own.status == 0);
  CHECK(a.err.empty());
  const std::vector<float> sa = readChannel(path("a.exr"), 7), sb = readChannel(path("b.exr"), 7);
  REQUIRE(readChannel(path("a.exr"), 7).size() == 96 * 64);
  const Pixels ha = readPixels(path("ha.png")), hb = readPixels(path("hb.png")), hc = readPixels(path("hc.png"));
  REQUIRE(ha.width == 96);
  REQUIRE(ha.height > 64);
  CHECK(ha.height == hb.height);
  // The same step count has the same colour in both maps, whatever else differs.
  std::map<int, std::array<uint8_t, 3>> colour;
  for (int i = 0; i < 96 * 64; ++i) colour[int(sa[i])] = ha.at(i % 96, i / 96);
  int shared = 0, differ = 0;
  float maxA = 0;
  for (int i = 0; i < 96 * 64; ++i) {
    maxA = std::max(maxA, sa[i]);
    const auto it = colour.find(int(sb[i]));
    if (it == colour.end()) continue;
    ++shared;
    CHECK(it->second == hb.at(i % 96, i / 96));
  }
  CHECK(shared > 96 * 64 / 2);
  // Scaled to its own maximum (< 400), the same run's map is brighter where it took steps.
  REQUIRE(maxA < 400);
  for (int i = 0; i < 96 * 64; ++i)
    if (sa[i] > 0) differ += ha.at(i % 96, i / 96) != hc.at(i % 96, i / 96);
  CHECK(differ > 0);
  // No step is black; the top of the scale is the bar's last colour.
  for (int i = 0; i < 96 * 64; ++i)
    if (sa[i] == 0) CHECK(ha.at(i % 96, i / 96) == (std::array<uint8_t, 3>{0, 0, 0}));
  checkBarHasText(ha, 64);
  checkBarHasText(hc, 64);
  // The scale used is recorded.
  const auto j = nlohmann::json::parse(std::ifstream(path("b.json")));
  CHECK(j.at("heatmap").at("scale_max") == 400);
  CHECK(j.at("heatmap").at("fixed") == true);
  CHECK(j.at("heatmap").at("image_max").get<float>() > 0);
  const Run shown = run("render --size 32x24 --threads 1 --integrator primary -o " + path("d.png") + " --heatmap " +
                        path("hd.png") + " --heatmap-max 7");
  INFO(shown.out);
  CHECK_THAT(shown.out, Catch::Contains("colour bar 0 .. 7 (--heatmap-max; the image's largest"));
  // Refused before any work, one line each.
  for (const std::string& bad : {std::string(" --heatmap-max 10"), " --heatmap " + path("he.png") + " --heatmap-max 0",
                                 " --heatmap " + path("he.png") + " --heatmap-max -3"}) {
    const Run r = run("render --size 8x8 -o " + path("e.png") + bad);
    INFO(bad << ": " << r.err);
    CHECK(r.status == 1);
    CHECK(lines(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("oblong: --heatmap-max: "));
  }
}

TEST_CASE("oblong compare prints relMSE and PSNR, writes an error image and refuses mismatched sizes", "[cli]") {
  const auto dir = oblong::test::scratchDir("cli_compare");
  auto path = [&](const std::string& n) { return (dir / n).string(); };
  // Grey 2x2 images: the reference 0.5 everywhere, the image off by 0, 0.1, -0.1 and 0.3.
  oblong::test::writeGray(path("ref.exr"), 2, 2, {0.5f, 0.5f, 0.5f, 0.5f}, OIIO::TypeDesc::FLOAT);
  oblong::test::writeGray(path("img.exr"), 2, 2, {0.5f, 0.6f, 0.4f, 0.8f}, OIIO::TypeDesc::FLOAT);
  oblong::test::writeGray(path("wide.exr"), 3, 2, std::vector<float>(6, 0.5f), OIIO::TypeDesc::FLOAT);
  // relMSE = (0 + 0.01 + 0.01 + 0.09) / 4 / (0.25 + 0.01) = 0.105769...; MSE = 0.11 / 4 = 0.0275,
  // PSNR = 10 log10(1 / 0.0275) = 15.6067 dB.
  const Run j = run("compare " + path("img.exr") + " " + path("ref.exr") + " --json -o " + path("err.exr"));
  INFO(j.out << j.err);
  REQUIRE(j.status == 0);
  CHECK(j.err.empty());
  const auto k = nlohmann::json::parse(j.out);
  CHECK(k.at("relmse").get<double>() == Approx(0.11 / 4 / 0.26).epsilon(1e-5));
  CHECK(k.at("mse").get<double>() == Approx(0.0275).epsilon(1e-5));
  CHECK(k.at("psnr_db").get<double>() == Approx(15.6067).epsilon(1e-4));
  CHECK(k.at("width") == 2);
  // The float error image holds each pixel's relative squared error.
  const std::vector<float> e = readChannel(path("err.exr"), 0);
  REQUIRE(e.size() == 4);
  CHECK(e[0] == 0.0f);
  CHECK(e[1] == Approx(0.01 / 0.26).epsilon(1e-4));
  CHECK(e[3] == Approx(0.09 / 0.26).epsilon(1e-4));
  // The text summary states the definitions; identical images have an infinite PSNR.
  const Run t = run("compare " + path("img.exr") + " " + path("img.exr"));
  INFO(t.out);
  REQUIRE(t.status == 0);
  CHECK_THAT(t.out, Catch::Contains("relMSE   : 0 (mean over pixels and RGB of (a-b)^2/(b^2+0.01)"));
  CHECK_THAT(t.out, Catch::Contains("PSNR     : inf"));
  // A false-colour error image with a numbered bar; --max fixes its scale.
  const std::string big = path("big.exr"), bigRef = path("bigref.exr");
  std::vector<float> v(128 * 32), r(128 * 32, 0.5f);
  for (size_t i = 0; i < v.size(); ++i) v[i] = 0.5f + 0.3f * float(i % 128) / 127.0f;
  oblong::test::writeGray(big, 128, 32, v, OIIO::TypeDesc::FLOAT);
  oblong::test::writeGray(bigRef, 128, 32, r, OIIO::TypeDesc::FLOAT);
  const Run png = run("compare " + big + " " + bigRef + " -o " + path("err.png") + " --max 1");
  INFO(png.out << png.err);
  REQUIRE(png.status == 0);
  CHECK_THAT(png.out, Catch::Contains("colour bar 0.001 .. 1 (--max;"));
  const Pixels p = readPixels(path("err.png"));
  CHECK(p.width == 128);
  CHECK(p.height > 32);
  CHECK(p.at(0, 10) == (std::array<uint8_t, 3>{0, 0, 0}));  // no error: black
  CHECK(p.at(127, 10) != p.at(64, 10));
  checkBarHasText(p, 32);
  // Mismatched sizes, a missing file, a bad --max: one line naming the problem, exit 1.
  auto oneLine = [](const Run& x, const std::string& what) {
    INFO(x.out << x.err);
    CHECK(x.status == 1);
    CHECK(lines(x.err) == 1);
    CHECK_THAT(x.err, Catch::StartsWith("oblong: ") && Catch::Contains(what));
  };
  const Run m = run("compare " + path("wide.exr") + " " + path("ref.exr"));
  oneLine(m, path("wide.exr") + ": is 3x2, the reference " + path("ref.exr") + " is 2x2");
  CHECK(m.out.empty());
  oneLine(run("compare " + path("missing.exr") + " " + path("ref.exr")), path("missing.exr") + ": file not found");
  oneLine(run("compare " + path("img.exr") + " " + path("ref.exr") + " -o " + path("e2.png") + " --max 0"), "--max");
  oneLine(run("compare " + path("img.exr") + " " + path("ref.exr") + " -o " + path("ref.exr")),
          "names an input of this command");
  oneLine(run("compare " + path("img.exr") + " " + path("ref.exr") + " --max 1"), "--max: applies to the error image");
  CHECK(!std::filesystem::exists(path("e2.png")));
}
