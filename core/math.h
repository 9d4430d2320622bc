// Basic geometric types shared by every component: rays, intervals, axis-aligned
// boxes and uv rectangles. Plain structs, no virtuals, usable in hot loops.
#pragma once

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace oblong {

using glm::dvec2;
using glm::dvec3;
using glm::ivec2;
using glm::vec2;
using glm::vec3;
using glm::vec4;

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// v rounded to float, per component. Out of line on purpose: GCC 12.2's SLP vectorizer
// (-O2 and up, x86-64) drops the rounding of a vectorised double -> float conversion
// when the result is converted back to double in the same function, so
// `dvec3(vec3(d))` can come out as d (wrong code, seen on glm vectors; reproduced
// standalone). Code that reads back a rounded value calls this.
[[gnu::noinline]] vec3 roundToFloat(const dvec3& v);
// Largest scene coordinate (positions, displaced points, ray origins): the traversal
// multiplies up to three coordinates in float, and 2^120 stays below float's 2^128.
constexpr float kMaxCoordinate = 1099511627776.0f;  // 2^40

struct Ray {
  vec3 o{0.0f};
  vec3 d{0.0f, 0.0f, 1.0f};
  float tmin = 0.0f;
  float tmax = kInfinity;
  // The ray's level of detail under a per-ray rule (docs/lod.md); < 0: none (the
  // displacements' own surface).
  float lod = -1.0f;
  vec3 at(float t) const { return o + t * d; }
};

// Closed interval [lo, hi]; empty when lo > hi.
template <typename T>
struct IntervalT {
  T lo = std::numeric_limits<T>::infinity();
  T hi = -std::numeric_limits<T>::infinity();

  static IntervalT empty() { return {}; }
  bool isEmpty() const { return lo > hi; }
  T width() const { return hi - lo; }
  bool contains(T x) const { return lo <= x && x <= hi; }
  bool contains(const IntervalT& o) const { return o.isEmpty() || (lo <= o.lo && o.hi <= hi); }
  void extend(T x) {
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  void extend(const IntervalT& o) {
    lo = std::min(lo, o.lo);
    hi = std::max(hi, o.hi);
  }
  IntervalT intersect(const IntervalT& o) const { return {std::max(lo, o.lo), std::min(hi, o.hi)}; }
  friend bool operator==(const IntervalT&, const IntervalT&) = default;
};
using Interval = IntervalT<float>;
using IntervalD = IntervalT<double>;

struct AABB {
  vec3 lo{kInfinity};
  vec3 hi{-kInfinity};

  bool isEmpty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const AABB& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  vec3 extent() const { return hi - lo; }
  bool contains(const vec3& p) const {
    return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
  }

  // Slab test; returns the parametric interval of the ray inside the box clipped to
  // [ray.tmin, ray.tmax] (empty if missed). Rays starting inside get [tmin, t_exit].
  Interval intersect(const Ray& r) const {
    Interval t{r.tmin, r.tmax};
    for (int a = 0; a < 3; ++a) {
      const float inv = 1.0f / r.d[a];
      float t0 = (lo[a] - r.o[a]) * inv;
      float t1 = (hi[a] - r.o[a]) * inv;
      if (t0 > t1) std::swap(t0, t1);
      // NaN (0 * inf when the origin lies on a slab plane of a parallel ray) keeps t.
      if (t0 > t.lo) t.lo = t0;
      if (t1 < t.hi) t.hi = t1;
    }
    return t;
  }
};

// Axis-aligned rectangle in texture space (uv before tiling).
struct Rect {
  vec2 lo{0.0f};
  vec2 hi{0.0f};
  vec2 size() const { return hi - lo; }
  bool isEmpty() const { return lo.x > hi.x || lo.y > hi.y; }
};

}  // namespace oblong
