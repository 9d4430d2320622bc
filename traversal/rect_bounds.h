// Conservative world box of the micro-geometry over a uv rectangle (docs/design.md invariant 2;
// RMIP Alg. 1 line 12, "surface bounds(triangle, bound, rmip)").
//
// The caller passes the rectangle already snapped outward to whole grid cells (the
// micro-triangles touching a rectangle reach one texel beyond it) and clipped to T's uv
// box (every micro-vertex is a point of S inside T), in local sample coordinates, and
// the RangeQuery's heights [hlo, hhi] over those cells. Every micro-vertex is then
//     P(x) + h·N(x)/|N(x)| = P(x) + (h/|N(x)|)·N(x),   x in the rectangle, h in [hlo, hhi],
// and is bounded with interval arithmetic: P and N are affine in x (their ranges over
// the rectangle are exact), |N| over T lies in [max(m, dist(0, box of N)), min(1, max
// corner)], so k = h/|N| lies in an interval, and k·N is an interval product. The four
// corners alone are NOT enough (normalised normals bulge). Micro-triangles are convex
// hulls of their vertices, so the box holds them too.
//
// Precision: computed in double and padded explicitly by `pad` (the float error of the
// micro-vertices, PrismParams::vertexErr, plus the ray test's own rounding); the box is
// never converted to float (the ray/box test runs in double).
#pragma once

#include "traversal/prism.h"
#include "traversal/psi.h"

namespace oblong {

// Frame: a LocalFrame, or anything with its P and N members (Pc, PX, PY, Nc, NX, NY)
// expressed in another orthonormal basis (tfdm's texture frame).
template <typename Frame>
inline BoxD boxOverRect(const Frame& F, double m, const dvec2& lo, const dvec2& hi, double hlo, double hhi,
                        double pad) {
  BoxD box;
  dvec3 Nlo, Nhi;
  for (int k = 0; k < 3; ++k) {
    const double px0 = F.PX[k] * lo.x, px1 = F.PX[k] * hi.x, py0 = F.PY[k] * lo.y, py1 = F.PY[k] * hi.y;
    box.lo[k] = F.Pc[k] + std::min(px0, px1) + std::min(py0, py1);
    box.hi[k] = F.Pc[k] + std::max(px0, px1) + std::max(py0, py1);
    const double nx0 = F.NX[k] * lo.x, nx1 = F.NX[k] * hi.x, ny0 = F.NY[k] * lo.y, ny1 = F.NY[k] * hi.y;
    Nlo[k] = F.Nc[k] + std::min(nx0, nx1) + std::min(ny0, ny1);
    Nhi[k] = F.Nc[k] + std::max(nx0, nx1) + std::max(ny0, ny1);
  }
  // |N| bounds over (rectangle ∩ T).
  double d2 = 0, c2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double g = std::max({0.0, Nlo[k], -Nhi[k]});
    d2 += g * g;
    const double c = std::max(std::abs(Nlo[k]), std::abs(Nhi[k]));
    c2 += c * c;
  }
  const double nMin = std::max(m, std::sqrt(d2)) * (1 - 1e-12);
  const double nMax = std::min(1.0, std::sqrt(c2)) * (1 + 1e-12);
  // k = h/|N|, |N| in [nMin, nMax] (positive).
  const double klo = hlo < 0 ? hlo / nMin : hlo / nMax;
  const double khi = hhi > 0 ? hhi / nMin : hhi / nMax;
  for (int k = 0; k < 3; ++k) {
    const double a = klo * Nlo[k], b = klo * Nhi[k], c = khi * Nlo[k], d = khi * Nhi[k];
    box.lo[k] += std::min({a, b, c, d});
    box.hi[k] += std::max({a, b, c, d});
  }
  const double mag = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                               std::abs(box.hi.y), std::abs(box.hi.z)});
  box.pad(pad + 1e-14 * mag);  // plus double rounding of the above
  return box;
}

}  // namespace oblong
