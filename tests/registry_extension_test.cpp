// Extending oblong (docs/extending.md): a throwaway strategy of each interface,
// registered here with one line each as a user would in their own .cpp, is picked up by
// both conformance suites (tests/fixtures/traversal_cases.h reads the registries), listed in the
// CLI help and selectable by name, with no other edit. Part of oblong_docs_tests, whose
// registries alone hold example strategies: in oblong_tests they would multiply every
// conformance suite's combinations.
#include "strategies/range_query.h"
#include "strategies/splitter.h"
#include "inversion/newton.h"
#include "traversal/intersector.h"
#include "traversal/strategy_catalog.h"
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
    const double c = double(p.a.uv[ax]) + (double(p.b.uv[ax]) - double(p.a.uv[ax])) / 3.0;
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
  // And it answers as the brute force, per (ray, triangle) pair.
  TraversalConfig bfc;
  bfc.baseline = "bruteforce";
  const auto bf = createIntersector(bfc, s.tris, s.disp);
  size_t hits = 0;
  for (const RayCase& rc : rayFamilies(s, *bf, 6, 3))
    for (uint32_t p = 0; p < s.tris.size(); ++p) {
      TriangleHit a, b;
      RayCounters c;
      const bool ha = is->intersect(rc.r, p, a, c), hb = bf->intersect(rc.r, p, b, c);
      REQUIRE(ha == hb);
      if (ha) CHECK(a.t == Approx(b.t).epsilon(1e-5).margin(1e-6));
      hits += hb;
    }
  CHECK(hits > 20);
  // A name registered twice is refused.
  CHECK_THROWS_WITH(RangeQueryRegistry::instance().add("global", {}), Catch::Contains("registered twice"));
}

TEST_CASE("registry: both conformance suites run every registered combination", "[registry][conformance]") {
  const auto configs = conformanceConfigs();
  size_t combos = 0;
  bool global = false, thirds = false, slowSubset = false;
  for (const auto& [c, slow] : configs) {
    combos += c.marchingScale == TraversalConfig{}.marchingScale && c.inversionInTraversal && c.rangeParams.empty();
    global |= c.range == "global";
    thirds |= c.splitter == "thirds";
    if (inverterTraits(c.inverter).slowReference) slowSubset |= slow;
    if (inverterTraits(c.inverter).slowReference) CHECK(slow);
  }
  CHECK(global);
  CHECK(thirds);
  CHECK(slowSubset);
  CHECK(combos >= rangeQueryNames().size() * inverterNames().size() * splitterNames().size());
}
