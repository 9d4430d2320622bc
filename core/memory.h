// Per-structure memory report: every acceleration structure lists its parts.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace oblong {

struct MemoryItem {
  std::string name;  // "rmip/layers", "embree/bvh", ...
  size_t bytes = 0;
};
using MemoryReport = std::vector<MemoryItem>;

inline size_t totalBytes(const MemoryReport& r) {
  size_t s = 0;
  for (const auto& m : r) s += m.bytes;
  return s;
}

}  // namespace oblong
