// RGB float images written through OpenImageIO: PNG/JPEG get sRGB-encoded 8-bit,
// EXR/HDR/TIFF/PFM float keep linear values.
#pragma once

#include "core/math.h"

#include <string>
#include <vector>

namespace oblong {

struct Image {
  int width = 0, height = 0;
  std::vector<vec3> pixels;  // row-major, row 0 at the top
  Image(int w, int h) : width(w), height(h), pixels(size_t(w) * h, vec3(0.0f)) {}
  vec3& at(int x, int y) { return pixels[size_t(y) * width + x]; }
  const vec3& at(int x, int y) const { return pixels[size_t(y) * width + x]; }
};

// Throws oblong::Error naming the file when it cannot be written (render/output.h: a
// temporary file renamed into place, every write checked). .pfm is written by hand
// (OpenImageIO reads PFM but cannot write it).
void writeImage(const Image& img, const std::string& path);
// Before any work: the path can be written (checkOutputPath) and names a format.
void checkImageOutput(const std::string& path, const std::string& what = "image");

// Pixels of `channels` interleaved values (float32, or uint8 when `float32` is false),
// written through OpenImageIO in the format `path` names, so that any failed write is
// an error naming `path` and no truncated file is left (render/output.h). `names`
// labels the channels (empty: OpenImageIO's defaults); `zChannel` marks depth (-1: none).
struct ImagePixels {
  int width = 0, height = 0, channels = 3;
  bool float32 = true;
  const void* data = nullptr;
  std::vector<std::string> names;
  int zChannel = -1;
};
void writeImagePixels(const ImagePixels& px, const std::string& path, const std::string& what);

}  // namespace oblong
