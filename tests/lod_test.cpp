// Levels of detail (core/lod.h, docs/lod.md): the levels, the surface at a fractional
// λ, its continuity in λ, and a closed torus at fractional λ that leaks no ray. The
// exactness of every strategy combination at λ is in conformance_test.cpp ([lod]).
#include "core/lod.h"
#include "core/procedural.h"
#include "core/scene.h"
#include "render/embree_scene.h"
#include "traversal/strategy_catalog.h"
#include "tests/fixtures/traversal_cases.h"

#include <catch2/catch.hpp>

#include <numbers>
#include <random>

using namespace oblong;

namespace {

// A closed displaced torus (64x48 map: 4 levels), for rays shot from inside.
Scene closedTorus() {
  Scene s;
  SceneMesh torus;
  torus.mesh = torusMesh(1.0f, 0.4f, 24, 12);
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(64, 48, 9));
  torus.displacement = Displacement{map, 0.15f, -0.5f, vec2(3.0f, 2.0f)};
  s.meshes.push_back(std::move(torus));
  return s;
}

HeightMap randomMap(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-1.0f, 3.0f);
  std::vector<float> t(size_t(w) * h);
  for (float& x : t) x = U(rng);
  return HeightMap(w, h, std::move(t), "random");
}

}  // namespace

TEST_CASE("lod: a level exists while 2^k divides both sizes and leaves 2 samples", "[lod][unit]") {
  CHECK(lodLevels(randomMap(32, 32, 1)) == 4);
  CHECK(lodLevels(randomMap(384, 256, 1)) == 7);  // the default scene's map: 3x2 at level 7
  CHECK(lodLevels(randomMap(64, 40, 1)) == 3);
  CHECK(lodLevels(randomMap(61, 47, 1)) == 0);
  CHECK(lodLevels(randomMap(4320, 2160, 1)) == 4);
  CHECK(lodLevels(randomMap(2, 2, 1)) == 0);
  CHECK(lodLevels(randomMap(4, 4, 1)) == 1);
  CHECK_THROWS_AS(downsampleLevel(randomMap(6, 5, 1)), Error);
}

TEST_CASE("lod: level k+1 is the tent filter of level k at the even samples, wrapped", "[lod][unit]") {
  const HeightMap m = randomMap(12, 8, 2);
  const HeightMap c = downsampleLevel(m);
  REQUIRE(c.width() == 6);
  REQUIRE(c.height() == 4);
  const double w[3] = {0.25, 0.5, 0.25};
  const Interval r0 = m.range(), r1 = c.range();
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 6; ++i) {
      double e = 0.0;
      for (int b = -1; b <= 1; ++b)
        for (int a = -1; a <= 1; ++a) e += w[a + 1] * w[b + 1] * m.at(2 * i + a, 2 * j + b);
      CHECK(c.at(i, j) == Approx(e).margin(1e-6));
    }
  // A convex combination: no level leaves level 0's range.
  CHECK(r1.lo >= r0.lo);
  CHECK(r1.hi <= r0.hi);
}

TEST_CASE("lod: the grids nest, and the surface is continuous in lambda", "[lod][unit]") {
  auto map = std::make_shared<const HeightMap>(randomMap(64, 32, 3));
  const Displacement d0{map, 0.3f, -0.5f, vec2(2.0f, 3.0f)};
  REQUIRE(lodLevels(*map) == 4);
  // λ = 0 is the full-resolution displacement itself: nothing built.
  const Displacement z = atLod(d0, 0.0f);
  CHECK(z.map == map);
  CHECK(!z.level0);
  CHECK(z.sampleOffset == 0.5);
  for (int k = 1; k <= 4; ++k) {
    const Displacement dk = atLod(d0, float(k));
    CHECK(dk.map->width() == 64 >> k);
    CHECK(dk.level0 == map);
    CHECK(dk.sampleOffset == std::ldexp(0.5, -k));
    // Level k's sample (i, j) is level 0's (2^k i, 2^k j), bit for bit in uv.
    for (int j = -2; j < 5; ++j)
      for (int i = -3; i < 7; ++i) CHECK(dk.sampleToUV(i, j) == d0.sampleToUV(i << k, j << k));
    // Level k's sample heights are level k-1's tent-filtered ones.
    const Displacement prev = atLod(d0, float(k - 1));
    const HeightMap expect = downsampleLevel(*prev.map);
    CHECK(dk.map->texels() == expect.texels());
  }
  // λ = k + f blends level k toward level k+1's micro-geometry at level k's points.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> U(-0.7f, 1.9f);
  for (int k = 0; k < 4; ++k) {
    const Displacement a = atLod(d0, float(k) + 0.25f), next = atLod(d0, float(k + 1));
    const Displacement lo = atLod(d0, float(k));
    for (int j = 0; j < a.map->height(); ++j)
      for (int i = 0; i < a.map->width(); ++i) {
        const vec2 uv = a.sampleToUV(i, j);
        const float L = next.micro(uv), H = lo.micro(uv);
        CHECK(a.micro(uv) == Approx(0.75f * H + 0.25f * L).margin(1e-5));
      }
    // Just below k+1 the height field is level k+1's, everywhere (the grids nest and
    // level k's cells split level k+1's triangles): continuity in λ.
    const Displacement below = atLod(d0, std::nextafter(float(k + 1), 0.0f));
    CHECK(int(std::floor(below.lod)) == k);
    for (int s = 0; s < 500; ++s) {
      const vec2 uv(U(rng), U(rng));
      CHECK(below.micro(uv) == Approx(next.micro(uv)).margin(1e-4));
    }
  }
  // Above the last level: clamped.
  CHECK(atLod(d0, 9.5f).lod == 4.0f);
  CHECK_THROWS_AS(atLod(d0, -1.0f), Error);
  CHECK_THROWS_AS(atLod(d0, std::numeric_limits<float>::quiet_NaN()), Error);
  // Back to level 0 from any λ.
  const Displacement back = atLevel0(atLod(d0, 2.5f));
  CHECK(back.map == map);
  CHECK(back.sampleOffset == 0.5);
}

TEST_CASE("lod: setLod moves every displaced mesh, shares levels, and off restores level 0", "[lod][unit]") {
  Scene s = defaultScene();
  const auto full = s.meshes[0].displacement->map;
  setLod(s, 2.5f, "test");
  REQUIRE(s.lod);
  const Displacement& d = *s.meshes[0].displacement;
  CHECK(d.lod == 2.5f);
  CHECK(d.level0 == full);
  CHECK(d.map->width() == full->width() / 4);
  CHECK(d.scale == 0.12f);  // the mesh's own scale, bias, tiling stay
  setLod(s, 1.0f, "test");  // from level 0 again, not from 2.5
  CHECK(s.meshes[0].displacement->map->width() == full->width() / 2);
  setLod(s, std::nullopt, "test");
  CHECK(s.meshes[0].displacement->map == full);
  CHECK(!s.meshes[0].displacement->level0);
  CHECK_THROWS_AS(setLod(s, -0.5f, "test"), Error);
}

TEST_CASE("lod: a closed displaced torus at fractional lambda leaks no ray shot from inside", "[lod][watertight][bruteforce][tessellated]") {
  Scene s = closedTorus();
  for (const float lod : {0.5f, 1.75f, 3.25f}) {
    setLod(s, lod, "test");
    AccelOptions tessellated = AccelOptions::withBaseline("tessellated"), canonical, brute;
    brute.traversal.baseline = "bruteforce";
    for (const AccelOptions& opts : {tessellated, canonical, brute}) {
      EmbreeScene accel(s, opts);
      INFO("lod " << lod << ", " << accel.geometryName());
      const int n = 4000, leaks = test::torusLeaks(accel, n);
      INFO(leaks << " of " << n << " rays leaked");
      CHECK(leaks == 0);
    }
  }
}

TEST_CASE("lod: a closed displaced torus with a lambda per ray leaks no ray shot from inside", "[lod][watertight][unit]") {
  Scene s = closedTorus();
  setLodCone(s);
  AccelOptions canonical, brute;
  canonical.traversal.lodPerRay = brute.traversal.lodPerRay = true;
  brute.traversal.baseline = "bruteforce";
  for (const AccelOptions& opts : {canonical, brute}) {
    EmbreeScene accel(s, opts);
    INFO(accel.geometryName());
    const int n = 4000, leaks = test::torusLeaks(accel, n, 5, 4.5f);  // past the last level (4)
    INFO(leaks << " of " << n << " rays leaked");
    CHECK(leaks == 0);
  }
}

TEST_CASE("lod: the per-ray blend reads the heights of the whole-scene surface at that lambda", "[lod][unit]") {
  auto map = std::make_shared<const HeightMap>(proceduralHeightMap(64, 48, 4));
  const Displacement d0{map, 0.2f, -0.5f, vec2(2.0f, 1.0f)};
  const auto levels = lodPyramid(map);
  REQUIRE(levels.size() == size_t(lodLevels(*map)) + 1);
  for (const float lambda : {0.0f, 0.3f, 1.0f, 1.5f, 2.75f, 3.0f, 3.9f, 4.0f}) {
    const Displacement whole = atLod(d0, lambda);
    const int k = int(std::floor(lambda));
    const Displacement band = lodBand(d0, levels, k);
    const float f = band.blendOf(lambda);
    INFO("lambda " << lambda);
    CHECK(band.sampleOffset == whole.sampleOffset);
    REQUIRE(band.map->width() == whole.map->width());
    bool same = true;
    for (int j = -1; j <= band.map->height(); ++j)
      for (int i = -1; i <= band.map->width(); ++i) same = same && band.raw(i, j, f) == whole.map->at(i, j);
    CHECK(same);
    CHECK(band.blendOf(-1.0f) == 0.0f);  // a ray without a level of detail: level k's own heights
  }
}

TEST_CASE("lod: a lambda per ray on a map without levels traces level 0", "[lod][unit]") {
  Scene s = closedTorus();
  s.meshes[0].displacement->map = std::make_shared<const HeightMap>(proceduralHeightMap(63, 47, 9));  // odd: no level
  AccelOptions level0, perRay;
  perRay.traversal.lodPerRay = true;
  const EmbreeScene a(s, level0), b(s, perRay);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  int same = 0, hits = 0;
  const int n = 500;
  for (int k = 0; k < n; ++k) {
    Ray r{vec3(1.5f * U(rng), 3.0f, 1.5f * U(rng)), glm::normalize(vec3(0.3f * U(rng), -1.0f, 0.3f * U(rng))), 0.0f,
          kInfinity};  // down onto the torus (its axis is y)
    const Hit ha = a.intersect(r);
    r.lod = 4.0f * (U(rng) + 1.0f);
    const Hit hb = b.intersect(r);
    hits += ha.valid();
    same += ha.valid() == hb.valid() && (!ha.valid() || (ha.t == hb.t && ha.uv == hb.uv));
  }
  INFO(same << " of " << n << " rays identical, " << hits << " hits");
  CHECK(hits > n / 10);
  CHECK(same == n);
}
