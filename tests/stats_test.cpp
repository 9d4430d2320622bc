#include "core/stats.h"

#include <catch2/catch.hpp>

#include <thread>
#include <vector>

using namespace oblong;

OBLONG_STAT_COUNTER("test/Increments", statTestIncrements);

TEST_CASE("statistics counters sum over threads, including finished ones", "[stats][unit]") {
#if OBLONG_STATS
  Stats::reset();
  std::vector<std::thread> ts;
  for (int k = 0; k < 4; ++k)
    ts.emplace_back([] {
      for (int i = 0; i < 1000; ++i) OBLONG_STAT_INC(statTestIncrements);
    });
  for (auto& t : ts) t.join();
  OBLONG_STAT_ADD(statTestIncrements, 5);
  const auto snap = Stats::snapshot();
  REQUIRE(snap.count("test/Increments") == 1);
  CHECK(snap.at("test/Increments") == 4005);
  Stats::reset();
  CHECK(Stats::snapshot().at("test/Increments") == 0);
#else
  OBLONG_STAT_INC(statTestIncrements);  // compiles to nothing
  CHECK(Stats::snapshot().count("test/Increments") == 0);
#endif
}
