#include "render/camera.h"

namespace oblong {

PinholeCamera::PinholeCamera(const Camera& c, ivec2 size) : o_(c.from), size_(size) {
  forward_ = glm::normalize(c.to - c.from);
  right_ = glm::normalize(glm::cross(forward_, c.up));
  up_ = glm::cross(right_, forward_);
  tanHalf_ = std::tan(glm::radians(c.fovY) * 0.5f);
  aspect_ = float(size.x) / float(size.y);
}

Ray PinholeCamera::generate(float px, float py) const {
  const float sx = (2.0f * px / size_.x - 1.0f) * tanHalf_ * aspect_;
  const float sy = (1.0f - 2.0f * py / size_.y) * tanHalf_;
  Ray r;
  r.o = o_;
  r.d = glm::normalize(forward_ + sx * right_ + sy * up_);
  return r;
}

}  // namespace oblong
