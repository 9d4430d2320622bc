// libFuzzer entry point for the data files a scene refers to: displacement maps
// (HeightMap::load through OpenImageIO) and meshes (loadMesh through assimp, then
// finishMesh's checks). Built and run by scripts/fuzz.sh like fuzz_scene.
//
// Input: one byte choosing the kind (the file extension, and for meshes whether uvs are
// required), then the file's bytes. Outcomes other than a loaded map/mesh or an
// oblong::Error with a one-line message naming the file are bugs. The image and mesh
// libraries are Debian's (not instrumented): ASan sees what our code does with their
// results and intercepted libc calls; a crash inside them is still a crash.
#include "core/error.h"
#include "core/heightmap.h"
#include "core/mesh.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {

const char* const kExt[] = {".png", ".exr", ".tif", ".hdr", ".obj", ".ply", ".3ds", ".pgm"};

void check(const oblong::Error& e, const std::string& path) {
  const std::string msg = e.what();
  if (msg.rfind(path + ": ", 0) != 0 || msg.find('\n') != std::string::npos) {
    std::fprintf(stderr, "bad error message: %s\n", msg.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > 256 * 1024) return -1;
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("oblong_fuzz_files_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  const unsigned kind = data[0] % 8;
  const std::string path = (dir / (std::string("input") + kExt[kind])).string();
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  }
  try {
    if (kind < 4 || kind == 7) {
      const oblong::HeightMap m = oblong::HeightMap::load(path, (data[0] & 8) != 0);
      (void)m.range();
    } else {
      oblong::MeshLoadOptions opts;
      opts.needUVs = (data[0] & 8) != 0;
      opts.warn = false;
      const oblong::Mesh m = oblong::loadMesh(path, opts);
      for (size_t i = 0; i < m.triangles.size(); ++i) (void)m.triangle(i);
    }
  } catch (const oblong::Error& e) {
    check(e, path);
  }
  return 0;
}
