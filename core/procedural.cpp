#include "core/procedural.h"

#include <cmath>
#include <numbers>
#include <random>

namespace oblong {

HeightMap proceduralHeightMap(int width, int height, uint32_t seed) {
  constexpr double kTau = 2.0 * std::numbers::pi;
  // Periodic value noise on a lattice of (cw x ch) cells that divides the period.
  const int cw = 16, ch = 16;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<double> lattice(cw * ch);
  for (double& x : lattice) x = U(rng);
  auto noise = [&](double x, double y) {  // x, y in [0,1), periodic
    const double fx = x * cw, fy = y * ch;
    const int i = int(std::floor(fx)), j = int(std::floor(fy));
    const double tx = fx - i, ty = fy - j;
    auto L = [&](int a, int b) { return lattice[((b % ch + ch) % ch) * cw + (a % cw + cw) % cw]; };
    const double sx = tx * tx * (3 - 2 * tx), sy = ty * ty * (3 - 2 * ty);
    return (1 - sy) * ((1 - sx) * L(i, j) + sx * L(i + 1, j)) + sy * ((1 - sx) * L(i, j + 1) + sx * L(i + 1, j + 1));
  };
  std::vector<float> t(size_t(width) * height);
  for (int j = 0; j < height; ++j)
    for (int i = 0; i < width; ++i) {
      const double x = (i + 0.5) / width, y = (j + 0.5) / height;
      const double waves = 0.5 + 0.25 * std::sin(kTau * 3 * x) * std::cos(kTau * 2 * y) +
                           0.15 * std::sin(kTau * (5 * x + 7 * y));
      // Sharp-edged plateaus make the range queries work: flat tops, steep sides.
      const double n = noise(x, y);
      const double plateau = n > 0.6 ? 0.35 : 0.0;
      t[size_t(j) * width + i] = float(std::clamp(0.6 * waves + 0.4 * n + plateau - 0.2, 0.0, 1.0));
    }
  return HeightMap(width, height, std::move(t), "<procedural " + std::to_string(width) + "x" +
                                                    std::to_string(height) + ">");
}

Mesh torusMesh(float R, float r, int nu, int nv) {
  constexpr double kTau = 2.0 * std::numbers::pi;
  Mesh m;
  m.name = "<procedural torus>";
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      // Angles from the wrapped index: the seam's copies are bit-identical.
      const double a = kTau * (i % nu) / nu, b = kTau * (j % nv) / nv;
      const vec3 n(float(std::cos(a) * std::cos(b)), float(std::sin(b)), float(std::sin(a) * std::cos(b)));
      const vec3 c(float(R * std::cos(a)), 0.0f, float(R * std::sin(a)));
      m.positions.push_back(c + r * n);
      m.normals.push_back(glm::normalize(n));
      m.uvs.emplace_back(float(i) / nu, float(j) / nv);
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const unsigned a = j * (nu + 1) + i, b = a + 1, c = a + (nu + 1), d = c + 1;
      m.triangles.emplace_back(a, c, b);  // outward facing with the normals above
      m.triangles.emplace_back(b, c, d);
    }
  return m;
}

Mesh quadMesh(float s, float y, int n) {
  Mesh m;
  m.name = "<procedural quad>";
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float u = float(i) / n, v = float(j) / n;
      m.positions.emplace_back(-s + 2 * s * u, y, -s + 2 * s * v);
      m.normals.emplace_back(0.0f, 1.0f, 0.0f);
      m.uvs.emplace_back(u, v);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const unsigned a = j * (n + 1) + i, b = a + 1, c = a + (n + 1), d = c + 1;
      m.triangles.emplace_back(a, c, b);
      m.triangles.emplace_back(b, c, d);
    }
  return m;
}

Mesh planeMesh(vec2 size, ivec2 n, vec2 uv0, vec2 uv1) {
  Mesh m;
  m.name = "<procedural plane>";
  for (int j = 0; j <= n.y; ++j)
    for (int i = 0; i <= n.x; ++i) {
      // (1-t) a + t b is exact at both ends: edges of neighbouring planes agree.
      const float s = float(i) / float(n.x), t = float(j) / float(n.y);
      m.positions.emplace_back(size.x * (s - 0.5f), 0.0f, size.y * (t - 0.5f));
      m.normals.emplace_back(0.0f, 1.0f, 0.0f);
      m.uvs.emplace_back((1 - s) * uv0.x + s * uv1.x, (1 - t) * uv0.y + t * uv1.y);
    }
  for (int j = 0; j < n.y; ++j)
    for (int i = 0; i < n.x; ++i) {
      const unsigned a = j * (n.x + 1) + i, b = a + 1, c = a + (n.x + 1), d = c + 1;
      m.triangles.emplace_back(a, c, b);  // (c-a) x (b-a) = +y
      m.triangles.emplace_back(b, c, d);
    }
  return m;
}

Mesh sphereMesh(float radius, int nu, int nv) {
  constexpr double kPi = std::numbers::pi;
  Mesh m;
  m.name = "<procedural sphere>";
  // Unit direction at colatitude theta (0 at the north pole, +y) and longitude phi. phi
  // turns clockwise seen from +y, so that u increases to the right seen from outside.
  auto dir = [](double theta, double phi) {
    return vec3(float(std::sin(theta) * std::cos(phi)), float(std::cos(theta)), float(-std::sin(theta) * std::sin(phi)));
  };
  auto add = [&](const vec3& n, vec2 uv) {
    m.positions.push_back(radius * n);
    m.normals.push_back(n);
    m.uvs.push_back(uv);
    return unsigned(m.positions.size() - 1);
  };
  // Rings j = 1 .. nv-1, nu+1 vertices each (i = nu repeats i = 0 bit for bit).
  std::vector<unsigned> ring(size_t(nv + 1) * (nu + 1));
  for (int j = 1; j < nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const vec3 n = dir(kPi * j / nv, 2.0 * kPi * (i % nu) / nu);
      ring[size_t(j) * (nu + 1) + i] = add(n, vec2(float(i) / nu, float(j) / nv));
    }
  auto R = [&](int i, int j) { return ring[size_t(j) * (nu + 1) + i]; };
  for (int i = 0; i < nu; ++i) {
    const float u = (float(i) + 0.5f) / nu;
    const unsigned north = add(vec3(0.0f, 1.0f, 0.0f), vec2(u, 0.0f));
    m.triangles.emplace_back(north, R(i, 1), R(i + 1, 1));
  }
  for (int j = 1; j + 1 < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const unsigned a = R(i, j), b = R(i + 1, j), c = R(i, j + 1), d = R(i + 1, j + 1);
      m.triangles.emplace_back(a, c, b);
      m.triangles.emplace_back(b, c, d);
    }
  for (int i = 0; i < nu; ++i) {
    const float u = (float(i) + 0.5f) / nu;
    const unsigned south = add(vec3(0.0f, -1.0f, 0.0f), vec2(u, 1.0f));
    m.triangles.emplace_back(south, R(i + 1, nv - 1), R(i, nv - 1));
  }
  return m;
}

Scene defaultScene() {
  Scene s;
  s.path = "<default>";
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(384, 256, 7));
  SceneMesh torus;
  torus.mesh = torusMesh(1.0f, 0.42f, 48, 24);
  // Tiling keeps texels roughly square on the torus: (2 pi R / tu) / 384 ~ (2 pi r / tv) / 256.
  torus.displacement = Displacement{map, 0.12f, -0.5f, vec2(4.0f, 2.0f)};
  torus.albedo = vec3(0.8f, 0.55f, 0.35f);
  s.meshes.push_back(std::move(torus));
  SceneMesh ground;  // undisplaced: stays a plain Embree triangle mesh
  ground.mesh = quadMesh(3.0f, -0.6f, 1);
  ground.albedo = vec3(0.6f);
  s.meshes.push_back(std::move(ground));
  s.camera = Camera{vec3(0.0f, 2.0f, 3.2f), vec3(0.0f, -0.15f, 0.0f), vec3(0, 1, 0), 40.0f};
  s.lights.push_back(Light{Light::Type::Directional, vec3(0.0f), glm::normalize(vec3(-0.5f, -1.0f, -0.4f)), vec3(2.5f)});
  s.range.where = "<default>: strategies.range";
  return s;
}

}  // namespace oblong
