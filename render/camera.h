// Pinhole camera: pixel (x, y) -> primary ray, y = 0 the top row.
#pragma once

#include "core/scene.h"

#include <cmath>

namespace oblong {

class PinholeCamera {
 public:
  PinholeCamera(const Camera& c, ivec2 size);
  // (px, py) continuous pixel coordinates, (0,0) top-left corner of the image.
  Ray generate(float px, float py) const;
  // The angle one pixel subtends at the image centre (a ray cone's spread).
  float pixelSpread() const { return std::atan(2.0f * tanHalf_ / float(size_.y)); }

 private:
  vec3 o_, forward_, right_, up_;
  float tanHalf_, aspect_;
  ivec2 size_;
};

}  // namespace oblong
