#include "render/image.h"

#include "core/error.h"
#include "render/output.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>

namespace oblong {

namespace {
float toSRGB(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

// Portable float map (RGB): OpenImageIO reads it but has no writer. Rows go bottom to
// top; a negative scale means little-endian floats.
std::string encodePFM(const Image& img) {
  std::string out = fmt::format("PF\n{} {}\n-1.0\n", img.width, img.height);
  const size_t head = out.size();
  out.resize(head + size_t(img.width) * img.height * 3 * sizeof(float));
  char* o = out.data() + head;
  for (int y = img.height - 1; y >= 0; --y)
    for (int x = 0; x < img.width; ++x) {
      std::memcpy(o, &img.at(x, y), 3 * sizeof(float));  // x86-64 and arm64: little-endian
      o += 3 * sizeof(float);
    }
  return out;
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace

void checkImageOutput(const std::string& path, const std::string& what) {
  checkOutputPath(path, what);
  if (lowerExtension(path) == ".pfm") return;
  if (!OIIO::ImageOutput::create(path)) {
    const std::string ext = lowerExtension(path);
    fail(path, "cannot write {}: no image format for '{}' (use .png, .exr, .tif, .hdr, .pfm, ...)", what,
         ext.empty() ? std::string("a name without extension") : ext);
  }
}

void writeImage(const Image& img, const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".pfm") return writeTextOutput(path, encodePFM(img));
  const bool linear = ext == ".exr" || ext == ".hdr" || ext == ".tif" || ext == ".tiff";
  writeOutput(path, [&](const std::string& tmp) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) fail(path, "cannot write image ({})", OIIO::geterror());
    OIIO::ImageSpec spec(img.width, img.height, 3, linear ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
    if (!out->open(tmp, spec)) fail(path, "cannot write image ({})", out->geterror());
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
  });
}

}  // namespace oblong
