#include "core/triangle.h"

#include <glm/gtc/matrix_inverse.hpp>

#include <cmath>
#include <limits>

namespace oblong {

vec3 roundToFloat(const dvec3& v) { return vec3(float(v.x), float(v.y), float(v.z)); }

namespace {
// min over s in [0,1] of |a + s (b - a)|^2
double minOnSegment2(const dvec3& a, const dvec3& b) {
  const dvec3 d = b - a;
  const double dd = glm::dot(d, d);
  double s = dd > 0 ? -glm::dot(a, d) / dd : 0.0;
  s = std::clamp(s, 0.0, 1.0);
  const dvec3 q = a + s * d;
  return glm::dot(q, q);
}
}  // namespace

float minInterpolatedNormalLength(const vec3& n0f, const vec3& n1f, const vec3& n2f) {
  const dvec3 n0(n0f), n1(n1f), n2(n2f);
  double best = std::min({minOnSegment2(n0, n1), minOnSegment2(n1, n2), minOnSegment2(n2, n0)});
  // Interior stationary point of |n0 + u (n1-n0) + v (n2-n0)|^2: 2x2 normal equations.
  const dvec3 e1 = n1 - n0, e2 = n2 - n0;
  const double a = glm::dot(e1, e1), b = glm::dot(e1, e2), c = glm::dot(e2, e2);
  const double r1 = -glm::dot(n0, e1), r2 = -glm::dot(n0, e2);
  const double det = a * c - b * b;
  if (det > 1e-300) {
    const double u = (r1 * c - r2 * b) / det, v = (a * r2 - b * r1) / det;
    if (u >= 0 && v >= 0 && u + v <= 1) {
      const dvec3 q = n0 + u * e1 + v * e2;
      best = std::min(best, glm::dot(q, q));
    }
  }
  return float(std::sqrt(best));
}

float invNormalLengthBound(float mf) {
  const double q = (1.0 / double(mf)) * (1.0 + 0x1p-20);
  float f = float(q);
  if (double(f) < q) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

bool DisplacedTriangle::prepare() {
  const vec3 c = glm::cross(p[1] - p[0], p[2] - p[0]);
  const float len = glm::length(c);
  area = 0.5f * len;
  faceNormal = len > 0 ? c / len : vec3(0.0f);
  uvBox = Rect{glm::min(t[0], glm::min(t[1], t[2])), glm::max(t[0], glm::max(t[1], t[2]))};
  const vec2 d1 = t[1] - t[0], d2 = t[2] - t[0];
  uvArea2 = d1.x * d2.y - d1.y * d2.x;
  if (uvArea2 != 0.0f) {
    // Columns d1, d2 map barycentrics (u,v) to uv offsets; invert in double.
    const glm::dmat2 m{dvec2(d1), dvec2(d2)};
    uvToBary = glm::mat2(glm::inverse(m));
  }
  minNormalLength = minInterpolatedNormalLength(n[0], n[1], n[2]);
  return len > 0 && uvArea2 != 0.0f && minNormalLength > 1e-6f && std::isfinite(len);
}

}  // namespace oblong
