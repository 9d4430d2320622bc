#include "render/image.h"

#include "core/error.h"
#include "render/output.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <sys/statvfs.h>

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

// A library message on one line (docs/bad_input.md).
std::string oneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Why a written file may not read back: say so when its filesystem is full.
std::string spaceLeftNote(const std::string& file) {
  struct statvfs fs {};
  const std::string folder = std::filesystem::path(file).parent_path().string();
  if (::statvfs(folder.empty() ? "." : folder.c_str(), &fs) == 0 && fs.f_bavail == 0)
    return ": No space left on device";
  return "";
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

// OpenImageIO's file writers go through stdio and ignore a failed fwrite: on a full
// disk a PNG came out empty or cut short with no error. So the image is encoded into
// memory where the format's writer accepts an IOProxy (PNG, EXR, TIFF, HDR, JPEG, BMP,
// TGA, PPM, ...) and its bytes written with every write checked; a format without one is
// written to the file directly and then read back whole, which a cut file fails.
void writeImagePixels(const ImagePixels& px, const std::string& path, const std::string& what) {
  const OIIO::TypeDesc type = px.float32 ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8;
  OIIO::ImageSpec spec(px.width, px.height, px.channels, type);
  if (!px.names.empty()) spec.channelnames = px.names;
  if (px.zChannel >= 0) spec.z_channel = px.zChannel;
  writeOutput(path, [&](const std::string& tmp) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) fail(path, "cannot write {} ({})", what, oneLine(OIIO::geterror()));
    const bool inMemory = out->supports("ioproxy");
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput vec(bytes);
    if (inMemory && !out->set_ioproxy(&vec)) fail(path, "cannot write {} ({})", what, oneLine(out->geterror()));
    if (!out->open(tmp, spec) || !out->write_image(type, px.data) || !out->close())
      fail(path, "cannot write {} ({})", what, oneLine(out->geterror()));
    if (inMemory) return writeFileBytes(tmp, path, bytes.data(), bytes.size());
    auto in = OIIO::ImageInput::open(tmp);
    std::vector<unsigned char> back(size_t(px.width) * px.height * px.channels * type.size());
    if (!in || in->spec().width != px.width || in->spec().height != px.height ||
        !in->read_image(0, 0, 0, px.channels, type, back.data()))
      fail(path, "write failed (the written file does not read back{})", spaceLeftNote(tmp));
  });
}

void writeImage(const Image& img, const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".pfm") return writeTextOutput(path, encodePFM(img));
  const bool linear = ext == ".exr" || ext == ".hdr" || ext == ".tif" || ext == ".tiff";
  ImagePixels px{img.width, img.height, 3, linear, img.pixels.data(), {}, -1};
  std::vector<unsigned char> bytes;
  if (!linear) {
    bytes.resize(img.pixels.size() * 3);
    for (size_t i = 0; i < img.pixels.size(); ++i)
      for (int c = 0; c < 3; ++c) bytes[3 * i + c] = (unsigned char)std::lround(255.0f * toSRGB(img.pixels[i][c]));
    px.data = bytes.data();
  }
  writeImagePixels(px, path, "image");
}

}  // namespace oblong
