// Scratch folders of the tests: one per name and process (CTest runs test cases in
// parallel, each in its own process), removed when the test case that made it ends
// (tests/main.cpp's listener), so that a test run leaves nothing in the temporary folder.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <string>
#include <system_error>
#include <vector>

namespace oblong::test {

// Guards the list below: a test case may make its folder from several threads at once.
inline std::mutex& scratchMutex() {
  static std::mutex m;
  return m;
}

// The folders made since the current test case began.
inline std::vector<std::filesystem::path>& scratchDirsMade() {
  static std::vector<std::filesystem::path> made;
  return made;
}

inline std::filesystem::path scratchPath(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("oblong_test_" + name + "_" + std::to_string(::getpid()));
}

inline std::filesystem::path scratchDir(const std::string& name) {
  auto p = scratchPath(name);
  std::filesystem::create_directories(p);
  std::lock_guard lock(scratchMutex());
  auto& made = scratchDirsMade();
  if (std::find(made.begin(), made.end(), p) == made.end()) made.push_back(p);
  return p;
}

// Removes every scratch folder made so far; a later scratchDir of the same name makes it
// afresh (a test case never sees another's files).
inline void removeScratchDirs() {
  std::lock_guard lock(scratchMutex());
  for (const auto& p : scratchDirsMade()) {
    std::error_code ec;
    std::filesystem::remove_all(p, ec);
  }
  scratchDirsMade().clear();
}

// A folder for the whole process (a static object: removed at exit), for what outlives
// one test case, such as a shader cache the process's one Vulkan device writes.
struct ProcessScratch {
  std::filesystem::path path;
  explicit ProcessScratch(const std::string& name) : path(scratchPath(name)) { std::filesystem::create_directories(path); }
  ~ProcessScratch() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  ProcessScratch(const ProcessScratch&) = delete;
  ProcessScratch& operator=(const ProcessScratch&) = delete;
};

}  // namespace oblong::test
