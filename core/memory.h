// Per-structure memory report: every acceleration structure lists its parts. And the
// memory budget: a structure that would not fit is refused before it is allocated, with
// one oblong::Error line saying what it needs, what fits and what to try instead
// (docs/bad_input.md, "Memory").
#pragma once

#include <cstddef>
#include <optional>
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

// Share of the available memory one structure may take at its peak (while it is built):
// the rest of the run still needs the prisms, Embree's BVH, the images and the
// allocator's slack, and the page cache counted in MemAvailable must not all be evicted.
constexpr double kStructureShare = 0.8;

// Bytes this process can still allocate without swapping: Linux MemAvailable (swap not
// counted), lowered to a cgroup's limit minus its non-reclaimable usage (v2 memory.max,
// v1 memory.limit_in_bytes, every level up to the root). Unknown: SIZE_MAX. The
// environment variable OBLONG_MEMORY_LIMIT (bytes, optional K/M/G/T suffix, powers of
// 1024) replaces the measurement; a malformed value throws oblong::Error.
size_t availableMemoryBytes();
// The largest structure checkFits accepts: kStructureShare of availableMemoryBytes().
size_t structureBudgetBytes();
bool fitsInMemory(size_t bytes);

// "1234", "512K", "16G", "1.5 GiB" -> bytes; nullopt when malformed.
std::optional<size_t> parseByteSize(const std::string& s);
// Three significant digits: "18.0 GiB", "4.50 GiB", "716 MiB", "980 B".
std::string humanBytes(size_t bytes);

// Throws oblong::Error when `bytes` exceeds structureBudgetBytes():
//   WHERE: WHAT needs 26.0 GiB (DETAIL) but 17.1 GiB may be used (80% of the 21.3 GiB
//   of memory available); HINT
// `detail` (what the bytes are) and `hint` (what would fit) may be empty.
void checkFits(const std::string& where, const std::string& what, size_t bytes, const std::string& hint,
               const std::string& detail = "");

}  // namespace oblong
