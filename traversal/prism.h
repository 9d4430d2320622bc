// Bounding prisms of displaced triangles (docs/design.md §2, invariant 2; RMIP paper §4.1,
// Fig. 2c) and the per-triangle constants the traversal needs to stay conservative.
//
// Prism coordinates. With G(b, s) = P(b) + s·N(b) (N interpolated, not normalised), the
// surface point of height h at b is G(b, h/|N(b)|). Over T, |N| ∈ [m, 1] (m =
// T.minNormalLength), so every point of the micro-geometry has s = h/|N| in [a, b] with
//     a = hmin < 0 ? hmin/m : hmin,     b = hmax > 0 ? hmax/m : hmax
// ([hmin, hmax] from the RangeQuery over T's uv box, snapped: invariant 2). The exact
// prism is G(T × [a, b]): flat caps pi + a·ni, pi + b·ni and three bilinear side walls
// (the ruled surfaces G(edge, [a,b])). Each wall is computed from its edge's endpoints
// in a canonical order (lexicographic in position, then normal), so the two triangles
// sharing an edge (same positions and normals) get bit-identical wall equations.
//
// Why the traversal uses a slightly *inflated* prism. The micro-triangles are flat;
// their vertices lie in the exact prism, but where the normals vary a flat triangle
// between three points of the curved shell bulges out of the bilinear walls and caps by
// up to ~(normal variation per texel)·(height variation per texel). For the same reason
// the projection (along the displacement lines) of a point of a cell's micro-triangle
// lies up to ε outside that cell. analyzeShell() bounds both effects rigorously: with
// b̄, σ̄ the convex combination of a micro-triangle's vertices in prism coordinates, a
// point of the triangle is G(b̄, σ̄) + w, |w| ≤ Δσ·|F·Δb| with Δb within one cell and
// within T (+ float error), and its
// preimage moves by J(b̄, s)⁻¹ w (exactly, G being bilinear in (b, s)). |J⁻¹| is bounded
// from below on det J over T_δ × [s0, s1]: det J is affine in b (extremes at the
// vertices) and quadratic in s (closed-form minimum). The traversal then clips rays to
// G(T_δ × [a − Δs, b + Δs]) and dilates every uv rectangle by ε.
//
// When det J may vanish near the prism (folded shells, normals converging within the
// displacement range), the bounds do not exist: the triangle is marked ill-posed and the
// traversal uses projection-free box subdivision for it (slower, still exact).
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "core/triangle.h"
#include "core/kernels/prism.h"
#include "core/kernels/rect_bounds.h"
#include "traversal/psi.h"

namespace oblong {

struct BoxD {
  dvec3 lo{std::numeric_limits<double>::infinity()};
  dvec3 hi{-std::numeric_limits<double>::infinity()};
  bool isEmpty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void pad(double e) {
    lo -= dvec3(e);
    hi += dvec3(e);
  }
  BoxD intersect(const BoxD& o) const { return {glm::max(lo, o.lo), glm::min(hi, o.hi)}; }
  // Slab test in double: [t0, t1] ∩ [lo, hi] (t0 > t1 when missed); core/kernels/rect_bounds.h.
  void clip(const dvec3& O, const dvec3& invD, double& t0, double& t1) const {
    shared::clipBox(lo, hi, O, invD, t0, t1);
  }
  AABB toFloatOutward() const;  // rounded outward to float
};

// Per-triangle constants (computed once when the intersector is built).
struct PrismParams {
  bool valid = false;      // T could be prepared (else it is skipped)
  bool wellPosed = false;  // the projection bounds below exist (else box-only traversal)
  float hmin = 0, hmax = 0;  // heights over T's uv box (RangeQuery, snapped)
  double a = 0, b = 0;       // s-range of the exact prism
  double inflateB = 0;       // δ: barycentric inflation of the traversal prism (T_δ)
  double inflateS = 0;       // Δs: s inflation of the traversal prism
  dvec2 eps{0.0};            // ε (samples): cell dilation for the projection of micro-triangles
  dvec2 kb{0.0};             // |Δu| ≤ kb.x |r|, |Δv| ≤ kb.y |r| for a residual r of G (domain below)
  double ks = 0;             // |Δs| ≤ ks |r|
  dvec2 kxy{0.0};            // |ΔX| ≤ kxy.x |r|, |ΔY| ≤ kxy.y |r| (local sample coordinates)
  double domainB = 0;        // the bounds above hold for b ∈ T_domainB ...
  double domainS0 = 0, domainS1 = 0;  // ... and s ∈ [domainS0, domainS1]
  double vertexErr = 0;      // float micro-vertices lie within this of the exact Eq.-1 points
  AABB bounds;               // world AABB of the exact prism (padded by vertexErr, outward)
};

// maxCellDelta: the largest (max − min) of the four corner texels of any grid cell of
// the map (raw units): how much the micro-geometry's height varies within one cell.
float maxCellDelta(const HeightMap& m);
// The same over the cells [i0, i1) of row j (sample rows j and j+1, columns wrapped).
float cellRowDelta(const HeightMap& m, int j, int i0, int i1);

PrismParams analyzeShell(const DisplacedTriangle& T, const Displacement& d, const Interval& heights,
                         float maxCellDelta);

// A prism G(T' × [a, b]) of a triangle T' given in T's barycentrics (T itself, or T_δ).
class Prism {
 public:
  using Crossing = shared::Crossing;  // t, T's barycentrics (u, v), prism coordinate s

  // The exact prism (shared walls) and the traversal's inflated one.
  static Prism exact(const DisplacedTriangle& T, double a, double b);
  static Prism inflated(const LocalFrame& F, double a, double b, double delta);

  const dvec3& base(int k) const { return p_.q[k]; }
  const dvec3& dir(int k) const { return p_.n[k]; }
  dvec3 vertex(int k, bool top) const { return p_.q[k] + (top ? p_.b : p_.a) * p_.n[k]; }
  BoxD bounds() const;

  // How far the base triangle is grown beyond T, in barycentrics (Prism::inflated's delta).
  double growth() const { return shared::prismGrowth(p_); }
  // The shape the kernels take (core/kernels/prism.h).
  const shared::PrismShape& shape() const { return p_; }
  // Every crossing of the line O + tD with the prism's boundary (core/kernels/prism.h).
  int crossings(const dvec3& O, const dvec3& D, Crossing& first, Crossing& last) const {
    return shared::prismCrossings(p_, O, D, first, last);
  }

 private:
  shared::PrismShape p_{};
};

}  // namespace oblong
