// The intersectable micro-geometry (docs/design.md §1): the texel-centre grid, each cell split
// by the diagonal (i,j)-(i+1,j+1), each cell triangle clipped in uv against the base
// triangle T, every vertex mapped by Eq. 1 with T's own P and N, polygons fanned. The
// construction and its watertightness are core/kernels/microcells.h, which the Vulkan
// shaders compile too.
//
// MicroCells is the one implementation on the CPU: forEachMicroTriangle loops over cells with it,
// and the traversal (traversal/traversal.h) calls it cell by cell. It allocates nothing,
// so it can run in a per-ray hot loop, and both paths get bit-identical triangles.
#pragma once

#include "core/heightmap.h"
#include "core/kernels/microcells.h"
#include "core/math.h"
#include "core/triangle.h"

#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

namespace oblong {

// A micro-vertex: position and texture coordinates (before tiling).
using MicroVertex = shared::McVertex;

struct MicroTriangle {
  MicroVertex v[3];
};

// Cells of the sample grid overlapped by T's uv box: [x0,x1] x [y0,y1] cell indices
// (cell (i,j) spans samples i..i+1, j..j+1).
struct CellRange {
  int x0, y0, x1, y1;
};
CellRange cellsOverlapping(const DisplacedTriangle& T, const Displacement& d);

// Grid points already computed by MicroCells::cell for one triangle (direct-mapped,
// keyed by the sample index): neighbouring cells share corners, a march along a ray
// visits neighbouring cells. Only for one MicroCells (one triangle) at a time.
// Starts empty by clearing one word (`filled`, a bit per slot), not its 64 entries: a
// cache is set up for every ray and triangle that reaches a cell.
struct GridVertexCache {
  struct Entry {
    int i, j;
    MicroVertex v;
  };
  uint64_t filled = 0;
  Entry e[64];
  static int slot(int i, int j) { return (i & 7) | ((j & 7) << 3); }
};

// The micro-triangles of T cell by cell, without allocation. T and d must outlive it.
class MicroCells {
 public:
  // A cell triangle clipped by T has at most 6 vertices (4 fan triangles); two halves.
  static constexpr int kMaxPerCell = 8;

  // f: the blend fraction of a ray's level of detail (Displacement::blendOf; 0 when the
  // displacement has one surface for every ray).
  MicroCells(const DisplacedTriangle& T, const Displacement& d, float f = 0.0f);

  // Writes the micro-triangles of cell (i,j) (absolute sample indices; the map wraps)
  // to out in the order forEachMicroTriangle emits them; returns how many (0 for a cell
  // outside T). Cells whose four corners lie strictly inside T skip the clipping (the
  // result is the same: clipping would keep every vertex).
  int cell(int i, int j, MicroTriangle* out) const;
  // The same, reusing grid points of interior cells from `cache` (same values bit for
  // bit: they come from the same computation).
  int cell(int i, int j, MicroTriangle* out, GridVertexCache& cache) const;

  // T as the kernels (core/kernels/microcells.h) read it; the Vulkan path's records hold
  // these.
  const shared::McEdges& kernelEdges() const { return E_; }
  const shared::McTri& kernelTri() const { return Tm_; }

  // True when the cell's four corners lie strictly inside T (two unclipped triangles).
  bool interior(int i, int j) const;
  // For such a cell, its corners q = (v00, v10, v11, v01) (cell() emits the triangles
  // (v00, v10, v11) and (v00, v11, v01)): pointers into `cache`, valid until its next
  // use (the four corners of a cell take four different slots); false for a cell that
  // is not interior (clippedCell() then has its triangles).
  bool interiorCorners(int i, int j, GridVertexCache& cache, const MicroVertex* q[4]) const;
  // cell() for a cell interiorCorners() refused.
  int clippedCell(int i, int j, MicroTriangle* out, GridVertexCache& cache) const {
    return T_.uvArea2 == 0.0f ? 0 : clipped(i, j, out, &cache);
  }

 private:
  MicroVertex gridInterior(int i, int j) const;
  const MicroVertex& gridInterior(int i, int j, GridVertexCache& cache) const;
  int clipped(int i, int j, MicroTriangle* out, GridVertexCache* cache) const;
  friend struct MicroHeights;

  const DisplacedTriangle& T_;
  const Displacement& d_;
  float f_;
  shared::McEdges E_;  // T in sample coordinates: the edges' canonical order and sides
  shared::McTri Tm_;   // T's float data and the height transform, as the kernel reads them
};

// Calls emit for every micro-triangle of T over the cells in `cells` (all of T's cells
// by default), in cell order. Degenerate (repeated-vertex) triangles are not emitted.
void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d, const CellRange& cells,
                          const std::function<void(const MicroTriangle&)>& emit);
void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d,
                          const std::function<void(const MicroTriangle&)>& emit);

std::vector<MicroTriangle> microTriangles(const DisplacedTriangle& T, const Displacement& d);

}  // namespace oblong
