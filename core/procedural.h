// Procedural data for the built-in default scene and for tests: no files needed.
#pragma once

#include "core/heightmap.h"
#include "core/mesh.h"
#include "core/scene.h"

#include <cstdint>

namespace oblong {

// A tileable (periodic in both axes) height field in [0,1]: a few integer-frequency
// waves plus periodic value noise. Any size, including non-powers of two.
HeightMap proceduralHeightMap(int width, int height, uint32_t seed = 1);

// Torus in the xz-plane with uvs u (around the main axis) and v (around the tube) in
// [0,1]. Seam vertices are duplicated with bit-identical positions and normals, so a
// tileable map displaces it into a closed surface.
Mesh torusMesh(float majorRadius, float minorRadius, int segmentsU, int segmentsV);

// Square [-s,s]^2 in the xz-plane at height y, n x n quads, uvs in [0,1]^2, normal +y.
Mesh quadMesh(float halfSize, float y, int n);

}  // namespace oblong
