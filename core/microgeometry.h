// The intersectable micro-geometry (DESIGN §1): the texel-centre grid, each cell split
// by the diagonal (i,j)-(i+1,j+1), each cell triangle clipped in uv against the base
// triangle T, every vertex mapped by Eq. 1 with T's own P and N, polygons fanned.
//
// Watertightness: every vertex lying on an edge of T (edge/grid-line crossings, grid
// points exactly on the edge, T's vertices) is computed from that edge alone, with
// its endpoints in a canonical order (lexicographic in uv), so the two triangles
// sharing an edge produce bit-identical points along it.
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "core/triangle.h"

#include <functional>
#include <vector>

namespace oblong {

struct MicroVertex {
  vec3 p;   // world position
  vec2 uv;  // texture coordinates (before tiling)
};

struct MicroTriangle {
  MicroVertex v[3];
};

// Cells of the sample grid overlapped by T's uv box: [x0,x1] x [y0,y1] cell indices
// (cell (i,j) spans samples i..i+1, j..j+1).
struct CellRange {
  int x0, y0, x1, y1;
};
CellRange cellsOverlapping(const DisplacedTriangle& T, const Displacement& d);

// Calls emit for every micro-triangle of T over the cells in `cells` (all of T's cells
// by default), in cell order. Degenerate (repeated-vertex) triangles are not emitted.
void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d, const CellRange& cells,
                          const std::function<void(const MicroTriangle&)>& emit);
void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d,
                          const std::function<void(const MicroTriangle&)>& emit);

std::vector<MicroTriangle> microTriangles(const DisplacedTriangle& T, const Displacement& d);

}  // namespace oblong
