// The displaced triangle (docs/design.md §1): base positions, unit vertex normals, uvs and
// the derived constants the traversal needs.
#pragma once

#include "core/math.h"

namespace oblong {

struct DisplacedTriangle {
  vec3 p[3];  // base positions
  vec3 n[3];  // unit vertex normals
  vec2 t[3];  // texture coordinates (before tiling)

  // Derived constants (computed by prepare()).
  vec3 faceNormal{0.0f};   // unit geometric normal, (p1-p0) x (p2-p0) oriented
  float area = 0.0f;        // world-space area
  glm::mat2 uvToBary{1.0f};  // (u,v) barycentrics of a uv: uvToBary * (uv - t0)
  float uvArea2 = 0.0f;      // signed doubled uv area (0 for a degenerate uv triangle)
  float minNormalLength = 1.0f;  // m = min over T of |N(b)| (> 0 unless normals cancel)
  Rect uvBox;                // uv bounding box

  // Fills the derived constants. Returns false when the triangle cannot be displaced
  // (zero world or uv area, or the interpolated normal vanishes somewhere in T).
  bool prepare();

  // Barycentrics b = (1-u-v, u, v) -> quantities (affine in b).
  vec3 P(float u, float v) const { return (1 - u - v) * p[0] + u * p[1] + v * p[2]; }
  vec3 N(float u, float v) const { return (1 - u - v) * n[0] + u * n[1] + v * n[2]; }
  vec2 UV(float u, float v) const { return (1 - u - v) * t[0] + u * t[1] + v * t[2]; }
  vec2 baryOfUV(const vec2& uv) const { return uvToBary * (uv - t[0]); }
};

// min over the triangle of |b0 n0 + b1 n1 + b2 n2| (b in the simplex): a convex
// quadratic, minimised exactly over the interior, the three edges and the vertices.
float minInterpolatedNormalLength(const vec3& n0, const vec3& n1, const vec3& n2);

// A float >= 1/m for every m that rounds to the float mf (minInterpolatedNormalLength's
// result is rounded to nearest): 1/mf with a relative margin of 2^-20, rounded up. The
// boxes multiply by it (core/kernels/rect_bounds.h, boxFrameF's invM) instead of dividing by |N|.
float invNormalLengthBound(float mf);

}  // namespace oblong
