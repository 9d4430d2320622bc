// The ray's curve in texture space (RMIP paper §4.2, Eq. 3-4): the per-patch math is in
// core/kernels/patch_math.h, written once for the CPU and the Vulkan shaders (it says
// what local sample coordinates, ψ and the turning points are). Here: the frame's
// construction from a triangle and a displacement (host only), and C++ spellings of the
// shared functions.
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "core/triangle.h"
#include "core/kernels/patch_math.h"

#include <cmath>

namespace oblong {

// Affine maps of one base triangle over local sample coordinates (shared::PatchFrame),
// plus where local (0, 0) lies.
struct LocalFrame : shared::PatchFrame {
  ivec2 origin{0};  // absolute sample index of local (0, 0)
  dvec2 perUV{1.0};  // samples per uv unit: (W tx, H ty)

  static LocalFrame make(const DisplacedTriangle& T, const Displacement& d) {
    LocalFrame F;
    F.perUV = dvec2(double(d.map->width()) * d.tiling.x, double(d.map->height()) * d.tiling.y);
    const dvec2 s0 = d.toSample(T.uvBox.lo);
    const double lim = 1e9;  // keeps int conversion defined for absurd tilings
    F.origin = ivec2(int(std::clamp(std::floor(s0.x), -lim, lim)), int(std::clamp(std::floor(s0.y), -lim, lim)));
    const dvec2 t0(T.t[0]), t1(T.t[1]), t2(T.t[2]);
    const dvec2 du = t1 - t0, dv = t2 - t0;
    // (X,Y) of barycentrics.
    F.sc = t0 * F.perUV - d.sampleOffset - dvec2(F.origin);
    F.sU = du * F.perUV;
    F.sV = dv * F.perUV;
    // Inverse, in double (not T.uvToBary, which is float).
    const double det = F.sU.x * F.sV.y - F.sU.y * F.sV.x;
    const double id = det != 0.0 ? 1.0 / det : 0.0;
    // [sU sV]^{-1} = id * [[sV.y, -sV.x], [-sU.y, sU.x]] (rows)
    F.bX = dvec2(F.sV.y * id, -F.sU.y * id);
    F.bY = dvec2(-F.sV.x * id, F.sU.x * id);
    F.bc = -(F.bX * F.sc.x + F.bY * F.sc.y);
    F.p0 = dvec3(T.p[0]);
    F.e1 = dvec3(T.p[1]) - F.p0;
    F.e2 = dvec3(T.p[2]) - F.p0;
    F.n0 = dvec3(T.n[0]);
    F.f1 = dvec3(T.n[1]) - F.n0;
    F.f2 = dvec3(T.n[2]) - F.n0;
    F.Pc = F.p0 + F.e1 * F.bc.x + F.e2 * F.bc.y;
    F.PX = F.e1 * F.bX.x + F.e2 * F.bX.y;
    F.PY = F.e1 * F.bY.x + F.e2 * F.bY.y;
    F.Nc = F.n0 + F.f1 * F.bc.x + F.f2 * F.bc.y;
    F.NX = F.f1 * F.bX.x + F.f2 * F.bX.y;
    F.NY = F.f1 * F.bY.x + F.f2 * F.bY.y;
    return F;
  }

  dvec2 bary(const dvec2& p) const { return shared::frameBary(*this, p); }
  dvec2 local(const dvec2& b) const { return shared::frameLocal(*this, b); }
  dvec3 P(const dvec2& b) const { return shared::frameP(*this, b); }
  dvec3 N(const dvec2& b) const { return shared::frameN(*this, b); }
  // G(b, s) = P(b) + s N(b): the displaced point with s = h / |N(b)| (prism coordinates).
  dvec3 G(const dvec2& b, double s) const { return P(b) + s * N(b); }
};

// ψ over local sample coordinates (shared::Psi).
struct Psi : shared::Psi {
  static Psi make(const LocalFrame& F, const dvec3& O, const dvec3& D) {
    Psi p;
    static_cast<shared::Psi&>(p) = shared::psiMake(F, O, D);
    return p;
  }
  double eval(const dvec2& p) const { return shared::psiEval(*this, p); }
  dvec2 grad(const dvec2& p) const { return shared::psiGrad(*this, p); }
  void onLine(int axis, double c, double& q2, double& q1, double& q0) const {
    shared::psiOnLine(*this, axis, c, q2, q1, q0);
  }
};

using shared::monotoneSplits;
using shared::quadraticRoots;
using shared::rayParamAt;

inline dvec2 approxDirLocal(const LocalFrame& F, const dvec3& dir) {
  return shared::approxDirLocal(F, F.N(dvec2(1.0 / 3.0)), dir);
}

}  // namespace oblong
