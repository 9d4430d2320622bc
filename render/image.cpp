#include "render/image.h"

#include "core/error.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace oblong {

namespace {
float toSRGB(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}
}  // namespace

void writeImage(const Image& img, const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  const bool linear = ext == ".exr" || ext == ".hdr" || ext == ".tif" || ext == ".tiff" || ext == ".pfm";
  auto out = OIIO::ImageOutput::create(path);
  if (!out) fail(path, "cannot write image ({})", OIIO::geterror());
  OIIO::ImageSpec spec(img.width, img.height, 3, linear ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
  if (!out->open(path, spec)) fail(path, "cannot write image ({})", out->geterror());
  bool ok;
  if (linear) {
    ok = out->write_image(OIIO::TypeDesc::FLOAT, img.pixels.data());
  } else {
    std::vector<unsigned char> px(img.pixels.size() * 3);
    for (size_t i = 0; i < img.pixels.size(); ++i)
      for (int c = 0; c < 3; ++c) px[3 * i + c] = (unsigned char)std::lround(255.0f * toSRGB(img.pixels[i][c]));
    ok = out->write_image(OIIO::TypeDesc::UINT8, px.data());
  }
  if (!ok || !out->close()) fail(path, "cannot write image ({})", out->geterror());
}

}  // namespace oblong
