// The memory budget (core/memory.h): the estimates every structure is checked with
// before it is allocated equal what it then builds, and a structure that does not fit
// is refused with one line saying what it needs and what would fit.
#include "core/error.h"
#include "core/memory.h"
#include "core/procedural.h"
#include "render/embree_scene.h"
#include "strategies/minmax_mipmap.h"
#include "strategies/range_query.h"
#include "strategies/rmip.h"
#include "strategies/safety_zones.h"
#include "test_util.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include <cstdlib>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <sys/wait.h>

using namespace oblong;
using nlohmann::json;
using Catch::Matchers::Contains;

namespace {

// Sets OBLONG_MEMORY_LIMIT for one scope and restores what was there.
class MemoryLimit {
 public:
  explicit MemoryLimit(const char* value) {
    if (const char* old = std::getenv("OBLONG_MEMORY_LIMIT")) old_ = old;
    if (value) ::setenv("OBLONG_MEMORY_LIMIT", value, 1);
    else ::unsetenv("OBLONG_MEMORY_LIMIT");
  }
  ~MemoryLimit() {
    if (old_) ::setenv("OBLONG_MEMORY_LIMIT", old_->c_str(), 1);
    else ::unsetenv("OBLONG_MEMORY_LIMIT");
  }

 private:
  std::optional<std::string> old_;
};

std::shared_ptr<HeightMap> randomMap(int W, int H, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> t(size_t(W) * H);
  for (float& v : t) v = u(rng);
  return std::make_shared<HeightMap>(W, H, std::move(t), fmt::format("map{}x{}.png", W, H));
}

std::unique_ptr<RangeQuery> make(const std::string& name, const json& params, const Displacement& d,
                                 const QueryNeeds& needs) {
  ParamSet ps(params, "strategies.range");
  return createRangeQuery(name, ps, {d, needs});
}

// The message of the oblong::Error that f throws ("" when it throws none).
template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::vector<QueryNeeds> needsFor(const HeightMap& m) {
  return {QueryNeeds::all(m), {4, 3, false}, {m.width() / 2 + 1, 2, true}, {1, 1, false}, {m.width() + 1, 1, false}};
}

}  // namespace

TEST_CASE("byte sizes parse with K/M/G/T suffixes and print with three digits", "[memory][unit]") {
  CHECK(parseByteSize("0") == size_t(0));
  CHECK(parseByteSize("1234") == size_t(1234));
  CHECK(parseByteSize("512K") == size_t(512) << 10);
  CHECK(parseByteSize("64m") == size_t(64) << 20);
  CHECK(parseByteSize("16G") == size_t(16) << 30);
  CHECK(parseByteSize("1.5 GiB") == size_t(3) << 29);
  CHECK(parseByteSize("2TB") == size_t(2) << 40);
  CHECK(parseByteSize(" 7 B ") == size_t(7));
  for (const char* bad : {"", "G", "-1", "1.2.3", "12 parsecs", "1e9", ".5G", "99999999999T"})
    CHECK_FALSE(parseByteSize(bad).has_value());
  CHECK(humanBytes(980) == "980 B");
  CHECK(humanBytes(size_t(716) << 20) == "716 MiB");
  CHECK(humanBytes(size_t(9) << 29) == "4.50 GiB");
  CHECK(humanBytes(size_t(18) << 30) == "18.0 GiB");
}

TEST_CASE("OBLONG_MEMORY_LIMIT replaces the measured available memory", "[memory][unit]") {
  {
    MemoryLimit none(nullptr);
    const size_t avail = availableMemoryBytes();
    CHECK(avail > (size_t(16) << 20));  // a machine that runs the tests has more than this
    CHECK(structureBudgetBytes() <= avail);
  }
  {
    MemoryLimit lim("100M");
    CHECK(availableMemoryBytes() == size_t(100) << 20);
    CHECK(structureBudgetBytes() == size_t(double(size_t(100) << 20) * kStructureShare));
    CHECK(fitsInMemory(size_t(70) << 20));
    CHECK_FALSE(fitsInMemory(size_t(90) << 20));
    CHECK_NOTHROW(checkFits("x", "y", size_t(70) << 20, "hint"));
    const std::string msg = errorOf([] { checkFits("MAP", "thing", size_t(90) << 20, "try less", "what it is"); });
    CHECK(msg == "MAP: thing needs 90.0 MiB (what it is) but 80.0 MiB may be used (80% of the 100 MiB of memory "
                 "that OBLONG_MEMORY_LIMIT allows); try less");
  }
  {
    MemoryLimit bad("lots");
    CHECK_THROWS_WITH(availableMemoryBytes(), Contains("OBLONG_MEMORY_LIMIT") && Contains("'lots'"));
  }
}

TEST_CASE("range-query estimates equal the bytes of the built structures", "[memory][range_query][rmip][minmax_mipmap][safety_zones]") {
  MemoryLimit none(nullptr);
  for (auto [W, H] : std::vector<std::pair<int, int>>{{1, 1}, {3, 7}, {64, 64}, {100, 37}, {257, 130}, {1024, 1024}}) {
    const auto map = randomMap(W, H, uint32_t(W * 31 + H));
    const Displacement d{map, 0.5f, 0.1f, vec2(1.0f)};
    for (const QueryNeeds& needs : needsFor(*map)) {
      INFO(W << "x" << H << " needs " << needs.maxExtentX << "x" << needs.maxExtentY << " wrap " << needs.wrap);
      for (int res : {0, std::max(W, H) / 2, 7})
        for (int comp : {-1, 0, 1, 2, 99})  // -1: "pairs"
          for (int bits : {16, 32}) {
            // Uncompressed 1024^2: ~1 GB; on that map one "corners" case is enough.
            if (W * H > 1 << 16 && (comp == 99 || comp == 0 || comp == 2)) continue;
            INFO("resolution " << res << " compression " << comp << " bits " << bits);
            const Rmip::Options o{.resolution = res, .compression = std::max(comp, 0),
                                  .layout = comp < 0 ? Rmip::Scheme::Pairs : Rmip::Scheme::Corners, .bits = bits};
            json params{{"resolution", res}, {"bits", bits}, {"layout", comp < 0 ? "pairs" : "corners"}};
            if (comp >= 0) params["compression"] = comp;
            const auto rq = make("rmip", params, d, needs);
            const Rmip::Layout L = Rmip::layout(W, H, needs, o);
            CHECK(L.bytes() == rq->bytes());
            const auto* r = dynamic_cast<const Rmip*>(rq.get());
            REQUIRE(r);
            CHECK(L.rw == r->resolutionX());
            CHECK(L.P + 1 == r->layersX());
            const size_t entryBytes = bits == 16 ? 4 : 8;
            // Layers are stored in whole 4 x 4 tiles; the tiling pass copies the largest.
            size_t largest = 0, stored = 0;
            for (const Rmip::Layer& l : L.layers) {
              const size_t n = (size_t(l.nx) + 3) / 4 * ((size_t(l.ny) + 3) / 4) * 16;
              largest = std::max(largest, n);
              stored += n;
            }
            CHECK(stored == L.entries);
            if (comp < 0)
              CHECK(L.buildBytes() == L.bytes() + std::max(size_t(L.rh) * ((L.rw + 1) / 2), largest) * entryBytes);
            else
              CHECK(L.buildBytes() == L.bytes() + 4 * size_t(L.rw) * L.rh * sizeof(Interval) +
                                          (bits == 16 ? L.entries * sizeof(Interval) : 0) + largest * sizeof(Interval));
          }
      CHECK(MinMaxMipmap::layout(W, H, needs).bytes() == make("minmax_mipmap", json::object(), d, needs)->bytes());
      CHECK(MinMaxMipmap::layout(W, H, needs, 16).bytes() ==
            make("minmax_mipmap", {{"bits", 16}}, d, needs)->bytes());
      CHECK(SafetyZones::bytes(W, H, SafetyZones::resolveDeltas(W, H, needs, {}).size(), 16) ==
            make("safety_zones", {{"bits", 16}}, d, needs)->bytes());
      CHECK(SafetyZones::bytes(W, H, SafetyZones::resolveDeltas(W, H, needs, {}).size()) ==
            make("safety_zones", json::object(), d, needs)->bytes());
      const std::vector<int> custom{5, 1, 1, 3};
      CHECK(SafetyZones::resolveDeltas(W, H, needs, custom) == std::vector<int>{1, 3, 5});
      CHECK(SafetyZones::bytes(W, H, 3) == make("safety_zones", {{"deltas", custom}}, d, needs)->bytes());
    }
  }
}

TEST_CASE("a range query that does not fit is refused in one line with what would fit", "[memory][range_query][rmip][minmax_mipmap][safety_zones][unit]") {
  const auto map = randomMap(1024, 1024, 7);
  const Displacement d{map, 0.5f, 0.0f, vec2(1.0f)};
  const QueryNeeds needs = QueryNeeds::all(*map);
  // rmip "corners" (compression 1, 16-bit) at full resolution: 36 MiB of codes + 32 MiB
  // of row/column scratch + 72 MiB of float entries before encoding; the budget is 51 MiB.
  const json corners{{"layout", "corners"}};
  const Rmip::Options cornersO{.layout = Rmip::Scheme::Corners};
  const size_t full = Rmip::layout(1024, 1024, needs, cornersO).buildBytes();
  MemoryLimit lim("64M");
  REQUIRE(!fitsInMemory(full));

  const std::string msg = errorOf([&] { make("rmip", corners, d, needs); });
  INFO(msg);
  CHECK(msg.find('\n') == std::string::npos);
  CHECK_THAT(msg, Contains("map1024x1024.png: rmip needs " + humanBytes(full)) && Contains("1024x1024 pixels") &&
                      Contains("may be used") && Contains("64.0 MiB") && Contains("OBLONG_MEMORY_LIMIT"));
  // The largest lower resolution that fits (512), the default layout and the mipmap.
  Rmip::Options halfO = cornersO;
  halfO.resolution = 512;
  const size_t half = Rmip::layout(1024, 1024, needs, halfO).buildBytes();
  const size_t pairs = Rmip::layout(1024, 1024, needs, {}).buildBytes();
  CHECK_THAT(msg, Contains(fmt::format("try \"resolution\": 512 ({})", humanBytes(half))) &&
                      Contains(fmt::format("\"layout\": \"pairs\", \"bits\": 16 ({})", humanBytes(pairs))) &&
                      Contains(fmt::format("--range minmax_mipmap ({})",
                                           humanBytes(MinMaxMipmap::layout(1024, 1024, needs).bytes()))));
  // What the hint offers builds under the same limit.
  CHECK(make("rmip", {{"layout", "corners"}, {"resolution", 512}}, d, needs)->bytes() > 0);
  CHECK(make("rmip", json::object(), d, needs)->bytes() > 0);
  CHECK(make("minmax_mipmap", {{"bits", 16}}, d, needs)->bytes() > 0);
  // Safety zones: nine 8 MiB maps + one to build them; five deltas fit.
  const std::string sz = errorOf([&] { make("safety_zones", json::object(), d, needs); });
  INFO(sz);
  CHECK(sz.find('\n') == std::string::npos);
  CHECK_THAT(sz, Contains("safety_zones needs") && Contains("\"deltas\": [1, 2, 4, 8, 16] in") &&
                     Contains("--range minmax_mipmap"));
  // In 1 MiB (0.8 MiB to use) a 256x256-pixel rmip fits (384 KiB + 128 KiB scratch).
  {
    MemoryLimit tiny("1M");
    const std::string mm = errorOf([&] { make("minmax_mipmap", json::object(), d, needs); });
    CHECK_THAT(mm, Contains("minmax_mipmap needs") && Contains("try --range rmip with \"resolution\": 256"));
    const std::string rm = errorOf([&] { make("rmip", json::object(), d, needs); });
    CHECK_THAT(rm, Contains("rmip needs") && !Contains("\"layout\"") && Contains("try \"resolution\": 256"));
  }
}

namespace {

Scene displacedScene(Mesh mesh, std::shared_ptr<const HeightMap> map, vec2 tiling) {
  Scene s;
  s.path = "memory_test.json";
  SceneMesh m;
  m.mesh = std::move(mesh);
  m.displacement = Displacement{std::move(map), 0.1f, -0.5f, tiling};
  s.meshes.push_back(std::move(m));
  return s;
}

size_t part(const MemoryReport& r, const std::string& name) {
  for (const auto& m : r)
    if (m.name == name) return m.bytes;
  return 0;
}

}  // namespace

TEST_CASE("the tessellation estimate counts the micro-triangles the baseline builds", "[memory][render][tessellated][unit]") {
  MemoryLimit none(nullptr);
  auto odd = std::make_shared<const HeightMap>(proceduralHeightMap(61, 47, 9));
  auto square = std::make_shared<const HeightMap>(proceduralHeightMap(128, 128, 3));
  std::vector<Scene> scenes;
  scenes.push_back(displacedScene(planeMesh(vec2(2.0f), ivec2(1)), square, vec2(1.0f)));
  scenes.push_back(displacedScene(planeMesh(vec2(2.0f), ivec2(5, 3), vec2(-0.3f, 0.1f), vec2(1.7f, 0.9f)), odd,
                                  vec2(3.0f, 2.0f)));
  scenes.push_back(displacedScene(torusMesh(1.0f, 0.4f, 24, 12), odd, vec2(3.0f, 2.0f)));
  scenes.push_back(displacedScene(sphereMesh(1.0f, 16, 8), square, vec2(1.0f)));
  for (const Scene& s : scenes) {
    const SceneMesh& sm = s.meshes[0];
    INFO(sm.mesh.name << " " << sm.mesh.triangles.size() << " triangles");
    const TessellationEstimate e = estimateTessellation(sm.mesh, *sm.displacement);
    const EmbreeScene accel(s, AccelOptions::withBaseline("tessellated"));
    const MemoryReport mem = accel.memory();
    // Exact: the micro-triangles, and the buffers sized by them.
    CHECK(e.microTriangles == accel.microTriangles());
    CHECK(part(mem, "mesh/indices") == e.microTriangles * sizeof(glm::uvec3));
    CHECK(part(mem, "tessellated/base_prim") == e.microTriangles * sizeof(uint32_t));
    // The shared vertices: a bound (grid points on a base edge count once per grid line
    // through them), a few percent over on these small maps, under 1% at 8192^2.
    const size_t vertices = part(mem, "mesh/uvs") / sizeof(vec2);
    INFO("vertices " << vertices << ", estimated " << e.vertices);
    CHECK(part(mem, "mesh/vertices") == (vertices + 1) * sizeof(vec4));
    CHECK(e.vertices >= vertices);
    CHECK(double(e.vertices) <= 1.05 * double(vertices) + 64);
    const size_t geometry = part(mem, "mesh/vertices") + part(mem, "mesh/uvs") + part(mem, "mesh/indices") +
                            part(mem, "tessellated/base_prim");
    CHECK(geometry <= e.geometryBytes());
    // Embree's BVH against the measured factor.
    const size_t bvh = part(mem, "embree/bvh");
    INFO("bvh " << bvh << " bytes, estimated " << e.bvhBytes());
    CHECK(double(bvh) <= 1.25 * double(e.bvhBytes()) + (1 << 20));
  }
}

TEST_CASE("a tessellation that does not fit is refused before it is built", "[memory][render][tessellated]") {
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(256, 256, 5));
  const Scene s = displacedScene(planeMesh(vec2(2.0f), ivec2(1)), map, vec2(1.0f));
  const TessellationEstimate e = estimateTessellation(s.meshes[0].mesh, *s.meshes[0].displacement);
  const size_t peak = tessellationPeakBytes({e}, 64);
  CHECK(peak > e.geometryBytes() + e.bvhBytes());
  // 12 MiB: the traversal's rmip (4.6 + 2 MiB) fits, the 130 K micro-triangles do not.
  MemoryLimit lim("12M");
  REQUIRE(!fitsInMemory(peak));
  const std::string msg = errorOf([&] { const EmbreeScene a(s, AccelOptions::withBaseline("tessellated")); });
  INFO(msg);
  CHECK(msg.find('\n') == std::string::npos);
  CHECK_THAT(msg, Contains("memory_test.json: meshes[0] (map ") && Contains("--baseline tessellated needs") &&
                      Contains(fmt::format("{} micro-triangles", e.microTriangles)) &&
                      Contains("leave out --baseline tessellated"));
  CHECK(errorOf([&] { const EmbreeScene a(s, AccelOptions{}); }).empty());
}

namespace {

struct Run {
  int status;
  std::string err;
};

Run runOblong(const std::string& env, const std::string& args) {
  const auto dir = test::scratchDir("memory");
  const std::string e = (dir / "stderr.txt").string();
  const std::string cmd = env + " " + std::string(OBLONG_BINARY) + " " + args + " >/dev/null 2>" + e;
  const int raw = std::system(cmd.c_str());
  std::ifstream f(e);
  std::stringstream ss;
  ss << f.rdbuf();
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, ss.str()};
}

}  // namespace

TEST_CASE("oblong info and render refuse what does not fit with one line and exit 1", "[memory][cli]") {
  const auto dir = test::scratchDir("memory");
  const std::string png = (dir / "map256.png").string(), scene = (dir / "plane.json").string();
  std::vector<float> v(256 * 256);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float((i * 2654435761u) % 1000) / 1000.0f;
  test::writeGray(png, 256, 256, v, OIIO::TypeDesc::UINT16);
  std::ofstream(scene) << json{{"meshes", {{{"shape", {{"type", "plane"}}},
                                            {"displacement", {{"map", png}, {"scale", 0.1}}}}}}}.dump();
  const std::string out = (dir / "out.png").string();
  const std::string render = "render " + scene + " --size 8x8 -q -o " + out;

  // The default rmip of a 256^2 map takes 384 KiB (+ 128 KiB while building): 256K refuses it.
  Run r = runOblong("OBLONG_MEMORY_LIMIT=256K", "info " + scene);
  INFO(r.err);
  CHECK(r.status == 1);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK_THAT(r.err, Contains("oblong: " + png + ": rmip needs") && Contains("may be used"));

  r = runOblong("OBLONG_MEMORY_LIMIT=12M", render + " --baseline tessellated");
  INFO(r.err);
  CHECK(r.status == 1);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK_THAT(r.err, Contains("oblong: " + scene + ": meshes[0] (map " + png + "): --baseline tessellated needs"));

  r = runOblong("OBLONG_MEMORY_LIMIT=12M", render);
  INFO(r.err);
  CHECK(r.status == 0);

  r = runOblong("OBLONG_MEMORY_LIMIT=12parsecs", "info " + scene);
  CHECK(r.status == 1);
  CHECK_THAT(r.err, Contains("oblong: OBLONG_MEMORY_LIMIT: expected bytes"));
}
