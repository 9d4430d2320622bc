// The "tfdm" baseline: Tessellation-Free Displacement Mapping (Thonat et al. 2021) as it
// traverses, the RMIP paper's main competitor (RMIP paper §3, §6; docs/design.md §2). Per ray and
// displaced triangle:
//   - a texture-space quad-tree over a min-max mipmap (conservative 16-bit codes per
//     node as the paper's TFDM stores it, or floats with `bits: 32`), descended from the
//     coarsest nodes covering T's cells (at most 2×2 roots: the level at which T's cell
//     range spans at most two nodes per axis);
//   - per node, a conservative box of the micro-geometry over node ∩ T's uv box from the
//     node's [min, max] (oblong's interval bounds, rect_bounds.h: TFDM's affine
//     arithmetic, made conservative for normalised normals), axis-aligned in T's texture
//     frame (the map's u axis, the face normal and their cross product: GfxExp's TFDM
//     bounds in texture space) or, with the parameter `boxes: "world"`, in world
//     space; and a ray/box test against [tmin, closest hit so far];
//   - nodes whose square misses T's uv triangle are skipped without a box test;
//   - children in a fixed order from the signs of the ray's texture-space direction;
//   - leaves at single cells of the micro-geometry, tested with the same watertight
//     micro-triangles as every other intersector; the closest hit is kept and the
//     traversal goes on (no termination at the first hit: pruning only by it).
// There is no prism clip, no ψ-curve, no inversion and no texel marching.
// Steps as the RMIP paper's Fig. 9 counts them: every node whose box is tested
// (`boxes`) plus every leaf cell tested (`cells_marched`). docs/tfdm.md gives the
// sources of each choice.
#include "traversal/tfdm_view.h"

#include "core/error.h"
#include "core/kernels/tfdm.h"
#include "core/stats.h"
#include "strategies/quantize.h"
#include "traversal/closest_hit.h"
#include "core/kernels/rect_bounds.h"
#include "traversal/texture_frame.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

namespace oblong {

OBLONG_STAT_COUNTER("tfdm/Prisms", tfPrisms);
OBLONG_STAT_COUNTER("tfdm/Hits", tfHits);
OBLONG_STAT_COUNTER("tfdm/Nodes", tfNodes);
OBLONG_STAT_COUNTER("tfdm/NodesOutsideTriangle", tfOutside);
OBLONG_STAT_COUNTER("tfdm/Leaves", tfLeaves);
OBLONG_STAT_COUNTER("tfdm/MicroTriangles", tfMicroTris);

namespace {

// The min-max mipmap over the micro-geometry's cells. Level 0 holds, per cell (i, j),
// the [min, max] of its four corner samples (i..i+1, j..j+1, wrapped): every
// micro-vertex of the cell, clipped or not, lies between them (docs/design.md invariant 2).
// Level L+1 is the union of 2×2 nodes of level L. Levels are periodic (the map wraps,
// tiling is free) while 2^L divides both sides; a node above the last stored level is
// the union of the stored nodes it covers, or, when that is more than kMaxFold nodes
// (maps whose sides are not powers of two), the `minmax_mipmap` range query's bound over
// the node's samples (built only then, in floats).
// With 16 bits a stored node is one word of conservative codes (strategies/quantize.h),
// as the paper's TFDM stores its mipmap: level 0 encodes the float [min, max] outward,
// level L+1 joins the codes of level L. Codes are monotone, so the join equals encoding
// the float union: the decoded node contains the 32-bit pyramid's node at every level.
class CellPyramid {
 public:
  static constexpr int64_t kMaxFold = 64;

  CellPyramid(const Displacement& d, int topLevel, int bits) : map_(*d.map), bits_(bits) {
    const int W = map_.width(), H = map_.height();
    int ls = 0;
    while (ls < topLevel && W % (2 << ls) == 0 && H % (2 << ls) == 0) ++ls;
    size_t bytes = 0;
    for (int L = 0; L <= ls; ++L) bytes += size_t(W >> L) * size_t(H >> L) * nodeBytes();
    checkFits(map_.name(), "tfdm's min-max mipmap", bytes,
              "use a smaller map, or the canonical traversal (its rmip can be built at a lower resolution)",
              fmt::format("levels 0..{} over {}x{} cells, {} bytes per node", ls, W, H, nodeBytes()));
    if (bits_ == 16) q_ = Quantizer16::over(Quantizer16::rangeFor(map_.range()));
    dims_.resize(ls + 1);
    dims_[0] = {W, H};
    for (int L = 1; L <= ls; ++L) dims_[L] = {dims_[L - 1].x / 2, dims_[L - 1].y / 2};
    if (bits_ == 16) {
      build(codes_, [this](const Interval& v) { return q_.encode(v); }, join16);
    } else {
      auto join = [](const Interval& a, const Interval& b) {
        return Interval{std::min(a.lo, b.lo), std::max(a.hi, b.hi)};
      };
      build(levels_, [](const Interval& v) { return v; }, join);
    }
  }

  int storedTop() const { return int(dims_.size()) - 1; }
  const std::vector<ivec2>& dims() const { return dims_; }
  // Level L's stored words: one code pair per node (16 bits), or lo and hi floats (32).
  const uint32_t* words(int L) const {
    return bits_ == 16 ? codes_[L].data() : reinterpret_cast<const uint32_t*>(levels_[L].data());
  }
  // True when a node of level L is answered by folding stored nodes.
  bool folds(int L) const {
    const int s = storedTop();
    if (L <= s) return true;
    const int64_t n = int64_t(1) << std::min(L - s, 40);
    return std::min<int64_t>(n, dims_[s].x) * std::min<int64_t>(n, dims_[s].y) <= kMaxFold;
  }
  void setUpper(std::unique_ptr<RangeQuery> q) { upper_ = std::move(q); }
  const RangeQuery* upper() const { return upper_.get(); }
  int bits() const { return bits_; }
  const Quantizer16& quantizer() const { return q_; }

  // Raw [min, max] over cells [x·2^L, (x+1)·2^L) × [y·2^L, (y+1)·2^L) (absolute cell
  // indices, unwrapped).
  Interval node(int L, int64_t x, int64_t y) const {
    if (folds(L)) {  // core/kernels/tfdm.h, as the Vulkan path reads it
      const vec2 v = shared::tfdmNode(*this, bits_, storedTop(), L, int(x), int(y));
      return {v.x, v.y};
    }
    // Samples x·2^L .. (x+1)·2^L inclusive (the cells' far corners); clamped to int, a
    // range wider than the map is the whole map's anyway.
    auto clampI = [](int64_t v) { return int(std::clamp<int64_t>(v, -(int64_t(1) << 30), int64_t(1) << 30)); };
    const int64_t W = map_.width(), H = map_.height();
    const int64_t x0 = x << L, y0 = y << L;
    const int64_t x1 = std::min((x + 1) << L, x0 + W), y1 = std::min((y + 1) << L, y0 + H);
    return upper_->rawRange(SampleRange{clampI(x0), clampI(y0), clampI(x1), clampI(y1)});
  }
  // The stored pyramid as core/kernels/tfdm.h's tfdmNode reads it (TfdmPyr).
  friend ivec2 tfdmDims(const CellPyramid& p, int L) { return p.dims_[L]; }
  friend uint32_t tfdmCode(const CellPyramid& p, int L, uint32_t at) { return p.codes_[L][at]; }
  friend vec2 tfdmPair(const CellPyramid& p, int L, uint32_t at) {
    const Interval& v = p.levels_[L][at];
    return vec2(v.lo, v.hi);
  }
  friend vec2 tfdmDecode(const CellPyramid& p, uint32_t codes) {
    const Interval v = p.q_.decodePair(codes);
    return vec2(v.lo, v.hi);
  }

  size_t bytes() const {
    size_t b = 0;
    for (const auto& l : levels_) b += l.capacity() * sizeof(Interval);
    for (const auto& l : codes_) b += l.capacity() * sizeof(uint32_t);
    return b;
  }

 private:
  size_t nodeBytes() const { return bits_ == 16 ? sizeof(uint32_t) : sizeof(Interval); }

  // Fills every stored level: level 0 from the cells' corner samples through `encode`,
  // level L+1 by `join` of 2×2 nodes of level L.
  template <typename T, typename Encode, typename Join>
  void build(std::vector<std::vector<T>>& levels, Encode encode, Join join) {
    const int W = dims_[0].x, H = dims_[0].y;
    levels.resize(dims_.size());
    levels[0].resize(size_t(W) * H);
    tbb::parallel_for(0, H, [&](int j) {
      T* row = &levels[0][size_t(j) * W];
      for (int i = 0; i < W; ++i) {
        const float a = map_.at(i, j), b = map_.at(i + 1, j), c = map_.at(i, j + 1), e = map_.at(i + 1, j + 1);
        row[i] = encode(Interval{std::min({a, b, c, e}), std::max({a, b, c, e})});
      }
    });
    for (size_t L = 1; L < dims_.size(); ++L) {
      const int w = dims_[L].x, h = dims_[L].y, pw = dims_[L - 1].x;
      levels[L].resize(size_t(w) * h);
      const T* p = levels[L - 1].data();
      T* q = levels[L].data();
      tbb::parallel_for(0, h, [&](int j) {
        for (int i = 0; i < w; ++i) {
          const T* r0 = p + size_t(2 * j) * pw + 2 * i;
          const T* r1 = r0 + pw;
          q[size_t(j) * w + i] = join(join(r0[0], r0[1]), join(r1[0], r1[1]));
        }
      });
    }
  }

  const HeightMap& map_;
  int bits_;
  Quantizer16 q_;
  std::vector<std::vector<Interval>> levels_;  // bits 32
  std::vector<std::vector<uint32_t>> codes_;   // bits 16
  std::vector<ivec2> dims_;
  std::unique_ptr<RangeQuery> upper_;
};

// The roots of a triangle: the level at which its cell range spans at most two nodes
// per axis (core/kernels/tfdm.h), and those nodes.
struct Roots {
  int level = 0;
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  static Roots of(const CellRange& c) {
    Roots r;
    r.level = shared::tfdmRootLevel(ivec2(c.x0, c.y0), ivec2(c.x1, c.y1));
    r.x0 = c.x0 >> r.level, r.x1 = c.x1 >> r.level;
    r.y0 = c.y0 >> r.level, r.y1 = c.y1 >> r.level;
    return r;
  }
};

// One ray against one triangle: the traversal of core/kernels/tfdm_body.h (the Vulkan
// shader's own code) with the CPU's hooks: the pyramid, the boxes in the frame X, the
// closest hit and the micro-cells (built at the first leaf).
struct TfdmRay : shared::TfdmLoop<TfdmRay> {
  TfdmRay(const CellPyramid& pyr, const Displacement& d, const TextureFrame& X, const DisplacedTriangle& T,
          const Ray& r, double boxPad, double tAbs)
      : pyr(pyr), d(d), X(X), T(T), r(r), wr(r), boxPadF(shared::floatAbove(boxPad, boxPad)), tAbs(tAbs) {}

  double slack(double t) const { return OBLONG_TRAV_SLACK_REL * std::abs(t) + tAbs; }
  vec2 tfdmHeights(int L, int x, int y) const {
    const Interval h = d.toHeight(pyr.node(L, x, y));
    return vec2(h.lo, h.hi);
  }
  void tfdmBox(const vec2& lo, const vec2& hi, const vec2& h, vec3& blo, vec3& bhi) const {
    shared::boxOverRectF(X.box, lo, hi, h.x, h.y, boxPadF, blo, bhi);
  }
  double tfdmLimit() const {
    return best.found ? double(best.t) + slack(best.t) : double(r.tmax) + slack(r.tmax);
  }
  int tfdmLeaf(int x, int y) {
    if (!cells) cells.emplace(T, d);
    MicroTriangle buf[MicroCells::kMaxPerCell];
    const int k = cells->cell(x, y, buf);
    for (int q = 0; q < k; ++q) best.test(wr, buf[q], r.tmin, r.tmax);
    return k;
  }

  const CellPyramid& pyr;
  const Displacement& d;
  const TextureFrame& X;
  const DisplacedTriangle& T;
  const Ray& r;
  const WatertightRay wr;
  float boxPadF;  // the boxes' pad, rounded up
  double tAbs;
  ClosestHit best;
  std::optional<MicroCells> cells;
};

class Tfdm final : public TfdmIntersector {
 public:
  Tfdm(TraversalMesh mesh, std::vector<Roots> roots, std::vector<TextureFrame> frames, std::unique_ptr<CellPyramid> pyr,
       int maxRootLevel, bool worldBoxes)
      : mesh_(std::move(mesh)),
        roots_(std::move(roots)),
        texFrames_(std::move(frames)),
        pyr_(std::move(pyr)),
        maxRootLevel_(maxRootLevel),
        worldBoxes_(worldBoxes) {}
  std::string name() const override { return "tfdm"; }
  size_t size() const override { return mesh_.tris.size(); }
  // Embree's bounds: the AABB of T's bounding prism (heights from the root nodes).
  AABB bounds(uint32_t prim) const override { return mesh_.bounds(prim); }
  MemoryReport memory() const override {
    MemoryReport r{{"tfdm/mipmap", pyr_->bytes()}};
    if (pyr_->upper())
      for (MemoryItem m : pyr_->upper()->memory()) r.push_back({"tfdm/upper_levels (" + m.name + ")", m.bytes});
    r.push_back({"tfdm/triangles",
                 mesh_.bytes() + roots_.capacity() * sizeof(Roots) + texFrames_.capacity() * sizeof(TextureFrame)});
    return r;
  }
  nlohmann::json describe() const override {
    nlohmann::json j = {{"name", "tfdm"},
            {"stored_levels", pyr_->storedTop() + 1},
            {"max_root_level", maxRootLevel_},
            {"upper_levels", pyr_->upper() ? std::string(pyr_->upper()->name()) : std::string("folded")},
            {"boxes", worldBoxes_ ? "world" : "texture"},
            {"bits", pyr_->bits()},
            {"bounds", "prism AABB"}};
    if (pyr_->bits() == 16) j["quantization"] = {{"base", pyr_->quantizer().base}, {"step", pyr_->quantizer().step}};
    return j;
  }

  TfdmView view() const override {
    TfdmView v;
    v.mesh = &mesh_;
    v.bits = pyr_->bits();
    v.base = pyr_->quantizer().base, v.step = pyr_->quantizer().step;
    v.dims = pyr_->dims();
    for (int L = 0; L <= pyr_->storedTop(); ++L) v.words.push_back(pyr_->words(L));
    v.folds = pyr_->upper() == nullptr;
    v.topLevel = maxRootLevel_;
    v.worldBoxes = worldBoxes_;
    return v;
  }

  bool intersect(const Ray& r, uint32_t prim, TriangleHit& hit, RayCounters& c) const override {
    const PrismParams& P = mesh_.params[prim];
    if (!P.valid) return false;
    const DisplacedTriangle& T = mesh_.tris[prim];
    const LocalFrame& F = mesh_.frames[prim];
    const TextureFrame& X = worldBoxes_ ? texFrames_[prim] : mesh_.texFrames[prim];
    const CellRange& cr = mesh_.cells[prim];
    const Displacement& d = mesh_.disp;
    ++c.prisms;
    OBLONG_STAT_INC(tfPrisms);

    const dvec3 O(r.o), D(r.d);
    const double maxO = std::max({std::abs(O.x), std::abs(O.y), std::abs(O.z)});
    const RayMargins m = RayMargins::make(P, maxAbsVertex(T), maxO);
    // The ray in the boxes' frame; its rotation's rounding (and the frame's) is padded.
    const shared::BoxRayF R = shared::boxRayF(X.rot(O), X.rot(D), X.Pc);
    const double boxPad = worldBoxes_ ? m.boxPad : shared::texPiecePad(m.boxPad, maxO, maxAbsVertex(T), P.a, P.b);
    const double tSlackAbs = shared::tSlackAbs(boxPad, shared::lengthD(D));
    const dvec2 uvLo = d.toSample(T.uvBox.lo) - dvec2(F.origin), uvHi = d.toSample(T.uvBox.hi) - dvec2(F.origin);
    // T's uv triangle in sample coordinates, with the inside sign of each edge.
    dvec2 S[3];
    for (int k = 0; k < 3; ++k) S[k] = d.toSample(T.t[k]);
    // Child order: from the signs of the ray's texture-space direction.
    const dvec2 dl = approxDirLocal(F, D);
    TfdmRay tr(*pyr_, d, X, T, r, boxPad, tSlackAbs);
    shared::TfdmWork w;
    tr.tfdmTraverse(ivec2(cr.x0, cr.y0), ivec2(cr.x1, cr.y1), F.origin, S[0], S[1], S[2], uvLo, uvHi, dl, R,
                    r.tmin - tr.slack(r.tmin), w);
    if (w.overflow) fail("tfdm", "traversal stack overflow");  // cannot happen: depth <= 94
    RayCounters local;
    local.boxes = local.rangeQueries = w.boxes;
    local.cellsMarched = w.leaves;
    local.microTriangles = w.microTris;
    OBLONG_STAT_ADD(tfOutside, w.outside);
    const ClosestHit& best = tr.best;
    c += local;
    OBLONG_STAT_ADD(tfNodes, local.boxes);
    OBLONG_STAT_ADD(tfLeaves, local.cellsMarched);
    OBLONG_STAT_ADD(tfMicroTris, local.microTriangles);
    if (!best.found) return false;
    OBLONG_STAT_INC(tfHits);
    best.fill(hit);
    return true;
  }

 private:
  TraversalMesh mesh_;
  std::vector<Roots> roots_;
  std::vector<TextureFrame> texFrames_;
  std::unique_ptr<CellPyramid> pyr_;
  int maxRootLevel_;
  bool worldBoxes_;
};

std::unique_ptr<Intersector> makeTfdm(ParamSet& params, const BaselineContext& ctx) {
  const std::string boxFrame = params.get<std::string>("boxes", "texture");
  if (boxFrame != "texture" && boxFrame != "world")
    fail(params.where(), "boxes must be \"texture\" or \"world\", got \"{}\"", boxFrame);
  const bool world = boxFrame == "world";
  const int bits = params.get<int>("bits", 16);
  if (bits != 16 && bits != 32) fail(params.where(), "parameter 'bits' = {} is not 16 or 32", bits);
  const Displacement& disp = ctx.disp;
  std::vector<DisplacedTriangle>& tris = *ctx.triangles;
  std::vector<Roots> roots(tris.size());
  std::vector<Rect> boxes;
  int top = 0;
  for (size_t i = 0; i < tris.size(); ++i) {
    if (tris[i].uvArea2 == 0.0f) continue;
    const CellRange c = cellsOverlapping(tris[i], disp);
    // The kernels' cell indices are ints with room for a node's far side.
    constexpr int kMaxCell = 1 << 29;
    if (std::max({std::abs(c.x0), std::abs(c.y0), std::abs(c.x1), std::abs(c.y1)}) > kMaxCell)
      fail(params.where(), "triangle {}'s texels reach cell {} (tiling {}x{}), beyond the {} tfdm indexes", i,
           std::max({std::abs(c.x0), std::abs(c.y0), std::abs(c.x1), std::abs(c.y1)}), disp.tiling.x, disp.tiling.y,
           kMaxCell);
    roots[i] = Roots::of(c);
    top = std::max(top, roots[i].level);
    boxes.push_back(tris[i].uvBox);
  }
  auto pyr = std::make_unique<CellPyramid>(disp, top, bits);
  if (!pyr->folds(top)) {
    ParamSet none(nlohmann::json::object(), "tfdm: upper levels");
    pyr->setUpper(createRangeQuery("minmax_mipmap", none, RangeQueryContext{disp, QueryNeeds::forRects(disp, boxes)}));
  }
  // T's heights for its prism: the union of its root nodes (what TFDM bounds T with).
  TraversalMesh mesh;
  mesh.build(std::move(tris), disp, [&](const DisplacedTriangle& T) {
    const Roots& r = roots[size_t(&T - mesh.tris.data())];
    Interval h;
    for (int64_t y = r.y0; y <= r.y1; ++y)
      for (int64_t x = r.x0; x <= r.x1; ++x) {
        const Interval v = pyr->node(r.level, x, y);
        h.lo = std::min(h.lo, v.lo), h.hi = std::max(h.hi, v.hi);
      }
    return disp.toHeight(h);
  });
  warnSkippedTriangles(mesh, "tfdm");
  // The boxes' frame: the mesh's texture frames, or the world's axes.
  std::vector<TextureFrame> frames(world ? mesh.tris.size() : 0);
  for (size_t i = 0; i < frames.size(); ++i)
    if (mesh.params[i].valid) frames[i] = TextureFrame::make(mesh.frames[i], mesh.tris[i], mesh.cells[i], true);
  return std::make_unique<Tfdm>(std::move(mesh), std::move(roots), std::move(frames), std::move(pyr), top, world);
}

}  // namespace

OBLONG_REGISTER_BASELINE("tfdm", makeTfdm,
                         StrategyTraits{.summary = "Thonat et al. 2021: texture-space quad-tree over a min-max mipmap, "
                                                   "node boxes, fixed child order, no early exit (exact)",
                                        .vulkanKernel = "core/kernels/tfdm.h"});

}  // namespace oblong
