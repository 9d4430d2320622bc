// Conservative 16-bit storage of (min, max) pairs, shared by the range queries' `bits: 16`
// option (docs/range_query.md, "16-bit storage"). A pair is two codes a <= b in one
// 32-bit word (a in the low half); it decodes to [base + a*step, base + b*step] with
// float arithmetic, unfused (the CPU build has no FMA contraction; the shader marks the
// decode `precise`), and encoding rounds outward so the decoded pair always contains the
// stored one: min rounded down, max rounded up. Decoding is monotone in the code, so the
// min/max of codes is the code of the min/max: a structure can be built on codes.
#pragma once

#include "core/kernels/quantize16.h"
#include "core/math.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace oblong {

struct Quantizer16 {
  float base = 0.0f, step = 1.0f;
  float invStep = 1.0f;  // 1 / step: only for the encoder's first guess

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
    q.invStep = 1.0f / q.step;
    return q;
  }
  bool covers(const Interval& v) const { return v.isEmpty() || (v.lo >= base && v.hi <= decode(65535)); }

  float decode(uint32_t code) const { return shared::decodeCode16(base, step, code); }
  // Largest code whose value is <= v (v >= base), smallest code whose value is >= v.
  uint32_t codeBelow(float v) const {
    const float c = (v - base) * invStep;  // a guess, corrected by the loops
    uint32_t k = c >= 65535.0f ? 65535u : (c > 0.0f ? uint32_t(c) : 0u);
    while (k > 0 && decode(k) > v) --k;
    while (k < 65535 && decode(k + 1) <= v) ++k;
    return k;
  }
  uint32_t codeAbove(float v) const {
    const float c = std::ceil((v - base) * invStep);
    uint32_t k = c >= 65535.0f ? 65535u : (c > 0.0f ? uint32_t(c) : 0u);
    while (k < 65535 && decode(k) < v) ++k;
    while (k > 0 && decode(k - 1) >= v) --k;
    return k;
  }
  // One value (a sample): the code below it, and the same code when it decodes exactly
  // to the value, else the next one (codeBelow leaves decode(k + 1) > v).
  uint32_t encodeSample(float v) const {
    const uint32_t k = codeBelow(v);
    return k | ((decode(k) == v ? k : std::min<uint32_t>(k + 1, 65535u)) << 16);
  }
  // An empty interval encodes as lo code 65535, hi code 0 (the identity of join16).
  // Where the step is below the float spacing of the values, neighbouring codes decode to
  // the same float: the high code is kept >= the low one so the pair never reads as empty.
  uint32_t encode(const Interval& v) const {
    if (v.isEmpty()) return 0xffffu;
    const uint32_t lo = codeBelow(v.lo);
    return lo | (std::max(lo, codeAbove(v.hi)) << 16);
  }
  Interval decodePair(uint32_t w) const {
    if ((w & 0xffffu) > (w >> 16)) return Interval::empty();
    return {decode(w & 0xffffu), decode(w >> 16)};
  }
};

// A vector that leaves its elements uninitialised on resize: large structures are
// written in full by their (parallel) build, so a zero-fill would only add a serial pass
// over memory and fault every page in on one thread.
// Blocks of 4 MiB and more are 2 MiB-aligned and advised to use transparent huge pages
// (where the kernel leaves that to madvise): 512 times fewer page faults on first touch;
// smaller ones start on a 64-byte cache line.
void* allocateLarge(size_t bytes);
void deallocateLarge(void* p, size_t bytes);

template <typename T>
struct UninitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = UninitAllocator<U>;
  };
  UninitAllocator() = default;
  template <typename U>
  UninitAllocator(const UninitAllocator<U>&) {}
  T* allocate(size_t n) { return static_cast<T*>(allocateLarge(n * sizeof(T))); }
  void deallocate(T* p, size_t n) { deallocateLarge(p, n * sizeof(T)); }
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... A>
  void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};
template <typename T>
using UninitVector = std::vector<T, UninitAllocator<T>>;

// Union of two encoded pairs: min of the low codes, max of the high codes.
inline uint32_t join16(uint32_t a, uint32_t b) { return shared::joinCodes16(a, b); }
constexpr uint32_t kEmpty16 = 0xffffu;

}  // namespace oblong
