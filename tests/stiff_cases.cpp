#include "tests/stiff_cases.h"

#include "core/mesh.h"
#include "inversion/cubic.h"

#include <random>
#include <stdexcept>

namespace oblong::test {

namespace {

DisplacedTriangle makeTri(vec3 p0, vec3 p1, vec3 p2, vec3 n0, vec3 n1, vec3 n2,
                          vec2 t0 = {0, 0}, vec2 t1 = {1, 0}, vec2 t2 = {0, 1}) {
  DisplacedTriangle T;
  T.p[0] = p0, T.p[1] = p1, T.p[2] = p2;
  T.n[0] = glm::normalize(n0), T.n[1] = glm::normalize(n1), T.n[2] = glm::normalize(n2);
  T.t[0] = t0, T.t[1] = t1, T.t[2] = t2;
  if (!T.prepare()) throw std::logic_error("stiff case triangle cannot be prepared");
  return T;
}

// Unit vector tilted by `deg` degrees from +z towards direction `dir` (in the xy plane).
vec3 tilt(vec2 dir, double deg) {
  const double a = deg * 3.14159265358979323846 / 180.0;
  const dvec2 d = glm::normalize(dvec2(dir));
  return vec3(dvec3(std::sin(a) * d.x, std::sin(a) * d.y, std::cos(a)));
}

const vec3 kP0{0, 0, 0}, kP1{1, 0, 0}, kP2{0.3f, 0.9f, 0};
const vec2 kCentroid{(0 + 1 + 0.3f) / 3, 0.3f};

// The regular triangle with normals tilted radially from its centroid by `deg`
// (negative: towards it), like a smooth convex (concave) mesh.
DisplacedTriangle radial(double deg, vec3 offset = vec3(0.0f)) {
  const vec3 p[3] = {kP0, kP1, kP2};
  vec3 n[3];
  for (int i = 0; i < 3; ++i) n[i] = tilt(vec2(p[i]) - kCentroid, deg);
  return makeTri(p[0] + offset, p[1] + offset, p[2] + offset, n[0], n[1], n[2]);
}

// A triangle of size ~1 cut from a sphere of radius R (exact sphere normals).
DisplacedTriangle sphereCap(double R) {
  const dvec3 c(0.0, 0.0, -R);
  dvec3 d[3];
  const dvec3 q[3] = {dvec3(kP0), dvec3(kP1), dvec3(kP2)};
  for (int i = 0; i < 3; ++i) d[i] = glm::normalize(q[i] - c);
  return makeTri(vec3(c + R * d[0]), vec3(c + R * d[1]), vec3(c + R * d[2]), vec3(d[0]), vec3(d[1]),
                 vec3(d[2]));
}

std::vector<StiffCase> build() {
  std::vector<StiffCase> v;
  auto add = [&](std::string name, std::string what, DisplacedTriangle T, double hmin, double hmax,
                 unsigned mix = kAll, std::string issue = "") {
    v.push_back({std::move(name), std::move(what), T, hmin, hmax, mix, std::move(issue)});
  };
  add("regular", "well-shaped triangle, normals 15° from the face, h in ±0.2 (baseline)", radial(15), -0.2,
      0.2);
  add("prism_corners_edges", "points exactly on the prism's 6 corners, 9 edges and 3 side walls",
      radial(15), -0.2, 0.2, kBoundary);
  add("h_extremes", "points on the caps s = a, s = b and at h = hmin, hmax; heights -0.5..1",
      radial(15), -0.5, 1.0, kExtremes);
  {
    const vec3 p2{0.5f, 1e-4f, 0};
    add("sliver_1e4", "aspect ratio 1e4 (1 x 1e-4), normals spread 20° along the long edge",
        makeTri(kP0, kP1, p2, tilt({-1, 0}, 10), tilt({1, 0}, 10), tilt({0, 1}, 0)), -0.01, 0.01);
    add("sliver_1e4_twisted", "the sliver with normals also tilting 5° across it; h = ±100 widths",
        makeTri(kP0, kP1, p2, tilt({-1, -0.5f}, 10), tilt({1, -0.5f}, 10), tilt({0, 1}, 5)), -0.01, 0.01);
  }
  {
    DisplacedTriangle T = radial(15);
    T.t[0] = {0, 0}, T.t[1] = {1, 0}, T.t[2] = {0.5f, 1e-6f};
    T.prepare();
    add("uv_near_degenerate", "uv triangle of doubled area 1e-6 (almost a segment in texture space)", T,
        -0.2, 0.2);
  }
  add("normals_near_tangent", "vertex normals 88°, 89°, 89.5° from the face normal (azimuths 0, 20, 40°)",
      makeTri(kP0, kP1, kP2, tilt({1, 0}, 88), tilt({std::cos(0.349f), std::sin(0.349f)}, 89),
              tilt({std::cos(0.698f), std::sin(0.698f)}, 89.5)),
      -0.05, 0.05);
  add("normals_diverging_100deg", "normals tilted 50° outward (spread 100°), h -0.1..0.5", radial(50), -0.1,
      0.5);
  add("normals_converging_100deg", "normals tilted 50° inward (spread 100°), h -0.1..0.3", radial(-50),
      -0.1, 0.3, kAll,
      "inward normals cross above the triangle at s ~ 0.3-0.6 (edge-dependent): where the cap passes "
      "the focus the offset triangle is degenerate and nearby points are ill-conditioned");
  {
    const vec3 z{0, 0, 1};
    add("parallel_normals", "flat shading: n_i = face normal (the cubic is linear)",
        makeTri(kP0, kP1, kP2, z, z, z), -0.3, 0.3);
    const vec3 t = tilt({1, 1}, 60);
    add("parallel_normals_tilted", "all normals equal, 60° from the face normal (linear, sheared prism)",
        makeTri(kP0, kP1, kP2, t, t, t), -0.3, 0.3);
    add("coplanar_normals", "cylinder-like: n0 = n1, normals coplanar (the cubic is quadratic)",
        makeTri(kP0, kP1, kP2, tilt({0, -1}, 20), tilt({0, -1}, 20), tilt({0, 1}, 20)), -0.3, 0.3);
  }
  add("displacement_100x", "h in ±100 on a triangle of size 1 (sphere-like normals, R = 200)",
      sphereCap(200), -100, 100);
  add("displacement_100x_focal", "h in ±100, sphere-like normals with R = 50: the prism passes the focus",
      sphereCap(50), -100, 100, kAll,
      "at s = -R the whole offset triangle collapses to the sphere's centre: F is singular there and "
      "points within ~1e-3 of it cannot be resolved in uv (any uv maps nearby)");
  add("translated_1e4", "the regular case translated by (1e4, -1e4, 1e4)", radial(15, vec3(1e4f, -1e4f, 1e4f)),
      -0.2, 0.2, kAll,
      "float API: X rounded to float (ulp 1e-3 at 1e4) already moves it by ~1e-3 triangle sizes");
  add("translated_1e6", "the regular case translated by (1e6, 1e6, -1e6)", radial(15, vec3(1e6f, 1e6f, -1e6f)),
      -0.2, 0.2, kAll,
      "float API: X rounded to float (ulp 0.0625 at 1e6) moves it by ~0.06 triangle sizes; the answer "
      "is that of the rounded point, and points near the prism walls invert outside T");
  return v;
}

}  // namespace

double StiffCase::capLo() const { return hmin < 0 ? hmin / tri.minNormalLength : hmin; }
double StiffCase::capHi() const { return hmax > 0 ? hmax / tri.minNormalLength : hmax; }

std::vector<InversionSample> StiffCase::samples(int nInterior, uint32_t seed) const {
  return prismSamples(tri, hmin, hmax, mix, (mix & kInterior) ? nInterior : 0, seed);
}

const std::vector<StiffCase>& stiffCatalogue() {
  static const std::vector<StiffCase> c = build();
  return c;
}

const StiffCase& stiffCase(std::string_view name) {
  for (const StiffCase& c : stiffCatalogue())
    if (c.name == name) return c;
  throw std::out_of_range("unknown stiff case " + std::string(name));
}

double longestEdge(const DisplacedTriangle& T) { return inv::Frame<double>(T).L; }

int preimageCount(const dvec3& X, const DisplacedTriangle& T, double a, double b, double eps) {
  const inv::Frame<double> F(T);
  const dvec3 W = X - dvec3(T.p[0]);
  const double iL = 1.0 / F.L;
  const dvec3 e1 = F.e1 * iL, e2 = F.e2 * iL, w = W * iL;
  using inv::det3;
  const double a0 = det3(e1, e2, w);
  const double a1 = det3(F.f1, e2, w) + det3(e1, F.f2, w) - det3(e1, e2, F.n0);
  const double a2 = det3(F.f1, F.f2, w) - det3(F.f1, e2, F.n0) - det3(e1, F.f2, F.n0);
  const double a3 = -det3(F.f1, F.f2, F.n0);
  double r[3];
  int degree;
  const int n = inv::polyRoots(a0, a1, a2, a3, r, degree);
  int count = 0;
  double found[3];
  for (int i = 0; i < n; ++i) {
    const double sg = r[i], s = sg * F.L;
    if (s < a - 1e-9 * F.L || s > b + 1e-9 * F.L) continue;
    // Verify it is a real root (the Cardano candidate for a split double root may not be).
    const double f = ((a3 * sg + a2) * sg + a1) * sg + a0;
    if (std::abs(f) > 1e-9 * std::max({std::abs(a0), std::abs(a1), std::abs(a2), std::abs(a3)})) continue;
    const dvec3 A = e1 + sg * F.f1, B = e2 + sg * F.f2, R = w - sg * F.n0;
    const dvec3 nS = glm::cross(A, B);
    const double d = glm::dot(nS, nS);
    if (!(d > 0)) continue;
    const double u = glm::dot(glm::cross(R, B), nS) / d, v = glm::dot(glm::cross(A, R), nS) / d;
    if (u < -eps || v < -eps || u + v > 1 + eps) continue;
    bool dup = false;
    for (int k = 0; k < count; ++k) dup |= std::abs(found[k] - sg) < 1e-7;
    if (!dup) found[count++] = sg;
  }
  return count;
}

std::vector<InversionSample> prismSamples(const DisplacedTriangle& T, double hmin, double hmax, unsigned mix,
                                          int nInterior, uint32_t seed) {
  constexpr double kHuge = 1e300;
  const double m = T.minNormalLength;
  const double a = hmin < 0 ? hmin / m : hmin, b = hmax > 0 ? hmax / m : hmax;
  const dvec3 p[3] = {dvec3(T.p[0]), dvec3(T.p[1]), dvec3(T.p[2])};
  const dvec3 n[3] = {dvec3(T.n[0]), dvec3(T.n[1]), dvec3(T.n[2])};
  std::vector<InversionSample> out;
  auto push = [&](double u, double v, double s) {
    InversionSample x;
    const double w = 1 - u - v;
    const dvec3 P = w * p[0] + u * p[1] + v * p[2], N = w * n[0] + u * n[1] + v * n[2];
    x.X = P + s * N;
    x.u = u, x.v = v, x.s = s, x.h = s * glm::length(N);
    // Ill-posed: the offset triangle through X (nearly) collapses: det J, J = [P_u + s N_u,
    // P_v + s N_v, N], below 1e-3 of its value at s = 0 (the base triangle), so a whole
    // segment of uvs maps to (nearly) X.
    const dvec3 Ja = p[1] - p[0] + s * (n[1] - n[0]), Jb = p[2] - p[0] + s * (n[2] - n[0]);
    const double det0 = glm::dot(glm::cross(p[1] - p[0], p[2] - p[0]), N);
    const double relDet = std::abs(glm::dot(glm::cross(Ja, Jb), N) / det0);
    x.ambiguous = relDet < 1e-3 || preimageCount(x.X, T, -kHuge, kHuge) > 1;
    out.push_back(x);
  };
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  auto randomBary = [&](double& u, double& v) {
    u = U(rng), v = U(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;
  };
  if (mix & kInterior)
    for (int i = 0; i < nInterior; ++i) {
      double u, v;
      randomBary(u, v);
      push(u, v, a + (b - a) * U(rng));
    }
  if (mix & kBoundary) {
    const double vu[3] = {0, 1, 0}, vv[3] = {0, 0, 1};
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3;
      push(vu[i], vv[i], a);  // corners
      push(vu[i], vv[i], b);
      for (int k = 1; k <= 5; ++k) {
        const double t = k / 6.0;
        push(vu[i], vv[i], a + (b - a) * t);  // vertical edge
        const double eu = vu[i] + t * (vu[j] - vu[i]), ev = vv[i] + t * (vv[j] - vv[i]);
        push(eu, ev, a);  // cap edges
        push(eu, ev, b);
      }
      for (int k = 0; k < 4; ++k) {  // side wall
        const double t = U(rng);
        push(vu[i] + t * (vu[j] - vu[i]), vv[i] + t * (vv[j] - vv[i]), a + (b - a) * U(rng));
      }
    }
  }
  if (mix & kExtremes)
    for (int i = 0; i < 20; ++i) {
      double u, v;
      randomBary(u, v);
      const double len = glm::length((1 - u - v) * n[0] + u * n[1] + v * n[2]);
      push(u, v, a);
      push(u, v, b);
      push(u, v, hmin / len);
      push(u, v, hmax / len);
    }
  return out;
}

double inversionError(const InversionResultD& r, double u, double v, double h, double L) {
  return std::max({std::abs(r.bary.x - u), std::abs(r.bary.y - v), std::abs(r.h - h) / std::max(L, std::abs(h))});
}

void accumulate(Evaluation& into, const Evaluation& e) {
  const double it = into.meanIterations * into.n + e.meanIterations * e.n;
  into.n += e.n;
  into.converged += e.converged;
  into.meanIterations = into.n ? it / into.n : 0;
  into.maxIterations = std::max(into.maxIterations, e.maxIterations);
  into.maxErrRef = std::max(into.maxErrRef, e.maxErrRef);
  into.refCompared += e.refCompared;
  into.maxErrTruth = std::max(into.maxErrTruth, e.maxErrTruth);
  into.maxOutside = std::max(into.maxOutside, e.maxOutside);
  into.ambiguous += e.ambiguous;
  into.failures += e.failures;
  into.ambiguousFailures += e.ambiguousFailures;
}

std::vector<StiffCase> meshCases(const std::string& path, const std::string& prefix, double relHeight) {
  const Mesh mesh = loadMesh(path);
  std::vector<StiffCase> out;
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    DisplacedTriangle T = mesh.triangle(i);
    // Meshes without uvs still invert (uvs only enter through T.UV): give them a uv map.
    if (!mesh.hasUVs()) T.t[0] = {0, 0}, T.t[1] = {1, 0}, T.t[2] = {0, 1};
    if (!T.prepare()) continue;
    const double L = longestEdge(T);
    out.push_back({prefix + "#" + std::to_string(i), "mesh triangle", T, -relHeight * L, relHeight * L, kAll, ""});
  }
  return out;
}

std::vector<StiffCase> randomCases(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  std::vector<StiffCase> out;
  while (int(out.size()) < n) {
    DisplacedTriangle T;
    for (int k = 0; k < 3; ++k) T.p[k] = {U(rng), U(rng), U(rng)};
    const vec3 c = glm::cross(T.p[1] - T.p[0], T.p[2] - T.p[0]);
    if (glm::length(c) < 0.05f) continue;
    const vec3 fn = glm::normalize(c);
    for (int k = 0; k < 3; ++k) {
      vec3 d{U(rng), U(rng), U(rng)};
      d -= glm::dot(d, fn) * fn;  // tangent direction, |d| <= sqrt(3)
      T.n[k] = glm::normalize(fn + 0.577f * d);
    }
    T.t[0] = {0, 0}, T.t[1] = {1, 0}, T.t[2] = {0, 1};
    if (!T.prepare()) continue;
    const double L = longestEdge(T);
    out.push_back({"synthetic#" + std::to_string(out.size()), "random twisted triangle", T, -0.3 * L, 0.3 * L,
                   kAll, ""});
  }
  return out;
}

EvalLimits doubleLimits() { return {1e-6, 1e-9}; }
EvalLimits floatLimits() { return {1e-3, 1e-4}; }

Evaluation evaluate(const Inverter& inv, bool floatApi, const StiffCase& c,
                    const std::vector<InversionSample>& samples, const std::vector<InversionResultD>* reference,
                    const EvalLimits& lim) {
  const DisplacedTriangle& T = c.tri;
  const double L = longestEdge(T);
  Evaluation e;
  double iterSum = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const InversionSample& x = samples[i];
    InversionResultD r;
    if (floatApi) {
      const InversionResult f = inv.invert(vec3(x.X), T);
      r = {dvec2(f.bary), dvec2(f.uv), double(f.h), f.converged, f.iterations};
    } else {
      r = inv.invertD(x.X, T);
    }
    ++e.n;
    iterSum += r.iterations;
    e.maxIterations = std::max(e.maxIterations, r.iterations);
    bool fail = !r.converged;
    if (r.converged) ++e.converged;
    const double outside = r.outside();
    if (!x.ambiguous) e.maxOutside = std::max(e.maxOutside, std::isfinite(outside) ? outside : 1e300);
    if (!(outside <= lim.outside)) fail = true;
    if (x.ambiguous) {
      ++e.ambiguous;
      // Any preimage in T is correct: check that the result reproduces X.
      const dvec3 N = (1 - r.bary.x - r.bary.y) * dvec3(T.n[0]) + r.bary.x * dvec3(T.n[1]) +
                      r.bary.y * dvec3(T.n[2]);
      const dvec3 P = (1 - r.bary.x - r.bary.y) * dvec3(T.p[0]) + r.bary.x * dvec3(T.p[1]) +
                      r.bary.y * dvec3(T.p[2]);
      const double s = r.h / glm::length(N);
      const double rec = glm::length(P + s * N - x.X) / L;
      if (!(rec <= lim.err)) fail = true;
    } else {
      const double et = inversionError(r, x.u, x.v, x.h, L);
      if (std::isfinite(et)) e.maxErrTruth = std::max(e.maxErrTruth, et);
      if (!(et <= lim.err)) fail = true;
      if (reference && (*reference)[i].converged) {
        ++e.refCompared;
        const InversionResultD& ref = (*reference)[i];
        const double er = inversionError(r, ref.bary.x, ref.bary.y, ref.h, L);
        e.maxErrRef = std::max(e.maxErrRef, std::isfinite(er) ? er : 1e300);
      }
    }
    if (fail) ++e.failures, e.ambiguousFailures += x.ambiguous;
  }
  e.meanIterations = e.n ? iterSum / e.n : 0;
  return e;
}

}  // namespace oblong::test
