// The registries (core/registry.h) as the programs see them: the tessellated baseline
// registered where it is built, the oblong binary's help and strategy list, a name
// registered twice refused, and the opt-in static traversal instantiation answering
// exactly as the generic path. Throwaway example strategies are registered in
// oblong_docs_tests instead (tests/registry_extension_test.cpp), not in this program.
#include "core/procedural.h"
#include "inversion/newton.h"
#include "render/embree_scene.h"
#include "traversal/strategy_catalog.h"
#include "traversal/traversal.h"
#include "strategies/midpoint2d.h"
#include "strategies/range_query.h"
#include "strategies/rmip.h"
#include "strategies/splitter.h"
#include "tests/test_util.h"
#include "tests/fixtures/traversal_cases.h"

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>

using namespace oblong;
using namespace oblong::test;

namespace {

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

}  // namespace

TEST_CASE("registry: a name registered twice is refused, and ceres is a slow reference", "[registry][ceres][unit]") {
  // A copied example left under its old name fails at start-up, before main: the test
  // programs' build lists their test cases (tests/list_check.sh) and fails with it.
  for (const std::string& n : rangeQueryNames())
    CHECK_THROWS_WITH(RangeQueryRegistry::instance().add(n, {}), Catch::Contains("'" + n + "' is registered twice"));
  for (const std::string& n : inverterNames())
    CHECK_THROWS_WITH(InverterRegistry::instance().add(n, {}), Catch::Contains("registered twice"));
  for (const std::string& n : splitterNames())
    CHECK_THROWS_WITH(SplitterRegistry::instance().add(n, {}), Catch::Contains("registered twice"));
  for (const std::string& n : baselineNames())
    CHECK_THROWS_WITH(BaselineRegistry::instance().add(n, {}), Catch::Contains("registered twice"));
  CHECK(inverterTraits("ceres").slowReference);  // linked into this program: registered
}

TEST_CASE("registry: the tessellated baseline is registered where it is built, first of the baselines",
          "[registry][render][tessellated][unit]") {
  // Registered by render/embree_scene.cpp (linked here), like the intersectors' baselines
  // by theirs, marked as built by the scene: listed, chosen by name, kept out of the
  // intersectors' conformance suites.
  const BaselineRegistry& reg = BaselineRegistry::instance();
  REQUIRE(reg.has("tessellated"));
  CHECK(reg.traits("tessellated").builtByScene);
  CHECK_FALSE(reg.traits("tessellated").approximate);
  const std::vector<std::string> names = baselineNames();
  REQUIRE(!names.empty());
  CHECK(names.front() == "tessellated");  // where the hand-inserted name was
  CHECK(contains(names, "bruteforce"));
  CHECK(contains(names, "tfdm"));
  CHECK_FALSE(contains(exactBaselines(), "tessellated"));
  const nlohmann::json j = strategiesJson();
  REQUIRE(!j.at("baselines").empty());
  CHECK(j.at("baselines")[0].at("name") == "tessellated");
  CHECK(j.at("baselines")[0].at("summary") == "the micro-triangles built and traced by Embree (the speed limit)");
  CHECK(j.at("baselines").size() == names.size());
  // Chosen like any baseline: EmbreeScene builds it from TraversalConfig::baseline, and
  // its parameters are checked like every baseline's (it has none).
  Scene scene;
  scene.path = "<quad>";
  SceneMesh q;
  q.mesh = quadMesh(1.0f, 0.0f, 2);
  q.displacement = Displacement{std::make_shared<const HeightMap>(proceduralHeightMap(16, 16, 3)), 0.05f, 0.0f, vec2(1.0f)};
  scene.meshes.push_back(std::move(q));
  AccelOptions tess = AccelOptions::withBaseline("tessellated");
  const EmbreeScene accel(scene, tess);
  CHECK(accel.tessellated());
  CHECK(accel.geometryName() == "tessellated");
  CHECK(accel.microTriangles() > 0);
  tess.traversal.baselineParams = {{"bogus", 1}};
  CHECK_THROWS_WITH(EmbreeScene(scene, tess), Catch::Contains("strategies.baseline") && Catch::Contains("bogus"));
}

TEST_CASE("registry: the Vulkan kernels the traits name exist, and the coverage is what they allow",
          "[registry][vulkan_kernels][unit]") {
  const nlohmann::json j = strategiesJson();
  int withKernel = 0;
  for (const char* role : {"range", "inverter", "splitter", "baselines"})
    for (const auto& e : j.at(role)) {
      const std::string name = e.at("name"), kernel = e.at("vulkan_kernel");
      INFO(role << " " << name << ": " << kernel);
      CHECK(e.at("devices") == (kernel.empty() ? nlohmann::json{"cpu"} : nlohmann::json{"cpu", "vulkan"}));
      if (kernel.empty()) continue;
      ++withKernel;
      // "FILE" or "FILE (FUNCTION)": the file is in the source tree, the function in it.
      const std::string file = kernel.substr(0, kernel.find(' '));
      const std::filesystem::path path = std::filesystem::path(OBLONG_SOURCE_DIR) / file;
      REQUIRE(std::filesystem::is_regular_file(path));
      if (kernel.size() > file.size()) {
        std::ifstream in(path);
        const std::string text((std::istreambuf_iterator<char>(in)), {});
        const std::string fn = kernel.substr(file.size() + 2, kernel.size() - file.size() - 3);
        CHECK(text.find(fn + "(") != std::string::npos);
      }
    }
  CHECK(withKernel >= 4);  // the canonical combination's three and tfdm
  // The coverage is the product of the roles' kernels, then the baselines with one.
  for (const StrategyCombination& c : allCombinations()) {
    const std::string combo = c.config.range + "+" + c.config.inverter + "+" + c.config.splitter;
    const bool all = !strategyTraits(StrategyKind::Range, c.config.range).vulkanKernel.empty() &&
                     !strategyTraits(StrategyKind::Inverter, c.config.inverter).vulkanKernel.empty() &&
                     !strategyTraits(StrategyKind::Splitter, c.config.splitter).vulkanKernel.empty();
    INFO(combo);
    CHECK(missingVulkanKernels(c.config).empty() == all);
    CHECK((vulkanCoverage().find(combo) != std::string::npos) == all);
  }
  const TraversalConfig canonical;
  CHECK(missingVulkanKernels(canonical).empty());
  TraversalConfig oracle;
  oracle.baseline = "bruteforce";
  CHECK(missingVulkanKernels(oracle) == std::vector<std::string>{"bruteforce (baseline)"});
  CHECK(j.at("vulkan") == vulkanCoverage());
}

TEST_CASE("registry: the oblong binary's help and strategy list read its registries", "[registry][cli]") {
  const CliRun help = runOblongCli("render --help");
  REQUIRE(help.status == 0);
  const CliRun list = runOblongCli("info --strategies --json");
  INFO(list.out << list.err);
  REQUIRE(list.status == 0);
  const nlohmann::json j = nlohmann::json::parse(list.out);
  // Every strategy the binary knows is in its help and in its list.
  size_t known = 0;
  for (const char* kind : {"range", "inverter", "splitter"})
    for (const auto& e : j.at(kind)) {
      const std::string n = e.at("name");
      INFO(kind << " " << n);
      CHECK(help.out.find(n) != std::string::npos);
      ++known;
    }
  CHECK(known >= 9);
  bool ceres = false;
  for (const auto& e : j.at("inverter")) ceres |= e.at("name") == "ceres" && e.at("slow_reference") == true;
  CHECK(ceres);
  // Every baseline, the one the scene builds (tessellated) first, in --help's choices too.
  REQUIRE(j.at("baselines").size() >= 4);
  CHECK(j.at("baselines")[0].at("name") == "tessellated");
  for (const auto& e : j.at("baselines")) CHECK(help.out.find(e.at("name").get<std::string>()) != std::string::npos);
  CHECK(help.out.find("tessellated | bruteforce") != std::string::npos);
  // The text list names each strategy's devices and what runs on Vulkan.
  const CliRun text = runOblongCli("info --strategies");
  REQUIRE(text.status == 0);
  for (const char* kind : {"range", "inverter", "splitter", "baselines"})
    for (const auto& e : j.at(kind)) {
      const std::string devices = e.at("vulkan_kernel").get<std::string>().empty() ? "[cpu]" : "[cpu, vulkan]";
      const std::string name = e.at("name");
      INFO(text.out);
      CHECK(text.out.find(fmt::format("  {:<14} {:<13} ", name, devices)) != std::string::npos);
    }
  CHECK(text.out.find("on vulkan: " + j.at("vulkan").get<std::string>() + "\n") != std::string::npos);
}

TEST_CASE("registry: an opt-in static instantiation answers as the generic path", "[registry][traversal][unit]") {
  const Scenario s = torus();
  const auto generic = createIntersector(TraversalConfig{}, s.tris, s.disp);
  staticTraversals().push_back(staticTraversal<Rmip, Newton, Midpoint2D>());
  const auto fast = createIntersector(TraversalConfig{}, s.tris, s.disp);
  staticTraversals().pop_back();
  CHECK(dynamic_cast<const TraversalIntersectorBase&>(*generic).path() == "generic");
  CHECK(dynamic_cast<const TraversalIntersectorBase&>(*fast).path() == "static");
  TraversalConfig bfc;
  bfc.baseline = "bruteforce";
  const auto bf = createIntersector(bfc, s.tris, s.disp);
  size_t pairs = 0;
  for (const RayCase& rc : rayFamilies(s, *bf, 20, 5))
    for (uint32_t p = 0; p < s.tris.size(); ++p) {
      TriangleHit a, b;
      RayCounters ca, cb;
      const bool ha = generic->intersect(rc.r, p, a, ca), hb = fast->intersect(rc.r, p, b, cb);
      pairs += ca.prisms > 0;
      REQUIRE(ha == hb);
      if (ha) REQUIRE(a.t == b.t);
      REQUIRE(ca.boxes == cb.boxes);
      REQUIRE(ca.inversions == cb.inversions);
      REQUIRE(ca.cellsMarched == cb.cellsMarched);
      REQUIRE(ca.microTriangles == cb.microTriangles);
    }
  CHECK(pairs > 1000);
}
