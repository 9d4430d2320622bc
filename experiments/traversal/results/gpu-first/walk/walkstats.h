#pragma once
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <set>
struct WalkStats {
  std::atomic<long> pieces{0}, oldCells{0}, newCells{0}, missing{0}, reported{0};
  ~WalkStats() { std::fprintf(stderr, "WALKCHECK pieces %ld old cells %ld new cells %ld (x%.3f) missing %ld\n", pieces.load(), oldCells.load(), newCells.load(), double(newCells.load()) / double(oldCells.load() ? oldCells.load() : 1), missing.load()); }
};
inline WalkStats& walkStats() { static WalkStats s; return s; }
