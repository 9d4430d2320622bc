// Per-triangle constants of a displaced mesh's traversal, built once: the shell analysis
// (traversal/prism.h), the local frame (psi.h), the inflated prism with its boxes
// padded for the watertight micro-triangle test's rounding, and the cheap per-ray reject.
#pragma once

#include "core/kernels/ray_patch.h"

#include "core/microgeometry.h"
#include "traversal/intersector.h"
#include "core/kernels/constants.h"
#include "traversal/microtri.h"
#include "traversal/prism.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include "traversal/psi.h"
#include "traversal/texture_frame.h"

#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

namespace oblong {

inline double maxAbsVertex(const DisplacedTriangle& T) {
  double m = 0;
  for (int k = 0; k < 3; ++k)
    m = std::max({m, std::abs(double(T.p[k].x)), std::abs(double(T.p[k].y)), std::abs(double(T.p[k].z))});
  return m;
}

// What the traversal derives from a ray alone (its origin and direction in the mesh's
// frame): the same for every triangle the ray visits.
struct RayConstants {
  dvec3 o, d, invD;
  double lenD, maxO;  // |d|, max-norm of o
  WatertightRay wt;
  explicit RayConstants(const Ray& r)
      : o(r.o),
        d(r.d),
        invD(1.0 / d),
        lenD(glm::length(d)),
        maxO(std::max({std::abs(o.x), std::abs(o.y), std::abs(o.z)})),
        wt(r) {}
};

// The constants of the last ray seen on this thread. Embree calls the traversal once per
// prism box a ray meets (2.3 times per camera ray on the asteroid), and the divisions and
// the square root are the same each time. A pure function of the ray's origin and
// direction bits, so the memo is right for any caller.
inline const RayConstants& rayConstants(const Ray& r) {
  // Plain storage: constant-initialised, no guard on each access.
  alignas(RayConstants) thread_local unsigned char storage[sizeof(RayConstants)];
  thread_local float key[6];
  thread_local bool valid = false;
  static_assert(std::is_trivially_destructible_v<RayConstants>);
  const float k[6] = {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z};
  if (!valid || std::memcmp(k, key, sizeof k) != 0) {
    new (storage) RayConstants(r);
    std::memcpy(key, k, sizeof k);
    valid = true;
  }
  return *std::launder(reinterpret_cast<const RayConstants*>(storage));
}

// Margins for the watertight micro-triangle test's own rounding (a few ulps of |p − o|)
// for rays whose origin has max-norm at most maxO: the boxes and the inflated prism must
// hold the triangle as that test sees it.
// The formulas are the kernel's (core/kernels/ray_patch.h, rayMargin), shared with the shaders.
struct RayMargins : shared::RayMargin {
  static RayMargins make(const PrismParams& P, double maxP, double maxO) {
    return {shared::rayMargin(maxP, maxO, P.a, P.b, P.vertexErr, P.inflateS, P.inflateB, P.kb, P.ks)};
  }
  Prism prism(const LocalFrame& F) const { return Prism::inflated(F, lo, hi, delta); }
};

// Slabs in T's frame around the six vertices of a prism, hence around the prism (a
// convex combination of them): along the face normal and, in T's plane, along edge 0 and
// perpendicular to each of the three edges — a box with its corners cut to T's shape.
// Most rays Embree hands over meet the world AABB of a tilted prism but miss the prism;
// this test rejects them before the exact crossings (traversal/prism.cpp).
// The slabs are tested in the order that rejects soonest (the loop stops at the first
// miss): on the asteroid's primary rays the normal's slab alone rejects 59 % of the rays
// the whole box rejects, each edge's perpendicular 17-20 %, the slab along edge 0 8 %.
struct PrismOBB {
  static constexpr int kAxes = 5;
  dvec3 axis[kAxes]{dvec3(0.0), dvec3(0.0), dvec3(0.0), dvec3(0.0), dvec3(0.0)};
  double lo[kAxes]{0, 0, 0, 0, 0}, hi[kAxes]{-1, -1, -1, -1, -1};  // relative to the world origin

  static PrismOBB around(const Prism& p, const DisplacedTriangle& T, double pad) {
    PrismOBB b;
    const dvec3 e = dvec3(T.p[1]) - dvec3(T.p[0]), f = dvec3(T.p[2]) - dvec3(T.p[0]);
    const dvec3 n = glm::cross(e, f);
    if (!(glm::length(n) > 0) || !(glm::length(e) > 0)) return b;  // empty: not used
    const dvec3 un = glm::normalize(n), ue = glm::normalize(e);
    b.axis[0] = un;
    b.axis[1] = glm::cross(un, ue);
    for (int k = 1; k < 3; ++k) {  // the in-plane perpendiculars of edges 1 and 2
      const dvec3 ek = dvec3(T.p[(k + 1) % 3]) - dvec3(T.p[k]);
      const dvec3 m = glm::cross(un, ek);
      b.axis[1 + k] = glm::length(m) > 0 ? glm::normalize(m) : b.axis[1];
    }
    b.axis[4] = ue;
    double mag = 0;
    for (int a = 0; a < kAxes; ++a) b.lo[a] = std::numeric_limits<double>::infinity(), b.hi[a] = -b.lo[a];
    for (int k = 0; k < 6; ++k) {
      const dvec3 v = p.vertex(k % 3, k >= 3);
      for (int a = 0; a < kAxes; ++a) {
        const double c = glm::dot(b.axis[a], v);
        b.lo[a] = std::min(b.lo[a], c);
        b.hi[a] = std::max(b.hi[a], c);
      }
      mag = std::max({mag, std::abs(v.x), std::abs(v.y), std::abs(v.z)});
    }
    // The pad of the boxes, plus the rounding of these dot products here and per ray.
    const double r = pad + OBLONG_TRAV_OBB_ROUND * (mag + 1);
    for (int a = 0; a < kAxes; ++a) b.lo[a] -= r, b.hi[a] += r;
    return b;
  }
  bool valid() const { return lo[0] <= hi[0]; }
};

// Everything a displaced mesh's intersector shares, whatever the strategies.
struct TraversalMesh {
  std::vector<DisplacedTriangle> tris;
  std::vector<PrismParams> params;
  std::vector<CellRange> cells;  // cellsOverlapping(T) per triangle
  // Per-ray work that does not depend on the ray, done once per triangle: the local
  // frame, and the inflated prism and exact-prism box padded for the watertight test's
  // rounding of any ray whose origin lies within `originBudget` (max-norm) — a larger
  // pad is still conservative. Rays from farther away rebuild them (RayPatch).
  std::vector<LocalFrame> frames;
  std::vector<Prism> prisms;
  std::vector<BoxD> prismBoxes;     // exact prism box, padded
  std::vector<BoxD> inflatedBoxes;  // inflated prism box, padded
  std::vector<PrismOBB> obbs;       // oriented box around the inflated prism, padded
  // T's texture frame (texture_frame.h), the frame of the boxes the traversal bounds its
  // pieces and cells with, the exact prism's box in it (unpadded: texPrismBox pads it)
  // and the largest coordinate of the prism's vertices (the rotation's rounding).
  std::vector<TextureFrame> texFrames;
  std::vector<BoxD> texPrismBoxes;
  std::vector<double> texPrismMag;
  std::vector<double> originBudget;
  std::vector<double> budgetPad;  // RayMargins::boxPad for an origin at the budget
  Displacement disp;
  float cellDelta = 0;  // maxCellDelta(map)
  // cellRowDelta per cell row and block of kDeltaBlock columns, and per row: an edit
  // rescans only its blocks, then takes the maxima (cellDelta after an edit).
  static constexpr int kDeltaBlock = 256;
  int deltaBlocks = 0;
  std::vector<float> blockDelta, rowDelta;
  std::vector<Interval> lastHeights;  // each prism's heights (range query over T's uv box)
  std::vector<float> lastDelta;       // each prism's cell delta (localCellDelta)

  // Builds the per-triangle constants; heights(T) is [hmin, hmax] over T's uv box.
  template <typename Heights>
  void build(std::vector<DisplacedTriangle> triangles, const Displacement& d, Heights&& heights);
  // After an edit of the map's samples in `changed` (the range query already updated):
  // rebuilds the prisms whose heights changed, or all of them when the map's largest
  // cell delta changed. Returns them.
  template <typename Heights>
  std::vector<uint32_t> update(const SampleRange& changed, Heights&& heights);
  template <typename Heights>
  void buildTriangle(size_t i, Heights&& heights);
  // Recomputes blocks [b0, b1) of cell row j, then the row's maximum.
  void rowDeltaOf(int j, int b0, int b1) {
    const int W = disp.map->width();
    float* blocks = blockDelta.data() + size_t(j) * deltaBlocks;
    for (int b = b0; b < b1; ++b)
      blocks[b] = cellRowDelta(*disp.map, j, b * kDeltaBlock, std::min(W, (b + 1) * kDeltaBlock));
    rowDelta[size_t(j)] = *std::max_element(blocks, blocks + deltaBlocks);
  }
  // The largest cell delta over the cells in c (their rows' blocks): the bulge bound
  // needs only the cells a triangle's micro-triangles lie in, and relief is rarely as
  // rough everywhere as at its roughest. Under a per-ray blend, the map-wide bound of
  // both levels (cellDelta).
  float localCellDelta(const CellRange& c) const {
    if (disp.next) return cellDelta;
    const int W = disp.map->width(), H = disp.map->height();
    const int64_t rows = std::min<int64_t>(int64_t(c.y1) - c.y0 + 1, H);
    const int64_t cols = int64_t(c.x1) - c.x0 + 1;
    const int i0 = HeightMap::wrap(c.x0, W);
    const int64_t i1 = i0 + cols - 1;  // may pass W: wrap
    float best = 0;
    for (int64_t r = 0; r < rows; ++r) {
      const int j = HeightMap::wrap(int(int64_t(c.y0) + r), H);
      if (cols >= W) {
        best = std::max(best, rowDelta[size_t(j)]);
        continue;
      }
      const float* blocks = blockDelta.data() + size_t(j) * deltaBlocks;
      const int b1 = int(std::min<int64_t>(i1, W - 1) / kDeltaBlock);
      for (int b = i0 / kDeltaBlock; b <= b1; ++b) best = std::max(best, blocks[b]);
      if (i1 >= W)
        for (int b = 0; b <= int((i1 - W) / kDeltaBlock); ++b) best = std::max(best, blocks[b]);
    }
    return best;
  }
  size_t bytes() const {
    return tris.capacity() * sizeof(DisplacedTriangle) + params.capacity() * sizeof(PrismParams) +
           cells.capacity() * sizeof(CellRange) + frames.capacity() * sizeof(LocalFrame) +
           prisms.capacity() * sizeof(Prism) + (prismBoxes.capacity() + inflatedBoxes.capacity() + texPrismBoxes.capacity()) * sizeof(BoxD) +
           texFrames.capacity() * sizeof(TextureFrame) +
           (originBudget.capacity() + budgetPad.capacity() + texPrismMag.capacity()) * sizeof(double) + obbs.capacity() * sizeof(PrismOBB) +
           (blockDelta.capacity() + rowDelta.capacity() + lastDelta.capacity()) * sizeof(float) +
           lastHeights.capacity() * sizeof(Interval);
  }
  // The box of triangle `prim`'s exact prism in its texture frame padded like the world
  // box by `worldPad` (RayMargins::boxPad) for rays whose origin has max-norm up to maxO.
  BoxD texPrismBox(size_t prim, double worldPad, double maxO) const {
    BoxD b = texPrismBoxes[prim];
    b.pad(shared::texBoxPad(worldPad, maxO, texPrismMag[prim]));
    return b;
  }
  // The world box of triangle `prim`'s exact prism (empty when it is skipped).
  AABB bounds(uint32_t prim) const { return params[prim].valid ? params[prim].bounds : AABB{}; }

  // A cheap exact reject before any per-ray set-up (core/kernels/prism.h, shared with
  // the shaders): true when [tmin, tmax] (with the traversal's own slack) misses the
  // padded boxes around the inflated prism. Only for origins within the budget; beyond
  // it, false (the full test decides).
  bool missesPrism(uint32_t prim, const Ray& r, const RayConstants& rc) const {
    const PrismOBB& b = obbs[prim];
    return shared::missesPrism(r.tmin, r.tmax, rc.maxO, originBudget[prim], budgetPad[prim], rc.lenD, rc.o, rc.d,
                               rc.invD, inflatedBoxes[prim].lo, inflatedBoxes[prim].hi, b.valid(), b.axis, b.lo, b.hi);
  }
};

// Skipped triangles (not displaceable) are reported once per mesh.
void warnSkippedTriangles(const TraversalMesh& mesh, const std::string& what);

template <typename Heights>
void TraversalMesh::build(std::vector<DisplacedTriangle> triangles, const Displacement& d, Heights&& heights) {
  tris = std::move(triangles);
  disp = d;
  const int W = d.map->width(), H = d.map->height();
  deltaBlocks = (W + kDeltaBlock - 1) / kDeltaBlock;
  blockDelta.resize(size_t(H) * deltaBlocks);
  rowDelta.resize(size_t(H));
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int j = rows.begin(); j != rows.end(); ++j) rowDeltaOf(j, 0, deltaBlocks);
  });
  cellDelta = rowDelta.empty() ? 0.0f : *std::max_element(rowDelta.begin(), rowDelta.end());
  if (d.next) {
    // Per-ray blend toward level k + 1 (docs/lod.md): a blended cell's heights are convex
    // combinations of level k's and of level k + 1's micro-geometry at level k's points,
    // which varies within a level-k cell by at most level k + 1's cell delta; a few ulps
    // more for the blend's rounding.
    const Interval a = d.map->range(), b = d.next->range();
    const float mag = std::max({std::abs(a.lo), std::abs(a.hi), std::abs(b.lo), std::abs(b.hi)});
    cellDelta = std::max(cellDelta, maxCellDelta(*d.next)) + 8.0f * std::numeric_limits<float>::epsilon() * mag;
  }
  params.resize(tris.size());
  cells.resize(tris.size());
  frames.resize(tris.size());
  prisms.resize(tris.size());
  prismBoxes.resize(tris.size());
  inflatedBoxes.resize(tris.size());
  obbs.resize(tris.size());
  texFrames.resize(tris.size());
  texPrismBoxes.resize(tris.size());
  texPrismMag.resize(tris.size());
  originBudget.assign(tris.size(), -1.0);
  budgetPad.assign(tris.size(), 0.0);
  lastHeights.assign(tris.size(), Interval{});
  lastDelta.assign(tris.size(), 0.0f);
  for (size_t i = 0; i < tris.size(); ++i) buildTriangle(i, heights);
}

template <typename Heights>
void TraversalMesh::buildTriangle(size_t i, Heights&& heights) {
  const Displacement& d = disp;
  const DisplacedTriangle& T = tris[i];
  cells[i] = cellsOverlapping(T, d);
  const bool ok = T.uvArea2 != 0.0f && T.area > 0.0f && T.minNormalLength > 1e-6f && std::isfinite(T.area);
  if (ok) lastHeights[i] = heights(T);
  lastDelta[i] = localCellDelta(cells[i]);
  params[i] = ok ? analyzeShell(T, d, lastHeights[i], lastDelta[i]) : PrismParams{};
  if (!params[i].valid) return;
  frames[i] = LocalFrame::make(T, d);
  // Origins up to 16 times the triangle's own extent from the world origin (plus 16).
  const double maxP = maxAbsVertex(T), ab = std::abs(params[i].a) + std::abs(params[i].b);
  originBudget[i] = 16 * (maxP + ab) + 16;
  const RayMargins m = RayMargins::make(params[i], maxP, originBudget[i]);
  budgetPad[i] = m.boxPad;
  prisms[i] = m.prism(frames[i]);
  prismBoxes[i] = Prism::exact(T, params[i].a, params[i].b).bounds();
  prismBoxes[i].pad(m.boxPad);
  inflatedBoxes[i] = prisms[i].bounds();
  inflatedBoxes[i].pad(m.boxPad);
  obbs[i] = PrismOBB::around(prisms[i], T, m.boxPad);
  texFrames[i] = TextureFrame::make(frames[i], T, cells[i]);
  const Prism exact = Prism::exact(T, params[i].a, params[i].b);
  BoxD tb;
  double mag = 0;
  for (int k = 0; k < 6; ++k) {
    const dvec3 v = exact.vertex(k % 3, k >= 3);
    tb.extend(texFrames[i].rot(v));
    mag = std::max({mag, std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  }
  texPrismBoxes[i] = tb;
  texPrismMag[i] = mag;
}

template <typename Heights>
std::vector<uint32_t> TraversalMesh::update(const SampleRange& changed, Heights&& heights) {
  const HeightMap& m = *disp.map;
  const int H = m.height(), W = m.width();
  // Cells y0-1 .. y1 and x0-1 .. x1 hold the edited samples: their rows' blocks.
  const int rows = int(std::min<int64_t>(int64_t(changed.y1) - changed.y0 + 2, H));
  const int cols = int(std::min<int64_t>(int64_t(changed.x1) - changed.x0 + 2, W));
  const int c0 = HeightMap::wrap(changed.x0 - 1, W), c1 = c0 + cols - 1;  // c1 may pass W: wrap
  const bool allBlocks = cols >= W;
  for (int r = 0; r < rows; ++r) {
    const int j = HeightMap::wrap(changed.y0 - 1 + r, H);
    if (allBlocks || c1 >= W) {
      rowDeltaOf(j, allBlocks ? 0 : c0 / kDeltaBlock, deltaBlocks);
      if (!allBlocks) rowDeltaOf(j, 0, (c1 - W) / kDeltaBlock + 1);
    } else {
      rowDeltaOf(j, c0 / kDeltaBlock, c1 / kDeltaBlock + 1);
    }
  }
  cellDelta = *std::max_element(rowDelta.begin(), rowDelta.end());
  // A prism depends on the map only through its heights (a range query over T's uv box)
  // and the largest cell delta over its cells. A query can read stored entries well
  // beyond the box (a pyramid's blocks, a mipmap's nodes, a safety zone's box, a global
  // fallback), so each triangle's heights and delta are asked again: a few lookups per
  // triangle, and exactly the prisms whose inputs changed are rebuilt.
  std::vector<uint32_t> touched;
  for (size_t i = 0; i < tris.size(); ++i) {
    const DisplacedTriangle& T = tris[i];
    const bool ok = T.uvArea2 != 0.0f && T.area > 0.0f && T.minNormalLength > 1e-6f && std::isfinite(T.area);
    if (!ok || (localCellDelta(cells[i]) == lastDelta[i] && heights(T) == lastHeights[i])) continue;
    buildTriangle(i, heights);
    touched.push_back(uint32_t(i));
  }
  return touched;
}

}  // namespace oblong
