// The renderer: deterministic for a seed whatever the thread count, AOVs in one EXR,
// the heat map, and the integrators' basic behaviour.
#include "core/procedural.h"
#include "render/camera.h"
#include "render/embree_scene.h"
#include "render/figures.h"
#include "render/renderer.h"
#include "test_util.h"

#include <OpenImageIO/imageio.h>
#include <catch2/catch.hpp>

#include <random>

using namespace oblong;

namespace {
const EmbreeScene& defaultAccel() {
  static const Scene s = defaultScene();
  static const EmbreeScene a(s, AccelOptions{});
  return a;
}
}  // namespace

TEST_CASE("render: the same seed gives the same image with 1 or 2 threads", "[render][unit]") {
  const Scene s = defaultScene();
  for (Integrator integ : {Integrator::Primary, Integrator::AO, Integrator::Path}) {
    RenderOptions o;
    o.size = {48, 36};
    o.spp = 2;
    o.integrator = integ;
    o.seed = 7;
    o.progress = nullptr;
    o.threads = 1;
    const RenderResult a = render(s, defaultAccel(), o);
    o.threads = 2;
    const RenderResult b = render(s, defaultAccel(), o);
    INFO(integratorName(integ));
    REQUIRE(a.aov.color.pixels == b.aov.color.pixels);
    CHECK(a.aov.steps == b.aov.steps);
    CHECK(a.counters.steps() == b.counters.steps());
    o.seed = 8;
    const RenderResult c = render(s, defaultAccel(), o);
    if (integ != Integrator::Primary) CHECK(c.aov.color.pixels != a.aov.color.pixels);
  }
}

TEST_CASE("render: AOVs go to one multi-channel EXR, steps to a heat map", "[render][unit]") {
  const Scene s = defaultScene();
  RenderOptions o;
  o.size = {40, 30};
  o.integrator = Integrator::Primary;
  o.progress = nullptr;
  const RenderResult r = render(s, defaultAccel(), o);
  // Primary: colour is the shading normal, 0.5 n + 0.5, on every hit pixel.
  size_t hitPixels = 0, traversed = 0;
  for (size_t i = 0; i < r.aov.depth.size(); ++i) {
    if (!std::isfinite(r.aov.depth[i])) {
      CHECK(r.aov.normal[i] == vec3(0.0f));
      continue;
    }
    ++hitPixels;
    traversed += r.aov.steps[i] > 0;  // the ground is a plain triangle: no steps there
    CHECK(glm::length(r.aov.normal[i]) == Approx(1.0f).margin(1e-4));
    CHECK(r.aov.color.pixels[i].x == Approx(0.5f * r.aov.normal[i].x + 0.5f));
  }
  CHECK(hitPixels > r.aov.depth.size() / 3);
  CHECK(traversed > hitPixels / 3);
  const auto dir = test::scratchDir("render");
  const std::string exr = (dir / "aovs.exr").string(), png = (dir / "steps.png").string();
  writeAOVs(r.aov, exr);
  writeHeatMap(r.aov, png, heatMapScale(r.aov));
  auto in = OIIO::ImageInput::open(exr);
  REQUIRE(in);
  const OIIO::ImageSpec& spec = in->spec();
  CHECK(spec.nchannels == 11);
  CHECK(spec.channelnames.at(3) == "Z");
  CHECK(spec.channelnames.at(7) == "steps");
  std::vector<float> px(size_t(spec.width) * spec.height * spec.nchannels);
  REQUIRE(in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data()));
  CHECK(px[size_t(15 * 40 + 20) * 11 + 7] == r.aov.steps[15 * 40 + 20]);
  in->close();
  auto hm = OIIO::ImageInput::open(png);
  REQUIRE(hm);
  CHECK(hm->spec().width == 40);
  CHECK(hm->spec().height > 30);  // with the colour bar
}

// Smooth shading normals (PDM paper §5.1, Eq. 19).
namespace {

Displacement mapOf(int w, int h, std::vector<float> texels, float scale, vec2 tiling = vec2(1.0f)) {
  Displacement d;
  d.map = std::make_shared<HeightMap>(w, h, std::move(texels));
  d.scale = scale;
  d.tiling = tiling;
  return d;
}

// A displaced 2x2 plane seen from above; only its middle is in view, far from the map's
// border (where wrap addressing would break a ramp).
Scene planeScene(const Displacement& d) {
  Scene s;
  s.path = "<test plane>";
  s.meshes.push_back(SceneMesh{planeMesh(vec2(2.0f), ivec2(2)), d, vec3(0.7f)});
  s.camera.from = vec3(0.2f, 2.0f, 0.3f);
  s.camera.to = vec3(0.0f);
  s.camera.up = vec3(0.0f, 0.0f, -1.0f);
  s.camera.fovY = 30.0f;
  return s;
}

RenderResult renderNormals(const Scene& s, ShadingNormals n) {
  const EmbreeScene accel(s, AccelOptions{});
  RenderOptions o;
  o.size = {40, 30};
  o.integrator = Integrator::Primary;
  o.normals = n;
  o.progress = nullptr;
  return render(s, accel, o);
}

}  // namespace

TEST_CASE("smooth normals: the bilinear height gradient matches finite differences", "[render][normals][unit]") {
  std::vector<float> t(7 * 5);
  for (size_t i = 0; i < t.size(); ++i) t[i] = float((i * 37) % 11) / 10.0f;
  const Displacement d = mapOf(7, 5, t, -0.7f, vec2(3.0f, 2.0f));
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  for (int k = 0; k < 200; ++k) {
    // A point well inside a cell, so that the central difference stays in it.
    const vec2 cell(float(rng() % 21), float(rng() % 10)), f(0.2f + 0.6f * U(rng), 0.2f + 0.6f * U(rng));
    const vec2 uv = (cell + f + 0.5f) / vec2(7.0f * 3.0f, 5.0f * 2.0f);
    const float e = 1e-3f / 21.0f;
    const vec2 g = bilinearHeightGradient(d, uv);
    const float gx = (d.bilinear(uv + vec2(e, 0)) - d.bilinear(uv - vec2(e, 0))) / (2 * e);
    const float gy = (d.bilinear(uv + vec2(0, e)) - d.bilinear(uv - vec2(0, e))) / (2 * e);
    INFO("uv " << uv.x << " " << uv.y);
    CHECK(g.x == Approx(gx).margin(0.02f * std::max(1.0f, std::abs(gx))));
    CHECK(g.y == Approx(gy).margin(0.02f * std::max(1.0f, std::abs(gy))));
  }
}

TEST_CASE("smooth normals: a constant map gives the interpolated (Phong) normal", "[render][normals][unit]") {
  DisplacedTriangle T;
  T.p[0] = vec3(0, 0, 0), T.p[1] = vec3(1, 0, 0), T.p[2] = vec3(0, 1, 0);
  T.n[0] = glm::normalize(vec3(-0.5f, 0, 1)), T.n[1] = glm::normalize(vec3(0.5f, 0.3f, 1)), T.n[2] = vec3(0, 0, 1);
  T.t[0] = vec2(0.1f, 0.1f), T.t[1] = vec2(0.6f, 0.2f), T.t[2] = vec2(0.2f, 0.7f);
  REQUIRE(T.prepare());
  const Displacement flat = mapOf(4, 4, std::vector<float>(16, 0.3f), 0.5f);
  for (const vec2 b : {vec2(0.2f, 0.3f), vec2(0.0f), vec2(1.0f, 0.0f), vec2(0.45f, 0.45f)}) {
    const vec3 phong = glm::normalize(T.N(b.x, b.y));
    const vec3 a = smoothDisplacedNormal(T, &flat, b.x, b.y), c = smoothDisplacedNormal(T, nullptr, b.x, b.y);
    CHECK(glm::length(a - phong) < 1e-5f);
    CHECK(glm::length(c - phong) < 1e-5f);
  }
  // Reversed winding: the same normal, turned to the side of P_u x P_v.
  std::swap(T.p[1], T.p[2]), std::swap(T.n[1], T.n[2]), std::swap(T.t[1], T.t[2]);
  REQUIRE(T.prepare());
  const vec3 r = smoothDisplacedNormal(T, &flat, 0.3f, 0.2f);
  CHECK(glm::length(r + glm::normalize(T.N(0.3f, 0.2f))) < 1e-5f);
}

TEST_CASE("smooth normals: exact on a flat triangle with an affine height, either winding", "[render][normals][unit]") {
  // Constant normals and a height affine in uv (a linear ramp, away from the map's
  // border): the displaced surface is a plane, whose normal Eq. 19 gives exactly.
  const int W = 8;
  std::vector<float> ramp(W * W);
  for (int j = 0; j < W; ++j)
    for (int i = 0; i < W; ++i) ramp[j * W + i] = 0.6f * float(i) - 0.35f * float(j);
  const Displacement d = mapOf(W, W, ramp, 0.05f);
  for (const vec3 up : {vec3(0, 0, 1), vec3(0, 0, -1)})
    for (bool reversed : {false, true}) {
      DisplacedTriangle T;
      T.p[0] = vec3(0, 0, 0), T.p[1] = vec3(1, 0.2f, 0), T.p[2] = vec3(0.1f, 0.9f, 0);
      T.t[0] = vec2(0.2f, 0.2f), T.t[1] = vec2(0.8f, 0.25f), T.t[2] = vec2(0.3f, 0.75f);
      T.n[0] = T.n[1] = T.n[2] = up;
      if (reversed) std::swap(T.p[1], T.p[2]), std::swap(T.t[1], T.t[2]);
      REQUIRE(T.prepare());
      auto S = [&](float u, float v) { return T.P(u, v) + d.bilinear(T.UV(u, v)) * up; };
      const vec3 exact = glm::normalize(glm::cross(S(1, 0) - S(0, 0), S(0, 1) - S(0, 0)));
      INFO("up " << up.z << " reversed " << reversed);
      CHECK(glm::length(smoothDisplacedNormal(T, &d, 0.25f, 0.3f) - exact) < 1e-4f);
      CHECK(glm::length(exact - glm::dot(exact, up) * up) > 0.1f);  // the slope is not negligible
    }
}

TEST_CASE("smooth normals agree with micro normals on planar surfaces, differ on bumpy ones", "[render][normals][unit]") {
  const int W = 16;
  std::vector<float> ramp(W * W), bumps(W * W);
  for (int j = 0; j < W; ++j)
    for (int i = 0; i < W; ++i) {
      ramp[j * W + i] = float(i) / float(W - 1) + 0.5f * float(j) / float(W - 1);
      bumps[j * W + i] = 0.5f + 0.5f * std::sin(1.7f * float(i)) * std::cos(2.3f * float(j));
    }
  struct Case {
    const char* name;
    Displacement d;
    bool planar;
  } cases[] = {
      {"constant map", mapOf(W, W, std::vector<float>(W * W, 0.4f), 0.3f), true},
      {"linear ramp", mapOf(W, W, ramp, 0.3f), true},
      {"bumps", mapOf(W, W, bumps, 0.05f), false},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const Scene s = planeScene(c.d);
    const RenderResult micro = renderNormals(s, ShadingNormals::Micro);
    const RenderResult smooth = renderNormals(s, ShadingNormals::Smooth);
    const PinholeCamera cam(s.camera, ivec2(40, 30));
    size_t hits = 0, differ = 0;
    float minDot = 1.0f;
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 40; ++x) {
        const size_t i = size_t(y) * 40 + x;
        REQUIRE(std::isfinite(micro.aov.depth[i]));  // only the plane's middle is in view
        REQUIRE(smooth.aov.depth[i] == micro.aov.depth[i]);  // shading does not move hits
        const vec3 nm = micro.aov.normal[i], ns = smooth.aov.normal[i];
        const vec3 toEye = -cam.generate(x + 0.5f, y + 0.5f).d;
        ++hits;
        CHECK(glm::length(ns) == Approx(1.0f).margin(1e-5));
        CHECK(glm::dot(ns, toEye) > 0.0f);  // faces the side the ray came from
        CHECK(glm::dot(ns, nm) > 0.0f);
        minDot = std::min(minDot, glm::dot(ns, nm));
        if (c.planar) CHECK(glm::length(ns - nm) < 1e-4f);
        differ += glm::length(ns - nm) > 1e-3f;
      }
    CHECK(hits == 40 * 30);
    if (!c.planar) {
      CHECK(differ > hits / 2);  // the micro-triangles' facets are gone
      CHECK(minDot > 0.8f);      // ... but the bumps are the same bumps
    }
  }
}
