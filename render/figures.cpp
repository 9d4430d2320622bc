#include "render/figures.h"

#include "core/error.h"
#include "core/heightmap.h"
#include "render/image.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace oblong {

namespace {

// A compact perceptual colour map (viridis-like, 5 stops, linear in between).
vec3 colormap(float t) {
  static const vec3 stops[] = {{0.267f, 0.005f, 0.329f}, {0.229f, 0.322f, 0.546f}, {0.128f, 0.567f, 0.551f},
                               {0.369f, 0.789f, 0.383f}, {0.993f, 0.906f, 0.144f}};
  t = std::clamp(t, 0.0f, 1.0f) * 4.0f;
  const int i = std::min(3, int(t));
  return glm::mix(stops[i], stops[i + 1], t - float(i));
}

// writeImage sRGB-encodes 8-bit files, so display values are stored decoded.
vec3 linear(vec3 display) { return glm::pow(display, vec3(2.2f)); }

constexpr const char* kFont = "DejaVuSans";

// A number as short as it reads on a bar: steps (means over samples: one decimal where not
// whole), errors with two digits.
std::string label(float v, ColourScale::Kind kind) {
  if (kind == ColourScale::Kind::Steps)
    return v == std::round(v) ? fmt::format("{:.0f}", v) : fmt::format("{:.1f}", v);
  return fmt::format("{:.2g}", v);
}

struct Tick {
  float value;
  std::string text;
};

std::vector<Tick> ticks(const ColourScale& s) {
  std::vector<Tick> t;
  if (s.kind == ColourScale::Kind::Steps) {
    t.push_back({0.0f, "0"});
    for (float p = 1.0f; p < s.max * 0.999f; p *= 10.0f) t.push_back({p, label(p, s.kind)});
  } else {
    const float lo = s.max * std::pow(10.0f, -float(s.decades));
    // Whole decades inside the range, so the numbers read as powers of ten.
    t.push_back({lo, label(lo, s.kind)});
    // At most one tick a decade (a bounded loop even if lo were 0 or a subnormal).
    float p = std::pow(10.0f, std::ceil(std::log10(lo) + 1e-4f));
    for (int d = 0; d < s.decades && p > 0 && p < s.max * 0.999f; ++d, p *= 10.0f) t.push_back({p, label(p, s.kind)});
  }
  t.push_back({s.max, label(s.max, s.kind)});
  return t;
}

}  // namespace

float ColourScale::position(float v) const {
  if (!(v > 0)) return 0.0f;
  if (kind == Kind::Steps) return std::clamp(std::log1p(v) / std::log1p(std::max(max, 1e-6f)), 0.0f, 1.0f);
  const float lo = max * std::pow(10.0f, -float(decades));
  return std::clamp(std::log10(v / lo) / float(decades), 0.0f, 1.0f);
}

FalseColourResult writeFalseColour(const std::vector<float>& values, int W, int H, const ColourScale& scale,
                                   const std::string& path) {
  // The bar's proportions follow the width, so a thumbnail and a full frame both read.
  const int fs = std::clamp(W / 28, 9, 18);  // font size, pixels
  const int gap = std::max(2, fs / 4), strip = std::max(6, fs), tickLen = std::max(2, fs / 4);
  const int barH = gap + strip + tickLen + 2 * (fs + gap) + fs / 2;  // the caption's descenders too
  Image img(W, H + barH);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float v = values[size_t(y) * W + x];
      img.at(x, y) = (v > 0 && std::isfinite(v)) ? linear(colormap(scale.position(v))) : vec3(0.0f);
    }
  const int y0 = H + gap;
  for (int y = y0; y < y0 + strip; ++y)
    for (int x = 0; x < W; ++x) img.at(x, y) = linear(colormap(float(x) / float(std::max(1, W - 1))));

  // The numbers and the caption go into a buffer of the bar's size, then into the image.
  OIIO::ImageBuf text(OIIO::ImageSpec(W, barH, 3, OIIO::TypeDesc::FLOAT));
  OIIO::ImageBufAlgo::zero(text);
  const int yTick = gap + strip;
  const std::vector<Tick> tk = ticks(scale);
  bool labelled = true;
  int lastRight = std::numeric_limits<int>::min() / 2;
  const int rightEdge = W - 1;
  const int lastWidth = OIIO::ImageBufAlgo::text_size(tk.back().text, fs, kFont).width();
  OIIO::geterror();  // a missing font is reported through the return values below
  for (size_t i = 0; i < tk.size(); ++i) {
    const int x = int(std::lround(scale.position(tk[i].value) * float(W - 1)));
    const OIIO::ROI r = OIIO::ImageBufAlgo::text_size(tk[i].text, fs, kFont);
    if (!r.defined()) {
      labelled = false;
      break;
    }
    const int w = r.width();
    // The ends are aligned inside the image; a middle number that would touch a neighbour
    // is left out (the ends always stay).
    int left = i == 0 ? 0 : (i + 1 == tk.size() ? rightEdge - w : x - w / 2);
    left = std::clamp(left, 0, std::max(0, rightEdge - w));
    const bool last = i + 1 == tk.size();
    if (!last && (left < lastRight + fs / 2 || left + w > rightEdge - lastWidth - fs / 2) && i != 0) continue;
    for (int t = 0; t < tickLen; ++t)
      for (int c = 0; c < 3; ++c) text.setpixel(std::clamp(x, 0, W - 1), yTick + t, c, 1.0f);
    if (!OIIO::ImageBufAlgo::render_text(text, left, yTick + tickLen + gap / 2, tk[i].text, fs, kFont, 1.0f,
                                         OIIO::ImageBufAlgo::TextAlignX::Left, OIIO::ImageBufAlgo::TextAlignY::Top)) {
      labelled = false;
      break;
    }
    lastRight = left + w;
  }
  for (const std::string& caption : scale.captions) {
    if (!labelled || OIIO::ImageBufAlgo::text_size(caption, fs, kFont).width() > W - 2) continue;
    labelled = OIIO::ImageBufAlgo::render_text(text, W / 2, yTick + tickLen + fs + 2 * gap, caption, fs, kFont,
                                               0.85f, OIIO::ImageBufAlgo::TextAlignX::Center,
                                               OIIO::ImageBufAlgo::TextAlignY::Top);
    break;
  }
  if (!labelled) OIIO::geterror();  // cleared: the caller warns
  for (int y = 0; y < barH; ++y)
    for (int x = 0; x < W; ++x) {
      float c[3];
      text.getpixel(x, y, c, 3);
      if (c[0] > 0) img.at(x, H + y) = linear(vec3(c[0], c[1], c[2]));
    }
  writeImage(img, path);
  return {labelled, W, H + barH};
}

HeatMapScale heatMapScale(const AOVs& aov, float fixedMax) {
  HeatMapScale s;
  for (float v : aov.steps) s.imageMax = std::max(s.imageMax, v);
  s.fixed = fixedMax > 0;
  s.max = s.fixed ? fixedMax : std::max(1.0f, s.imageMax);
  for (float v : aov.steps) s.pixelsAbove += v > s.max;
  return s;
}

FalseColourResult writeHeatMap(const AOVs& aov, const std::string& path, const HeatMapScale& scale) {
  ColourScale cs;
  cs.kind = ColourScale::Kind::Steps;
  cs.max = scale.max;
  cs.captions = {"traversal steps per camera ray, log scale", "steps per camera ray, log", "steps, log"};
  return writeFalseColour(aov.steps, aov.color.width, aov.color.height, cs, path);
}

namespace {

struct RGB {
  int width = 0, height = 0;
  std::vector<float> px;  // 3 per pixel, linear
};

float srgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

RGB readRGB(const std::string& path) {
  // The height maps' reader and checks (a regular file, a header's claims against the
  // file's size, the library's messages on one line); at most render's 2^26 pixels.
  const ImageRead in = readImageFile(path, 0, int64_t(1) << 26, "image");
  const int C = in.channels, W = in.width;
  const bool srgb = OIIO::Strutil::iequals(in.colorSpace, "sRGB");
  RGB img;
  img.width = in.width, img.height = in.height;
  img.px.resize(size_t(in.width) * in.height * 3);
  for (size_t i = 0; i < size_t(in.width) * in.height; ++i)
    for (int c = 0; c < 3; ++c) {
      const float v = in.px[i * C + (C >= 3 ? c : 0)];
      if (!std::isfinite(v)) fail(path, "pixel ({}, {}) is not finite ({})", i % W, i / W, v);
      img.px[i * 3 + c] = srgb ? srgbToLinear(v) : v;
    }
  return img;
}

}  // namespace

Comparison compareImages(const std::string& a, const std::string& reference) {
  const RGB A = readRGB(a), B = readRGB(reference);
  if (A.width != B.width || A.height != B.height)
    fail(a, "is {}x{}, the reference {} is {}x{}: only images of the same size compare", A.width, A.height,
         reference, B.width, B.height);
  Comparison r;
  r.width = A.width, r.height = A.height;
  const size_t n = size_t(A.width) * A.height;
  r.perPixel.resize(n);
  double rel = 0, sq = 0;
  for (size_t i = 0; i < n; ++i) {
    double pr = 0;
    for (int c = 0; c < 3; ++c) {
      const double d = double(A.px[i * 3 + c]) - double(B.px[i * 3 + c]), b = B.px[i * 3 + c];
      pr += d * d / (b * b + 1e-2);
      sq += d * d;
    }
    rel += pr;
    r.perPixel[i] = float(pr / 3.0);
    r.maxPerPixel = std::max(r.maxPerPixel, r.perPixel[i]);
  }
  r.relMSE = rel / double(3 * n);
  r.mse = sq / double(3 * n);
  r.psnr = r.mse > 0 ? 10.0 * std::log10(1.0 / r.mse) : std::numeric_limits<double>::infinity();
  return r;
}

}  // namespace oblong
