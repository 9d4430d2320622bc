// Displacement maps (docs/design.md §1). A HeightMap holds the first channel of an image as
// float texels; a Displacement adds scale, bias and tiling and evaluates heights:
//   h(uv) = scale · (H(tiling ⊙ uv) + bias),
// H bilinear with texel centres at ((i+½)/W, (j+½)/H) and wrap addressing.
// Texel (i, j) is column i, row j of the file as read (row 0 = first scanline), so
// v = 0 is the image's top edge unless the scene asks for flip_v.
#pragma once

#include "core/math.h"
#include "core/memory.h"
#include "core/kernels/heights.h"
#include "core/kernels/texels.h"

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace oblong {

// An image file's pixels as float, read with every check a displacement map gets: the
// file must be a regular file; chunk lengths and the claimed size are checked against
// the file before anything is allocated; at most `maxPixels` pixels; what the image
// library prints while reading is captured and becomes part of the one error line (or
// one warning line for a file that loaded). `channels` > 0 reads that many channels
// (the first ones), 0 all of them. `what` names the image in messages.
struct ImageRead {
  int width = 0, height = 0, channels = 0;
  std::vector<float> px;   // interleaved, row 0 first
  std::string colorSpace;  // OpenImageIO's "oiio:ColorSpace"
};
ImageRead readImageFile(const std::string& path, int channels, int64_t maxPixels, const std::string& what);

class HeightMap {
 public:
  HeightMap() = default;
  HeightMap(int width, int height, std::vector<float> texels, std::string name = "<memory>");

  // Reads the first channel of any image OpenImageIO can read (8/16-bit integer as
  // [0,1], signed 16-bit as [-1,1], float as is). Errors name the file: missing, not a
  // regular file, unreadable, larger than kMaxSide per side or kMaxTexels in all,
  // any non-finite texel.
  static HeightMap load(const std::string& path, bool flipV = false);
  static constexpr int kMaxSide = 1 << 16;
  static constexpr int64_t kMaxTexels = int64_t(1) << 28;  // 1 GiB of float texels

  int width() const { return w_; }
  int height() const { return h_; }
  const std::string& name() const { return name_; }
  const std::vector<float>& texels() const { return texels_; }
  std::vector<float> takeTexels() && { return std::move(texels_); }

  // Texel with wrap (repeat) addressing; i, j may be any integers.
  float at(int i, int j) const { return texels_[size_t(wrap(j, h_)) * w_ + wrap(i, w_)]; }
  // Texel without wrapping (0 <= i < W, 0 <= j < H).
  float atUnchecked(int i, int j) const { return texels_[size_t(j) * w_ + i]; }

  // Edits a texel (wrap addressing). Structures built over the map are refreshed with
  // RangeQuery::update over the changed samples.
  void set(int i, int j, float v) { texels_[size_t(wrap(j, h_)) * w_ + wrap(i, w_)] = v; }

  Interval range() const;  // min and max texel
  size_t bytes() const { return texels_.size() * sizeof(float); }

  static int wrap(int i, int n) { return shared::wrapIndex(i, n); }

 private:
  int w_ = 0, h_ = 0;
  std::vector<float> texels_;
  std::string name_;
};

// A map applied to a mesh: scale, bias and tiling (docs/design.md §1).
struct Displacement {
  std::shared_ptr<const HeightMap> map;
  float scale = 1.0f;
  float bias = 0.0f;
  vec2 tiling{1.0f, 1.0f};
  // Level of detail (core/lod.h, docs/lod.md). At λ = lod > 0, `map` holds level
  // k = floor(λ)'s grid with the heights at λ, its sample (i, j) sits at level 0's
  // (2^k i, 2^k j), so uv 0 is at sample −sampleOffset = −½·2^-k; `level0` keeps the
  // full-resolution map. LoD off: lod 0, sampleOffset ½, no level0.
  float lod = 0.0f;
  double sampleOffset = 0.5;
  std::shared_ptr<const HeightMap> level0{};
  // Per-ray level of detail (docs/lod.md, "A λ per ray"): `map` is level k = lod's own
  // map and `next` level k + 1's; a ray at λ = k + f reads the heights of the surface at
  // λ, blended on the fly (raw(i, j, f)), bit for bit those of heightsAtLod(λ). Null
  // otherwise (one surface for every ray).
  std::shared_ptr<const HeightMap> next{};

  // Continuous sample coordinates of a uv: at level 0 the texel centre of texel (i, j)
  // is (i, j).
  dvec2 toSample(const vec2& uv) const { return toSample(dvec2(uv)); }
  dvec2 toSample(const dvec2& uv) const {
    return shared::dispToSample(uv, tiling, map->width(), map->height(), sampleOffset);
  }
  // uv of the sample point (i, j) (inverse of toSample).
  vec2 sampleToUV(double i, double j) const {
    return shared::dispSampleToUV(i, j, tiling, map->width(), map->height(), sampleOffset);
  }

  // The blend fraction f of a ray at level of detail `rayLod` (< 0: none) on this
  // displacement: 0 unless it blends per ray.
  float blendOf(float rayLod) const {
    if (!next || !(rayLod > lod)) return 0.0f;
    return std::min(float(double(rayLod) - double(lod)), 1.0f);
  }
  // Raw height of sample (i, j) for a ray with blend fraction f (blendOf).
  float raw(int i, int j, float f) const {
    if (next) [[unlikely]] return lodHeight(*map, *next, i, j, f);
    return map->at(i, j);
  }
  // The height at level k's point (i, j) of the surface at λ = k + f: level k's height
  // blended toward level k + 1's micro-geometry there (docs/lod.md; the formula is
  // core/kernels/heights.h's dispLodHeight).
  static float lodHeight(const HeightMap& level, const HeightMap& next, int i, int j, float f) {
    return shared::dispLodHeight(LodMaps{level, next}, i, j, f);
  }
  // The two levels, as the kernel (core/kernels/heights.h) reads them.
  struct LodMaps {
    const HeightMap& level;
    const HeightMap& next;
    friend float dispTexel(const LodMaps& m, int next, int i, int j) { return (next ? m.next : m.level).at(i, j); }
  };

  // Height of one sample point (grid vertex of the micro-geometry).
  float sampleHeight(int i, int j, float f = 0.0f) const { return scale * (raw(i, j, f) + bias); }
  // Raw texel interval -> height interval (scale may be negative).
  Interval toHeight(const Interval& raw) const {
    const float a = scale * (raw.lo + bias), b = scale * (raw.hi + bias);
    return {std::min(a, b), std::max(a, b)};
  }

  // The smooth surface's height: bilinear in the texels.
  float bilinear(const vec2& uv) const;
  // The micro-geometry's height: piecewise linear on the two triangles of each grid
  // cell split by the diagonal (i,j)-(i+1,j+1). Equal to bilinear() at grid points.
  float micro(const vec2& uv, float f = 0.0f) const;
  float microAtSample(const dvec2& s, float f = 0.0f) const;
};

}  // namespace oblong
