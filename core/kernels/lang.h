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
//   OBLONG_INOUT_ARRAY before an array parameter that is read and written (GLSL inout)
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
// quotient or square root is written divF(a, b) / sqrtF(x) (rcpSqrtF(x) for
// divF(1.0f, sqrtF(x))): correctly rounded on both sides (GLSL's float `/` and sqrt are
// not, on every GPU). An
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
inline float rcpSqrtF(float x) { return divF(1.0f, sqrtF(x)); }
inline double dotD(const dvec3& a, const dvec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline dvec3 crossD(const dvec3& x, const dvec3& y) {
  return dvec3(x.y * y.z - y.y * x.z, x.z * y.x - y.z * x.x, x.x * y.y - y.x * x.y);
}
inline double lengthD(const dvec3& v) { return std::sqrt(dotD(v, v)); }
// GLSL's bit built-ins that nearestF uses, so that the C++ tests run its code.
inline uint floatBitsToUint(float x) { return std::bit_cast<uint>(x); }
inline float uintBitsToFloat(uint x) { return std::bit_cast<float>(x); }
inline int findMSB(uint v) { return int(std::bit_width(v)) - 1; }  // GLSL's, for v > 0
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
#define OBLONG_INOUT_ARRAY
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
#define OBLONG_INOUT_ARRAY inout
#define OBLONG_PRECISE precise
#define OBLONG_TEMPLATE1(A)
#define OBLONG_TEMPLATE2(A, B)

#define kInfD double(uintBitsToFloat(0x7f800000u))
#define kNaNF uintBitsToFloat(0x7fc00000u)
#define kInfF uintBitsToFloat(0x7f800000u)
bool finiteD(double x) { return abs(x) < kInfD; }  // false for NaN (an ordered comparison); no branch
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
bool finiteF(float x) { return abs(x) < kInfF; }
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
// divF and sqrtF: nearestF (below, common to both languages) corrects the GPU's float
// `/` and sqrt, which need not be correctly rounded (docs/decisions.md, "GPU arithmetic").
float nearestF(float r, float A, float B, bool root);
float divF(float a, float b) {
  precise float q = a / b;
  // a, b and q finite and non-zero (|x|'s bits minus one below the largest finite's): the
  // three tests as one vector comparison, without a branch each.
  uvec3 m = (floatBitsToUint(vec3(a, b, q)) & 0x7fffffffu) - 1u;
  if (!all(lessThan(m, uvec3(0x7f7fffffu)))) return q;
  float r = nearestF(abs(q), abs(a), abs(b), false);
  return (a < 0.0f) != (b < 0.0f) ? -r : r;
}
float sqrtF(float x) {
  precise float q = sqrt(x);
  if (!(x > 0.0f) || isinf(x) || q == 0.0f) return q;
  return nearestF(q, x, 1.0f, true);
}
float lengthF(vec3 v) { return sqrtF(dotF(v, v)); }
// divF(1.0f, sqrtF(x)), the two corrections from one nearestF call site (a shader inlines
// each call): the root, then its reciprocal, each as divF and sqrtF take them.
float rcpSqrtF(float x) {
  float num = x, den = 1.0f;
  precise float q = sqrt(x);
  for (int k = 0; k < 2; ++k) {
    bool root = k == 0;
    uvec3 m = (floatBitsToUint(vec3(num, den, q)) & 0x7fffffffu) - 1u;
    if (all(lessThan(m, uvec3(0x7f7fffffu))) && num > 0.0f) {
      float r = nearestF(abs(q), num, abs(den), root);
      q = den < 0.0f ? -r : r;
    }
    if (root) {
      num = 1.0f;
      den = q;
      precise float rq = 1.0f / q;
      q = rq;
    }
  }
  return q;
}

#endif

// ---- both languages ----------------------------------------------------------------------
OBLONG_KERNELS_BEGIN
// The float nearest to A / B (root false) or to √A (root true), A, B > 0 finite, from an
// estimate r > 0 within 4 ulp of it (a GPU's `/` or sqrt: Vulkan allows 2.5 ulp for a
// quotient): r steps to a neighbour while A lies beyond the midpoint between them, A
// against the midpoint times B (or squared); an exact midpoint goes to the even one (a
// quotient's; a root is never one). The comparisons are exact in 32-bit integers: with
// r = R·2^e (R its integer significand, e its ulp's exponent) and B = M·2^f, A − r·B is an
// integer D in units of 2^(e+f−k) (a root's A − r²: of 2^(2e−2k)), k = 1, or 2 where r is
// a power of two; within 4 ulp |D| <= (8R + 16)·2^(2k) < 2^31 for a root and 2^(k+26) for
// a quotient, so its 32-bit wrap-around value is D itself; the midpoints are small
// integers. No double: a GPU without shaderFloat64 runs it,
// one with FP64 at 1/64 rate does not pay for it. divF and sqrtF call it on the GPU; C++
// runs it in the tests, against IEEE's quotients and roots.
// x > 0 finite as m·2^e, m in [2^23, 2^24) (a subnormal's significand normalised).
OBLONG_INLINE void splitF(float x, OBLONG_OUT(uint) m, OBLONG_OUT(int) e) {
  uint b = floatBitsToUint(x);
  int be = int(b >> 23u);
  m = b & 0x7fffffu;
  if (be == 0) {
    int sh = 23 - findMSB(m);
    m = m << uint(sh);
    e = -149 - sh;
  } else {
    m = m | 0x800000u;
    e = be - 150;
  }
}
OBLONG_INLINE float nearestF(float r, float A, float B, bool root) {
  uint ma, mb;
  int ea, eb;
  splitF(A, ma, ea);
  splitF(B, mb, eb);
  for (int it = 0; it < 4; ++it) {
    uint bits = floatBitsToUint(r);
    int be = int(bits >> 23u);
    uint R = be == 0 ? (bits & 0x7fffffu) : ((bits & 0x7fffffu) | 0x800000u);
    int e = be == 0 ? -149 : be - 150;
    // The midpoints are c ± 1 in units of 2^(e−k), c = R·2^k: k = 2 at a power of two (the
    // neighbour below is half an ulp away: its midpoint is c − 1, the one above c + 2).
    bool pow2 = R == 0x800000u && be > 1;
    int k = pow2 ? 2 : 1;
    uint c = R << uint(k);
    // A − r·B (r²) in units of 2^(e−k)·2^eb (2^(2e−2k)): A = ma·2^s of them.
    int s = root ? ea - 2 * e + 2 * k : ea - e - eb + k;
    uint M = root ? c : mb;
    int d = int((ma << uint(clamp(s, 0, 31))) - c * M);
    // The midpoints' D: (c ± 1)·M − c·M, or (c ± 1)² − c² for a root.
    int hi = int((pow2 ? 2u : 1u) * (root ? 2u * c + (pow2 ? 2u : 1u) : mb));
    int lo = root ? 1 - int(2u * c) : -int(mb);
    if (s < 0) d = lo - 1;  // far below (not within 4 ulp): step down
    if (s > 31) d = hi + 1;
    bool odd = (bits & 1u) != 0u;
    if (d < lo || (d == lo && odd)) r = uintBitsToFloat(bits - 1u);
    else if (d > hi || (d == hi && odd)) r = uintBitsToFloat(bits + 1u);
    if ((d < lo || d > hi) && r > 0.0f && !isinfF(r)) continue;
    break;
  }
  return r;
}
OBLONG_KERNELS_END

#endif
