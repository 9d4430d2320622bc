#include "core/stats.h"

#include <array>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

namespace oblong {

namespace {
struct Global {
  std::mutex mutex;
  std::vector<std::string> names;
  std::set<Stats::ThreadBlock*> live;
  std::array<int64_t, Stats::kMaxCounters> retired{};  // from threads that ended
};
Global& global() {
  static Global* g = new Global;  // never destroyed: threads may exit after main
  return *g;
}
}  // namespace

struct Stats::ThreadBlock {
  std::array<int64_t, kMaxCounters> c{};
  ThreadBlock() {
    std::lock_guard lock(global().mutex);
    global().live.insert(this);
  }
  ~ThreadBlock() {
    std::lock_guard lock(global().mutex);
    for (int i = 0; i < kMaxCounters; ++i) global().retired[i] += c[i];
    global().live.erase(this);
  }
};

int Stats::registerCounter(const char* name) {
  std::lock_guard lock(global().mutex);
  auto& names = global().names;
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return int(i);
  if (names.size() >= size_t(kMaxCounters)) throw std::length_error("too many statistics counters");
  names.emplace_back(name);
  return int(names.size() - 1);
}

int64_t* Stats::threadCounters() {
  thread_local ThreadBlock block;
  return block.c.data();
}

std::map<std::string, int64_t> Stats::snapshot() {
  std::lock_guard lock(global().mutex);
  std::map<std::string, int64_t> out;
  const auto& names = global().names;
  for (size_t i = 0; i < names.size(); ++i) {
    int64_t s = global().retired[i];
    for (const ThreadBlock* b : global().live) s += b->c[i];
    out[names[i]] += s;
  }
  return out;
}

void Stats::reset() {
  std::lock_guard lock(global().mutex);
  global().retired.fill(0);
  for (ThreadBlock* b : global().live) b->c.fill(0);
}

}  // namespace oblong
