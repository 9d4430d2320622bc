// The pre-tessellation baseline's micro-triangles (tessellation.h).
#include "render/tessellation.h"

#include "core/microgeometry.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace oblong {

namespace {

// Position (bitwise) -> vertex index, open addressing in one allocation: freed, it goes
// back to the system (a node-based map's small nodes stay in the heap and in the RSS).
class VertexTable {
 public:
  // At most 2/3 full for `vertices` entries; grows past that.
  static size_t slotsFor(size_t vertices) { return std::bit_ceil(vertices + vertices / 2 + 16); }
  static size_t bytes(size_t vertices) { return slotsFor(vertices) * sizeof(Slot); }
  explicit VertexTable(size_t vertices) : slots_(slotsFor(vertices)) {}

  // The index of p; `next` is stored and returned when p is new (fresh = true).
  uint32_t find(const vec3& p, uint32_t next, bool& fresh) {
    if (3 * (count_ + 1) > 2 * slots_.size()) grow();
    Slot key;
    std::memcpy(key.k, &p, sizeof key.k);
    for (size_t i = hash(key) & (slots_.size() - 1);; i = (i + 1) & (slots_.size() - 1)) {
      Slot& s = slots_[i];
      if (s.v == kEmpty) {
        s = key;
        s.v = next;
        ++count_;
        fresh = true;
        return next;
      }
      if (std::memcmp(s.k, key.k, sizeof key.k) == 0) {
        fresh = false;
        return s.v;
      }
    }
  }

 private:
  static constexpr uint32_t kEmpty = UINT32_MAX;
  struct Slot {
    uint32_t k[3] = {0, 0, 0};
    uint32_t v = kEmpty;
  };
  static size_t hash(const Slot& s) {
    uint64_t h = (uint64_t(s.k[0]) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(s.k[1]) * 0xC2B2AE3D27D4EB4Full) ^
                 (uint64_t(s.k[2]) * 0x165667B19E3779F9ull);
    return size_t(h ^ (h >> 29));
  }
  void grow() {
    std::vector<Slot> old(slots_.size() * 2);
    old.swap(slots_);
    for (const Slot& s : old)
      if (s.v != kEmpty)
        for (size_t i = hash(s) & (slots_.size() - 1);; i = (i + 1) & (slots_.size() - 1))
          if (slots_[i].v == kEmpty) {
            slots_[i] = s;
            break;
          }
  }
  std::vector<Slot> slots_;
  size_t count_ = 0;
};

TessellationPatchSize patchSize(const DisplacedTriangle& T, const Displacement& d) {
  TessellationPatchSize out;
  if (T.uvArea2 == 0.0f) return out;
  const CellRange cr = cellsOverlapping(T, d);
  dvec2 S[3];
  for (int k = 0; k < 3; ++k) S[k] = d.toSample(T.t[k]);
  const double cells = (double(cr.x1) - cr.x0 + 1) * (double(cr.y1) - cr.y0 + 1);
  if (cells > 0x1p36) {  // far beyond any memory: two per cell of T's area is close enough
    out.triangles = size_t(std::abs((S[1].x - S[0].x) * (S[2].y - S[0].y) - (S[1].y - S[0].y) * (S[2].x - S[0].x)));
    out.vertices = out.triangles / 2;
    return out;
  }
  // Per row of cells: the cells whose corners are all strictly inside T are contiguous
  // (T is convex) and give two triangles each; the clipped cells at both ends are counted
  // one by one, within T's x extent over the row (one cell of margin for rounding).
  const MicroCells mc(T, d);
  MicroTriangle buf[MicroCells::kMaxPerCell];
  for (int j = cr.y0; j <= cr.y1; ++j) {
    const double ya = j - 1e-6, yb = j + 1 + 1e-6;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int k = 0; k < 3; ++k) {
      const dvec2 a = S[k], b = S[(k + 1) % 3];
      if (a.y >= ya && a.y <= yb) lo = std::min(lo, a.x), hi = std::max(hi, a.x);
      for (const double y : {ya, yb})
        if ((a.y - y) * (b.y - y) < 0) {
          const double x = a.x + (b.x - a.x) * ((y - a.y) / (b.y - a.y));
          lo = std::min(lo, x), hi = std::max(hi, x);
        }
    }
    if (!(lo <= hi)) continue;
    const int i0 = std::max(cr.x0, int(std::floor(lo)) - 1), i1 = std::min(cr.x1, int(std::floor(hi)) + 1);
    int i = i0;
    for (; i <= i1 && !mc.interior(i, j); ++i) out.triangles += size_t(mc.cell(i, j, buf));
    if (i > i1) continue;
    int k = i1;
    for (; !mc.interior(k, j); --k) out.triangles += size_t(mc.cell(k, j, buf));
    out.triangles += 2 * size_t(k - i + 1);
  }
  // A triangulated disc: V = 1 + (F + B) / 2 with B the vertices on T's boundary, at
  // most T's corners plus each edge's crossings with the grid lines x, y, x - y = const
  // (a crossing at a grid point is counted once per line: a bound).
  auto crossings = [](double a, double b) -> size_t {
    if (a == b) return 0;
    const double c = std::ceil(std::max(a, b)) - std::floor(std::min(a, b)) - 1;
    return c > 0 ? size_t(c) : 0;
  };
  size_t B = 3;
  for (int k = 0; k < 3; ++k) {
    const dvec2 a = S[k], b = S[(k + 1) % 3];
    B += crossings(a.x, b.x) + crossings(a.y, b.y) + crossings(a.x - a.y, b.x - b.y);
  }
  out.vertices = out.triangles == 0 ? 0 : std::min(3 * out.triangles, 1 + (out.triangles + B + 1) / 2);
  return out;
}

}  // namespace

std::vector<TessellationPatchSize> tessellationPatchSizes(const Mesh& mesh, const Displacement& d) {
  std::vector<TessellationPatchSize> sizes(mesh.triangles.size());
  tbb::parallel_for(size_t(0), sizes.size(), [&](size_t ti) { sizes[ti] = patchSize(mesh.triangle(ti), d); });
  return sizes;
}

TessellationEstimate summarizeTessellation(const std::vector<TessellationPatchSize>& sizes) {
  TessellationEstimate e;
  for (const TessellationPatchSize& p : sizes) {
    e.microTriangles += p.triangles;
    e.vertices += p.vertices;
    if (p.triangles == 0) continue;
    const size_t table = VertexTable::bytes(p.vertices);
    e.tableBytes += table;
    e.largestTable = std::max(e.largestTable, table);
  }
  return e;
}

TessellationPatch tessellatePatch(const DisplacedTriangle& T, const Displacement& d,
                                  const TessellationPatchSize& size) {
  TessellationPatch out;
  // Sized from the estimate: no regrowth, so the build's peak is what was checked.
  VertexTable index(size.vertices);
  out.vertices.reserve(size.vertices);
  out.uvs.reserve(size.vertices);
  out.indices.reserve(size.triangles);
  auto vid = [&](const MicroVertex& v) {
    bool fresh;
    const uint32_t i = index.find(v.p, uint32_t(out.vertices.size()), fresh);
    if (fresh) {
      out.vertices.emplace_back(v.p, 0.0f);
      out.uvs.push_back(v.uv);
    }
    return i;
  };
  forEachMicroTriangle(T, d, [&](const MicroTriangle& m) {
    out.indices.emplace_back(vid(m.v[0]), vid(m.v[1]), vid(m.v[2]));
  });
  return out;
}

TessellationEstimate estimateTessellation(const Mesh& mesh, const Displacement& d) {
  return summarizeTessellation(tessellationPatchSizes(mesh, d));
}

std::vector<size_t> microTriangleCounts(const Mesh& mesh, const Displacement& d) {
  const std::vector<TessellationPatchSize> sizes = tessellationPatchSizes(mesh, d);
  std::vector<size_t> out(sizes.size());
  for (size_t i = 0; i < sizes.size(); ++i) out[i] = sizes[i].triangles;
  return out;
}

size_t tessellationPeakBytes(const std::vector<TessellationEstimate>& meshes, size_t threads) {
  // Meshes are tessellated one after the other (patches with the vertex maps of the
  // triangles in flight, then concatenated into buffers of the exact size), and
  // Embree's BVH over all of them is built at the end.
  size_t geometry = 0, triangles = 0, worst = 0;
  for (const TessellationEstimate& m : meshes) {
    geometry += m.geometryBytes();
    triangles += m.microTriangles;
    worst = std::max(worst, m.patchBytes() + std::min(m.tableBytes, threads * m.largestTable));
  }
  return geometry + std::max(worst, triangles * TessellationEstimate::kBvhBuildBytesPerTriangle);
}

}  // namespace oblong
