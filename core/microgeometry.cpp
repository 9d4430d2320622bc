#include "core/microgeometry.h"

namespace oblong {

namespace sh = shared;

// The kernel's heights (core/kernels/microcells.h): the displacement at the ray's blend
// fraction, and interior grid points through the cache when there is one.
struct MicroHeights {
  const MicroCells& mc;
  GridVertexCache* cache;
  float raw(int i, int j) const { return mc.d_.raw(i, j, mc.f_); }
  float microAt(const dvec2& s) const { return mc.d_.microAtSample(s, mc.f_); }
  MicroVertex grid(int i, int j) const { return cache ? mc.gridInterior(i, j, *cache) : mc.gridInterior(i, j); }
  glm::vec2 uv(int i, int j) const { return mc.d_.sampleToUV(i, j); }
};
inline float mcRaw(const MicroHeights& h, int i, int j) { return h.raw(i, j); }
inline float mcMicroAt(const MicroHeights& h, const dvec2& s) { return h.microAt(s); }
// Every grid point inside T through gridInterior (cached where a cache is given).
inline bool mcGridCached(const MicroHeights& h, int i, int j, MicroVertex& v) {
  v = h.grid(i, j);
  return true;
}
inline glm::vec2 mcGridUV(const MicroHeights& h, int i, int j) { return h.uv(i, j); }

MicroCells::MicroCells(const DisplacedTriangle& tri, const Displacement& disp, float f) : T_(tri), d_(disp), f_(f) {
  dvec2 S[3];
  for (int k = 0; k < 3; ++k) S[k] = d_.toSample(T_.t[k]);
  E_ = sh::mcEdges(S, T_.t);
  for (int k = 0; k < 3; ++k) Tm_.p[k] = T_.p[k], Tm_.n[k] = T_.n[k], Tm_.t[k] = T_.t[k];
  double sum;
  sh::mcBaryMap(S, Tm_, sum);
  Tm_.scale = d_.scale, Tm_.bias = d_.bias;
}

MicroVertex MicroCells::gridInterior(int i, int j) const {
  return sh::mcGridInterior(Tm_, i, j, d_.sampleToUV(i, j), d_.raw(i, j, f_));
}

bool MicroCells::interior(int i, int j) const { return sh::mcInterior(E_, i, j); }

const MicroVertex& MicroCells::gridInterior(int i, int j, GridVertexCache& cache) const {
  const int k = GridVertexCache::slot(i, j);
  GridVertexCache::Entry& e = cache.e[k];
  if (!(cache.filled >> k & 1) || e.i != i || e.j != j) {
    cache.filled |= uint64_t(1) << k;
    e.i = i, e.j = j;
    e.v = gridInterior(i, j);
  }
  return e.v;
}

int MicroCells::cell(int i, int j, MicroTriangle* out) const {
  if (T_.uvArea2 == 0.0f) return 0;
  if (interior(i, j)) {
    // Every clip keeps every vertex and no grid point lies on an edge of T: the
    // general path would produce exactly these two triangles.
    const MicroVertex v00 = gridInterior(i, j), v10 = gridInterior(i + 1, j);
    const MicroVertex v11 = gridInterior(i + 1, j + 1), v01 = gridInterior(i, j + 1);
    out[0] = MicroTriangle{{v00, v10, v11}};
    out[1] = MicroTriangle{{v00, v11, v01}};
    return 2;
  }
  return clipped(i, j, out, nullptr);
}

bool MicroCells::interiorCorners(int i, int j, GridVertexCache& cache, const MicroVertex* q[4]) const {
  if (T_.uvArea2 == 0.0f || !interior(i, j)) return false;
  q[0] = &gridInterior(i, j, cache), q[1] = &gridInterior(i + 1, j, cache);
  q[2] = &gridInterior(i + 1, j + 1, cache), q[3] = &gridInterior(i, j + 1, cache);
  return true;
}

int MicroCells::cell(int i, int j, MicroTriangle* out, GridVertexCache& cache) const {
  if (T_.uvArea2 == 0.0f) return 0;
  const MicroVertex* q[4];
  if (interiorCorners(i, j, cache, q)) {
    out[0] = MicroTriangle{{*q[0], *q[1], *q[2]}};
    out[1] = MicroTriangle{{*q[0], *q[2], *q[3]}};
    return 2;
  }
  return clipped(i, j, out, &cache);
}

// Cells crossing T's boundary: each half clipped (the kernel's mcHalf), then fanned.
int MicroCells::clipped(int i, int j, MicroTriangle* out, GridVertexCache* cache) const {
  const int mask = sh::mcClipMask(E_, i, j);
  const MicroHeights hs{*this, cache};
  int count = 0;
  int diagEdge = -1;  // the edge whose crossing with the diagonal is diagVertex
  MicroVertex diagVertex{};
  sh::McPV buf[2 * OBLONG_MC_POLY];
  for (int half = 0; half < 2; ++half) {
    int base = 0;
    const int m = sh::mcHalf(E_, i, j, half, mask, buf, base);
    if (m < 3) continue;
    MicroVertex w[OBLONG_MC_POLY];
    for (int k = 0; k < m; ++k) {
      // The crossing of an edge of T with the cell's diagonal is a vertex of both
      // halves: computed once (its position is a function of the edge and the line).
      const sh::McPV& v = buf[base + k];
      const bool diag = v.kind == OBLONG_MC_CROSS && v.lineType == OBLONG_MC_LINE_D;
      if (diag && diagEdge == v.a) {
        w[k] = diagVertex;
        continue;
      }
      w[k] = sh::mcWorld(Tm_, E_, hs, v, mask);
      if (diag) diagEdge = v.a, diagVertex = w[k];
    }
    for (int k = 1; k + 1 < m; ++k) out[count++] = MicroTriangle{{w[0], w[k], w[k + 1]}};
  }
  return count;
}

CellRange cellsOverlapping(const DisplacedTriangle& T, const Displacement& d) {
  const dvec2 a = d.toSample(T.uvBox.lo), b = d.toSample(T.uvBox.hi);
  return {int(std::floor(a.x)), int(std::floor(a.y)), int(std::floor(b.x)), int(std::floor(b.y))};
}

void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d, const CellRange& cells,
                          const std::function<void(const MicroTriangle&)>& emit) {
  if (T.uvArea2 == 0.0f) return;
  const MicroCells mc(T, d);
  MicroTriangle buf[MicroCells::kMaxPerCell];
  for (int j = cells.y0; j <= cells.y1; ++j)
    for (int i = cells.x0; i <= cells.x1; ++i) {
      const int n = mc.cell(i, j, buf);
      for (int k = 0; k < n; ++k) emit(buf[k]);
    }
}

void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d,
                          const std::function<void(const MicroTriangle&)>& emit) {
  forEachMicroTriangle(T, d, cellsOverlapping(T, d), emit);
}

std::vector<MicroTriangle> microTriangles(const DisplacedTriangle& T, const Displacement& d) {
  std::vector<MicroTriangle> out;
  forEachMicroTriangle(T, d, [&](const MicroTriangle& m) { out.push_back(m); });
  return out;
}

}  // namespace oblong
