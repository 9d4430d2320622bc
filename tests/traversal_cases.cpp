// See traversal_cases.h.
#include "tests/traversal_cases.h"

#include "core/procedural.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

namespace oblong::test {

std::vector<DisplacedTriangle> trianglesOf(const Mesh& m) {
  std::vector<DisplacedTriangle> t;
  for (size_t i = 0; i < m.triangles.size(); ++i) t.push_back(m.triangle(i));
  return t;
}

Scenario tiledQuad() {  // flat, high-frequency map tiled 4x4: deep hierarchies
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(32, 32, 3));
  return {"tiled quad", trianglesOf(quadMesh(1.0f, 0.0f, 2)), Displacement{map, 0.1f, -0.5f, vec2(4.0f, 4.0f)}};
}
Scenario torus() {  // curved, odd map sizes, tiled (3,2)
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(61, 47, 9));
  return {"torus", trianglesOf(torusMesh(1.0f, 0.4f, 16, 8)), Displacement{map, 0.15f, -0.5f, vec2(3.0f, 2.0f)}};
}
Scenario coarseTorus() {  // big curved triangles, strong displacement: large bulge / ε
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(96, 48, 4));
  return {"coarse torus", trianglesOf(torusMesh(1.0f, 0.45f, 8, 6)), Displacement{map, 0.2f, -0.4f, vec2(2.0f, 1.0f)}};
}
Scenario sphere() {  // sphere-like, normals converging to the centre
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(64, 40, 11));
  return {"sphere", trianglesOf(sphereMesh(1.0f, 12, 8)), Displacement{map, 0.12f, -0.5f, vec2(4.0f, 2.0f)}};
}

Scenario twisted() {
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> W(-0.5f, 0.5f);
  Mesh m = quadMesh(1.0f, 0.0f, 3);
  for (vec3& n : m.normals) n = glm::normalize(vec3(W(rng), 1.0f, W(rng)));
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(48, 48, 7));
  return {"twisted", trianglesOf(m), Displacement{map, 0.15f, -0.5f, vec2(2.0f, 2.0f)}};
}
Scenario deepSphere() {
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(64, 32, 5));
  return {"deep sphere", trianglesOf(sphereMesh(1.0f, 10, 6)), Displacement{map, 0.6f, -1.0f, vec2(2.0f, 1.0f)}};
}
Scenario highTiling() {
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(23, 19, 8));
  return {"10x tiling", trianglesOf(quadMesh(1.0f, 0.0f, 1)), Displacement{map, 0.03f, -0.5f, vec2(10.0f, 11.0f)}};
}
Scenario farAway() {
  Mesh m = quadMesh(1.0f, 0.0f, 2);
  for (vec3& p : m.positions) p += vec3(1e4f, -3e3f, 2e4f);
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(32, 32, 6));
  return {"far from the origin", trianglesOf(m), Displacement{map, 0.1f, -0.5f, vec2(3.0f, 3.0f)}};
}

Scenario rotatedUVs() {  // mirrored, rotated, negative uvs: the grid is not aligned with T
  Mesh m = quadMesh(1.0f, 0.0f, 2);
  const float c = std::cos(0.5f), sn = std::sin(0.5f);
  for (vec2& uv : m.uvs) uv = vec2(-1.3f + 1.7f * (c * uv.x - sn * uv.y), 0.4f - 1.1f * (sn * uv.x + c * uv.y));
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(29, 35, 12));
  return {"rotated mirrored uvs", trianglesOf(m), Displacement{map, 0.08f, -0.5f, vec2(2.0f, 3.0f)}};
}

std::vector<Scenario> scenarios() { return {tiledQuad(), torus(), coarseTorus(), sphere()}; }
std::vector<Scenario> stiffScenarios() { return {twisted(), deepSphere(), highTiling(), farAway(), rotatedUVs()}; }

vec3 randomDir(std::mt19937& rng) {
  std::normal_distribution<float> G;
  vec3 d;
  do d = vec3(G(rng), G(rng), G(rng));
  while (glm::length(d) < 1e-3f);
  return glm::normalize(d);
}

SurfacePoint randomBasePoint(const Scenario& s, std::mt19937& rng) {
  std::uniform_int_distribution<size_t> tri(0, s.tris.size() - 1);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  const size_t k = tri(rng);
  const DisplacedTriangle& T = s.tris[k];
  float u = U(rng), v = U(rng);
  if (u + v > 1) u = 1 - u, v = 1 - v;
  return {T.P(u, v), glm::normalize(T.N(u, v)), uint32_t(k)};
}

const char* const kFamilies[6] = {"camera", "grazing", "along +-N", "inside the shell", "spawned (path tracer)",
                           "shadow (finite tmax)"};

bool closest(const Intersector& is, const Ray& r, TriangleHit& best) {
  bool found = false;
  Ray q = r;
  RayCounters c;
  for (uint32_t p = 0; p < is.size(); ++p) {
    const AABB b = is.bounds(p);
    if (b.isEmpty() || b.intersect(q).isEmpty()) continue;
    TriangleHit h;
    if (is.intersect(q, p, h, c) && h.t <= q.tmax) found = true, best = h, q.tmax = h.t;
  }
  return found;
}

std::vector<RayCase> rayFamilies(const Scenario& s, const Intersector& bf, int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  AABB box;
  for (uint32_t p = 0; p < bf.size(); ++p) box.extend(bf.bounds(p));
  const vec3 c = 0.5f * (box.lo + box.hi);
  const float diag = glm::length(box.extent());
  const float hmax = std::max(std::abs(s.disp.scale * s.disp.bias), std::abs(s.disp.scale * (1 + s.disp.bias)));
  std::vector<RayCase> out;
  std::vector<Ray> camera;
  for (int i = 0; i < count; ++i) {
    {  // camera: from outside towards a random point on the base surface
      const vec3 o = c + 1.5f * diag * randomDir(rng);
      const SurfacePoint sp = randomBasePoint(s, rng);
      const vec3 target = sp.p + (U(rng) - 0.5f) * 2.0f * hmax * sp.n;
      camera.push_back(Ray{o, glm::normalize(target - o), 0.0f, kInfinity});
      out.push_back({camera.back(), 0});
    }
    {  // grazing: within a few degrees of the tangent plane
      const SurfacePoint sp = randomBasePoint(s, rng);
      vec3 t = glm::cross(sp.n, randomDir(rng));
      if (glm::length(t) < 1e-3f) t = glm::cross(sp.n, vec3(1, 0, 0));
      const float tilt = (U(rng) - 0.5f) * (i % 2 ? 0.02f : 0.2f);
      const vec3 d = glm::normalize(glm::normalize(t) + tilt * sp.n);
      const vec3 target = sp.p + (U(rng) - 0.5f) * 2.0f * hmax * sp.n;
      out.push_back({Ray{target - 0.6f * diag * d, d, 0.0f, kInfinity}, 1});
    }
    {  // along +-N: the interpolated normal itself, from above, below or inside
      const SurfacePoint sp = randomBasePoint(s, rng);
      const float side = U(rng) < 0.5f ? 1.0f : -1.0f;
      const float start = (i % 3 == 0) ? (U(rng) * 2 - 1) * hmax : side * 3.0f * hmax;
      out.push_back({Ray{sp.p + start * sp.n, -side * sp.n, 0.0f, kInfinity}, 2});
    }
    {  // inside the shell, random direction
      const SurfacePoint sp = randomBasePoint(s, rng);
      const vec3 o = sp.p + (U(rng) * 2.0f - 1.0f) * 1.2f * hmax * sp.n;
      out.push_back({Ray{o, randomDir(rng), 0.0f, kInfinity}, 3});
    }
  }
  // Directions that are not unit length (Embree does not normalise) and axis-aligned
  // ones (slab tests with infinite reciprocals), mixed into the camera family.
  for (int i = 0; i < count / 4; ++i) {
    Ray r = camera[size_t(i) % camera.size()];
    r.d *= (i % 2) ? 7.5f : 0.02f;
    out.push_back({r, 0});
    const SurfacePoint sp = randomBasePoint(s, rng);
    vec3 d(0.0f);
    d[i % 3] = (i / 3) % 2 ? 1.0f : -1.0f;
    out.push_back({Ray{sp.p - 2.0f * hmax * d - (0.5f * diag) * d, d, 0.0f, kInfinity}, 0});
    // From far away (beyond the origin budget of the precomputed prisms: rebuilt per ray).
    const vec3 far = c + 1000.0f * diag * randomDir(rng);
    const vec3 target = randomBasePoint(s, rng).p;
    out.push_back({Ray{far, glm::normalize(target - far), 0.0f, kInfinity}, 0});
  }
  // Spawned from the oracle's hits of the camera rays: exactly at the hit with a small
  // tmin, or offset along the facing normal; into the hemisphere; plus shadow rays
  // towards a point with a finite tmax.
  int k = 0;
  for (const Ray& r : camera) {
    TriangleHit h;
    if (!closest(bf, r, h)) continue;
    vec3 n = h.ng;
    if (glm::dot(n, r.d) > 0) n = -n;
    const vec3 p = r.at(h.t);
    vec3 d = randomDir(rng);
    if (glm::dot(d, n) < 0) d = -d;
    const float eps = 1e-4f * std::max(1.0f, glm::length(p));
    if (k++ % 2) out.push_back({Ray{p + eps * n, d, 0.0f, kInfinity}, 4});
    else out.push_back({Ray{p, d, eps, kInfinity}, 4});
    const vec3 light = c + 1.2f * diag * randomDir(rng);
    const vec3 L = light - p;
    out.push_back({Ray{p + eps * n, glm::normalize(L), 0.0f, glm::length(L) * (0.3f + 0.7f * U(rng))}, 5});
  }
  return out;
}

std::vector<ConformanceConfig> conformanceConfigs() {
  std::vector<ConformanceConfig> out;
  for (const StrategyCombination& c : allCombinations()) out.push_back({c.config, c.slowReference});
  auto variant = [&](auto&& change) {
    TraversalConfig c;  // the canonical configuration, changed
    change(c);
    out.push_back({c, false});
  };
  variant([](TraversalConfig& c) { c.inversionInTraversal = false; });
  for (float ms : {0.5f, 1.0f, 16.0f, 1e6f}) variant([ms](TraversalConfig& c) { c.marchingScale = ms; });
  variant([](TraversalConfig& c) {  // the RMIP driver with TFDM's mipmap and quad-tree splits
    c.range = "minmax_mipmap", c.splitter = "quadtree", c.inversionInTraversal = false, c.marchingScale = 1.0f;
  });
  variant([](TraversalConfig& c) { c.rangeParams = {{"resolution", 8}, {"layout", "corners"}, {"compression", 0}}; });
  variant([](TraversalConfig& c) { c.rangeParams = {{"resolution", 8}, {"bits", 32}}; });
  // Every registered baseline that claims exactness (tfdm, ...), the oracle aside.
  for (const std::string& b : exactBaselines()) variant([&b](TraversalConfig& c) { c.baseline = b; });
  variant([](TraversalConfig& c) {  // tfdm with world-space node boxes (its default: texture frame)
    c.baseline = "tfdm", c.baselineParams = {{"boxes", "world"}};
  });
  return out;
}

std::string describe(const TraversalConfig& c) {
  if (!c.baseline.empty()) return c.baseline + (c.baselineParams.empty() ? "" : " " + c.baselineParams.dump());
  return fmt::format("{}+{}+{} (march {}, inversion {}{}{})", c.range, c.inverter, c.splitter, c.marchingScale,
                     c.inversionInTraversal ? "on" : "off", c.rangeParams.empty() ? "" : ", range ",
                     c.rangeParams.empty() ? "" : c.rangeParams.dump());
}

int torusLeaks(const EmbreeScene& accel, int n, unsigned seed, float maxLod) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  int leaks = 0;
  for (int k = 0; k < n; ++k) {
    const float a = 2.0f * std::numbers::pi_v<float> * U(rng);
    const float z = 2 * U(rng) - 1, phi = 2.0f * std::numbers::pi_v<float> * U(rng);
    const float rr = std::sqrt(std::max(0.0f, 1 - z * z));
    Ray r{vec3(std::cos(a), 0.0f, std::sin(a)), vec3(rr * std::cos(phi), rr * std::sin(phi), z), 0.0f, kInfinity};
    if (maxLod >= 0.0f) r.lod = maxLod * U(rng);
    if (!accel.intersect(r).valid()) ++leaks;
  }
  return leaks;
}

}  // namespace oblong::test
