// The ray's curve in texture space (RMIP paper §4.2, Eq. 3-4).
//
// Everything here works in *local sample coordinates* (X, Y): the sample coordinates of
// docs/design.md §1 (s = tiling ⊙ uv ⊙ (W,H) − ½, texel centres at integers, grid cells
// [i,i+1]×[j,j+1]) minus an integer origin near T. Cells keep integer bounds and the
// numbers stay small whatever the tiling. Barycentrics b = (1−u−v, u, v), texture
// coordinates, P and N are all affine in (X, Y) (LocalFrame), so
//
//     ψ(X,Y) = det(P(X,Y) − O, N(X,Y), D)
//
// is a quadratic in (X, Y); its zero set (a conic) is the projection of the whole ray
// line along the displacement directions. ψ_X = 0 and ψ_Y = 0 are lines; where the
// conic meets them the curve's Y (resp. X) is stationary: the turning points. Between
// consecutive turning points the curve is monotone in X and Y, so the rectangle spanned
// by a piece's endpoints bounds it (Patterson et al. 1991).
//
// All in double: this is per ray and per prism, not per step.
#pragma once

#include "core/heightmap.h"
#include "core/math.h"
#include "core/triangle.h"
#include "core/kernels/patch_math.h"

#include <cmath>

namespace oblong {

// Affine maps of one base triangle over local sample coordinates.
struct LocalFrame {
  ivec2 origin{0};  // absolute sample index of local (0, 0)
  dvec2 perUV{1.0};  // samples per uv unit: (W tx, H ty)
  // Barycentrics (u, v) = bc + bX X + bY Y.
  dvec2 bc{0.0}, bX{0.0}, bY{0.0};
  // Local sample coordinates of barycentrics: (X, Y) = sc + sU u + sV v.
  dvec2 sc{0.0}, sU{0.0}, sV{0.0};
  // World quantities: P = p0 + e1 u + e2 v, N = n0 + f1 u + f2 v (N not normalised).
  dvec3 p0{0.0}, e1{0.0}, e2{0.0}, n0{0.0}, f1{0.0}, f2{0.0};
  // The same over (X, Y): P = Pc + PX X + PY Y, N = Nc + NX X + NY Y.
  dvec3 Pc{0.0}, PX{0.0}, PY{0.0}, Nc{0.0}, NX{0.0}, NY{0.0};

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

  dvec2 bary(const dvec2& p) const { return bc + bX * p.x + bY * p.y; }
  dvec2 local(const dvec2& b) const { return sc + sU * b.x + sV * b.y; }
  dvec3 P(const dvec2& b) const { return p0 + e1 * b.x + e2 * b.y; }
  dvec3 N(const dvec2& b) const { return n0 + f1 * b.x + f2 * b.y; }
  // G(b, s) = P(b) + s N(b): the displaced point with s = h / |N(b)| (prism coordinates).
  dvec3 G(const dvec2& b, double s) const { return P(b) + s * N(b); }
};

// ψ over local sample coordinates: c0 + cX X + cY Y + cXX X² + cXY XY + cYY Y².
struct Psi {
  double c0 = 0, cX = 0, cY = 0, cXX = 0, cXY = 0, cYY = 0;

  static Psi make(const LocalFrame& F, const dvec3& O, const dvec3& D) {
    // D · (A × N) with A = P − O affine, N affine.
    const dvec3 A0 = F.Pc - O;
    Psi p;
    p.c0 = glm::dot(D, glm::cross(A0, F.Nc));
    p.cX = glm::dot(D, glm::cross(A0, F.NX) + glm::cross(F.PX, F.Nc));
    p.cY = glm::dot(D, glm::cross(A0, F.NY) + glm::cross(F.PY, F.Nc));
    p.cXX = glm::dot(D, glm::cross(F.PX, F.NX));
    p.cYY = glm::dot(D, glm::cross(F.PY, F.NY));
    p.cXY = glm::dot(D, glm::cross(F.PX, F.NY) + glm::cross(F.PY, F.NX));
    return p;
  }

  double eval(const dvec2& p) const {
    return c0 + p.x * (cX + cXX * p.x + cXY * p.y) + p.y * (cY + cYY * p.y);
  }
  dvec2 grad(const dvec2& p) const { return {cX + 2 * cXX * p.x + cXY * p.y, cY + cXY * p.x + 2 * cYY * p.y}; }

  // ψ on the line {axis = c} as a quadratic q2 w² + q1 w + q0 in the other coordinate w.
  void onLine(int axis, double c, double& q2, double& q1, double& q0) const {
    if (axis == 0) {
      q2 = cYY, q1 = cY + cXY * c, q0 = c0 + c * (cX + cXX * c);
    } else {
      q2 = cXX, q1 = cX + cXY * c, q0 = c0 + c * (cY + cYY * c);
    }
  }
};

// quadraticRoots(q2, q1, q0, w, pad): real roots of q2 w² + q1 w + q0 with their error
// bounds, shared with the shaders (patch_math.h).
using shared::quadraticRoots;

// Points of the conic ψ = 0 on the lines ψ_X = 0 and ψ_Y = 0 (turning-point candidates
// of the ray's curve; other branches of the conic also show up). Returns the count (≤ 4).
inline int turningPoints(const Psi& p, dvec2 out[4]) {
  int n = 0;
  // Line a X + b Y + c = 0: ψ_X = 0 is (2cXX, cXY, cX); ψ_Y = 0 is (cXY, 2cYY, cY).
  const double lines[2][3] = {{2 * p.cXX, p.cXY, p.cX}, {p.cXY, 2 * p.cYY, p.cY}};
  for (const auto& L : lines) {
    const double a = L[0], b = L[1], c = L[2];
    const double nn = a * a + b * b;
    if (!(nn > 0)) continue;  // ψ_X (or ψ_Y) constant: no turning point of that kind
    const dvec2 Q = -c / nn * dvec2(a, b);
    const dvec2 R = dvec2(-b, a) / std::sqrt(nn);
    // ψ(Q + τ R) = ψ(Q) + τ ∇ψ(Q)·R + τ² Rᵀ H R / 2, H = [[2cXX, cXY], [cXY, 2cYY]].
    const double q0 = p.eval(Q);
    const double q1 = glm::dot(p.grad(Q), R);
    const double q2 = p.cXX * R.x * R.x + p.cXY * R.x * R.y + p.cYY * R.y * R.y;
    double tau[2], pad[2];
    const int m = quadraticRoots(q2, q1, q0, tau, pad);
    for (int k = 0; k < m; ++k) out[n++] = Q + tau[k] * R;
  }
  return n;
}

// The ray parameter t and prism coordinate s where the displacement line through the
// local point p comes closest to the ray (they meet when ψ(p) = 0): least squares on
// O + tD = P(p) + s N(p). False when the two lines are parallel (ray along N).
inline bool rayParamAt(const LocalFrame& F, const dvec3& O, const dvec3& D, const dvec2& p, double& t, double& s) {
  const dvec2 b = F.bary(p);
  const dvec3 A = F.P(b) - O, N = F.N(b);
  const double dd = glm::dot(D, D), nn = glm::dot(N, N), dn = glm::dot(D, N);
  const double den = dd * nn - dn * dn;
  if (!(den > 1e-24 * dd * nn)) return false;
  const double da = glm::dot(D, A), na = glm::dot(N, A);
  // minimise |tD − sN − A|²: [dd, −dn; −dn, nn] [t; s] = [da; −na]
  t = (nn * da - dn * na) / den;
  s = (dn * da - dd * na) / den;
  return std::isfinite(t) && std::isfinite(s);
}

// The initial split (paper Alg. 1 line 5): ray parameters in (tIn, tOut) where the
// curve may turn, sorted. The caller finds the curve's point at each (by inversion) and
// splits [tIn, tOut] there into pieces that are monotone in X and Y.
inline int monotoneSplits(const LocalFrame& F, const Psi& psi, const dvec3& O, const dvec3& D, double tIn,
                          double tOut, double ts[4]) {
  dvec2 cand[4];
  const int n = turningPoints(psi, cand);
  int m = 0;
  for (int k = 0; k < n; ++k) {
    double t, s;
    if (!rayParamAt(F, O, D, cand[k], t, s)) continue;
    if (t > tIn && t < tOut) ts[m++] = t;
  }
  for (int i = 1; i < m; ++i)  // insertion sort (m <= 4)
    for (int j = i; j > 0 && ts[j] < ts[j - 1]; --j) std::swap(ts[j], ts[j - 1]);
  int u = 0;
  for (int i = 0; i < m; ++i)
    if (u == 0 || ts[i] != ts[u - 1]) ts[u++] = ts[i];
  return u;
}

// Approximate direction of a ray's texture-space curve in local sample coordinates
// (ordering only: front-to-back order in the traversal, child order in tfdm): the ray
// direction solved in the frame (PX, PY, N) at T's centroid.
inline dvec2 approxDirLocal(const LocalFrame& F, const dvec3& dir) {
  const dvec3 N = F.N(dvec2(1.0 / 3.0));
  const double det = glm::dot(F.PX, glm::cross(F.PY, N));
  if (!(std::abs(det) > 0)) return dvec2(1.0);
  return {glm::dot(dir, glm::cross(F.PY, N)) / det, glm::dot(F.PX, glm::cross(dir, N)) / det};
}

}  // namespace oblong
