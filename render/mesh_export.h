// `oblong export` (docs/export.md): a scene's surface as one binary little-endian PLY,
// so that other renderers and tools can load it.
//
// The triangles are the pre-tessellation baseline's (`--baseline tessellated`,
// render/tessellation.h), in the same order: per
// displaced mesh, the micro-triangles forEachMicroTriangle emits for each base triangle
// (the oracle's, core/microgeometry.h), at the scene's level of detail; per plain mesh,
// its triangles. Positions are in world coordinates, each micro-vertex rounded once from
// the mesh's frame, where the baseline traces it (worldFloat; ExportMerged counts what
// that rounding merges far from the origin);
// uvs are each micro-triangle's own (the baseline shares a vertex by position within a
// base triangle and keeps the uv of its first occurrence, which may be an ulp apart).
// No vertex is shared: triangle k is vertices 3k, 3k+1, 3k+2, so that the file is
// written in one streaming pass with bounded memory and its size is known before.
#pragma once

#include "core/scene.h"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace oblong {

// What an export of `scene` holds, counted without building anything.
struct ExportPlan {
  struct Part {
    int mesh = -1;
    bool displaced = false;
    size_t triangles = 0;
    std::vector<size_t> perTriangle;  // displaced: micro-triangles per base triangle
  };
  std::vector<Part> parts;  // one per mesh, in scene order
  size_t triangles = 0;     // in all
  size_t microTriangles = 0, plainTriangles = 0;
  size_t displacedMeshes = 0, plainMeshes = 0;

  // Each vertex: float x y z u v; each face: a uchar count and three uint32 indices.
  static constexpr size_t kVertexBytes = 5 * sizeof(float);
  static constexpr size_t kFaceBytes = 1 + 3 * sizeof(uint32_t);
  static constexpr size_t kBytesPerTriangle = 3 * kVertexBytes + kFaceBytes;
  size_t vertices() const { return 3 * triangles; }
  size_t bodyBytes() const { return triangles * kBytesPerTriangle; }
};
ExportPlan planExport(const Scene& scene);

// The PLY header of an export (`comment` lines: the scene and its level of detail).
std::string exportHeader(const Scene& scene, const ExportPlan& plan);

// Throws oblong::Error (one line naming the scene) when the export cannot be written to
// `path`: more vertices than uint32 indices address, more bytes than the output's folder
// has free (or, for a device such as /dev/stdout, which output.h writes through from a
// copy, than memory may hold). The message says what it needs and what would fit.
void checkExportFits(const Scene& scene, const ExportPlan& plan, const std::string& path);

// Micro-triangles whose vertices are distinct in their mesh's frame but not as the
// file's float world positions (counted while writing): a mesh far from the origin for
// the size of its texels, where floats are coarser than the micro-geometry.
struct ExportMerged {
  size_t triangles = 0;   // in all
  int mesh = -1;          // the first mesh that has any
  double spacing = 0.0;   // the float spacing at that mesh's farthest coordinate
  double farthest = 0.0;  // and that coordinate's magnitude
};
// The one warning line for `merged` (empty when nothing merged), without "oblong: ".
std::string exportMergedWarning(const std::string& path, const ExportPlan& plan, const ExportMerged& merged);

// Writes the export to `path` (render/output.h: never a truncated file under that name;
// a write error is one oblong::Error line naming `path`). Returns false, having written
// nothing, when `interrupt` was set before it finished. `merged`, when given, gets the
// micro-triangles the float positions merged.
bool writeExport(const Scene& scene, const ExportPlan& plan, const std::string& path,
                 const std::atomic<bool>* interrupt = nullptr, ExportMerged* merged = nullptr);

}  // namespace oblong
