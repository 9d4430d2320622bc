// RayPatch: one ray against one displaced triangle, the state of the RMIP traversal
// (Thonat et al. 2023, Alg. 1; docs/design.md §2) and the splitters' context.
//
// Per ray and displaced triangle (docs/traversal.md has the reasoning):
//   1. Clip the ray to the triangle's inflated prism (prism.h); its crossings give the
//      interval [tIn, tOut] and the uv of its ends; a ray starting (or ending) inside
//      gets its end's uv from a point claimed between the crossings (pointBetween), else
//      by inversion.
//   2. Split [tIn, tOut] where the curve may turn (psi.h): monotone pieces.
//   3. Fixed-size stack of pieces, front to back. A piece whose rectangle is at most
//      `marchingScale` texels is marched (below); otherwise its rectangle, dilated by ε
//      and snapped outward to whole cells, is bounded (RangeQuery + interval arithmetic,
//      rect_bounds.h), the ray is clipped to that box, the piece is optionally tightened
//      by re-projecting the clipped ends (Fig. 5a, "inversion during traversal"; claimed,
//      else inverted), and the splitter cuts it in two.
//   4. Texel marching (§4.4): the cells within ε of the monotone piece, column by column
//      along its major axis, front to back; ψ's crossing with each column's sides gives
//      the rows to test. Each cell's micro-triangles come from core/microgeometry's
//      MicroCells (bit-identical to the oracle's) and are tested watertight.
//   5. Every hit updates the closest hit; pieces starting beyond it are skipped, so the
//      first hit ends the traversal in practice (front-to-back order).
// Whenever the curve machinery cannot vouch for a piece (ill-posed triangle, failed
// inversion, failed split), that part falls back to projection-free box subdivision of
// whole cell ranges: slower, never wrong.
#pragma once

#include "core/microgeometry.h"
#include "core/stats.h"
#include "inversion/inverter.h"
#include "traversal/intersector.h"
#include "traversal/closest_hit.h"
#include "core/kernels/constants.h"
#include "traversal/prism.h"
#include "traversal/psi.h"
#include "traversal/rect_bounds.h"
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

// One ray against one displaced triangle: the state of Alg. 1 and the splitters'
// context. Lives on the stack of intersect(); allocates nothing.
template <typename RQ, typename Inv>
class RayPatch final : public SplitContext {
 public:
  static constexpr int kStack = OBLONG_TRAV_STACK;

  RayPatch(const TraversalMesh& mesh, uint32_t prim, const RQ& rq, const Inv& inv, const TraversalOptions& opt,
           const Ray& ray, const RayConstants& rc, RayCounters& counters)
      : tri_(mesh.tris[prim]),
        shell_(mesh.params[prim]),
        claim_{shell_.domainB, shell_.domainS0, shell_.domainS1, shell_.kb, shell_.ks, shell_.kxy},
        disp_(mesh.disp),
        rq_(rq),
        inv_(inv),
        opt_(opt),
        ray_(ray),
        counters_(counters),
        frame_(mesh.frames[prim]),
        tex_(mesh.texFrames[prim]),
        blend_(mesh.disp.blendOf(ray.lod)),
        watertightRay_(rc.wt),
        origin_(rc.o),
        dir_(rc.d),
        invDir_(rc.invD),
        originT_(tex_.rot(rc.o)),
        invDirT_(1.0 / tex_.rot(rc.d)) {
    const CellRange& cr = mesh.cells[prim];
    cellLo_ = ivec2(cr.x0, cr.y0) - frame_.origin;
    cellHi_ = ivec2(cr.x1, cr.y1) - frame_.origin;
    const dvec2 s0 = disp_.toSample(tri_.uvBox.lo), s1 = disp_.toSample(tri_.uvBox.hi);
    uvBoxLo_ = s0 - dvec2(frame_.origin);
    uvBoxHi_ = s1 - dvec2(frame_.origin);
    // Rounding of the watertight test itself (RayMargins). Within the origin budget the
    // precomputed prism and boxes (padded for the budget) serve; beyond it, rebuilt.
    const double maxO = rc.maxO;
    const double budget = mesh.originBudget[prim];
    const bool pre = maxO <= budget;
    // This ray's own margins: the dilation ε and the pads of the boxes built per step
    // (a budget-sized rayErr would widen ε by a tenth of a texel on the asteroid).
    const RayMargins m = RayMargins::make(shell_, maxAbsVertex(tri_), maxO);
    boxPad_ = m.boxPad;
    // Slack for comparing float hit distances with double interval ends.
    tSlackAbs_ = OBLONG_TRAV_T_ABS_PADS * boxPad_ / rc.lenD;
    dilation_ = shell_.eps + shell_.kxy * (OBLONG_TRAV_RAY_ERR_FACTOR * m.rayErr);
    const double maxDil = std::max(dilation_.x, dilation_.y);
    wideEps_ = maxDil > OBLONG_TRAV_WIDE_EPS_REL * opt_.marchingScale;
    leafScale_ = wideEps_ ? std::max(double(opt_.marchingScale), OBLONG_TRAV_WIDE_LEAF_EPS * maxDil) : opt_.marchingScale;
    const double ab = std::abs(shell_.a) + std::abs(shell_.b);
    texPad_ = TextureFrame::pad(boxPad_, maxO + maxAbsVertex(tri_) + ab);
    texPrismBox_ = pre ? mesh.texPrismBox(prim, mesh.budgetPad[prim], budget) : mesh.texPrismBox(prim, boxPad_, maxO);
    if (pre) {
      prism_ = &mesh.prisms[prim];
      prismBox_ = mesh.prismBoxes[prim];
      inflatedBox_ = mesh.inflatedBoxes[prim];
    } else {
      ownPrism_ = m.prism(frame_, shell_);
      prism_ = &ownPrism_;
      prismBox_ = Prism::exact(tri_, shell_.a, shell_.b).bounds();
      prismBox_.pad(boxPad_);
      inflatedBox_ = ownPrism_.bounds();
      inflatedBox_.pad(boxPad_);
    }
  }

  // --- SplitContext -------------------------------------------------------------------
  bool crossing(const CurvePiece& p, int axis, double c, CurvePoint& out) final {
    double q2, q1, q0, w[2], rp[2];
    psi_.onLine(axis, c, q2, q1, q0);
    const int n = quadraticRoots(q2, q1, q0, w, rp);
    if (n <= 0) return false;
    const int mi = 1 - axis;
    const dvec2 lo = p.lo(), hi = p.hi();
    int found = 0;
    for (int k = 0; k < n; ++k) {
      if (w[k] < lo[mi] - rp[k] || w[k] > hi[mi] + rp[k]) continue;
      const dvec2 uv = axis == 0 ? dvec2(c, w[k]) : dvec2(w[k], c);
      double t, s;
      if (!rayParamAt(frame_, origin_, dir_, uv, t, s)) continue;
      if (!(t > p.a.t && t < p.b.t)) continue;
      CurvePoint cp;
      if (!makePoint(t, frame_.bary(uv), s, cp)) continue;
      out = cp;
      ++found;
    }
    return found == 1;
  }

  bool pointAt(const CurvePiece&, double t, CurvePoint& out) final { return invertAt(t, out); }

  ivec2 sampleOrigin() const final { return frame_.origin; }

  // --- the traversal ------------------------------------------------------------------
  template <typename Split>
  bool run(const Split& splitter) {
    if (!shell_.wellPosed) {
      OBLONG_STAT_INC(travIllPosed);
      return runBoxOnly();
    }
    // 1. Inflated prism (with the margin for the watertight test's rounding).
    const Prism& prism = *prism_;
    const BoxD& pbox = inflatedBox_;
    double t0 = ray_.tmin - slack(ray_.tmin), t1 = ray_.tmax + slack(ray_.tmax);
    pbox.clip(origin_, invDir_, t0, t1);
    if (!(t0 <= t1)) return false;
    Prism::Crossing first, last;
    const int nc = prism.crossings(origin_, dir_, first, last);
    if (nc == 0) return false;  // the line misses the inflated prism
    if (nc < 2) {
      OBLONG_STAT_INC(travGrazes);
      return runBoxOnly();
    }
    const double tIn = std::max(first.t, double(ray_.tmin) - slack(ray_.tmin));
    const double tOut = std::min(last.t, double(ray_.tmax) + slack(ray_.tmax));
    if (!(tIn <= tOut)) return false;
    // A ray that starts (or ends) inside the prism: that end's point from the crossings'
    // points, else by inversion.
    CurvePoint F, L, A, B;
    const bool okF = makePoint(first.t, first.bary, first.s, F), okL = makePoint(last.t, last.bary, last.s, L);
    const bool okA = tIn == first.t ? (A = F, okF) : (okF && okL && pointBetween(F, L, tIn, A)) || invertAt(tIn, A);
    const bool okB = tOut == last.t ? (B = L, okL) : (okF && okL && pointBetween(F, L, tOut, B)) || invertAt(tOut, B);
    if (!okA || !okB) return runBoxOnly();
    psi_ = Psi::make(frame_, origin_, dir_);
    dirLocal_ = dirLocal();

    // 2. Monotone pieces.
    double ts[4];
    const int ns = monotoneSplits(frame_, psi_, origin_, dir_, tIn, tOut, ts);
    CurvePoint pts[6];
    int np = 0;
    pts[np++] = A;
    for (int k = 0; k < ns; ++k) {
      CurvePoint m;
      if (!invertAt(ts[k], m)) return runBoxOnly();
      pts[np++] = m;
      OBLONG_STAT_INC(travTurning);
    }
    pts[np++] = B;
    for (int k = np - 2; k >= 0; --k) pushPiece({pts[k], pts[k + 1]});

    // 3. Front to back.
    while (stackSize_ > 0) {
      const Entry e = stack()[--stackSize_];
      if (e.box) processBox(e);
      else processPiece(e.piece, splitter);
    }
    return hit_.found;
  }

  const ClosestHit& hit() const { return hit_; }

 private:
  struct Entry {
    CurvePiece piece;  // curve mode
    ivec2 clo, chi;    // box mode: local cell range
    double ta, tb;     // box mode: ray interval
    bool box;
  };
  static_assert(std::is_trivially_copyable_v<Entry>);
  // Raw storage: a std::array<Entry> would run 128 default constructors per prism.
  Entry* stack() { return reinterpret_cast<Entry*>(stackRaw_); }

  double slack(double t) const { return OBLONG_TRAV_SLACK_REL * std::abs(t) + tSlackAbs_; }
  double bestLimit() const { return hit_.found ? double(hit_.t) + slack(hit_.t) : double(ray_.tmax) + slack(ray_.tmax); }

  void pushPiece(const CurvePiece& p) {
    Entry* e = new (&stack()[stackSize_++]) Entry;
    e->piece = p;
    e->box = false;
  }
  void pushBox(ivec2 lo, ivec2 hi, double ta, double tb) {
    Entry* e = new (&stack()[stackSize_++]) Entry;
    e->box = true;
    e->clo = lo, e->chi = hi, e->ta = ta, e->tb = tb;
  }

  // A curve point from prism coordinates (b, s) claimed to be the projection of the ray
  // point at t (core/kernels/curve_point.h: the residual bounds its error).
  bool makePoint(double t, const dvec2& b, double s, CurvePoint& out) const {
    return shared::makePoint(frame_, claim_, origin_, dir_, t, b, s, out);
  }

  bool invertAt(double t, CurvePoint& out) {
    ++counters_.inversions;
    const dvec3 X = origin_ + t * dir_;
    const InversionResult r = detail::invert(inv_, vec3(X), tri_);
    const dvec2 b(r.bary);
    const double nl = glm::length(frame_.N(b));
    if (!(nl > 0) || !std::isfinite(r.h)) {
      OBLONG_STAT_INC(travBadInversions);
      return false;
    }
    if (!makePoint(t, b, double(r.h) / nl, out)) {
      OBLONG_STAT_INC(travBadInversions);
      return false;
    }
    return true;
  }

  // The curve point at t taken from the closest hit instead of an inversion: the hit's
  // texture position gives T's barycentrics b, and s is the least-squares height of
  // X(t) on b's displacement line. makePoint's residual bounds the error for any claimed
  // (b, s), so the point is as safe as an inverted one; its pad is larger by the
  // micro-triangle's bulge and the move from the hit to t (both well under ε).
  bool pointFromHit(double t, CurvePoint& out) const {
    if (!hit_.found) return false;
    const MicroTriangle& m = hit_.tri;
    const MicroHit& h = hit_.h;
    const dvec2 uv = double(h.b0) * dvec2(m.v[0].uv) + double(h.b1) * dvec2(m.v[1].uv) +
                     double(h.b2) * dvec2(m.v[2].uv);
    const dvec2 b = frame_.bary(disp_.toSample(uv) - dvec2(frame_.origin));
    return makePoint(t, b, shared::heightOnLine(frame_, origin_ + t * dir_, b), out);
  }

  // The curve point at t, between curve points a and b, without an inversion: uv
  // interpolated linearly in t (exact where T's normals are parallel), s by least
  // squares, one Newton step on G(b, s) = X(t) in double; makePoint's residual bound
  // holds for any claimed (b, s). Refused when its pad exceeds OBLONG_TRAV_CLAIM_PAD.
  bool pointBetween(const CurvePoint& a, const CurvePoint& b, double t, CurvePoint& out) const {
    dvec2 bc;
    double s;
    if (!shared::claimBetween(frame_, origin_, dir_, a, b, t, bc, s)) return false;
    return makePoint(t, bc, s, out) && out.pad.x + out.pad.y <= OBLONG_TRAV_CLAIM_PAD;
  }

  dvec2 dirLocal() const { return approxDirLocal(frame_, dir_); }

  // Local cells touching [lo, hi], clipped to T's cells. False when empty.
  bool snap(const dvec2& lo, const dvec2& hi, ivec2& clo, ivec2& chi) const {
    constexpr double lim = OBLONG_TRAV_SNAP_LIMIT;
    for (int k = 0; k < 2; ++k) {
      const double eta = OBLONG_TRAV_SNAP_ETA * (1 + std::abs(lo[k]) + std::abs(hi[k]));
      clo[k] = int(std::clamp(std::floor(lo[k] - eta), -lim, lim));
      chi[k] = int(std::clamp(std::floor(hi[k] + eta), -lim, lim));
    }
    clo = glm::max(clo, cellLo_);
    chi = glm::min(chi, cellHi_);
    return clo.x <= chi.x && clo.y <= chi.y;
  }

  // Ray interval [t0, t1] (clipped in place) through the box of the micro-geometry over
  // local cells [clo, chi] with heights h, in T's texture frame. False when empty.
  bool clipToBox(const ivec2& clo, const ivec2& chi, const Interval& h, double& t0, double& t1) {
    const dvec2 lo = glm::max(dvec2(clo), uvBoxLo_), hi = glm::min(dvec2(chi + 1), uvBoxHi_);
    BoxD box = boxOverRect(tex_, double(tri_.minNormalLength), lo, hi, h.lo, h.hi, texPad_);
    box = box.intersect(texPrismBox_);
    if (box.isEmpty()) return false;
    box.clip(originT_, invDirT_, t0, t1);
    return t0 <= t1;
  }
  // The same with the heights of the RangeQuery over the cells.
  bool clipToCells(const ivec2& clo, const ivec2& chi, double& t0, double& t1) {
    const SampleRange sr{clo.x + frame_.origin.x, clo.y + frame_.origin.y, chi.x + 1 + frame_.origin.x,
                         chi.y + 1 + frame_.origin.y};
    ++counters_.rangeQueries;
    ++counters_.boxes;
    return clipToBox(clo, chi, disp_.toHeight(detail::rawRange(rq_, sr)), t0, t1);
  }

  // One step of the march: a cell, rejected by its box or tested.
  void testCell(int i, int j) {
    ++counters_.cellsMarched;
    const int I = i + frame_.origin.x, J = j + frame_.origin.y;
    // The leaf test of TFDM before the micro-triangles: the box over the cell from its
    // four corner samples, which bound every micro-vertex of the cell (clipped ones are
    // interpolated along its edges; docs/design.md invariant 2).
    {
      const float a = disp_.raw(I, J, blend_), b = disp_.raw(I + 1, J, blend_);
      const float c = disp_.raw(I, J + 1, blend_), e = disp_.raw(I + 1, J + 1, blend_);
      double t0 = ray_.tmin - slack(ray_.tmin), t1 = bestLimit();
      if (!clipToBox(ivec2(i, j), ivec2(i, j), disp_.toHeight({std::min({a, b, c, e}), std::max({a, b, c, e})}), t0, t1))
        return;
    }
    MicroTriangle buf[MicroCells::kMaxPerCell];
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
      counters_.microTriangles += 2;
      hit_.testCell(watertightRay_, q, ray_.tmin, ray_.tmax);
      return;
    }
    OBLONG_STAT_INC(travClippedCells);
    const int n = cells().clippedCell(I, J, buf, cache());
    counters_.microTriangles += n;
    for (int k = 0; k < n; ++k) hit_.test(watertightRay_, buf[k], ray_.tmin, ray_.tmax);
  }
  void testCells(const ivec2& clo, const ivec2& chi) {
    OBLONG_STAT_INC(travLeaves);
    // Front to back along the approximate direction (order only matters for ties).
    const int sx = dirLocal_.x >= 0 ? 1 : -1, sy = dirLocal_.y >= 0 ? 1 : -1;
    for (int j = sy > 0 ? clo.y : chi.y; sy > 0 ? j <= chi.y : j >= clo.y; j += sy)
      for (int i = sx > 0 ? clo.x : chi.x; sx > 0 ? i <= chi.x : i >= clo.x; i += sx) testCell(i, j);
  }

  // An endpoint whose major coordinate may be c (within its pad).
  static bool atEnd(const CurvePoint& e, int ax, double c) {
    return std::abs(c - e.uv[ax]) <= e.pad[ax] * OBLONG_TRAV_END_PAD_REL + OBLONG_TRAV_END_PAD_ABS;
  }

  // The minor coordinate range of the monotone piece where its major coordinate is c.
  void minorAt(const CurvePiece& p, int ax, double c, double& wlo, double& whi) const {
    const int mi = 1 - ax;
    const dvec2 lo = p.lo(), hi = p.hi();
    wlo = std::numeric_limits<double>::infinity(), whi = -wlo;
    // An endpoint whose major coordinate may be c (within its pad): the sub-arc may
    // start or end there.
    for (const CurvePoint* e : {&p.a, &p.b})
      if (atEnd(*e, ax, c)) {
        wlo = std::min(wlo, e->uv[mi] - e->pad[mi]);
        whi = std::max(whi, e->uv[mi] + e->pad[mi]);
      }
    double q2, q1, q0, w[2], rp[2];
    psi_.onLine(ax, c, q2, q1, q0);
    const int n = quadraticRoots(q2, q1, q0, w, rp);
    if (n < 0) {  // ψ vanishes on the whole line: the curve may run along it
      wlo = lo[mi], whi = hi[mi];
      return;
    }
    for (int k = 0; k < n; ++k)
      if (w[k] >= lo[mi] - rp[k] && w[k] <= hi[mi] + rp[k]) {
        wlo = std::min(wlo, w[k] - rp[k]);
        whi = std::max(whi, w[k] + rp[k]);
      }
    if (!(wlo <= whi)) wlo = lo[mi], whi = hi[mi];  // lost to rounding: the whole range
    wlo = std::max(wlo, lo[mi]);
    whi = std::min(whi, hi[mi]);
  }

  // Texel marching (§4.4) over the cells within ε of the piece.
  void march(const CurvePiece& p) {
    OBLONG_STAT_INC(travLeaves);
    const dvec2 d = p.b.uv - p.a.uv;
    const int ax = std::abs(d.x) >= std::abs(d.y) ? 0 : 1, mi = 1 - ax;
    const dvec2 lo = p.lo(), hi = p.hi();
    ivec2 clo, chi;
    if (!snap(lo - dilation_, hi + dilation_, clo, chi)) return;
    const int sa = d[ax] >= 0 ? 1 : -1, sm = d[mi] >= 0 ? 1 : -1;
    // Where a column's minor range cannot narrow its rows, its two solves are skipped;
    // the cells tested stay exactly the same:
    // - every row any column could get is one row: minorAt stays within the piece's
    //   minor range, so a column's rows lie in [mLo − η, mHi + η] with the snap's η
    //   below etaMax (twice the bound, for its rounding);
    // - the column spans the whole piece and minorAt's endpoint test holds for one
    //   endpoint at each end: the two ranges then join to the piece's minor range.
    const double mLo = lo[mi] - dilation_[mi], mHi = hi[mi] + dilation_[mi];
    const double etaMax = 2.0 * OBLONG_TRAV_SNAP_ETA * (1 + 2 * std::max(std::abs(mLo), std::abs(mHi)));
    const bool oneRow = std::floor(mLo - etaMax) == std::floor(mHi + etaMax);
    const bool endsAtEndpoints = (atEnd(p.a, ax, lo[ax]) && atEnd(p.b, ax, hi[ax])) ||
                                 (atEnd(p.b, ax, lo[ax]) && atEnd(p.a, ax, hi[ax]));
    // Once a hit is known, cells past the curve's point at the best hit's limit t* cannot
    // hold a better one: the piece is monotone, so its points before t* lie on this side
    // of that point's (padded) coordinates, and every hit lies within ε of its cell. Hits
    // at t outside the piece are other pieces' to find. Per axis, only where the piece's
    // direction along it is certain.
    const int sgn[2] = {ax == 0 ? sa : sm, ax == 0 ? sm : sa};
    bool certain[2], stopAxis[2] = {false, false};
    for (int a = 0; a < 2; ++a) certain[a] = std::abs(d[a]) > p.a.pad[a] + p.b.pad[a];
    bool stopSet = !certain[0] && !certain[1];
    dvec2 stop(0.0);
    auto setStop = [&] {  // false when no cell of the piece can hold a better hit
      stopSet = true;
      const double tStar = bestLimit();
      if (tStar <= p.a.t) return false;
      CurvePoint m;
      if (tStar < p.b.t && (pointFromHit(tStar, m) || invertAt(tStar, m)))
        for (int a = 0; a < 2; ++a)
          if (certain[a]) {
            const double margin = m.pad[a] + p.a.pad[a] + p.b.pad[a];
            stop[a] = sgn[a] > 0 ? m.uv[a] + margin : m.uv[a] - margin;
            stopAxis[a] = true;
          }
      return true;
    };
    auto past = [&](int a, int k) {
      return stopAxis[a] && (sgn[a] > 0 ? k - dilation_[a] > stop[a] : k + 1 + dilation_[a] < stop[a]);
    };
    for (int k = sa > 0 ? clo[ax] : chi[ax]; sa > 0 ? k <= chi[ax] : k >= clo[ax]; k += sa) {
      if ((!stopSet && hit_.found && !setStop()) || past(ax, k)) {
        OBLONG_STAT_INC(travMarchStops);
        return;
      }
      // The piece's points whose major coordinate is within ε of column k.
      const double c0 = std::max(k - dilation_[ax], lo[ax]), c1 = std::min(k + 1 + dilation_[ax], hi[ax]);
      if (c0 > c1) continue;
      double a0, a1, b0, b1;
      if (oneRow || (endsAtEndpoints && c0 == lo[ax] && c1 == hi[ax])) {
        a0 = b0 = lo[mi];
        a1 = b1 = hi[mi];
      } else {
        minorAt(p, ax, c0, a0, a1);
        minorAt(p, ax, c1, b0, b1);
      }
      // Monotone: in between, the minor coordinate lies between its values at c0 and c1.
      const double wlo = std::min(a0, b0) - dilation_[mi], whi = std::max(a1, b1) + dilation_[mi];
      const double eta = OBLONG_TRAV_SNAP_ETA * (1 + std::abs(wlo) + std::abs(whi));
      const int j0 = std::max(int(std::floor(wlo - eta)), clo[mi]), j1 = std::min(int(std::floor(whi + eta)), chi[mi]);
      for (int j = sm > 0 ? j0 : j1; sm > 0 ? j <= j1 : j >= j0; j += sm) {
        if (!stopSet && hit_.found && !setStop()) {
          OBLONG_STAT_INC(travMarchStops);
          return;
        }
        if (past(mi, j)) {
          OBLONG_STAT_INC(travMarchStops);
          break;
        }
        if (ax == 0) testCell(k, j);
        else testCell(j, k);
      }
    }
  }

  // A piece too small to split: marched, unless ε (float rounding at a fine texel: a texel
  // or more at high tiling) is wide against the marching scale; then its cells are
  // subdivided as boxes, down to blocks of OBLONG_TRAV_WIDE_BOX_CELLS, which prune across
  // the curve where the march would test every cell within ε of it. Such pieces stop
  // splitting at a few ε (leafScale_): neighbourhoods of pieces much shorter than ε would
  // overlap, and their cells be tested again and again.
  void leaf(const CurvePiece& p) {
    if (!wideEps_) return march(p);
    OBLONG_STAT_INC(travWideLeaves);
    ivec2 clo, chi;
    if (!snap(p.lo() - dilation_, p.hi() + dilation_, clo, chi)) return;
    pushBox(clo, chi, p.a.t, std::min(p.b.t, bestLimit()));
  }

  template <typename Split>
  void processPiece(CurvePiece p, const Split& splitter) {
    if (p.a.t > bestLimit()) return;
    dvec2 ext = p.hi() - p.lo();
    const double ms = leafScale_;
    // Pads that dominate the rectangle cannot be split away: march.
    const dvec2 pads = p.a.pad + p.b.pad;
    auto small = [&] {
      const int la = ext.x >= ext.y ? 0 : 1;
      return ext[la] <= ms || pads[la] > OBLONG_TRAV_PAD_DOMINANCE * ext[la];
    };
    if (small()) return leaf(p);
    ivec2 clo, chi;
    if (!snap(p.lo() - dilation_, p.hi() + dilation_, clo, chi)) return;
    double t0 = p.a.t, t1 = std::min(p.b.t, bestLimit());
    if (!clipToCells(clo, chi, t0, t1)) return;
    if (opt_.inversionInTraversal) {
      // Fig. 5a: the clipped ends' projections can give a much smaller rectangle.
      const double dt = p.b.t - p.a.t;
      const double minGain =
          std::max(OBLONG_TRAV_MIN_GAIN * dt, OBLONG_TRAV_MIN_GAIN_CELLS * dt / std::max(ext.x, ext.y));
      CurvePoint m;
      if (t0 > p.a.t + minGain && (pointBetween(p.a, p.b, t0, m) || invertAt(t0, m))) p.a = m;
      if (t1 < p.b.t - minGain && (pointBetween(p.a, p.b, t1, m) || invertAt(t1, m))) p.b = m;
      ext = p.hi() - p.lo();
      if (small()) return leaf(p);
    }
    CurvePiece front, back;
    if (stackSize_ + 2 > opt_.stackDepth) {
      OBLONG_STAT_INC(travOverflows);
      return march(p);  // correct, just not hierarchical (a box would need a slot too)
    }
    if (!detail::split(splitter, p, *this, front, back)) {
      OBLONG_STAT_INC(travBoxOnly);
      pushBox(clo, chi, t0, t1);
      return;
    }
    pushPiece(back);
    pushPiece(front);
  }

  void processBox(const Entry& e) {
    const double limit = bestLimit();
    if (e.ta > limit) return;
    const ivec2 n = e.chi - e.clo + 1;
    const float block = wideEps_ ? std::min(float(OBLONG_TRAV_WIDE_BOX_CELLS), opt_.marchingScale) : opt_.marchingScale;
    if (std::max(n.x, n.y) <= std::max(float(OBLONG_TRAV_MIN_BOX_CELLS), block))
      return testCells(e.clo, e.chi);
    double t0 = e.ta, t1 = std::min(e.tb, limit);
    if (!clipToCells(e.clo, e.chi, t0, t1)) return;
    if (stackSize_ + 2 > opt_.stackDepth) {
      OBLONG_STAT_INC(travOverflows);
      return testCells(e.clo, e.chi);
    }
    const int ax = n.x >= n.y ? 0 : 1;
    const int mid = e.clo[ax] + (n[ax] - 1) / 2;
    ivec2 aHi = e.chi, bLo = e.clo;
    aHi[ax] = mid;
    bLo[ax] = mid + 1;
    // Lower half first when the ray runs towards +axis (order matters for speed only).
    if (dirLocal_[ax] >= 0) {
      pushBox(bLo, e.chi, t0, t1);
      pushBox(e.clo, aHi, t0, t1);
    } else {
      pushBox(e.clo, aHi, t0, t1);
      pushBox(bLo, e.chi, t0, t1);
    }
  }

  // Projection-free subdivision of all of T's cells (ill-posed triangles, fallbacks).
  bool runBoxOnly() {
    OBLONG_STAT_INC(travBoxOnlyPrisms);
    double t0 = ray_.tmin - slack(ray_.tmin), t1 = bestLimit();
    prismBox_.clip(origin_, invDir_, t0, t1);
    if (!(t0 <= t1)) return hit_.found;
    dirLocal_ = dirLocal();
    stackSize_ = 0;
    pushBox(cellLo_, cellHi_, t0, t1);
    while (stackSize_ > 0) {
      const Entry e = stack()[--stackSize_];
      processBox(e);
    }
    return hit_.found;
  }

  // The triangle and what was precomputed for it (TraversalMesh).
  const DisplacedTriangle& tri_;
  const PrismParams& shell_;  // shell analysis: heights [a, b], bulge, ε, error bounds
  const shared::ClaimBounds claim_;  // its bounds on the claims' errors (makePoint)
  const Displacement& disp_;
  const RQ& rq_;
  const Inv& inv_;
  const TraversalOptions& opt_;
  const Ray& ray_;
  RayCounters& counters_;
  const LocalFrame& frame_;  // P, N, barycentrics over local sample coordinates
  const TextureFrame& tex_;  // the boxes' frame
  const float blend_;        // the ray's level-of-detail blend (Displacement::blendOf)
  const WatertightRay watertightRay_;
  // The ray in double, and what it needs per triangle.
  const dvec3 origin_, dir_, invDir_;
  const dvec3 originT_, invDirT_;  // in the texture frame
  double texPad_ = 0;              // boxPad_ in the texture frame
  BoxD texPrismBox_;               // the exact prism's box in the texture frame, padded
  ivec2 cellLo_, cellHi_;    // the triangle's cells, local sample coordinates
  dvec2 uvBoxLo_, uvBoxHi_;  // the triangle's uv box, local sample coordinates
  double boxPad_ = 0, tSlackAbs_ = 0;
  dvec2 dilation_{0.0};      // ε: cells within it of the curve are marched
  bool wideEps_ = false;     // ε wide against the marching scale: leaves are boxes (leaf())
  double leafScale_ = 0;     // pieces up to this many texels are leaves
  const Prism* prism_ = nullptr;  // inflated prism: precomputed, or ownPrism_ for far origins
  Prism ownPrism_;
  BoxD prismBox_, inflatedBox_;
  Psi psi_;                  // the ray's implicit curve in texture space (Eq. 3)
  dvec2 dirLocal_{1.0};      // approximate curve direction (front-to-back order)
  ClosestHit hit_;
  int stackSize_ = 0;
  alignas(Entry) unsigned char stackRaw_[kStack * sizeof(Entry)];
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
