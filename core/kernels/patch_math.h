// Per-patch math shared word for word by the CPU traversal and the Vulkan shaders: this
// file compiles as C++ (included by traversal/psi.h, functions in
// oblong::shared) and as GLSL (included by render/vulkan/shaders/traversal.glsl, which
// defines finiteD, copysignD and kInfD before it). Only the common subset of the two
// languages is used: scalars and fixed arrays, `OBLONG_OUT` for GLSL's out parameters
// (C++ arrays are passed by pointer), `OBLONG_PRECISE` for GLSL's `precise` (no fused or
// reordered arithmetic, as the CPU's strict IEEE double). An unsuffixed literal is a
// float in GLSL; glslang folds its conversion to double from the literal's own double
// value (core/kernels/constants.h), so both sides use the same constants.
//
// Functions move here from psi.h, prism.cpp, rect_bounds.h and the shaders one at a
// time; the parity test (tests/vulkan_test.cpp) checks the rest of the mirror.
#ifndef OBLONG_TRAVERSAL_PATCH_MATH_H
#define OBLONG_TRAVERSAL_PATCH_MATH_H

#ifdef __cplusplus
#include <algorithm>
#include <cmath>
#include <limits>
namespace oblong::shared {
using std::abs;
using std::max;
using std::min;
using std::sqrt;
inline bool finiteD(double x) { return std::isfinite(x); }
inline double copysignD(double m, double s) { return std::copysign(m, s); }
constexpr double kInfD = std::numeric_limits<double>::infinity();
#define OBLONG_INLINE inline
#define OBLONG_OUT
#define OBLONG_PRECISE
#else
#define OBLONG_INLINE
#define OBLONG_OUT out
#define OBLONG_PRECISE precise
#endif

// Real roots of q2 w² + q1 w + q0 (stable formulas; a slightly negative discriminant
// counts as a double root). pad[k] bounds the error of root k: an error δ of the
// polynomial's value (coefficients rounded relative 1e-13) moves a simple root by
// δ / |q'(w)|, a double root by at most √(δ / |q2|). Returns the count (0..2); a
// quadratic that vanishes identically returns -1.
OBLONG_INLINE int quadraticRoots(double q2, double q1, double q0, OBLONG_OUT double w[2], OBLONG_OUT double pad[2]) {
  w[0] = 0.0;
  w[1] = 0.0;
  pad[0] = 0.0;
  pad[1] = 0.0;
  double scale = max(max(abs(q2), abs(q1)), abs(q0));
  if (!(scale > 0.0) || !finiteD(scale)) return scale == 0.0 ? -1 : 0;
  double e = 1e-14;
  int n = 0;
  if (abs(q2) <= e * scale) {  // linear (a huge second root is dropped)
    if (abs(q1) <= e * scale) return abs(q0) <= e * scale ? -1 : 0;
    w[n++] = -q0 / q1;
  } else {
    OBLONG_PRECISE double disc = q1 * q1 - 4.0 * q2 * q0;
    OBLONG_PRECISE double discErr = 1e-13 * (q1 * q1 + 4.0 * abs(q2 * q0));
    if (disc < 0.0) {
      if (disc < -discErr) return 0;
      disc = 0.0;
    }
    OBLONG_PRECISE double q = -0.5 * (q1 + copysignD(sqrt(disc), q1));
    if (q != 0.0) {
      w[n++] = q / q2;
      w[n++] = q0 / q;
    } else {
      w[n++] = -q1 / (2.0 * q2);
    }
  }
  for (int k = 0; k < n; ++k) {
    OBLONG_PRECISE double x = w[k];
    OBLONG_PRECISE double delta = 1e-13 * (abs(q2) * x * x + abs(q1 * x) + abs(q0));
    OBLONG_PRECISE double slope = abs(2.0 * q2 * x + q1);
    // min(δ / |q'|, √(δ / |q2|)), the square root only where it is the smaller
    // (δ·|q2| ≥ q'²; at a near-tie the two agree to rounding).
    OBLONG_PRECISE double a2 = abs(q2);
    OBLONG_PRECISE double p = kInfD;
    if (a2 > 0.0 && !(delta * a2 < slope * slope)) p = sqrt(delta / a2);
    else if (slope > 0.0) p = delta / slope;
    pad[k] = 4.0 * p + 1e-14 * abs(x);
  }
  return n;
}

#undef OBLONG_INLINE
#undef OBLONG_OUT
#undef OBLONG_PRECISE
#ifdef __cplusplus
}  // namespace oblong::shared
#endif

#endif
