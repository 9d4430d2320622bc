// Statistics counters, pbrt-style: declared next to the code they count, named
// "Category/Name" (the category is the strategy name: "rmip/Queries"), thread-local
// so hot loops pay one increment, and compiled out when OBLONG_STATS is 0 (timing
// builds). Stats::snapshot() sums every thread's counters.
#pragma once

#include <cstdint>
#include <map>
#include <string>

namespace oblong {

class Stats {
 public:
  // Registers a counter name, returns its slot. Called from static initialisers.
  static int registerCounter(const char* name);
  // Sum over every thread (live and finished) of every counter.
  static std::map<std::string, int64_t> snapshot();
  static void reset();

  static constexpr int kMaxCounters = 256;
  struct ThreadBlock;
  static int64_t* threadCounters();  // this thread's block (created on first use)
};

}  // namespace oblong

#define OBLONG_CONCAT_(a, b) a##b
#define OBLONG_CONCAT(a, b) OBLONG_CONCAT_(a, b)

#if OBLONG_STATS
// OBLONG_STAT_COUNTER("rmip/Queries", rmipQueries); ... OBLONG_STAT_ADD(rmipQueries, 1);
#define OBLONG_STAT_COUNTER(name, var) static const int var = ::oblong::Stats::registerCounter(name)
#define OBLONG_STAT_ADD(var, n) (::oblong::Stats::threadCounters()[var] += (n))
#else
#define OBLONG_STAT_COUNTER(name, var) static_assert(true, "")
#define OBLONG_STAT_ADD(var, n) ((void)0)
#endif
#define OBLONG_STAT_INC(var) OBLONG_STAT_ADD(var, 1)
