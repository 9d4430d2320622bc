#include "core/error.h"
#include "core/heightmap.h"
#include "core/procedural.h"
#include "test_util.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

using namespace oblong;

namespace {
std::vector<float> ramp(int w, int h) {
  std::vector<float> v(size_t(w) * h);
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) v[size_t(j) * w + i] = float(i + w * j) / float(w * h - 1);
  return v;
}
}  // namespace

TEST_CASE("height maps load 8-bit, 16-bit and float PNG/TIFF/EXR of any size", "[heightmap]") {
  const auto dir = test::scratchDir("heightmap");
  const int w = 5, h = 3;  // not powers of two
  const auto v = ramp(w, h);
  struct Case {
    const char* file;
    OIIO::TypeDesc type;
    float tol;
  } cases[] = {{"a8.png", OIIO::TypeDesc::UINT8, 0.501f / 255},
               {"a16.png", OIIO::TypeDesc::UINT16, 0.501f / 65535},
               {"a16.tif", OIIO::TypeDesc::UINT16, 0.501f / 65535},
               {"af.tif", OIIO::TypeDesc::FLOAT, 0.0f},
               {"af.exr", OIIO::TypeDesc::FLOAT, 0.0f},
               {"ah.exr", OIIO::TypeDesc::HALF, 1e-3f}};
  for (const auto& c : cases) {
    const std::string path = (dir / c.file).string();
    test::writeGray(path, w, h, v, c.type);
    INFO(path);
    const HeightMap m = HeightMap::load(path);
    REQUIRE(m.width() == w);
    REQUIRE(m.height() == h);
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) CHECK(std::abs(m.atUnchecked(i, j) - v[size_t(j) * w + i]) <= c.tol);
  }
  // First channel of a multi-channel image; flip_v reverses the rows.
  const std::string rgb = (dir / "rgb.png").string();
  {
    auto out = OIIO::ImageOutput::create(rgb);
    OIIO::ImageSpec spec(2, 2, 3, OIIO::TypeDesc::UINT8);
    out->open(rgb, spec);
    const unsigned char px[12] = {255, 0, 0, 0, 9, 9, 51, 7, 7, 102, 1, 1};
    out->write_image(OIIO::TypeDesc::UINT8, px);
    out->close();
  }
  const HeightMap m = HeightMap::load(rgb);
  CHECK(m.atUnchecked(0, 0) == Approx(1.0f));
  CHECK(m.atUnchecked(1, 0) == Approx(0.0f));
  CHECK(m.atUnchecked(0, 1) == Approx(0.2f));
  const HeightMap f = HeightMap::load(rgb, true);
  CHECK(f.atUnchecked(0, 0) == Approx(0.2f));
  CHECK(f.atUnchecked(1, 1) == Approx(0.0f));
}

TEST_CASE("bad height maps give an error naming the file", "[heightmap]") {
  const auto dir = test::scratchDir("heightmap_bad");
  const std::string missing = (dir / "missing.png").string();
  REQUIRE_THROWS_WITH(HeightMap::load(missing), Catch::Contains(missing));
  const std::string garbage = (dir / "garbage.png").string();
  {
    std::FILE* fp = std::fopen(garbage.c_str(), "wb");
    std::fputs("this is not a png", fp);
    std::fclose(fp);
  }
  REQUIRE_THROWS_AS(HeightMap::load(garbage), Error);
  REQUIRE_THROWS_WITH(HeightMap::load(garbage), Catch::Contains(garbage));
  const std::string nan = (dir / "nan.exr").string();
  std::vector<float> v = {0.0f, 1.0f, std::numeric_limits<float>::quiet_NaN(), 0.5f};
  test::writeGray(nan, 2, 2, v, OIIO::TypeDesc::FLOAT);
  REQUIRE_THROWS_WITH(HeightMap::load(nan), Catch::Contains(nan) && Catch::Contains("non-finite"));
  v[2] = std::numeric_limits<float>::infinity();
  test::writeGray(nan, 2, 2, v, OIIO::TypeDesc::FLOAT);
  REQUIRE_THROWS_WITH(HeightMap::load(nan), Catch::Contains("non-finite height at texel (0, 1)"));
}

TEST_CASE("bilinear heights use texel centres, wrap addressing, scale, bias and tiling", "[heightmap]") {
  const int w = 4, h = 3;
  auto map = std::make_shared<const HeightMap>(w, h, ramp(w, h));
  Displacement d{map, 2.0f, -0.25f, vec2(1.0f)};
  // At texel centres the bilinear and micro heights are the texel.
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      const vec2 uv((i + 0.5f) / w, (j + 0.5f) / h);
      CHECK(d.bilinear(uv) == Approx(2.0f * (map->atUnchecked(i, j) - 0.25f)));
      CHECK(d.micro(uv) == Approx(d.bilinear(uv)));
      CHECK(d.sampleHeight(i, j) == Approx(d.bilinear(uv)));
    }
  // uv = 0 lies half-way between the last and first texel columns and rows (wrap).
  const float corner = 0.25f * (map->at(-1, -1) + map->at(0, -1) + map->at(-1, 0) + map->at(0, 0));
  CHECK(d.bilinear(vec2(0.0f)) == Approx(2.0f * (corner - 0.25f)));
  CHECK(map->at(-1, -1) == map->atUnchecked(w - 1, h - 1));
  CHECK(map->at(w + 1, 2 * h) == map->atUnchecked(1, 0));
  // Tiling (3,2): uv and uv + (1/3, 1/2) give the same height.
  Displacement t{map, 1.0f, 0.0f, vec2(3.0f, 2.0f)};
  for (float u : {0.05f, 0.21f, 0.6f})
    for (float v : {0.1f, 0.33f})
      CHECK(t.bilinear(vec2(u, v)) == Approx(t.bilinear(vec2(u + 1.0f / 3, v + 0.5f))).margin(1e-5));
  // The micro-geometry height is piecewise linear: exact at midpoints of cell edges.
  const dvec2 s(1.5, 1.0);  // middle of the horizontal cell edge (1,1)-(2,1)
  CHECK(d.microAtSample(s) == Approx(2.0f * (0.5f * (map->at(1, 1) + map->at(2, 1)) - 0.25f)));
  const dvec2 diag(1.5, 1.5);  // middle of the cell diagonal (1,1)-(2,2)
  CHECK(d.microAtSample(diag) == Approx(2.0f * (0.5f * (map->at(1, 1) + map->at(2, 2)) - 0.25f)));
}

TEST_CASE("procedural default map is tileable and in [0,1]", "[heightmap]") {
  const HeightMap m = proceduralHeightMap(96, 64, 3);
  const Interval r = m.range();
  CHECK(r.lo >= 0.0f);
  CHECK(r.hi <= 1.0f);
  CHECK(r.width() > 0.5f);
  // Periodic: the jump across the border is no larger than steps inside the map.
  float inner = 0, border = 0;
  for (int j = 0; j < m.height(); ++j) {
    for (int i = 0; i + 1 < m.width(); ++i) inner = std::max(inner, std::abs(m.at(i + 1, j) - m.at(i, j)));
    border = std::max(border, std::abs(m.at(0, j) - m.at(m.width() - 1, j)));
  }
  CHECK(border <= inner + 1e-6f);
}
