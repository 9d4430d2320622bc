// Triangle meshes, loaded through assimp (OBJ, PLY, 3DS, glTF, DAE, ...).
#pragma once

#include "core/math.h"
#include "core/triangle.h"

#include <glm/mat4x4.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace oblong {

struct Mesh {
  std::string name;  // file path or "<procedural ...>"
  // The mesh's frame: a vertex lies at origin + positions[v] in the world (the sum taken
  // exactly, in double). Everything that depends on the geometry (micro-geometry, prisms,
  // the traversal, the tessellation) is computed from `positions`; rays are moved into the
  // frame by subtracting `origin` (docs/decisions.md, "Mesh frames"). `origin` is the
  // scene transform's translation, plus the mesh's centre when its box lies far from it.
  vec3 origin{0.0f};
  std::vector<vec3> positions;
  std::vector<vec3> normals;  // unit length, one per position
  std::vector<vec2> uvs;      // empty when the file has none
  std::vector<glm::uvec3> triangles;
  size_t skippedTriangles = 0;  // degenerate triangles dropped by finishMesh (warned about)
  // Per triangle: its index before finishMesh dropped the degenerate ones (the numbering
  // of the warning line, after assimp's triangulation; not the file's face index, which
  // assimp's post-processing does not keep). Filled by finishMesh; empty otherwise.
  std::vector<uint32_t> inputTriangle;

  bool hasUVs() const { return !uvs.empty(); }
  // Triangle i in the mesh's frame (positions, not world coordinates).
  DisplacedTriangle triangle(size_t i) const;
  // Vertex v in the world, in double (exact).
  dvec3 world(size_t v) const { return dvec3(origin) + dvec3(positions[v]); }
  size_t bytes() const;
};

struct MeshLoadOptions {
  glm::mat4 transform{1.0f};  // applied to positions (normals by the inverse transpose)
  bool needUVs = false;       // displaced meshes: a mesh without uvs is an error
  bool warn = true;           // print a warning line on stderr for skipped triangles
  // Replace the file's normals by area-weighted smooth ones shared per position: split
  // vertices of per-face (flat) normals would displace apart and crack at hard edges.
  bool smoothNormals = false;
};

// Loads every mesh of the file as one Mesh (node transforms applied). Vertex normals
// are normalised; when the file has none, area-weighted smooth normals are computed,
// accumulated per position so that uv seams do not split the normal. Texture
// coordinates are as the file stores them (assimp's v flip for glTF and others is
// undone). A PLY file is checked against its header, and node hierarchies and other
// nesting against kMaxMeshNesting (core/mesh_check.h), before assimp reads the file; the
// load runs on a thread with a large stack. Errors name the file.
Mesh loadMesh(const std::string& path, const MeshLoadOptions& opts = {});

// The checks every mesh goes through (loaded or generated), in this order: triangles
// with zero area (or, when needUVs, zero uv area) are marked degenerate; zero and
// non-finite normals are replaced by smooth ones (fixNormals); the transform is applied;
// degenerate triangles are dropped with one warning line on stderr ("oblong: warning:
// NAME: skipped K of N degenerate triangles (...)"); the frame is recentred
// (recentreMesh). Errors (naming m.name): every
// triangle degenerate, a triangle whose area overflows a float, a vertex or (when
// needUVs) a triangle interior where the normals cancel, a used vertex beyond
// kMaxCoordinate after the transform.
void finishMesh(Mesh& m, const MeshLoadOptions& opts);

// Area-weighted smooth normals accumulated per distinct position.
void computeSmoothNormals(Mesh& m);
// Applies the transform's linear part to positions and normals (normals renormalised);
// its translation is added to m.origin.
void transformMesh(Mesh& m, const glm::mat4& transform);
// Moves the frame's origin to the centre of the mesh's box (rounded to a power of two
// below the box's size, so that the move is exact) when the box lies farther from the
// origin than its own size: precision then depends on the mesh's extent, not on where
// it sits. No-op otherwise.
void recentreMesh(Mesh& m);

}  // namespace oblong
