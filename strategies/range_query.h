// RangeQuery (docs/design.md §2): bounds of the displaced micro-geometry's heights over a uv
// rectangle. The contract: query(rect) contains every height the micro-geometry can
// take over the rectangle. The micro-geometry over a rectangle is made of the grid
// cells it touches, whose corners are texel-centre samples up to one texel outside it
// (docs/design.md invariant 2), so the base class snaps the rectangle outward to that sample
// range and each strategy bounds the raw texels over an integer, possibly wrapping,
// sample range.
//
// Strategies are `final` classes deriving from RangeQueryImpl<Self> and implementing
// `Interval rawRangeFast(const SampleRange&) const`. The names are the same across the
// three interfaces: query / rawRange (here), invert (Inverter) and split (Splitter) are
// the virtual entry points every caller uses; the ...Fast forms are the strategies'
// inline, non-virtual implementations, which a static traversal instantiation calls
// directly (docs/traversal.md, "Generic path": opt-in, kept only where a benchmark shows
// a gain).
//
// A strategy registers itself in its .cpp (core/registry.h):
//     OBLONG_REGISTER_RANGE_QUERY("name", factory, StrategyTraits{...});
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "core/memory.h"
#include "core/registry.h"

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace oblong {

// Inclusive sample-index range [x0,x1] x [y0,y1]. Indices may lie outside [0,W) and
// wrap (repeat addressing); x1 - x0 + 1 is the extent in samples.
struct SampleRange {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int extentX() const { return x1 - x0 + 1; }
  int extentY() const { return y1 - y0 + 1; }
};

// What the scene can ask of a map (docs/design.md invariant 4: build nothing else).
struct QueryNeeds {
  int maxExtentX = 1;  // largest sample extent of any query, per axis
  int maxExtentY = 1;
  bool wrap = false;  // some query crosses the map's border (tiled or out-of-[0,1] uvs)

  // Everything a query on this map could ever need (tests, benchmarks).
  static QueryNeeds all(const HeightMap& m) { return {m.width() + 1, m.height() + 1, true}; }
  // What queries within these uv rectangles (the triangles' uv boxes) can ask.
  static QueryNeeds forRects(const Displacement& d, const std::vector<Rect>& uvBoxes);
};

class RangeQuery {
 public:
  RangeQuery(const Displacement& d, const QueryNeeds& needs) : disp_(d), needs_(needs) {}
  virtual ~RangeQuery() = default;

  virtual std::string_view name() const = 0;
  // Heights (scale and bias applied) over the micro-geometry on `uv`; at a level of
  // detail lod > 0 over the surface at that λ (docs/lod.md), conservatively: the raw
  // range of the level-0 samples snapAtLod names. A structure built on a displacement
  // already at a level of detail answers lod 0 only.
  virtual Interval query(const Rect& uv, float lod = 0.0f) const = 0;
  // Raw texel bounds over a sample range: the strategy's core.
  virtual Interval rawRange(const SampleRange& r) const = 0;
  // Bytes of the strategy's own structures (not the map it reads).
  virtual size_t bytes() const = 0;
  virtual MemoryReport memory() const { return {{std::string(name()), bytes()}}; }
  // True when rawRange equals the brute-force range on every sample range.
  virtual bool exact() const = 0;
  // The map's samples in `changed` (inclusive, may wrap) were edited: refresh what they
  // affect. The result equals a full build on the edited map, bit for bit.
  virtual void update(const SampleRange& changed) = 0;
  // The stored entries as raw bytes (for bit-for-bit comparisons of builds).
  virtual std::span<const std::byte> storage() const = 0;
  // What was built, for `oblong info` and --stats: name, exactness, bytes and the
  // QueryNeeds it was built for; strategies add their own layout (describeLayout).
  nlohmann::json describe() const;

  const Displacement& displacement() const { return disp_; }
  const HeightMap& map() const { return *disp_.map; }
  const QueryNeeds& needs() const { return needs_; }

 protected:
  // The strategy's own structure (levels, layers, deltas...); empty by default.
  virtual nlohmann::json describeLayout() const { return nlohmann::json::object(); }

 public:

  // Cells touched by the rectangle -> their corner samples. A tiny outward margin
  // keeps the snap conservative against rounding of uv * tiling * size.
  SampleRange snap(const Rect& uv) const {
    const dvec2 a = disp_.toSample(uv.lo), b = disp_.toSample(uv.hi);
    constexpr double eps = 1e-5;
    return {int(std::floor(a.x - eps)), int(std::floor(a.y - eps)), int(std::ceil(b.x + eps)),
            int(std::ceil(b.y + eps))};
  }

  // The level-0 samples the surface at λ = lod reads over the cells `uv` touches:
  // level ⌈λ⌉'s cells (the coarsest level its heights come from; every finer level's
  // cells lie within them, the grids nest), widened on each side by the tent cascade's
  // support, 2^⌈λ⌉ − 1 level-0 samples. λ is clamped to the map's last level.
  SampleRange snapAtLod(const Rect& uv, float lod) const;

 protected:
  Displacement disp_;
  QueryNeeds needs_;
};

template <typename Self>
class RangeQueryImpl : public RangeQuery {
 public:
  using RangeQuery::RangeQuery;
  // Non-virtual entry point for templated callers.
  Interval queryFast(const Rect& uv) const {
    return disp_.toHeight(static_cast<const Self*>(this)->rawRangeFast(snap(uv)));
  }
  Interval query(const Rect& uv, float lod) const final;
  Interval rawRange(const SampleRange& r) const final {
    return static_cast<const Self*>(this)->rawRangeFast(r);
  }
};

template <typename Self>
Interval RangeQueryImpl<Self>::query(const Rect& uv, float lod) const {
  if (lod == 0.0f) return queryFast(uv);
  return disp_.toHeight(static_cast<const Self*>(this)->rawRangeFast(snapAtLod(uv, lod)));
}

struct RangeQueryContext {
  Displacement displacement;
  QueryNeeds needs;
};
using RangeQueryRegistry = Registry<RangeQuery, RangeQueryContext>;
#define OBLONG_REGISTER_RANGE_QUERY(name, ...) OBLONG_REGISTER(::oblong::RangeQueryRegistry, name, __VA_ARGS__)

// Creates a strategy by name; unknown names and unused parameters throw oblong::Error.
std::unique_ptr<RangeQuery> createRangeQuery(const std::string& name, ParamSet& params,
                                             const RangeQueryContext& ctx);
std::vector<std::string> rangeQueryNames();
const StrategyTraits& rangeQueryTraits(const std::string& name);

// Helpers for strategies: one axis [a0,a1] of a sample range on a map axis of size n.
// wrapAxis (core/kernels/texels.h): the whole axis [0,n-1] when the extent is >= n; else
// the start wrapped into [0,n) and the end relative to it (e may reach up to 2n-2: the
// range crosses the border).
using shared::wrapAxis;
// splitAxis: the same as one or two non-crossing pieces within [0,n).
struct AxisPieces {
  int count = 1;
  int lo[2] = {0, 0}, hi[2] = {0, 0};
};
inline AxisPieces splitAxis(int a0, int a1, int n) {
  AxisPieces p;
  int s, e;
  wrapAxis(a0, a1, n, s, e);
  p.lo[0] = s;
  if (e < n) {
    p.hi[0] = e;
  } else {
    p.count = 2, p.hi[0] = n - 1, p.lo[1] = 0, p.hi[1] = e - n;
  }
  return p;
}

// After an edit of the samples in `changed`: do the 16-bit codes over `q` stay those a
// fresh build would write? A requested range (non-empty `requested`) holds while it
// covers the edited samples (else it is dropped); the derived range [0, 1] holds while
// the edited samples stay in it; any other derived range needs a scan of the whole map.
struct Quantizer16;
bool keepsQuantizer(const HeightMap& m, const SampleRange& changed, const Quantizer16& q, Interval& requested);

// Brute force over the texels of a sample range (wrapping): the oracle.
Interval bruteForceRange(const HeightMap& m, const SampleRange& r);

}  // namespace oblong
