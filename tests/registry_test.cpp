// Extending oblong (docs/extending.md): a throwaway strategy of each interface,
// registered here with one line each as a user would in their own .cpp, is picked up by
// both conformance suites (tests/fixtures/traversal_cases.h reads the registries), listed in the
// CLI help and selectable by name, with no other edit. Also: the opt-in static
// traversal instantiation answers exactly as the generic path.
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

#include <algorithm>

using namespace oblong;
using namespace oblong::test;

namespace {

// RangeQuery "global": the whole map's [min, max] for every range (conservative, loose).
class Global final : public RangeQueryImpl<Global> {
 public:
  Global(const Displacement& d, const QueryNeeds& n) : RangeQueryImpl(d, n) { all_ = map().range(); }
  std::string_view name() const override { return "global"; }
  size_t bytes() const override { return sizeof(all_); }
  bool exact() const override { return false; }
  void update(const SampleRange&) override { all_ = map().range(); }
  std::span<const std::byte> storage() const override { return std::as_bytes(std::span(&all_, 1)); }
  Interval rawRangeFast(const SampleRange&) const { return all_; }

 private:
  Interval all_;
};
OBLONG_REGISTER_RANGE_QUERY("global", [](ParamSet&, const RangeQueryContext& c) -> std::unique_ptr<RangeQuery> {
    return std::make_unique<Global>(c.displacement, c.needs);
  },
  StrategyTraits{false, "test: the whole map's [min, max]"});

// Splitter "thirds": cut where the curve crosses the line a third of the way along the
// piece's longer side (by inversion at a third of its t-range when that fails).
class Thirds final : public SplitterImpl<Thirds> {
 public:
  std::string_view name() const override { return "thirds"; }
  template <typename Ctx>
  bool splitFast(const CurvePiece& p, Ctx& ctx, CurvePiece& front, CurvePiece& back) const {
    const int ax = split::longerAxis(p);
    const double c = p.a.uv[ax] + (p.b.uv[ax] - p.a.uv[ax]) / 3.0;
    CurvePoint m;
    if (!split::strictlyBetween(p, ax, c) || !ctx.crossing(p, ax, c, m))
      if (!ctx.pointAt(p, (2.0 * p.a.t + p.b.t) / 3.0, m)) return false;
    split::around(p, m, front, back);
    return true;
  }
};
OBLONG_REGISTER_SPLITTER("thirds", [](ParamSet&, const SplitterContext&) -> std::unique_ptr<Splitter> {
    return std::make_unique<Thirds>();
  },
  StrategyTraits{false, "test: split a third of the way along the longer side"});

// Inverter "newton_double": Newton in double precision, flagged as a slow reference so
// the suites' subset path is exercised too.
class NewtonDouble final : public InverterImpl<NewtonDouble> {
 public:
  std::string_view name() const override { return "newton_double"; }
  InversionResult invertFast(const vec3& X, const DisplacedTriangle& T) const { return n_.invert(X, T); }
  InversionResultD invertFastD(const dvec3& X, const DisplacedTriangle& T) const { return n_.invertD(X, T); }

 private:
  static NewtonOptions options() {
    NewtonOptions o;
    o.doublePrecision = true;
    o.tolerance = 1e-10;
    return o;
  }
  Newton n_{options()};
};
OBLONG_REGISTER_INVERTER("newton_double", [](ParamSet&, const InverterContext&) -> std::unique_ptr<Inverter> {
    return std::make_unique<NewtonDouble>();
  },
  StrategyTraits{true, "test: Newton in double precision"});

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

TraversalConfig config(const std::string& r, const std::string& i, const std::string& s) {
  TraversalConfig c;
  c.range = r, c.inverter = i, c.splitter = s;
  return c;
}

}  // namespace

TEST_CASE("registry: a strategy registered with one line is listed and selectable by name", "[registry]") {
  CHECK(contains(rangeQueryNames(), "global"));
  CHECK(contains(splitterNames(), "thirds"));
  CHECK(contains(inverterNames(), "newton_double"));
  CHECK(inverterTraits("newton_double").slowReference);
  CHECK(inverterTraits("ceres").slowReference);  // linked into this program: registered
  CHECK_FALSE(rangeQueryTraits("global").slowReference);
  // The CLI's --help lists strategyChoices().
  CHECK(strategyChoices(StrategyKind::Range).find("global") != std::string::npos);
  CHECK(strategyChoices(StrategyKind::Splitter).find("thirds") != std::string::npos);
  CHECK(strategyChoices(StrategyKind::Inverter).find("newton_double") != std::string::npos);
  const nlohmann::json j = strategiesJson();
  bool listed = false;
  for (const auto& e : j.at("inverter")) listed |= e.at("name") == "newton_double" && e.at("slow_reference") == true;
  CHECK(listed);
  // Selectable by name: the traversal builds with them and describes what it built.
  const Scenario s = tiledQuad();
  const auto is = createIntersector(config("global", "newton_double", "thirds"), s.tris, s.disp);
  CHECK(is->name() == "global+newton_double+thirds");
  const nlohmann::json d = is->describe();
  CHECK(d.at("path") == "generic");
  CHECK(d.at("range").at("name") == "global");
  CHECK(d.at("splitter").at("name") == "thirds");
  // A name registered twice is refused.
  CHECK_THROWS_WITH(RangeQueryRegistry::instance().add("global", {}), Catch::Contains("registered twice"));
}

TEST_CASE("registry: the tessellated baseline is registered where it is built, first of the baselines",
          "[registry][render]") {
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

TEST_CASE("registry: both conformance suites run every registered combination", "[registry][conformance]") {
  const auto configs = conformanceConfigs();
  size_t combos = 0;
  bool global = false, thirds = false, slowSubset = false;
  for (const auto& [c, slow] : configs) {
    combos += c.marchingScale == TraversalConfig{}.marchingScale && c.inversionInTraversal && c.rangeParams.empty();
    global |= c.range == "global";
    thirds |= c.splitter == "thirds";
    if (c.inverter == "newton_double" || c.inverter == "ceres") slowSubset |= slow;
    if (c.inverter == "newton_double" || c.inverter == "ceres") CHECK(slow);
  }
  CHECK(global);
  CHECK(thirds);
  CHECK(slowSubset);
  CHECK(combos >= rangeQueryNames().size() * inverterNames().size() * splitterNames().size());
}

TEST_CASE("registry: the oblong binary's help and strategy list read its registries", "[registry][cli]") {
  const CliRun help = runOblongCli("render --help");
  REQUIRE(help.status == 0);
  const CliRun list = runOblongCli("info --strategies --json");
  INFO(list.out << list.err);
  REQUIRE(list.status == 0);
  const nlohmann::json j = nlohmann::json::parse(list.out);
  // Every strategy the binary knows (this test's throwaway ones are registered only in
  // the test program) is in its help and in its list.
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
}

TEST_CASE("registry: an opt-in static instantiation answers as the generic path", "[registry][traversal]") {
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
