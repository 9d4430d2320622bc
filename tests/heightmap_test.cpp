#include "core/error.h"
#include "core/heightmap.h"
#include "core/procedural.h"
#include "test_util.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
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

TEST_CASE("height maps load 8-bit, 16-bit and float PNG/TIFF/EXR of any size", "[heightmap][unit]") {
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

TEST_CASE("bad height maps give an error naming the file", "[heightmap][unit]") {
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

TEST_CASE("bilinear heights use texel centres, wrap addressing, scale, bias and tiling", "[heightmap][unit]") {
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

TEST_CASE("procedural default map is tileable and in [0,1]", "[heightmap][unit]") {
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

namespace {
// A grey+alpha or grey image whose file holds exactly these values (unassociated alpha).
void writeGreyAlpha(const std::string& path, int channels, OIIO::TypeDesc type, const std::vector<float>& px) {
  auto out = OIIO::ImageOutput::create(path);
  REQUIRE(out);
  OIIO::ImageSpec spec(2, 2, channels, type);
  if (channels == 2) spec.alpha_channel = 1;
  spec.attribute("oiio:UnassociatedAlpha", 1);  // the values are as stored, not premultiplied
  REQUIRE(out->open(path, spec));
  REQUIRE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
  out->close();
}

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}
std::string be32(uint32_t v) {
  return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}
}  // namespace

TEST_CASE("heights of a grey+alpha map are the grey values, not multiplied by alpha", "[heightmap][unit]") {
  const auto dir = test::scratchDir("heightmap_alpha");
  const std::vector<float> grey = {0.6f, 0.2f, 1.0f, 0.4f};
  for (const char* ext : {"png", "tif"})
    for (const OIIO::TypeDesc type : {OIIO::TypeDesc::UINT8, OIIO::TypeDesc::UINT16})
      for (const int channels : {1, 2}) {
        std::vector<float> px;
        for (float g : grey) {
          px.push_back(g);
          if (channels == 2) px.push_back(0.5f);  // OpenImageIO's default read gave g * 0.5
        }
        const std::string path =
            (dir / fmt::format("g{}_{}.{}", channels, type == OIIO::TypeDesc::UINT8 ? 8 : 16, ext)).string();
        writeGreyAlpha(path, channels, type, px);
        INFO(path);
        const HeightMap m = HeightMap::load(path);
        const float tol = type == OIIO::TypeDesc::UINT8 ? 0.501f / 255 : 0.501f / 65535;
        for (int k = 0; k < 4; ++k) CHECK(std::abs(m.atUnchecked(k % 2, k / 2) - grey[size_t(k)]) <= tol);
      }
}

TEST_CASE("a header claiming more pixels than the file can hold is refused before allocating", "[heightmap][unit]") {
  const auto dir = test::scratchDir("heightmap_claims");
  // A valid 1x1 PNG, its IHDR patched to 16384x16384 (CRC fixed): 67 bytes that
  // OpenImageIO read into a 1.1 GiB buffer before it failed.
  const std::string one = (dir / "one.png").string();
  test::writeGray(one, 1, 1, {0.5f}, OIIO::TypeDesc::UINT8);
  std::string png = slurp(one);
  REQUIRE(png.compare(12, 4, "IHDR") == 0);
  png.replace(16, 8, be32(16384) + be32(16384));
  png.replace(29, 4, be32(test::crc32(png.substr(12, 17))));
  const std::string huge = (dir / "huge.png").string();
  std::ofstream(huge, std::ios::binary) << png;
  CHECK_THROWS_WITH(HeightMap::load(huge),
                    Catch::Contains(huge + ": header claims 16384x16384 pixels (at least 268435456 bytes at 8 bits per "
                                           "sample), more than this " +
                                    std::to_string(png.size()) + "-byte png file can hold (deflate"));
  // Uncompressed: the pixels must be in the file.
  const std::string pgm = (dir / "claims.pgm").string();
  std::ofstream(pgm, std::ios::binary) << "P5\n4096 4096\n255\n" << std::string(1000, '\x7f');
  CHECK_THROWS_WITH(HeightMap::load(pgm), Catch::Contains(pgm + ": header claims 4096x4096 pixels") &&
                                              Catch::Contains("-byte pnm file can hold (uncompressed)"));
  // A map that compresses about as well as deflate can still loads: 2048x2048 of one value.
  const std::string flat = (dir / "flat.png").string();
  test::writeGray(flat, 2048, 2048, std::vector<float>(2048 * 2048, 0.25f), OIIO::TypeDesc::UINT8);
  INFO(std::filesystem::file_size(flat) << " bytes");
  CHECK(HeightMap::load(flat).atUnchecked(2047, 2047) == Approx(0.25f).margin(0.5 / 255));
}

TEST_CASE("PNG chunks and EXR attributes claiming more than the file holds are refused before allocating",
          "[heightmap][bad_input][unit]") {
  const auto dir = test::scratchDir("heightmap_lengths");
  // A zTXt chunk claiming 0x7FFFFFF0 bytes in a 2 KB PNG: libpng allocated 2.2 GB first.
  const std::string one = (dir / "one.png").string();
  test::writeGray(one, 1, 1, {0.5f}, OIIO::TypeDesc::UINT8);
  std::string png = slurp(one);
  REQUIRE(png.compare(12, 4, "IHDR") == 0);  // 25 bytes from byte 8: the next chunk starts at 33
  png.insert(33, be32(0x7FFFFFF0) + "zTXt" + "k" + std::string(2, '\0') + std::string(2000, 'x'));
  const std::string ztxt = (dir / "ztxt.png").string();
  std::ofstream(ztxt, std::ios::binary) << png;
  CHECK_THROWS_MATCHES(HeightMap::load(ztxt), Error,
                       Catch::Matchers::Message(ztxt + ": PNG chunk 'zTXt' at byte 33 claims 2147483632 bytes, more "
                                                       "than the " +
                                                std::to_string(png.size() - 33 - 12) + " bytes left in the file"));
  // Whatever the extension: OpenImageIO finds the PNG by its signature.
  const std::string dat = (dir / "ztxt.dat").string();
  std::ofstream(dat, std::ios::binary) << png;
  CHECK_THROWS_WITH(HeightMap::load(dat), Catch::Contains(dat + ": PNG chunk 'zTXt' at byte 33 claims"));

  // A string attribute claiming 0x7FFFFFF0 bytes in a 17 KB EXR: OpenEXR allocated 2.2 GB first.
  const std::string exr = (dir / "ok.exr").string();
  test::writeGray(exr, 8, 8, std::vector<float>(64, 0.5f), OIIO::TypeDesc::FLOAT);
  std::string bytes = slurp(exr);
  REQUIRE(HeightMap::load(exr).width() == 8);
  const int32_t lie = 0x7FFFFFF0;
  bytes.insert(8, std::string("comments\0string\0", 16) + std::string(reinterpret_cast<const char*>(&lie), 4) + "hi");
  bytes += std::string(17000, '\0');
  const std::string liar = (dir / "liar.exr").string();
  std::ofstream(liar, std::ios::binary) << bytes;
  CHECK_THROWS_MATCHES(HeightMap::load(liar), Error,
                       Catch::Matchers::Message(liar + ": EXR header attribute 'comments' (string) at byte 8 claims "
                                                       "2147483632 bytes, more than the " +
                                                std::to_string(bytes.size() - 28) + " bytes left in the file"));
  // A negative size is no size either.
  bytes = slurp(exr);
  const int32_t negative = -5;
  bytes.insert(8, std::string("comments\0string\0", 16) + std::string(reinterpret_cast<const char*>(&negative), 4));
  const std::string neg = (dir / "negative.exr").string();
  std::ofstream(neg, std::ios::binary) << bytes;
  CHECK_THROWS_WITH(HeightMap::load(neg), Catch::Contains(neg + ": EXR header attribute 'comments' (string) at byte 8 "
                                                                "claims -5 bytes"));
}
