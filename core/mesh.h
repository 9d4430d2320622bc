// Triangle meshes, loaded through assimp (OBJ, PLY, 3DS, glTF, DAE, ...).
#pragma once

#include "core/math.h"
#include "core/triangle.h"

#include <glm/mat4x4.hpp>

#include <string>
#include <vector>

namespace oblong {

struct Mesh {
  std::string name;  // file path or "<procedural ...>"
  std::vector<vec3> positions;
  std::vector<vec3> normals;  // unit length, one per position
  std::vector<vec2> uvs;      // empty when the file has none
  std::vector<glm::uvec3> triangles;

  bool hasUVs() const { return !uvs.empty(); }
  DisplacedTriangle triangle(size_t i) const;
  size_t bytes() const;
};

struct MeshLoadOptions {
  glm::mat4 transform{1.0f};  // applied to positions (normals by the inverse transpose)
  bool needUVs = false;       // displaced meshes: a mesh without uvs is an error
};

// Loads every mesh of the file as one Mesh (node transforms applied). Vertex normals
// are normalised; when the file has none, area-weighted smooth normals are computed,
// accumulated per position so that uv seams do not split the normal. Errors name the file.
Mesh loadMesh(const std::string& path, const MeshLoadOptions& opts = {});

// Area-weighted smooth normals accumulated per distinct position.
void computeSmoothNormals(Mesh& m);
// Applies the transform to positions and normals (renormalised).
void transformMesh(Mesh& m, const glm::mat4& transform);

}  // namespace oblong
