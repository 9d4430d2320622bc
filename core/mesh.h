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
  // in double). Everything that depends on the geometry (micro-geometry, prisms, the
  // traversal, the tessellation) is computed from `positions`; rays are moved into the
  // frame by subtracting `origin` in double and rounding once (docs/decisions.md, "Mesh
  // frames"). finishMesh puts `origin` at the centre of the mesh's box of world positions
  // (recentreMesh): a rule that moves with the mesh, so the same mesh anywhere has the
  // same `positions`.
  dvec3 origin{0.0};
  std::vector<vec3> positions;
  std::vector<vec3> normals;  // unit length, one per position
  std::vector<vec2> uvs;      // empty when the file has none
  std::vector<glm::uvec3> triangles;
  size_t skippedTriangles = 0;  // degenerate triangles dropped by finishMesh (warned about)
  // Per triangle: its index before finishMesh dropped the degenerate ones (the numbering
  // of the warning line, after assimp's triangulation; not the file's face index, which
  // assimp's post-processing does not keep). Filled by finishMesh; empty otherwise.
  std::vector<uint32_t> inputTriangle;
  // The other files the loader read for it (an OBJ's .mtl, a glTF's .bin): inputs as
  // much as the mesh file, which no output may name.
  std::vector<std::string> files;

  bool hasUVs() const { return !uvs.empty(); }
  // Triangle i in the mesh's frame (positions, not world coordinates).
  DisplacedTriangle triangle(size_t i) const;
  // Vertex v in the world, in double.
  dvec3 world(size_t v) const { return origin + dvec3(positions[v]); }
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
// the frame is recentred (recentreMesh, over the triangles not marked so far); the float
// checks run on the recentred positions; degenerate triangles are dropped with one
// warning line on stderr ("oblong: warning: NAME: skipped K of N degenerate triangles
// (...)"). Errors (naming m.name): every
// triangle degenerate, a triangle whose area overflows a float, when needUVs a vertex
// or a triangle interior where the normals cancel (without needUVs such a vertex is
// shaded with its largest triangle's normal, with one warning line), a used vertex
// beyond kMaxCoordinate after the transform.
void finishMesh(Mesh& m, const MeshLoadOptions& opts);

// Area-weighted smooth normals accumulated per distinct position.
void computeSmoothNormals(Mesh& m);
// Applies the transform's linear part to positions and normals (normals renormalised);
// its translation is added to m.origin.
void transformMesh(Mesh& m, const glm::mat4& transform);
// Moves the frame's origin to the centre of the box of the triangles' world positions
// (min, max and their mean in double, so the centre moves exactly with the mesh) and
// the positions to float(world − origin), rounded once. Precision then depends on the
// mesh's extent, not on where it sits, and the same mesh translated by any T whose
// world positions stay exact gets the same positions bit for bit. A mesh symmetric
// about the world's origin keeps its positions.
void recentreMesh(Mesh& m);

}  // namespace oblong
