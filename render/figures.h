// Images for reading and comparing results: false-colour maps with a numbered colour bar
// (the step heat map of `render --heatmap`, the error image of `oblong compare`) and the
// comparison of two images (relMSE, PSNR) behind `oblong compare`.
#pragma once

#include "render/renderer.h"

#include <cstdint>
#include <string>
#include <vector>

namespace oblong {

// The colour scale of a false-colour map. Steps: log(1 + v) / log(1 + max), 0 at the left
// end. Decades: log10(v) from max / 10^decades to max. Values above max take the top colour.
struct ColourScale {
  enum class Kind { Steps, Decades } kind = Kind::Steps;
  float max = 1.0f;
  int decades = 3;
  // Under the bar: what the values are, with their unit; the first that fits the width
  // (longest first), none when none does.
  std::vector<std::string> captions;
  float position(float v) const;  // 0 .. 1 along the bar
};

// What a false-colour map was written with.
struct FalseColourResult {
  bool labelled = true;  // false: no font was found, the bar has no numbers
  int width = 0, height = 0;  // the file's size: the image's, and the bar's rows below it
};

// `values` (W x H, row-major) in false colour with the colour bar, its numbers and the
// caption below the image, as an 8-bit image (PNG, ...). A value that is not > 0 (no step,
// no error) or not finite is black. The numbers are drawn with OpenImageIO's render_text
// in DejaVu Sans (Debian's fonts-dejavu-core).
FalseColourResult writeFalseColour(const std::vector<float>& values, int W, int H, const ColourScale& scale,
                                   const std::string& path);

// The heat map of steps per camera ray (RMIP paper Fig. 9): `fixedMax` > 0 is the top of the
// scale (so that maps of different runs compare), otherwise the image's own maximum.
struct HeatMapScale {
  float max = 1.0f;        // the top of the colour bar
  float imageMax = 0.0f;   // the largest step count in the image
  bool fixed = false;      // max came from fixedMax
  int64_t pixelsAbove = 0; // pixels above max (drawn in the top colour)
};
HeatMapScale heatMapScale(const AOVs& aov, float fixedMax = 0.0f);
FalseColourResult writeHeatMap(const AOVs& aov, const std::string& path, const HeatMapScale& scale);

// `oblong compare A B`: B is the reference. Both are read as linear RGB (8-bit sRGB files
// such as PNG decoded to linear; one channel is grey). Throws oblong::Error naming a file
// when it cannot be read, has non-finite values, or the sizes differ.
//   relMSE = mean over pixels and the 3 channels of (a - b)^2 / (b^2 + 0.01)
//   PSNR   = 10 log10(1 / MSE) dB, MSE the mean of (a - b)^2 (peak value 1)
struct Comparison {
  int width = 0, height = 0;
  double relMSE = 0, mse = 0, psnr = 0;  // psnr: +inf for identical images
  std::vector<float> perPixel;            // each pixel's relative squared error, mean over RGB
  float maxPerPixel = 0;
};
Comparison compareImages(const std::string& a, const std::string& reference);

}  // namespace oblong
