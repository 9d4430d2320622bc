#include "core/heightmap.h"

#include "core/error.h"
#include "core/input_file.h"

#include <OpenImageIO/imageio.h>

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>

namespace oblong {

HeightMap::HeightMap(int width, int height, std::vector<float> texels, std::string name)
    : w_(width), h_(height), texels_(std::move(texels)), name_(std::move(name)) {
  if (w_ <= 0 || h_ <= 0) fail(name_, "height map has size {}x{}", w_, h_);
  if (texels_.size() != size_t(w_) * size_t(h_))
    fail(name_, "height map has {} texels, expected {}x{}", texels_.size(), w_, h_);
  for (size_t k = 0; k < texels_.size(); ++k)
    if (!std::isfinite(texels_[k]))
      fail(name_, "non-finite height at texel ({}, {})", k % size_t(w_), k / size_t(w_));
}

namespace {
// OpenImageIO's messages may span several lines; errors are one line.
std::string oneLine(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Some image libraries print to stderr themselves (OpenImageIO 2.4 leaves libpng's
// default handlers in place: "libpng error: IDAT: Read error: hit end of file" before
// our own error line). While a map is read, file descriptor 2 goes to a temporary file;
// what was written there is returned by release(). Loads are serialised by a mutex,
// since the descriptor is process-wide; scene loading prints nothing else meanwhile.
class StderrCapture {
 public:
  StderrCapture() : lock_(mutex()) {
    std::fflush(stderr);
    tmp_ = std::tmpfile();
    if (tmp_) saved_ = ::dup(2);
    if (saved_ >= 0 && ::dup2(::fileno(tmp_), 2) < 0) {
      ::close(saved_);
      saved_ = -1;
    }
  }
  ~StderrCapture() { release(); }
  std::string release() {
    std::string text;
    if (saved_ >= 0) {
      std::fflush(stderr);
      ::dup2(saved_, 2);
      ::close(saved_);
      saved_ = -1;
      std::rewind(tmp_);
      char buf[512];
      size_t n;
      while ((n = std::fread(buf, 1, sizeof buf, tmp_)) > 0 && text.size() < 4096) text.append(buf, n);
    }
    if (tmp_) std::fclose(tmp_), tmp_ = nullptr;
    return text;
  }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  std::FILE* tmp_ = nullptr;
  int saved_ = -1;
};
// A corrupt header can claim far more pixels than the file holds; the pixels are
// allocated before they are read (by us and by the reader), so the claim is checked
// against the file size first. The bound is the least raw data the claimed pixels are
// (one sample per pixel at the file's bits per sample, rows padded to bytes; every format
// stores at least that) over the best compression the format's codec can reach. Formats
// and codecs without a known best case (JPEG's arithmetic coding, run lengths that scale
// like HDR's old RLE or BMP's end-of-bitmap, zstd, ...) get only the kMaxTexels limit.
void checkPixelsFit(const std::string& path, OIIO::ImageInput& in, const OIIO::ImageSpec& spec) {
  const std::string format = in.format_name();
  const std::string compression = spec.get_string_attribute("compression");
  double ratio = 0.0;
  const char* why = "";
  if (format == "png") {
    ratio = 1032.0, why = "deflate codes a match of at most 258 bytes in at least 2 bits: 1032:1 at most";
  } else if (format == "pnm") {
    ratio = 1.0, why = "uncompressed";
  } else if (format == "targa") {
    ratio = 128.0, why = "a run of at most 128 pixels takes at least 2 bytes";
  } else if (format == "tiff" || format == "openexr") {
    if (compression == "none") ratio = 1.0, why = "uncompressed";
    else if (compression == "zip" || compression == "zips" || compression == "deflate")
      ratio = 1032.0, why = "deflate codes a match of at most 258 bytes in at least 2 bits: 1032:1 at most";
    else if (compression == "packbits" || compression == "rle")
      ratio = 64.0, why = "a run of at most 128 bytes takes 2 bytes";
    else if (format == "tiff" && compression == "lzw")
      ratio = 4096.0, why = "an LZW code of at least 9 bits stands for fewer than 4096 bytes";
  }
  if (ratio == 0.0) return;
  std::error_code ec;
  const double size = double(std::filesystem::file_size(path, ec));
  if (ec) return;
  // Bits per sample as the file stores them: OIIO expands PNG palettes and 1-bit PNM.
  int bits = spec.get_int_attribute("oiio:BitsPerSample", 0);
  if (bits <= 0) {
    bits = int(spec.format.size()) * 8;
    for (const OIIO::TypeDesc& t : spec.channelformats) bits = std::min(bits, int(t.size()) * 8);
  }
  std::ifstream f(path, std::ios::binary);
  char head[26] = {};
  f.read(head, sizeof head);
  if (format == "png" && f.gcount() == 26) bits = std::max(1, int((unsigned char)head[24]));  // IHDR bit depth
  if (format == "pnm" && (head[1] == '1' || head[1] == '4')) bits = 1;                          // PBM
  const double raw = std::ceil(double(spec.width) * bits / 8.0) * double(spec.height);
  if (raw > ratio * size)
    fail(path,
         "header claims {}x{} pixels (at least {:.0f} bytes at {} bits per sample), more than this {:.0f}-byte {}{}{} "
         "file can hold ({})",
         spec.width, spec.height, raw, bits, size, format, compression.empty() ? "" : " ", compression, why);
}

// PNG chunks and EXR header attributes carry their own lengths, and libpng (a zTXt
// chunk) and OpenEXR (a string attribute) allocate that much before they read it: a
// 2 KiB file claiming 2 GiB takes 2 GiB. Both are walked here, by their magic numbers
// (OpenImageIO tries every reader whatever the extension), and a length that runs past
// the end of the file is refused before OpenImageIO opens it. What else is wrong with
// the file is left to the readers.
class Bytes {
 public:
  explicit Bytes(const std::string& path) : in_(path, std::ios::binary) {
    in_.seekg(0, std::ios::end);
    size_ = in_ ? uint64_t(in_.tellg()) : 0;
  }
  uint64_t size() const { return size_; }
  bool read(uint64_t at, void* dst, size_t n) {  // false past the end
    if (at > size_ || n > size_ - at) return false;
    in_.clear();
    in_.seekg(std::streamoff(at));
    in_.read(static_cast<char*>(dst), std::streamsize(n));
    return in_.gcount() == std::streamsize(n);
  }
  // A NUL-terminated name of at most `max` characters at `at`; nullopt if there is none.
  std::optional<std::string> name(uint64_t at, size_t max) {
    std::string s;
    for (char c; s.size() <= max && read(at + s.size(), &c, 1);) {
      if (c == '\0') return s;
      s += c;
    }
    return std::nullopt;
  }

 private:
  std::ifstream in_;
  uint64_t size_ = 0;
};

std::string printable(std::string s) {
  for (char& c : s)
    if (!std::isprint((unsigned char)c)) c = '?';
  return s;
}

void checkPngChunks(const std::string& path, Bytes& f) {
  // Signature, then chunks: length (big-endian, at most 2^31 - 1), type, data, CRC.
  for (uint64_t at = 8; at + 8 <= f.size();) {
    unsigned char h[8];
    f.read(at, h, 8);
    const uint32_t length = uint32_t(h[0]) << 24 | uint32_t(h[1]) << 16 | uint32_t(h[2]) << 8 | h[3];
    const std::string type = printable(std::string(reinterpret_cast<const char*>(h + 4), 4));
    const uint64_t left = f.size() - at - 8;
    if (uint64_t(length) + 4 > left)
      fail(path, "PNG chunk '{}' at byte {} claims {} bytes, more than the {} bytes left in the file", type, at,
           length, left >= 4 ? left - 4 : 0);
    if (type == "IEND") break;
    at += 12 + uint64_t(length);
  }
}

void checkExrHeader(const std::string& path, Bytes& f) {
  // Magic, version and flags, then each header: attributes (name NUL, type NUL, int32
  // size, value) up to an empty name; a multi-part file has headers up to an empty one.
  unsigned char v[4];
  if (!f.read(4, v, 4)) return;
  const bool longNames = v[1] & 0x04, multipart = v[1] & 0x10;
  const size_t maxName = longNames ? 255 : 31;
  uint64_t at = 8;
  for (bool more = true; more;) {
    for (;;) {
      const auto name = f.name(at, maxName);
      if (!name) return;
      at += name->size() + 1;
      if (name->empty()) break;
      const auto type = f.name(at, maxName);
      if (!type) return;
      at += type->size() + 1;
      unsigned char b[4];
      if (!f.read(at, b, 4)) return;
      at += 4;
      const int32_t size = int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
      const uint64_t left = f.size() - at;
      if (size < 0 || uint64_t(size) > left)
        fail(path, "EXR header attribute '{}' ({}) at byte {} claims {} bytes, more than the {} bytes left in the file",
             printable(*name), printable(*type), at - 4 - type->size() - 1 - name->size() - 1, size, left);
      at += uint64_t(size);
    }
    char c = 0;
    more = multipart && f.read(at, &c, 1) && c != '\0';
  }
}

void checkLengths(const std::string& path) {
  Bytes f(path);
  unsigned char magic[8] = {};
  if (!f.read(0, magic, 8)) return;
  if (std::memcmp(magic, "\x89PNG\r\n\x1a\n", 8) == 0) checkPngChunks(path, f);
  else if (std::memcmp(magic, "\x76\x2f\x31\x01", 4) == 0) checkExrHeader(path, f);
}
}  // namespace

ImageRead readImageFile(const std::string& path, int channels, int64_t maxPixels, const std::string& what) {
  // Checked first: OpenImageIO would block on a FIFO or read a device forever.
  checkInputFile(path);
  checkLengths(path);
  StderrCapture capture;
  // Unassociated: OpenImageIO would otherwise multiply the first channel of a grey+alpha
  // PNG (or TIFF) by its alpha, and the heights with it.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    std::string err = oneLine(OIIO::geterror());
    if (err.empty()) err = oneLine(capture.release());
    if (err.empty()) err = "cannot open image";
    // OIIO prefixes its messages with the file name already in some versions.
    fail(path, "cannot read {} ({})", what, err);
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
    fail(path, "image has no pixels");
  if (spec.depth > 1) fail(path, "3D (volume) images are not {}s", what);
  const int C = channels > 0 ? std::min(channels, spec.nchannels) : spec.nchannels;
  // A corrupt header must not turn into a huge allocation (std::bad_alloc is no message).
  if (spec.width > HeightMap::kMaxSide || spec.height > HeightMap::kMaxSide ||
      int64_t(spec.width) * spec.height > maxPixels || C > 64)
    fail(path, "image is {}x{} with {} channels: larger than the supported {}x{}, {} pixels or 64 channels",
         spec.width, spec.height, C, HeightMap::kMaxSide, HeightMap::kMaxSide, maxPixels);
  checkPixelsFit(path, *in, spec);
  ImageRead r;
  r.width = spec.width, r.height = spec.height, r.channels = C;
  r.colorSpace = spec.get_string_attribute("oiio:ColorSpace");
  r.px.resize(size_t(spec.width) * size_t(spec.height) * size_t(C));
  if (!in->read_image(0, 0, 0, C, OIIO::TypeDesc::FLOAT, r.px.data())) {
    std::string err = oneLine(in->geterror());
    if (err.empty()) err = oneLine(capture.release());
    fail(path, "cannot read pixels ({})", err.empty() ? "unknown error" : err);
  }
  in->close();
  // A library's own complaint about a file that did load: one warning line.
  if (const std::string said = oneLine(capture.release()); !said.empty())
    eprint("oblong: warning: {}: {}\n", path, said);
  return r;
}

HeightMap HeightMap::load(const std::string& path, bool flipV) {
  ImageRead img = readImageFile(path, 1, kMaxTexels, "displacement map");
  std::vector<float> texels = std::move(img.px);
  if (flipV) {
    for (int j = 0; j < img.height / 2; ++j)
      std::swap_ranges(texels.begin() + size_t(j) * img.width,
                       texels.begin() + size_t(j + 1) * img.width,
                       texels.begin() + size_t(img.height - 1 - j) * img.width);
  }
  return HeightMap(img.width, img.height, std::move(texels), path);
}

Interval HeightMap::range() const {
  Interval r;
  for (float t : texels_) r.extend(t);
  return r;
}

float Displacement::bilinear(const vec2& uv) const {
  const dvec2 s = toSample(uv);
  const double fi = std::floor(s.x), fj = std::floor(s.y);
  const int i = int(fi), j = int(fj);
  const float fx = float(s.x - fi), fy = float(s.y - fj);
  const float h00 = map->at(i, j), h10 = map->at(i + 1, j);
  const float h01 = map->at(i, j + 1), h11 = map->at(i + 1, j + 1);
  const float H = (1 - fy) * ((1 - fx) * h00 + fx * h10) + fy * ((1 - fx) * h01 + fx * h11);
  return scale * (H + bias);
}

namespace {
// The heights of one ray, as the kernel (core/kernels/heights.h) reads them.
struct RayHeights {
  const Displacement& d;
  float f;
  friend float dispRaw(const RayHeights& h, int i, int j) { return h.d.raw(i, j, h.f); }
};
}  // namespace

float Displacement::microAtSample(const dvec2& s, float f) const {
  return shared::dispMicroAt(RayHeights{*this, f}, s, scale, bias);
}

float Displacement::micro(const vec2& uv, float f) const { return microAtSample(toSample(uv), f); }

}  // namespace oblong
