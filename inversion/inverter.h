// Inverter (docs/design.md §2, invariant 3): point-wise inversion of the displaced-surface map
// of one base triangle (RMIP paper §4.1, Eq. 2). Given a 3D point X, find (u, v, h) with
//
//     X = P(u,v) + h · N(u,v) / |N(u,v)|        b = (1-u-v, u, v)
//
// All inverters solve the equivalent 3x3 system in (u, v, s)
//
//     F(u,v,s) = P(u,v) + s · N(u,v) − X = 0,   h = s · |N(u,v)|,
//
// whose solutions are exactly the points of the offset triangles p_i + s·n_i (the
// bounding prism of T for heights [hmin,hmax] is the image of T × [a,b], docs/design.md
// invariant 2). The result is the barycentric pair (u,v), the texture coordinates
// T.UV(u,v), the height h, whether the solver converged and how many iterations it took.
//
// Strategies (one name everywhere: registry key, file, test tag, stats prefix):
//   newton  inversion/newton.h  Newton on F, float or double (the RMIP choice)
//   cubic   inversion/cubic.h   analytic: X on the offset triangle ⇒ cubic in s
//   ceres   inversion/ceres.h   Ceres autodiff in double: the correctness reference
//                               (library oblong_ceres; the only code that links Ceres)
//
// Concrete strategies are `final` classes deriving from InverterImpl<Self>: invert()
// and invertD() are the virtual entry points (final, so a call through the concrete
// type is devirtualised), and Self::invertFast / invertFastD are the inline, non-virtual
// implementations a static traversal instantiation calls. A strategy registers itself
// in its .cpp: OBLONG_REGISTER_INVERTER("name", factory, StrategyTraits{...}).
//
// What "inside T" means for a result: u >= -eps, v >= -eps, u + v <= 1 + eps. For X
// inside T's prism with a single, well-posed preimage in T (docs/inversion.md: folded
// prisms and collapsing offset triangles are ambiguous), newton (with its default cubic
// fallback), cubic and ceres return a uv inside T within eps = 1e-9 in double; the float
// API adds the rounding of X (1e-5 on smooth meshes near the origin).
#pragma once

#include "core/math.h"
#include "core/registry.h"
#include "core/triangle.h"
#include "core/kernels/invert.h"  // the formulas, shared with the Vulkan shaders

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace oblong {

template <typename S>
struct InversionResultT {
  glm::vec<2, S> bary{S(0)};  // (u, v): barycentrics b = (1-u-v, u, v)
  glm::vec<2, S> uv{S(0)};    // texture coordinates T.UV(u, v)
  S h = S(0);                 // height along N/|N|
  bool converged = false;
  int iterations = 0;

  // u >= -eps, v >= -eps, u + v <= 1 + eps.
  bool insideT(S eps = S(0)) const {
    return bary.x >= -eps && bary.y >= -eps && bary.x + bary.y <= S(1) + eps;
  }
  // How far outside T in barycentric units (0 inside).
  S outside() const { return std::max({S(0), -bary.x, -bary.y, bary.x + bary.y - S(1)}); }
};
using InversionResult = InversionResultT<float>;
using InversionResultD = InversionResultT<double>;

class Inverter {
 public:
  virtual ~Inverter() = default;
  virtual std::string_view name() const = 0;
  // Float entry point (the traversal's). Arithmetic precision is the strategy's choice
  // (parameter "precision" for newton and cubic; ceres always works in double).
  virtual InversionResult invert(const vec3& X, const DisplacedTriangle& T) const = 0;
  // Double-precision entry point: X in double, all arithmetic in double.
  virtual InversionResultD invertD(const dvec3& X, const DisplacedTriangle& T) const = 0;
};

template <typename Self>
class InverterImpl : public Inverter {
 public:
  InversionResult invert(const vec3& X, const DisplacedTriangle& T) const final {
    return static_cast<const Self*>(this)->invertFast(X, T);
  }
  InversionResultD invertD(const dvec3& X, const DisplacedTriangle& T) const final {
    return static_cast<const Self*>(this)->invertFastD(X, T);
  }
};

struct InverterContext {};
using InverterRegistry = Registry<Inverter, InverterContext>;
#define OBLONG_REGISTER_INVERTER(name, ...) OBLONG_REGISTER(::oblong::InverterRegistry, name, __VA_ARGS__)

// Creates an inverter by name ("newton", "cubic", and "ceres" in programs that link
// oblong_ceres); unknown names and unused parameters throw oblong::Error naming
// params.where().
std::unique_ptr<Inverter> createInverter(const std::string& name, ParamSet& params,
                                         const InverterContext& ctx = {});
std::unique_ptr<Inverter> createInverter(const std::string& name);
std::vector<std::string> inverterNames();
const StrategyTraits& inverterTraits(const std::string& name);

// Reads the "precision" parameter: "float" (default) or "double".
bool readDoublePrecision(ParamSet& ps, std::string_view strategy);

namespace inv {

// The kernel's types (core/kernels/invert.h) for scalar S: Frame<S> is T in a local frame
// at p0 (e1, e2, n0, f1, f2 and the longest edge L), Result<S> an inversion's (u, v, h).
template <typename S>
struct Kernel;
template <>
struct Kernel<float> {
  using Frame = shared::InvFrameF;
  using Result = shared::InvResultF;
  using Cubic = shared::CubicF;
};
template <>
struct Kernel<double> {
  using Frame = shared::InvFrameD;
  using Result = shared::InvResultD;
  using Cubic = shared::CubicD;
};
template <typename S>
using Frame = typename Kernel<S>::Frame;

template <typename S>
inline Frame<S> frameOf(const DisplacedTriangle& T) {
  using V = glm::vec<3, S>;
  return shared::invFrame(V(T.p[0]), V(T.p[1]), V(T.p[2]), V(T.n[0]), V(T.n[1]), V(T.n[2]));
}

// The kernel's result with the texture coordinates T.UV(u,v) (in S).
template <typename S>
inline InversionResultT<S> toResult(const typename Kernel<S>::Result& k, const DisplacedTriangle& T) {
  InversionResultT<S> r;
  r.bary = {k.u, k.v};
  using V2 = glm::vec<2, S>;
  r.uv = (S(1) - k.u - k.v) * V2(T.t[0]) + k.u * V2(T.t[1]) + k.v * V2(T.t[2]);
  r.h = k.h;
  r.converged = k.converged;
  r.iterations = k.iterations;
  return r;
}

// Fills the result from (u,v,s): h = s·|N(u,v)|, uv = T.UV(u,v) (in S).
template <typename S>
inline InversionResultT<S> finish(const Frame<S>& F, const DisplacedTriangle& T, S u, S v, S s,
                                  bool converged, int iterations) {
  return toResult<S>(shared::invFinish(F, u, v, s, converged, iterations), T);
}

}  // namespace inv

}  // namespace oblong
