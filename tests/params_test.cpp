#include "core/params.h"
#include "core/registry.h"

#include <catch2/catch.hpp>

using namespace oblong;

namespace {
struct Thing {
  virtual ~Thing() = default;
  int value = 0;
};
struct Ctx {
  int offset = 0;
};
}  // namespace

TEST_CASE("ParamSet reads typed values with defaults and rejects unused ones", "[params][unit]") {
  ParamSet p(nlohmann::json{{"a", 3}, {"b", "x"}}, "s.json: strategies.range");
  CHECK(p.get<int>("a", 0) == 3);
  CHECK(p.get<int>("missing", 7) == 7);
  REQUIRE_THROWS_WITH(p.checkUnused(), Catch::Contains("s.json: strategies.range") && Catch::Contains("'b'"));
  CHECK(p.get<std::string>("b", "") == "x");
  REQUIRE_NOTHROW(p.checkUnused());
  ParamSet q(nlohmann::json{{"a", "three"}, {"r", -1}}, "f.json");
  REQUIRE_THROWS_WITH(q.get<int>("a", 0), Catch::Contains("f.json") && Catch::Contains("'a'"));
  REQUIRE_THROWS_WITH(q.getInRange<int>("r", 0, 0, 10), Catch::Contains("'r'") && Catch::Contains("outside"));
  REQUIRE_THROWS_AS(ParamSet(nlohmann::json::array(), "g.json"), Error);
}

TEST_CASE("Registry creates by name, and unknown names list the known ones", "[params][unit]") {
  Registry<Thing, Ctx> reg;
  reg.add("plus", [](ParamSet& p, const Ctx& c) {
    auto t = std::make_unique<Thing>();
    t->value = p.get<int>("n", 1) + c.offset;
    return t;
  });
  ParamSet ok(nlohmann::json{{"n", 4}}, "here");
  CHECK(reg.create("plus", ok, Ctx{10})->value == 14);
  ParamSet extra(nlohmann::json{{"n", 4}, {"typo", 1}}, "here");
  REQUIRE_THROWS_WITH(reg.create("plus", extra, Ctx{}), Catch::Contains("unknown parameter 'typo'"));
  ParamSet none;
  REQUIRE_THROWS_WITH(reg.create("minus", none, Ctx{}), Catch::Contains("'minus'") && Catch::Contains("plus"));
  // The parameters a strategy read, with the defaults it used.
  ParamSet given(nlohmann::json{{"n", 4}}, "here");
  reg.create("plus", given, Ctx{});
  CHECK(given.resolved() == nlohmann::json{{"n", 4}});
  ParamSet defaults;
  reg.create("plus", defaults, Ctx{});
  CHECK(defaults.resolved() == nlohmann::json{{"n", 1}});
}
