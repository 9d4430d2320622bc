// Mesh files are checked before assimp reads them for what assimp 5.2 cannot survive
// (core/mesh_check.cpp says why and how): nesting deeper than it can recurse, and GLB
// chunk lengths that claim more than the file holds. Each is one oblong::Error line
// naming the file.
#pragma once

#include <cstdint>
#include <string>

namespace Assimp {
class Importer;
}

namespace oblong {

// Node hierarchies, JSON and XML elements and FBX/X scopes nested deeper than this are
// refused: assimp reads each level with a recursive call.
constexpr int kMaxMeshNesting = 1000;
// A glTF node used by several parents is copied by assimp for each: the copies are
// bounded too (a chain of nodes with two references each would double at every level).
constexpr uint64_t kMaxMeshNodeCopies = uint64_t(1) << 22;

// Does nothing for files of other formats, and leaves malformed files to assimp.
void checkMeshNesting(const std::string& path, const Assimp::Importer& importer);

// The element counts of the text formats whose readers allocate what the header claims
// before reading it (OFF, ASE, AC3D, DirectX .x in text) may not exceed the file's size
// in bytes: every element takes at least one byte. NFF's `tess` (a sphere of 20·4^tess
// triangles) is at most kMaxNffTess. Does nothing for other formats.
constexpr int kMaxNffTess = 8;
void checkMeshCounts(const std::string& path, const Assimp::Importer& importer);

}  // namespace oblong
