// RayPatch: one ray against one displaced triangle, the RMIP traversal (Thonat et al.
// 2023, Alg. 1; docs/design.md §2). The driver is core/kernels/ray_patch.h, written once for
// the CPU and the Vulkan shaders (it says what the traversal does, step by step); here are
// the CPU's hooks into it and the statistics counters.
#pragma once

#include "core/microgeometry.h"
#include "core/stats.h"
#include "inversion/inverter.h"
#include "traversal/intersector.h"
#include "traversal/closest_hit.h"
#include "core/kernels/constants.h"
#include "core/kernels/ray_patch.h"
#include "traversal/prism.h"
#include "traversal/psi.h"
#include "core/kernels/rect_bounds.h"
#include "traversal/traversal_mesh.h"
#include "strategies/range_query.h"
#include "strategies/splitter.h"

#include <new>
#include <type_traits>

namespace oblong {

OBLONG_STAT_COUNTER("traversal/Prisms", travPrisms);
OBLONG_STAT_COUNTER("traversal/Hits", travHits);
OBLONG_STAT_COUNTER("traversal/Boxes", travBoxes);
OBLONG_STAT_COUNTER("traversal/RangeQueries", travRangeQueries);
OBLONG_STAT_COUNTER("traversal/Inversions", travInversions);
OBLONG_STAT_COUNTER("traversal/CellsMarched", travCells);
OBLONG_STAT_COUNTER("traversal/MicroTriangles", travMicroTris);
OBLONG_STAT_COUNTER("traversal/Leaves", travLeaves);
OBLONG_STAT_COUNTER("traversal/TurningSplits", travTurning);
OBLONG_STAT_COUNTER("traversal/BoxOnlyPieces", travBoxOnly);
OBLONG_STAT_COUNTER("traversal/BoxOnlyPrisms", travBoxOnlyPrisms);
OBLONG_STAT_COUNTER("traversal/PrismGrazes", travGrazes);
OBLONG_STAT_COUNTER("traversal/IllPosedTriangles", travIllPosed);
OBLONG_STAT_COUNTER("traversal/RejectedInversions", travBadInversions);
OBLONG_STAT_COUNTER("traversal/StackOverflows", travOverflows);
OBLONG_STAT_COUNTER("traversal/MarchStops", travMarchStops);  // marching ended by the closest hit
OBLONG_STAT_COUNTER("traversal/WideLeaves", travWideLeaves);  // leaves subdivided as boxes (wide ε)
OBLONG_STAT_COUNTER("traversal/ClippedCells", travClippedCells);  // tested cells on an edge of T

// The counters of one intersect() call, flushed to RayCounters and the statistics once.
inline void flushCounters(const RayCounters& local, bool hit, RayCounters& c) {
  c += local;
  OBLONG_STAT_ADD(travPrisms, local.prisms);
  OBLONG_STAT_ADD(travBoxes, local.boxes);
  OBLONG_STAT_ADD(travRangeQueries, local.rangeQueries);
  OBLONG_STAT_ADD(travInversions, local.inversions);
  OBLONG_STAT_ADD(travCells, local.cellsMarched);
  OBLONG_STAT_ADD(travMicroTris, local.microTriangles);
  if (hit) OBLONG_STAT_INC(travHits);
  (void)hit;
}

namespace detail {

// Strategy calls: virtual through the interfaces (the default, generic path); inline
// for concrete strategy types (an opt-in static instantiation, OBLONG_STATIC_TRAVERSAL).
template <typename RQ>
inline Interval rawRange(const RQ& q, const SampleRange& r) {
  if constexpr (std::is_same_v<RQ, RangeQuery>) return q.rawRange(r);
  else return q.rawRangeFast(r);
}
template <typename Inv>
inline InversionResult invert(const Inv& inv, const vec3& X, const DisplacedTriangle& T) {
  if constexpr (std::is_same_v<Inv, Inverter>) return inv.invert(X, T);
  else return inv.invertFast(X, T);
}
template <typename Split, typename Ctx>
inline bool split(const Split& s, const CurvePiece& p, Ctx& ctx, CurvePiece& f, CurvePiece& b) {
  if constexpr (std::is_same_v<Split, Splitter>) return s.split(p, ctx, f, b);
  else return s.splitFast(p, ctx, f, b);
}

}  // namespace detail

struct TraversalOptions {
  float marchingScale = 4.0f;
  bool inversionInTraversal = true;
  int stackDepth = OBLONG_TRAV_STACK_DEFAULT;  // entries used of kStack (TraversalConfig::stackDepth)
};

// One ray against one displaced triangle: the driver of core/kernels/ray_patch.h (the
// Vulkan shader's own code) with the CPU's hooks: the strategies through their interfaces
// (or inline for concrete types), the micro-geometry of core/microgeometry.h with its
// vertex cache, the closest hit and the statistics. Lives on the stack of intersect();
// allocates nothing.
template <typename RQ, typename Inv, typename Split>
class RayPatch final : public shared::RayPatchLoop<RayPatch<RQ, Inv, Split>>, public SplitContext {
  using Loop = shared::RayPatchLoop<RayPatch<RQ, Inv, Split>>;
  friend Loop;

 public:
  RayPatch(const TraversalMesh& mesh, uint32_t prim, const RQ& rq, const Inv& inv, const Split& split,
           const TraversalOptions& opt, const Ray& ray, const RayConstants& rc)
      : tri_(mesh.tris[prim]),
        disp_(mesh.disp),
        rq_(rq),
        inv_(inv),
        split_(split),
        ray_(ray),
        tex_(mesh.texFrames[prim]),
        blend_(mesh.disp.blendOf(ray.lod)),
        watertightRay_(rc.wt) {
    const PrismParams& P = mesh.params[prim];
    const LocalFrame& F = mesh.frames[prim];
    Loop& s = *this;
    s.g_F = F;
    s.g_N13 = F.N(dvec2(1.0 / 3.0));
    s.g_claim = shared::ClaimBounds{P.domainB, P.domainS0, P.domainS1, P.kb, P.ks, P.kxy};
    s.g_wellPosed = P.wellPosed;
    s.g_tmin = ray.tmin;
    s.g_tmax = ray.tmax;
    s.g_O = rc.o;
    s.g_D = rc.d;
    s.g_invD = rc.invD;
    s.g_bray = shared::boxRayF(tex_.rot(rc.o), tex_.rot(rc.d), tex_.Pc);
    const CellRange& cr = mesh.cells[prim];
    s.g_origin = F.origin;
    s.g_cellLo = ivec2(cr.x0, cr.y0) - F.origin;
    s.g_cellHi = ivec2(cr.x1, cr.y1) - F.origin;
    s.g_sbLo = disp_.toSample(tri_.uvBox.lo) - dvec2(F.origin);
    s.g_sbHi = disp_.toSample(tri_.uvBox.hi) - dvec2(F.origin);
    s.g_marchingScale = opt.marchingScale;
    s.g_stackDepth = opt.stackDepth;
    s.g_inversionInTraversal = opt.inversionInTraversal;
    const double maxO = rc.maxO, maxP = maxAbsVertex(tri_);
    const RayMargins margins = RayMargins::make(P, maxP, maxO);
    s.rpInit(margins, maxP, maxO, P.a, P.b, P.eps, P.kxy, rc.lenD);
    // Within the origin budget the precomputed prism and boxes (padded for the budget)
    // serve; beyond it, rebuilt with this ray's margins.
    const double budget = mesh.originBudget[prim];
    const BoxD tb = maxO <= budget ? mesh.texPrismBox(prim, mesh.budgetPad[prim], budget)
                                   : mesh.texPrismBox(prim, s.g_boxPad, maxO);
    s.g_texLo = shared::relBelowF(tb.lo, tex_.Pc);
    s.g_texHi = shared::relAboveF(tb.hi, tex_.Pc);
    if (maxO <= budget) {
      prism_ = &mesh.prisms[prim];
      inflatedBox_ = mesh.inflatedBoxes[prim];
      s.g_boxLo = mesh.prismBoxes[prim].lo;
      s.g_boxHi = mesh.prismBoxes[prim].hi;
    } else {
      ownPrism_ = margins.prism(F);
      prism_ = &ownPrism_;
      BoxD box = Prism::exact(tri_, P.a, P.b).bounds();
      box.pad(s.g_boxPad);
      s.g_boxLo = box.lo;
      s.g_boxHi = box.hi;
      inflatedBox_ = ownPrism_.bounds();
      inflatedBox_.pad(s.g_boxPad);
    }
  }

  // --- SplitContext -------------------------------------------------------------------
  bool crossing(const CurvePiece& p, int axis, double c, CurvePoint& out) final {
    return this->crossingAt(p.a, p.b, axis, c, out);
  }
  bool pointAt(const CurvePiece&, double t, CurvePoint& out) final { return this->invertAt(t, out); }
  ivec2 sampleOrigin() const final { return this->g_origin; }

  // The traversal; the work done is added to `counters`.
  bool run(RayCounters& counters) {
    const bool found = this->rpRun();
    counters.boxes += this->g_boxes;
    counters.rangeQueries += this->g_rangeQueries;
    counters.inversions += this->g_inversions;
    counters.cellsMarched += this->g_cells;
    counters.microTriangles += this->g_microTris;
    return found;
  }

  const ClosestHit& hit() const { return hit_; }

 private:
  // --- the hooks (core/kernels/ray_patch.h) -------------------------------------------
  vec2 rpRangeRaw(int sx0, int sy0, int sx1, int sy1) {
    const Interval r = detail::rawRange(rq_, SampleRange{sx0, sy0, sx1, sy1});
    return vec2(r.lo, r.hi);
  }
  vec2 rpToHeight(const vec2& raw) const {
    const Interval h = disp_.toHeight(Interval{raw.x, raw.y});
    return vec2(h.lo, h.hi);
  }
  float rpRaw(int I, int J) const { return disp_.raw(I, J, blend_); }
  int rpCellMicro(int I, int J) {
    if (!cacheReady_) {  // first cell of this ray and triangle
      new (&cache_) GridVertexCache;
      cacheReady_ = true;
    }
    if (!cellsReady_) {  // built at the first cell: most prisms entered march no cell
      new (&mcRaw_) MicroCells(tri_, disp_, blend_);
      cellsReady_ = true;
    }
    const MicroVertex* q[4];
    if (cells().interiorCorners(I, J, cache(), q)) {  // most cells: two triangles, no copies
      hit_.testCell(watertightRay_, q, ray_.tmin, ray_.tmax);
      return 2;
    }
    OBLONG_STAT_INC(travClippedCells);
    MicroTriangle buf[MicroCells::kMaxPerCell];
    const int n = cells().clippedCell(I, J, buf, cache());
    for (int k = 0; k < n; ++k) hit_.test(watertightRay_, buf[k], ray_.tmin, ray_.tmax);
    return n;
  }
  void rpInvert(const vec3& X, vec2& bary, float& h) const {
    const InversionResult r = detail::invert(inv_, X, tri_);
    bary = r.bary;
    h = r.h;
  }
  int rpSplit(const shared::CurvePoint& a, const shared::CurvePoint& b, int&, shared::CurvePoint& m, double&) {
    CurvePiece p, front, back;
    static_cast<shared::CurvePoint&>(p.a) = a;
    static_cast<shared::CurvePoint&>(p.b) = b;
    if (!detail::split(split_, p, *this, front, back)) return 0;
    m = front.b;  // a splitter cuts at one point (split::around)
    return 1;
  }
  bool rpHitFound() const { return hit_.found; }
  float rpHitT() const { return hit_.t; }
  dvec2 rpHitUV() const {
    const MicroTriangle& m = hit_.tri;
    const MicroHit& h = hit_.h;
    return double(h.b0) * dvec2(m.v[0].uv) + double(h.b1) * dvec2(m.v[1].uv) + double(h.b2) * dvec2(m.v[2].uv);
  }
  dvec2 rpToSample(const dvec2& uv) const { return disp_.toSample(uv); }
  void rpBoxOverRect(const vec2& lo, const vec2& hi, const vec2& h, vec3& blo, vec3& bhi) const {
    shared::boxOverRectF(tex_.box, lo, hi, h.x, h.y, this->g_texPadF, blo, bhi);
  }
  void rpInflatedBox(dvec3& lo, dvec3& hi) const {
    lo = inflatedBox_.lo;
    hi = inflatedBox_.hi;
  }
  const shared::PrismShape& rpPrism() const { return prism_->shape(); }
  static void rpStat(int what) {
    switch (what) {
      case OBLONG_RP_STAT_ILL_POSED: OBLONG_STAT_INC(travIllPosed); break;
      case OBLONG_RP_STAT_GRAZE: OBLONG_STAT_INC(travGrazes); break;
      case OBLONG_RP_STAT_TURNING: OBLONG_STAT_INC(travTurning); break;
      case OBLONG_RP_STAT_BOX_ONLY_PIECE: OBLONG_STAT_INC(travBoxOnly); break;
      case OBLONG_RP_STAT_BOX_ONLY_PRISM: OBLONG_STAT_INC(travBoxOnlyPrisms); break;
      case OBLONG_RP_STAT_OVERFLOW: OBLONG_STAT_INC(travOverflows); break;
      case OBLONG_RP_STAT_MARCH_STOP: OBLONG_STAT_INC(travMarchStops); break;
      case OBLONG_RP_STAT_WIDE_LEAF: OBLONG_STAT_INC(travWideLeaves); break;
      case OBLONG_RP_STAT_LEAF: OBLONG_STAT_INC(travLeaves); break;
      case OBLONG_RP_STAT_BAD_INVERSION: OBLONG_STAT_INC(travBadInversions); break;
      default: break;
    }
  }

  // The triangle and what was precomputed for it (TraversalMesh).
  const DisplacedTriangle& tri_;
  const Displacement& disp_;
  const RQ& rq_;
  const Inv& inv_;
  const Split& split_;
  const Ray& ray_;
  const TextureFrame& tex_;  // the boxes' frame
  const float blend_;        // the ray's level-of-detail blend (Displacement::blendOf)
  const WatertightRay watertightRay_;
  const Prism* prism_ = nullptr;  // inflated prism: precomputed, or ownPrism_ for far origins
  Prism ownPrism_;
  BoxD inflatedBox_;
  ClosestHit hit_;
  // Micro-vertices shared by neighbouring cells; initialised at the first cell only.
  bool cacheReady_ = false;
  alignas(GridVertexCache) unsigned char cache_[sizeof(GridVertexCache)];
  GridVertexCache& cache() { return *reinterpret_cast<GridVertexCache*>(cache_); }
  bool cellsReady_ = false;
  static_assert(std::is_trivially_destructible_v<MicroCells>);
  alignas(MicroCells) unsigned char mcRaw_[sizeof(MicroCells)];
  const MicroCells& cells() const { return *reinterpret_cast<const MicroCells*>(mcRaw_); }
};

}  // namespace oblong
