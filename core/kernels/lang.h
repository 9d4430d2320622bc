// The common subset of C++ and GLSL that the headers of core/kernels/ are written in:
// each of them compiles as C++ (functions in oblong::shared) and as GLSL (included by
// render/vulkan/shaders/traversal.glsl), so a per-patch formula exists once for the CPU
// traversal and the Vulkan shaders (docs/architecture.md, "The CPU/GPU contract").
//
// What the subset allows: scalars, glm vectors under GLSL's names (dvec3, ivec2, ...),
// plain structs without initialisers or member functions, fixed arrays, and free
// functions whose parameters are written with the macros below:
//   OBLONG_IN(T)    a read-only argument    (C++ const T&, GLSL in T)
//   OBLONG_OUT(T)   an out argument         (C++ T&,       GLSL out T)
//   OBLONG_INOUT(T) an in-out argument      (C++ T&,       GLSL inout T)
//   OBLONG_IN_ARRAY before an array parameter that is read (C++ const)
//   OBLONG_OUT_ARRAY before an array parameter that is written (GLSL out; C++ arrays
//                   are passed by pointer)
//   OBLONG_FORCE_INLINE on hot C++ paths (GLSL inlines every call anyway)
//   OBLONG_PRECISE  on every declaration whose arithmetic must not be fused or
//                   reordered (GLSL precise; the CPU's strict IEEE double needs nothing)
//   OBLONG_TEMPLATE1(A), OBLONG_TEMPLATE2(A, B) before a function over types that each
//                   language supplies: C++ template parameters, GLSL macros the including shader defines
//                   (with the functions the kernel calls on them)
// min, max and abs are GLSL's on both sides (for scalars: y < x ? y : x, as std::min);
// dotD, crossD, dotF, crossF (and lengthD, lengthF) are glm's formulas, which GLSL's
// built-ins need not follow; cbrtF is std::cbrt on the CPU and pow on the GPU. A float
// quotient or square root is written divF(a, b) / sqrtF(x): correctly rounded on both
// sides (GLSL's float `/` and sqrt are not, on every GPU). An
// unsuffixed literal is a float in GLSL and a double in C++; glslang folds its conversion
// to double from the literal's own double value, so in double expressions both sides use
// the same constants. Float arithmetic takes the f suffix (1.0f), read as a float by both
// languages; a quotient of literals (1.0 / 3.0) is folded in float by GLSL: compute such
// values on the host.
#ifndef OBLONG_KERNELS_LANG_H
#define OBLONG_KERNELS_LANG_H

#ifdef __cplusplus
#include <glm/glm.hpp>

#include <bit>
#include <cmath>
#include <limits>

namespace oblong::shared {
using glm::dvec2;
using glm::dvec3;
using glm::ivec2;
using glm::vec2;
using glm::vec3;
using glm::ivec3;
using glm::vec4;
using glm::ivec4;
using glm::bvec2;
using uint = unsigned int;
// Scalars: non-templates, so that they win over glm's templates, which serve vectors.
inline double min(double a, double b) { return b < a ? b : a; }
inline double max(double a, double b) { return a < b ? b : a; }
inline int min(int a, int b) { return b < a ? b : a; }
inline int max(int a, int b) { return a < b ? b : a; }
inline int clamp(int x, int lo, int hi) { return x < lo ? lo : (hi < x ? hi : x); }
inline double abs(double x) { return std::abs(x); }
inline double clamp(double x, double lo, double hi) { return x < lo ? lo : (hi < x ? hi : x); }
inline double sqrt(double x) { return std::sqrt(x); }
inline double floor(double x) { return std::floor(x); }
using glm::abs;
using glm::max;
using glm::min;
inline bool finiteD(double x) { return std::isfinite(x); }
inline bool isinfD(double x) { return std::isinf(x); }
inline double copysignD(double m, double s) { return std::copysign(m, s); }
constexpr double kInfD = std::numeric_limits<double>::infinity();
constexpr float kNaNF = std::numeric_limits<float>::quiet_NaN();
constexpr float kInfF = std::numeric_limits<float>::infinity();
// Float scalars: exact matches, so that float arithmetic stays float (a double overload
// would promote the whole expression).
inline float min(float a, float b) { return b < a ? b : a; }
inline float max(float a, float b) { return a < b ? b : a; }
inline float abs(float x) { return std::abs(x); }
inline float clamp(float x, float lo, float hi) { return x < lo ? lo : (hi < x ? hi : x); }
inline float sqrt(float x) { return std::sqrt(x); }
using std::acos;
using std::cos;
inline bool finiteF(float x) { return std::isfinite(x); }
inline bool isinfF(float x) { return std::isinf(x); }
inline int findMSB(int v) { return int(std::bit_width(unsigned(v))) - 1; }  // GLSL's, for v > 0
inline float copysignF(float m, float s) { return std::copysign(m, s); }
inline float cbrtF(float x) { return std::cbrt(x); }
inline double cbrtD(double x) { return std::cbrt(x); }
// glm's dot, cross and length, written out (GLSL's built-ins need not follow them).
inline float dotF(const vec3& a, const vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline vec3 crossF(const vec3& x, const vec3& y) {
  return vec3(x.y * y.z - y.y * x.z, x.z * y.x - y.z * x.x, x.x * y.y - y.x * x.y);
}
inline float divF(float a, float b) { return a / b; }
inline float sqrtF(float x) { return std::sqrt(x); }
inline float lengthF(const vec3& v) { return std::sqrt(dotF(v, v)); }
inline double dotD(const dvec3& a, const dvec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline dvec3 crossD(const dvec3& x, const dvec3& y) {
  return dvec3(x.y * y.z - y.y * x.z, x.z * y.x - y.z * x.x, x.x * y.y - y.x * x.y);
}
inline double lengthD(const dvec3& v) { return std::sqrt(dotD(v, v)); }
}  // namespace oblong::shared

#define OBLONG_KERNELS_BEGIN namespace oblong::shared {
#define OBLONG_KERNELS_END }
#define OBLONG_INLINE inline
#define OBLONG_FORCE_INLINE [[gnu::always_inline]] inline
#define OBLONG_IN(T) const T&
#define OBLONG_OUT(T) T&
#define OBLONG_INOUT(T) T&
#define OBLONG_IN_ARRAY const
#define OBLONG_OUT_ARRAY
#define OBLONG_PRECISE
#define OBLONG_TEMPLATE1(A) template <typename A>
#define OBLONG_TEMPLATE2(A, B) template <typename A, typename B>

#else  // GLSL

#define OBLONG_KERNELS_BEGIN
#define OBLONG_KERNELS_END
#define OBLONG_INLINE
#define OBLONG_FORCE_INLINE
#define OBLONG_IN(T) in T
#define OBLONG_OUT(T) out T
#define OBLONG_INOUT(T) inout T
#define OBLONG_IN_ARRAY in
#define OBLONG_OUT_ARRAY out
#define OBLONG_PRECISE precise
#define OBLONG_TEMPLATE1(A)
#define OBLONG_TEMPLATE2(A, B)

#define kInfD double(uintBitsToFloat(0x7f800000u))
#define kNaNF uintBitsToFloat(0x7fc00000u)
#define kInfF uintBitsToFloat(0x7f800000u)
bool finiteD(double x) { return !isinf(x) && !isnan(x); }
bool isinfD(double x) { return isinf(x); }
double copysignD(double m, double s) {  // std::copysign
  bool neg = (unpackDouble2x32(s).y & 0x80000000u) != 0u;
  return neg ? -abs(m) : abs(m);
}
double dotD(dvec3 a, dvec3 b) {
  precise double r = a.x * b.x + a.y * b.y + a.z * b.z;
  return r;
}
dvec3 crossD(dvec3 x, dvec3 y) {
  precise dvec3 r = dvec3(x.y * y.z - y.y * x.z, x.z * y.x - y.z * x.x, x.x * y.y - y.x * x.y);
  return r;
}
double lengthD(dvec3 v) { return sqrt(dotD(v, v)); }
bool finiteF(float x) { return !isinf(x) && !isnan(x); }
bool isinfF(float x) { return isinf(x); }
float copysignF(float m, float s) { return (floatBitsToUint(s) & 0x80000000u) != 0u ? -abs(m) : abs(m); }
// std::cbrt's value from pow: not bit-identical to the C library's (docs/vulkan.md).
float cbrtF(float x) { return x == 0.0f ? 0.0f : copysignF(pow(abs(x), 1.0f / 3.0f), x); }
float dotF(vec3 a, vec3 b) {
  precise float r = a.x * b.x + a.y * b.y + a.z * b.z;
  return r;
}
vec3 crossF(vec3 x, vec3 y) {
  precise vec3 r = vec3(x.y * y.z - y.y * x.z, x.z * y.x - y.z * x.x, x.x * y.y - y.x * x.y);
  return r;
}
// Float quotients and square roots, correctly rounded as IEEE (and the CPU) has them:
// a GPU's float `/` and sqrt need not be (Vulkan allows 2.5 ulp, NVIDIA's differ from the
// CPU's), and a detour through double does not help (lavapipe's double quotient rounded
// to float differs from the float quotient). The GPU's result q is corrected against the
// midpoints to its float neighbours, m = (q + q±) / 2: m·b and m·m are exact in double
// (25 + 24 and 25 + 25 bits), so each comparison is exact; ties go to the even neighbour.
float nextUpF(float x) { return uintBitsToFloat(floatBitsToUint(x) + 1u); }    // x > 0, finite
float nextDownF(float x) { return uintBitsToFloat(floatBitsToUint(x) - 1u); }  // x > 0
// The float nearest to A / B (root false) or to √A (root true), A, B > 0, from an estimate
// r > 0 within 4 ulp of it: r steps to a neighbour while A lies beyond the midpoint m
// between them, A against m·B (or m·m); an exact midpoint goes to the even one (a
// quotient's; a root is never one).
float nearestF(float r, double A, double B, bool root) {
  for (int it = 0; it < 4; ++it) {
    float dn = nextDownF(r), up = nextUpF(r);
    precise double lo = (double(r) + double(dn)) * 0.5, hi = (double(r) + double(up)) * 0.5;
    precise double loB = lo * (root ? lo : B), hiB = hi * (root ? hi : B);
    if (A < loB) r = dn;
    else if (A > hiB) r = up;
    else {
      if (A == loB && (floatBitsToUint(r) & 1u) != 0u) r = dn;
      else if (A == hiB && (floatBitsToUint(r) & 1u) != 0u) r = up;
      break;
    }
  }
  return r;
}
float divF(float a, float b) {
  precise float q = a / b;
  if (a == 0.0f || isinf(a) || isnan(a) || b == 0.0f || isinf(b) || isnan(b) || q == 0.0f || isinf(q)) return q;
  float r = nearestF(abs(q), abs(double(a)), abs(double(b)), false);
  return (a < 0.0f) != (b < 0.0f) ? -r : r;
}
float sqrtF(float x) {
  precise float q = sqrt(x);
  if (!(x > 0.0f) || isinf(x) || q == 0.0f) return q;
  return nearestF(q, double(x), 1.0, true);
}
float lengthF(vec3 v) { return sqrtF(dotF(v, v)); }

#endif

#endif
