#include "core/microgeometry.h"

#include <array>

namespace oblong {

using micro::EdgeInfo;
using micro::Kind;
using micro::Line;
using micro::LineType;
using micro::PV;

namespace {

double orient(const dvec2& a, const dvec2& b, const dvec2& p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

bool uvLess(const vec2& a, const vec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }

PV grid(int i, int j, Line next) {
  PV v{};
  v.s = dvec2(i, j);
  v.kind = Kind::Grid;
  v.a = i;
  v.b = j;
  v.next = next;
  return v;
}

}  // namespace

MicroCells::MicroCells(const DisplacedTriangle& tri, const Displacement& disp, float f) : T_(tri), d_(disp), f_(f) {
  for (int k = 0; k < 3; ++k) S_[k] = d_.toSample(T_.t[k]);
  for (int e = 0; e < 3; ++e) {
    int A = e, B = (e + 1) % 3;
    if (uvLess(T_.t[B], T_.t[A])) std::swap(A, B);
    const int opp = 3 - A - B;
    E_[e] = {A, B, S_[A], S_[B], orient(S_[A], S_[B], S_[opp]) > 0 ? 1.0 : -1.0};
    // σ·orient grows with x where σ·(SB − SA).y < 0 and with y where σ·(SB − SA).x > 0.
    const dvec2 d = E_[e].SB - E_[e].SA;
    least_[e] = ivec2(E_[e].sigma * d.y < 0 ? 0 : 1, E_[e].sigma * d.x > 0 ? 0 : 1);
  }
}

bool MicroCells::inside(int e, const dvec2& p) const { return E_[e].sigma * orient(E_[e].SA, E_[e].SB, p) >= 0; }

bool MicroCells::strictlyInside(const dvec2& p) const {
  for (int e = 0; e < 3; ++e)
    if (!(E_[e].sigma * orient(E_[e].SA, E_[e].SB, p) > 0)) return false;
  return true;
}

// Parameter along edge e's line (canonical direction) where it meets grid line L.
// Not clamped: Sutherland-Hodgman clips against whole lines, and an intermediate
// crossing may lie beyond T's vertices (later clips remove it).
double MicroCells::crossParamRaw(int e, const Line& L) const {
  const dvec2 a = E_[e].SA, b = E_[e].SB;
  double t;
  switch (L.type) {
    case LineType::V: t = (L.c - a.x) / (b.x - a.x); break;
    case LineType::H: t = (L.c - a.y) / (b.y - a.y); break;
    default: t = (L.c - (a.x - a.y)) / ((b.x - b.y) - (a.x - a.y)); break;
  }
  return std::isfinite(t) ? t : 0.0;
}
// For a final vertex, which lies on the segment (up to rounding).
double MicroCells::crossParam(int e, const Line& L) const { return std::clamp(crossParamRaw(e, L), 0.0, 1.0); }

// World point on edge e at parameter t with raw height H.
MicroVertex MicroCells::onEdge(int e, double t, float rawHeight) const {
  const int A = E_[e].A, B = E_[e].B;
  const float tf = float(t);
  const vec3 P = (1.0f - tf) * T_.p[A] + tf * T_.p[B];
  const vec3 N = (1.0f - tf) * T_.n[A] + tf * T_.n[B];
  const float h = d_.scale * (rawHeight + d_.bias);
  return {P + h * glm::normalize(N), (1.0f - tf) * T_.t[A] + tf * T_.t[B]};
}

// Raw height on grid line L at sample point s (linear between the line's samples).
float MicroCells::lineHeight(const Line& L, const dvec2& s) const {
  const Displacement& d = d_;
  const float g = f_;
  if (L.type == LineType::V) {
    const int j = int(std::floor(s.y));
    const float f = float(s.y - j);
    const float a = d.raw(L.c, j, g);
    return a + f * (d.raw(L.c, j + 1, g) - a);
  }
  if (L.type == LineType::H) {
    const int i = int(std::floor(s.x));
    const float f = float(s.x - i);
    const float a = d.raw(i, L.c, g);
    return a + f * (d.raw(i + 1, L.c, g) - a);
  }
  const int j = int(std::floor(s.y)), i = j + L.c;
  const float f = float(s.y - j);
  const float a = d.raw(i, j, g);
  return a + f * (d.raw(i + 1, j + 1, g) - a);
}

// A grid point not on any edge of T: T's barycentrics of its uv.
MicroVertex MicroCells::gridInterior(int i, int j) const {
  const float raw = d_.raw(i, j, f_);
  const vec2 uv = d_.sampleToUV(i, j);
  const vec2 b = T_.baryOfUV(uv);
  const vec3 N = T_.N(b.x, b.y);
  return {T_.P(b.x, b.y) + (d_.scale * (raw + d_.bias)) * glm::normalize(N), uv};
}

MicroVertex MicroCells::world(const PV& v, const bool* onEdgePossible, GridVertexCache* cache) const {
  switch (v.kind) {
    case Kind::TVertex: {
      const int k = v.a;
      const float h = d_.microAtSample(S_[k], f_);
      return {T_.p[k] + h * T_.n[k], T_.t[k]};  // n[k] is unit
    }
    case Kind::Cross: {
      const double t = crossParam(v.a, v.line);
      const dvec2 s = E_[v.a].SA + t * (E_[v.a].SB - E_[v.a].SA);
      return onEdge(v.a, t, lineHeight(v.line, s));
    }
    case Kind::Grid:
    default: {
      // A grid point exactly on an edge of T is computed from that edge alone. Only
      // edges that may pass through the cell (onEdgePossible) are tested: for the others
      // σ·orient is positive at every corner of the cell.
      for (int e = 0; e < 3; ++e)
        if (onEdgePossible[e] && orient(E_[e].SA, E_[e].SB, v.s) == 0.0) {
          const dvec2 ab = E_[e].SB - E_[e].SA;
          const double t = std::clamp(glm::dot(v.s - E_[e].SA, ab) / glm::dot(ab, ab), 0.0, 1.0);
          return onEdge(e, t, d_.raw(v.a, v.b, f_));
        }
      return cache ? gridInterior(v.a, v.b, *cache) : gridInterior(v.a, v.b);
    }
  }
}

// Sutherland-Hodgman against edge e, tracking which line each polygon edge lies on.
int MicroCells::clip(int e, const PV* in, int n, PV* out) const {
  int m = 0;
  for (int k = 0; k < n; ++k) {
    const PV& a = in[k];
    const PV& b = in[(k + 1) % n];
    const bool ia = inside(e, a.s), ib = inside(e, b.s);
    if (ia) out[m++] = a;
    if (ia != ib) {
      PV x;
      if (a.next.type == LineType::Edge) {  // two edges of T meet at a vertex of T
        const int e2 = a.next.c;
        const int k3 = (e2 + 1) % 3 == e ? e : ((e + 1) % 3 == e2 ? e2 : -1);
        x.kind = Kind::TVertex;
        x.a = k3 >= 0 ? k3 : 0;
        x.b = 0;
        x.s = S_[x.a];
      } else {
        x.kind = Kind::Cross;
        x.a = e;
        x.b = 0;
        x.line = a.next;
        const double t = crossParamRaw(e, a.next);
        x.s = E_[e].SA + t * (E_[e].SB - E_[e].SA);
      }
      // Leaving: the polygon continues along T's edge; entering: along a's line.
      x.next = ia ? Line{LineType::Edge, e} : a.next;
      out[m++] = x;
    }
  }
  return m;
}

bool MicroCells::interior(int i, int j) const {
  // All four corners strictly inside every edge: per edge, its least corner (least_).
  for (int e = 0; e < 3; ++e)
    if (!(E_[e].sigma * orient(E_[e].SA, E_[e].SB, dvec2(i + least_[e].x, j + least_[e].y)) > 0)) return false;
  return true;
}

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

// Cells crossing T's boundary: Sutherland-Hodgman on each half, then the fan.
int MicroCells::clipped(int i, int j, MicroTriangle* out, GridVertexCache* cache) const {
  // An edge whose inner half-plane holds the whole cell with a margin is not clipped
  // against: Sutherland-Hodgman returns an all-inside polygon unchanged (same vertices,
  // same order), and every vertex the other clips create lies in the cell up to rounding
  // far below the margin. A cell on one edge of T clips once per half instead of three
  // times.
  bool clipAgainst[3];
  for (int e = 0; e < 3; ++e) {
    const dvec2 d = E_[e].SB - E_[e].SA;
    const double margin = 1e-9 * (std::abs(d.x) + std::abs(d.y)) *
                          (1.0 + std::abs(double(i)) + std::abs(double(j)) + std::abs(E_[e].SA.x) + std::abs(E_[e].SA.y));
    const double least = E_[e].sigma * orient(E_[e].SA, E_[e].SB, dvec2(i + least_[e].x, j + least_[e].y));
    clipAgainst[e] = !(least > margin);
  }
  int count = 0;
  int diagEdge = -1;  // the edge whose crossing with the diagonal is diagVertex
  MicroVertex diagVertex{};
  // A triangle clipped by three half-planes has at most 6 vertices.
  std::array<PV, 8> bufA, bufB;
  for (int half = 0; half < 2; ++half) {
    PV* poly = bufA.data();
    PV* tmp = bufB.data();
    int n = 0;
    const Line D{LineType::D, i - j};
    if (half == 0) {  // lower: (i,j) (i+1,j) (i+1,j+1)
      poly[n++] = grid(i, j, {LineType::H, j});
      poly[n++] = grid(i + 1, j, {LineType::V, i + 1});
      poly[n++] = grid(i + 1, j + 1, D);
    } else {  // upper: (i,j) (i+1,j+1) (i,j+1)
      poly[n++] = grid(i, j, D);
      poly[n++] = grid(i + 1, j + 1, {LineType::H, j + 1});
      poly[n++] = grid(i, j + 1, {LineType::V, i});
    }
    for (int e = 0; e < 3 && n > 0; ++e) {
      if (!clipAgainst[e]) continue;
      n = clip(e, poly, n, tmp);
      std::swap(poly, tmp);
    }
    // Drop repeated vertices (a grid point on an edge can appear twice).
    int m = 0;
    for (int k = 0; k < n; ++k)
      if (m == 0 || !poly[k].same(tmp[m - 1])) tmp[m++] = poly[k];
    while (m > 1 && tmp[0].same(tmp[m - 1])) --m;
    if (m < 3) continue;
    std::array<MicroVertex, 8> w;
    const int nv = std::min(m, int(w.size()));
    for (int k = 0; k < nv; ++k) {
      // The crossing of an edge of T with the cell's diagonal is a vertex of both
      // halves: computed once (world() is a function of the edge and the line).
      const PV& v = tmp[k];
      if (v.kind == Kind::Cross && v.line.type == LineType::D) {
        if (diagEdge == v.a) {
          w[k] = diagVertex;
          continue;
        }
        w[k] = world(v, clipAgainst, cache);
        diagEdge = v.a, diagVertex = w[k];
        continue;
      }
      w[k] = world(v, clipAgainst, cache);
    }
    for (int k = 1; k + 1 < nv; ++k) out[count++] = MicroTriangle{{w[0], w[k], w[k + 1]}};
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
