// libFuzzer entry point for the scene loader (docs/design.md invariant 6: bad input gets a
// clear error, never a crash). Built by scripts/fuzz.sh (clang, -fsanitize=fuzzer,
// address,undefined; CMake option OBLONG_BUILD_FUZZERS).
//
// Each input is a scene file. It is written to a scratch folder holding small mesh and
// map fixtures (quad.obj, nouv.obj, degenerate.obj, map.png, map16.png, nan.exr, ...;
// relative paths in the input resolve there) and loaded with loadScene(), the full
// loader: JSON with comments, keys, values, transforms, shapes, meshes through assimp,
// maps through OpenImageIO; maps/ and data/ link to the repository's scenes/ folders so
// that the shipped scenes (seeds) load too. The input is also given to parseScene() on the parsed JSON
// directly. Any outcome but a Scene or an oblong::Error with a one-line message that
// starts with the file name is a bug: another exception type escapes and aborts, and
// the sanitizers catch memory errors, undefined behaviour and leaks.
#include "core/error.h"
#include "core/scene.h"

#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

void writeText(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }

void writeGray(const fs::path& p, int w, int h, const std::vector<float>& v, OIIO::TypeDesc type) {
  auto out = OIIO::ImageOutput::create(p.string());
  if (!out) std::abort();
  out->open(p.string(), OIIO::ImageSpec(w, h, 1, type));
  out->write_image(OIIO::TypeDesc::FLOAT, v.data());
  out->close();
}

const fs::path& scratch() {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("oblong_fuzz_" + std::to_string(::getpid()));
    fs::create_directories(d);
    writeText(d / "quad.obj",
              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
    writeText(d / "nouv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    writeText(d / "degenerate.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 2/2 4/2\n");
    writeText(d / "cancel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\n"
                                "f 1/1/1 2/2/2 3/3/1\n");
    writeText(d / "garbage.png", "not an image");
    writeGray(d / "map.png", 4, 2, {0, 0.2f, 0.4f, 0.6f, 0.8f, 1, 1, 1}, OIIO::TypeDesc::UINT8);
    writeGray(d / "map16.png", 3, 5, std::vector<float>(15, 0.25f), OIIO::TypeDesc::UINT16);
    writeGray(d / "nan.exr", 2, 2, {0, 1, std::numeric_limits<float>::quiet_NaN(), 0.5f}, OIIO::TypeDesc::FLOAT);
    fs::create_directories(d / "folder");
    // The shipped scenes (seeds in tests/fuzz/corpus) refer to maps/ and data/.
    std::error_code ec;
    fs::create_directory_symlink(fs::path(OBLONG_SOURCE_DIR) / "scenes/maps", d / "maps", ec);
    fs::create_directory_symlink(fs::path(OBLONG_SOURCE_DIR) / "scenes/data", d / "data", ec);
    return d;
  }();
  return dir;
}

void checkMessage(const oblong::Error& e, const std::string& path) {
  const std::string msg = e.what();
  if (msg.rfind(path + ": ", 0) != 0 || msg.find('\n') != std::string::npos) {
    std::fprintf(stderr, "bad error message: %s\n", msg.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return -1;  // scene files are small; reject, do not explore
  const std::string text(reinterpret_cast<const char*>(data), size);
  const fs::path file = scratch() / "scene.json";
  writeText(file, text);
  try {
    (void)oblong::loadScene(file.string());
  } catch (const oblong::Error& e) {
    checkMessage(e, file.string());
  }
  // parseScene on the parsed document (no file I/O for the scene itself).
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::exception&) {
    return 0;
  }
  try {
    (void)oblong::parseScene(j, file.string());
  } catch (const oblong::Error& e) {
    checkMessage(e, file.string());
  }
  return 0;
}
