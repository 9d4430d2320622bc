// Conservative 16-bit storage of (min, max) pairs, shared by the range queries' `bits: 16`
// option (docs/range_query.md, "16-bit storage"). A pair is two codes a <= b in one
// 32-bit word (a in the low half); it decodes to [base + a*step, base + b*step] with
// float arithmetic, unfused (the CPU build has no FMA contraction; the shader marks the
// decode `precise`), and encoding rounds outward so the decoded pair always contains the
// stored one: min rounded down, max rounded up. Decoding is monotone in the code, so the
// min/max of codes is the code of the min/max: a structure can be built on codes.
#pragma once

#include "core/math.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace oblong {

struct Quantizer16 {
  float base = 0.0f, step = 1.0f;

  // The range that codes cover: [0, 1] when the values lie in it (every 8/16-bit map, so
  // that edits within [0, 1] keep the same codes), else the values' own [min, max].
  static Interval rangeFor(const Interval& values) {
    if (values.isEmpty() || (values.lo >= 0.0f && values.hi <= 1.0f)) return {0.0f, 1.0f};
    return values;
  }
  static Quantizer16 over(const Interval& range) {
    Quantizer16 q;
    q.base = range.lo;
    const float span = range.hi - range.lo;
    q.step = span > 0.0f ? span / 65535.0f : 1.0f;
    if (!std::isfinite(q.step) || q.step <= 0.0f) q.step = std::numeric_limits<float>::min();
    // The top code must reach the range's max after rounding.
    while (q.decode(65535) < range.hi) q.step = std::nextafter(q.step, std::numeric_limits<float>::infinity());
    return q;
  }
  bool covers(const Interval& v) const { return v.isEmpty() || (v.lo >= base && v.hi <= decode(65535)); }

  float decode(uint32_t code) const {
    const float scaled = float(code) * step;
    return base + scaled;
  }
  // Largest code whose value is <= v (v >= base), smallest code whose value is >= v.
  uint32_t codeBelow(float v) const {
    double c = std::floor((double(v) - double(base)) / double(step));
    uint32_t k = uint32_t(std::clamp(c, 0.0, 65535.0));
    while (k > 0 && decode(k) > v) --k;
    while (k < 65535 && decode(k + 1) <= v) ++k;
    return k;
  }
  uint32_t codeAbove(float v) const {
    double c = std::ceil((double(v) - double(base)) / double(step));
    uint32_t k = uint32_t(std::clamp(c, 0.0, 65535.0));
    while (k < 65535 && decode(k) < v) ++k;
    while (k > 0 && decode(k - 1) >= v) --k;
    return k;
  }
  // An empty interval encodes as lo code 65535, hi code 0 (the identity of join16).
  uint32_t encode(const Interval& v) const {
    if (v.isEmpty()) return 0xffffu;
    return codeBelow(v.lo) | (codeAbove(v.hi) << 16);
  }
  Interval decodePair(uint32_t w) const {
    if ((w & 0xffffu) > (w >> 16)) return Interval::empty();
    return {decode(w & 0xffffu), decode(w >> 16)};
  }
};

// Union of two encoded pairs: min of the low codes, max of the high codes.
inline uint32_t join16(uint32_t a, uint32_t b) {
  const uint32_t lo = std::min(a & 0xffffu, b & 0xffffu), hi = std::max(a >> 16, b >> 16);
  return lo | (hi << 16);
}
constexpr uint32_t kEmpty16 = 0xffffu;

}  // namespace oblong
