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

// Rectangle size.x by size.y in the xz-plane at y = 0, centred on the origin, with
// segments.x by segments.y quads (two triangles each), normal +y. u runs with +x from
// uv0.x to uv1.x, v with +z from uv0.y to uv1.y (so v = 0, the map's first scanline,
// is the far edge seen from +z).
Mesh planeMesh(vec2 size, ivec2 segments, vec2 uv0 = vec2(0.0f), vec2 uv1 = vec2(1.0f));

// UV sphere of the given radius centred on the origin, poles on the y axis: nu segments
// around (u = longitude, increasing to the right seen from outside, u = 0 = 1 at +x), nv
// segments from the north pole (v = 0, the map's first scanline) to the south pole
// (v = 1). Analytic unit normals; the seam column u = 1 duplicates u = 0 with
// bit-identical positions and normals. Each pole triangle has its own pole vertex with
// u at the middle of its segment. 2·nu·(nv−1) triangles, none degenerate. nu >= 3, nv >= 2.
Mesh sphereMesh(float radius, int nu, int nv);

}  // namespace oblong
