#include "core/microgeometry.h"

#include <array>

namespace oblong {

namespace {

// Lines of the construction: grid verticals x = c, horizontals y = c, diagonals
// x - y = c (sample coordinates), and T's edges.
enum class LineType : uint8_t { V, H, D, Edge };
struct Line {
  LineType type;
  int c;
};

// Polygon vertex: where it came from decides how its world position is computed.
enum class Kind : uint8_t { Grid, TVertex, Cross };
struct PV {
  dvec2 s;      // sample coordinates (for the side tests)
  Kind kind;
  int a, b;     // Grid: (i, j); TVertex: (k, -); Cross: (edge, -)
  Line line;    // Cross: the grid line crossed
  Line next;    // line carrying the polygon edge to the next vertex
  bool same(const PV& o) const {
    if (kind != o.kind) return false;
    if (kind == Kind::Cross) return a == o.a && line.type == o.line.type && line.c == o.line.c;
    return a == o.a && (kind == Kind::TVertex || b == o.b);
  }
};

struct EdgeInfo {
  int A, B;        // canonical endpoint order (vertex indices of T)
  dvec2 SA, SB;    // their sample coordinates
  double sigma;    // sign of orient(SA, SB, opposite vertex): the inside side
};

double orient(const dvec2& a, const dvec2& b, const dvec2& p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

bool uvLess(const vec2& a, const vec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }

struct Builder {
  const DisplacedTriangle& T;
  const Displacement& d;
  dvec2 S[3];
  EdgeInfo E[3];  // edge e joins vertices e and (e+1)%3

  Builder(const DisplacedTriangle& tri, const Displacement& disp) : T(tri), d(disp) {
    for (int k = 0; k < 3; ++k) S[k] = d.toSample(T.t[k]);
    for (int e = 0; e < 3; ++e) {
      int A = e, B = (e + 1) % 3;
      if (uvLess(T.t[B], T.t[A])) std::swap(A, B);
      const int opp = 3 - A - B;
      E[e] = {A, B, S[A], S[B], orient(S[A], S[B], S[opp]) > 0 ? 1.0 : -1.0};
    }
  }

  bool inside(int e, const dvec2& p) const { return E[e].sigma * orient(E[e].SA, E[e].SB, p) >= 0; }

  // Parameter along edge e's line (canonical direction) where it meets grid line L.
  // Not clamped: Sutherland-Hodgman clips against whole lines, and an intermediate
  // crossing may lie beyond T's vertices (later clips remove it).
  double crossParamRaw(int e, const Line& L) const {
    const dvec2 a = E[e].SA, b = E[e].SB;
    double t;
    switch (L.type) {
      case LineType::V: t = (L.c - a.x) / (b.x - a.x); break;
      case LineType::H: t = (L.c - a.y) / (b.y - a.y); break;
      default: t = (L.c - (a.x - a.y)) / ((b.x - b.y) - (a.x - a.y)); break;
    }
    return std::isfinite(t) ? t : 0.0;
  }
  // For a final vertex, which lies on the segment (up to rounding).
  double crossParam(int e, const Line& L) const { return std::clamp(crossParamRaw(e, L), 0.0, 1.0); }

  // World point on edge e at parameter t with raw height H.
  MicroVertex onEdge(int e, double t, float rawHeight) const {
    const int A = E[e].A, B = E[e].B;
    const float tf = float(t);
    const vec3 P = (1.0f - tf) * T.p[A] + tf * T.p[B];
    const vec3 N = (1.0f - tf) * T.n[A] + tf * T.n[B];
    const float h = d.scale * (rawHeight + d.bias);
    return {P + h * glm::normalize(N), (1.0f - tf) * T.t[A] + tf * T.t[B]};
  }

  // Raw height on grid line L at sample point s (linear between the line's samples).
  float lineHeight(const Line& L, const dvec2& s) const {
    const HeightMap& m = *d.map;
    if (L.type == LineType::V) {
      const int j = int(std::floor(s.y));
      const float f = float(s.y - j);
      return m.at(L.c, j) + f * (m.at(L.c, j + 1) - m.at(L.c, j));
    }
    if (L.type == LineType::H) {
      const int i = int(std::floor(s.x));
      const float f = float(s.x - i);
      return m.at(i, L.c) + f * (m.at(i + 1, L.c) - m.at(i, L.c));
    }
    const int j = int(std::floor(s.y)), i = j + L.c;
    const float f = float(s.y - j);
    return m.at(i, j) + f * (m.at(i + 1, j + 1) - m.at(i, j));
  }

  MicroVertex world(const PV& v) const {
    switch (v.kind) {
      case Kind::TVertex: {
        const int k = v.a;
        const float h = d.microAtSample(S[k]);
        return {T.p[k] + h * T.n[k], T.t[k]};  // n[k] is unit
      }
      case Kind::Cross: {
        const double t = crossParam(v.a, v.line);
        const dvec2 s = E[v.a].SA + t * (E[v.a].SB - E[v.a].SA);
        return onEdge(v.a, t, lineHeight(v.line, s));
      }
      case Kind::Grid:
      default: {
        const float raw = d.map->at(v.a, v.b);
        // A grid point exactly on an edge of T is computed from that edge alone.
        for (int e = 0; e < 3; ++e)
          if (orient(E[e].SA, E[e].SB, v.s) == 0.0) {
            const dvec2 ab = E[e].SB - E[e].SA;
            const double t = std::clamp(glm::dot(v.s - E[e].SA, ab) / glm::dot(ab, ab), 0.0, 1.0);
            return onEdge(e, t, raw);
          }
        const vec2 uv = d.sampleToUV(v.a, v.b);
        const vec2 b = T.baryOfUV(uv);
        const vec3 N = T.N(b.x, b.y);
        return {T.P(b.x, b.y) + (d.scale * (raw + d.bias)) * glm::normalize(N), uv};
      }
    }
  }

  // Sutherland-Hodgman against edge e, tracking which line each polygon edge lies on.
  void clip(int e, std::vector<PV>& in, std::vector<PV>& out) const {
    out.clear();
    const size_t n = in.size();
    for (size_t k = 0; k < n; ++k) {
      const PV& a = in[k];
      const PV& b = in[(k + 1) % n];
      const bool ia = inside(e, a.s), ib = inside(e, b.s);
      if (ia) out.push_back(a);
      if (ia != ib) {
        PV x;
        if (a.next.type == LineType::Edge) {  // two edges of T meet at a vertex of T
          const int e2 = a.next.c;
          const int k3 = (e2 + 1) % 3 == e ? e : ((e + 1) % 3 == e2 ? e2 : -1);
          x.kind = Kind::TVertex;
          x.a = k3 >= 0 ? k3 : 0;
          x.b = 0;
          x.s = S[x.a];
        } else {
          x.kind = Kind::Cross;
          x.a = e;
          x.b = 0;
          x.line = a.next;
          const double t = crossParamRaw(e, a.next);
          x.s = E[e].SA + t * (E[e].SB - E[e].SA);
        }
        // Leaving: the polygon continues along T's edge; entering: along a's line.
        x.next = ia ? Line{LineType::Edge, e} : a.next;
        out.push_back(x);
      }
    }
  }
};

}  // namespace

CellRange cellsOverlapping(const DisplacedTriangle& T, const Displacement& d) {
  const dvec2 a = d.toSample(T.uvBox.lo), b = d.toSample(T.uvBox.hi);
  return {int(std::floor(a.x)), int(std::floor(a.y)), int(std::floor(b.x)), int(std::floor(b.y))};
}

void forEachMicroTriangle(const DisplacedTriangle& T, const Displacement& d, const CellRange& cells,
                          const std::function<void(const MicroTriangle&)>& emit) {
  if (T.uvArea2 == 0.0f) return;
  Builder B(T, d);
  std::vector<PV> poly, tmp;
  poly.reserve(16);
  tmp.reserve(16);
  auto grid = [](int i, int j, Line next) {
    PV v{};
    v.s = dvec2(i, j);
    v.kind = Kind::Grid;
    v.a = i;
    v.b = j;
    v.next = next;
    return v;
  };
  for (int j = cells.y0; j <= cells.y1; ++j)
    for (int i = cells.x0; i <= cells.x1; ++i)
      for (int half = 0; half < 2; ++half) {
        poly.clear();
        const Line D{LineType::D, i - j};
        if (half == 0) {  // lower: (i,j) (i+1,j) (i+1,j+1)
          poly.push_back(grid(i, j, {LineType::H, j}));
          poly.push_back(grid(i + 1, j, {LineType::V, i + 1}));
          poly.push_back(grid(i + 1, j + 1, D));
        } else {  // upper: (i,j) (i+1,j+1) (i,j+1)
          poly.push_back(grid(i, j, D));
          poly.push_back(grid(i + 1, j + 1, {LineType::H, j + 1}));
          poly.push_back(grid(i, j + 1, {LineType::V, i}));
        }
        for (int e = 0; e < 3 && !poly.empty(); ++e) {
          B.clip(e, poly, tmp);
          std::swap(poly, tmp);
        }
        // Drop repeated vertices (a grid point on an edge can appear twice).
        tmp.clear();
        for (const PV& v : poly)
          if (tmp.empty() || !v.same(tmp.back())) tmp.push_back(v);
        while (tmp.size() > 1 && tmp.front().same(tmp.back())) tmp.pop_back();
        if (tmp.size() < 3) continue;
        std::array<MicroVertex, 8> w;
        const size_t nv = std::min(tmp.size(), w.size());
        for (size_t k = 0; k < nv; ++k) w[k] = B.world(tmp[k]);
        for (size_t k = 1; k + 1 < nv; ++k) emit(MicroTriangle{{w[0], w[k], w[k + 1]}});
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
