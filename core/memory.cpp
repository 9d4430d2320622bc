// Memory budget (core/memory.h): what is available, and the one-line refusal.
#include "core/memory.h"

#include "core/error.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace oblong {

namespace {

constexpr size_t kUnknown = std::numeric_limits<size_t>::max();

std::optional<uint64_t> readNumber(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::string s;
  if (!(f >> s) || s.empty() || !std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;  // missing, or "max"
  try {
    return std::stoull(s);
  } catch (...) {
    return std::nullopt;
  }
}

// Value of `key` in a "key value" file (memory.stat), 0 when absent.
uint64_t statValue(const std::filesystem::path& p, const std::string& key) {
  std::ifstream f(p);
  std::string k;
  uint64_t v;
  while (f >> k >> v)
    if (k == key) return v;
  return 0;
}

uint64_t memAvailable() {
  std::ifstream f("/proc/meminfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("MemAvailable:", 0) == 0) {
      std::istringstream in(line.substr(13));
      uint64_t kb = 0;
      if (in >> kb) return kb * 1024;
    }
  return kUnknown;
}

// Limit minus usage for the cgroup at `dir` and each of its parents up to `root`. The
// inactive page cache is reclaimable, so it does not count as used.
uint64_t cgroupRoom(const std::filesystem::path& root, std::filesystem::path dir, bool v2) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) dir = root;  // a cgroup namespace: our group is the root
  uint64_t room = kUnknown;
  for (;;) {
    const auto limit = readNumber(dir / (v2 ? "memory.max" : "memory.limit_in_bytes"));
    const auto usage = readNumber(dir / (v2 ? "memory.current" : "memory.usage_in_bytes"));
    // v1 writes "no limit" as a huge page-aligned number.
    if (limit && usage && *limit < (uint64_t(1) << 62)) {
      const uint64_t cache = statValue(dir / "memory.stat", v2 ? "inactive_file" : "total_inactive_file");
      const uint64_t used = *usage > cache ? *usage - cache : 0;
      room = std::min(room, *limit > used ? *limit - used : 0);
    }
    if (dir == root || !dir.has_parent_path() || dir.parent_path() == dir) break;
    dir = dir.parent_path();
  }
  return room;
}

uint64_t cgroupAvailable() {
  std::ifstream f("/proc/self/cgroup");
  std::string line;
  uint64_t room = kUnknown;
  while (std::getline(f, line)) {
    // "0::/path" (v2) or "4:memory:/path" (v1).
    const size_t a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    const std::string rel = path.empty() || path == "/" ? "" : path.substr(path[0] == '/' ? 1 : 0);
    if (line.rfind("0::", 0) == 0) {
      for (const char* root : {"/sys/fs/cgroup", "/sys/fs/cgroup/unified"})
        if (std::filesystem::exists(std::filesystem::path(root) / "cgroup.controllers"))
          room = std::min(room, cgroupRoom(root, rel.empty() ? std::filesystem::path(root) : std::filesystem::path(root) / rel, true));
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {
      const std::filesystem::path root = "/sys/fs/cgroup/memory";
      room = std::min(room, cgroupRoom(root, rel.empty() ? root : root / rel, false));
    }
  }
  return room;
}

}  // namespace

std::optional<size_t> parseByteSize(const std::string& s) {
  size_t i = 0, n = s.size();
  while (i < n && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
  const size_t start = i;
  while (i < n && (std::isdigit(static_cast<unsigned char>(s[i])) || s[i] == '.')) ++i;
  if (i == start) return std::nullopt;
  const std::string num = s.substr(start, i - start);
  if (std::count(num.begin(), num.end(), '.') > 1 || num.front() == '.' || num.back() == '.') return std::nullopt;
  while (i < n && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
  std::string unit;
  for (; i < n; ++i)
    if (!std::isspace(static_cast<unsigned char>(s[i]))) unit += char(std::toupper(static_cast<unsigned char>(s[i])));
  if (unit.size() > 1 && unit.back() == 'B') unit.pop_back();  // "GB", "GiB" -> "G", "GI"
  if (unit.size() == 2 && unit[1] == 'I') unit.pop_back();
  if (unit == "B") unit.clear();
  int shift = 0;
  if (unit.empty()) shift = 0;
  else if (unit == "K") shift = 10;
  else if (unit == "M") shift = 20;
  else if (unit == "G") shift = 30;
  else if (unit == "T") shift = 40;
  else return std::nullopt;
  const double v = std::strtod(num.c_str(), nullptr) * std::ldexp(1.0, shift);
  if (!std::isfinite(v) || v >= 0x1p63) return std::nullopt;
  return size_t(v);
}

std::string humanBytes(size_t bytes) {
  static const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  if (bytes < 1024) return fmt::format("{} B", bytes);
  double v = double(bytes);
  int u = 0;
  while (v >= 1024 && u < 6) v /= 1024, ++u;
  // Three significant digits; rounding may reach 1024 of a unit, printed as such.
  return fmt::format(fmt::runtime(v < 9.995 ? "{:.2f} {}" : v < 99.95 ? "{:.1f} {}" : "{:.0f} {}"), v, units[u]);
}

size_t availableMemoryBytes() {
  if (const char* env = std::getenv("OBLONG_MEMORY_LIMIT"); env && *env) {
    const auto v = parseByteSize(env);
    if (!v) fail("OBLONG_MEMORY_LIMIT", "expected bytes with an optional K, M, G or T suffix, got '{}'", env);
    return *v;
  }
  return size_t(std::min(memAvailable(), cgroupAvailable()));
}

size_t structureBudgetBytes() {
  const size_t avail = availableMemoryBytes();
  return avail == kUnknown ? kUnknown : size_t(double(avail) * kStructureShare);
}

bool fitsInMemory(size_t bytes) { return bytes <= structureBudgetBytes(); }

void checkFits(const std::string& where, const std::string& what, size_t bytes, const std::string& hint,
               const std::string& detail) {
  const size_t avail = availableMemoryBytes();
  if (avail == kUnknown || bytes <= size_t(double(avail) * kStructureShare)) return;
  const bool forced = std::getenv("OBLONG_MEMORY_LIMIT") && *std::getenv("OBLONG_MEMORY_LIMIT");
  fail(where, "{} needs {}{} but {} may be used ({:.0f}% of the {} of memory {}){}{}", what, humanBytes(bytes),
       detail.empty() ? "" : " (" + detail + ")", humanBytes(size_t(double(avail) * kStructureShare)),
       kStructureShare * 100, humanBytes(avail), forced ? "that OBLONG_MEMORY_LIMIT allows" : "available",
       hint.empty() ? "" : "; ", hint);
}

}  // namespace oblong
