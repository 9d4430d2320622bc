// Shared helpers for the tests: a scratch directory (one per process, since CTest
// runs test cases in parallel) and small image writers.
#pragma once

#include <OpenImageIO/imageio.h>

#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

namespace oblong::test {

inline std::filesystem::path scratchDir(const std::string& name) {
  auto p = std::filesystem::temp_directory_path() / ("oblong_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(p);
  return p;
}

// Writes a single-channel image from float values in [0,1] (or any, for float files).
inline void writeGray(const std::string& path, int w, int h, const std::vector<float>& v, OIIO::TypeDesc type) {
  auto out = OIIO::ImageOutput::create(path);
  OIIO::ImageSpec spec(w, h, 1, type);
  out->open(path, spec);
  out->write_image(OIIO::TypeDesc::FLOAT, v.data());
  out->close();
}

}  // namespace oblong::test
