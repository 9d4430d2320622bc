// PLY files are checked before assimp reads them (core/ply_check.cpp says why and how):
// a header whose counts the data cannot hold, or that assimp 5.2 would misread, is one
// oblong::Error line naming the file.
#pragma once

#include <cstdint>
#include <string>

namespace Assimp {
class Importer;
}

namespace oblong {

// What checkPly found: assimp may have to read a copy with `insert` inserted at `at`.
struct PlyCheck {
  bool patch = false;
  uint64_t at = 0;
  const char* insert = "";
};

// Does nothing for files assimp would not read as PLY.
PlyCheck checkPly(const std::string& path, const Assimp::Importer& importer);

}  // namespace oblong
