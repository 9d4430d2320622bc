// Pinhole camera: pixel (x, y) -> primary ray, y = 0 the top row.
#pragma once

#include "core/scene.h"

namespace oblong {

class PinholeCamera {
 public:
  PinholeCamera(const Camera& c, ivec2 size);
  // (px, py) continuous pixel coordinates, (0,0) top-left corner of the image.
  Ray generate(float px, float py) const;

 private:
  vec3 o_, forward_, right_, up_;
  float tanHalf_, aspect_;
  ivec2 size_;
};

}  // namespace oblong
