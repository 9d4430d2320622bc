// Point-wise inversion (inversion/inverter.h): Newton on F(u,v,s) = P(u,v) + s·N(u,v) − X
// from the centroid with its cubic fallback, and the cubic inverter itself, written once
// (core/kernels/invert_scalar.h) for the CPU's inverters and the Vulkan shaders. In
// C++ it is compiled for float (InvFrameF, ...) and double (InvFrameD, ...); in GLSL for
// float, as the traversal calls it. The formulas and their rationale: inversion/newton.h
// and inversion/cubic.h. The one difference between the languages is std::cbrt, acos and
// cos, which are the C library's on the CPU and GLSL's on the GPU (not bit-identical; only
// the starting point of the polishing Newton steps moves).
#ifndef OBLONG_KERNELS_INVERT_H
#define OBLONG_KERNELS_INVERT_H

#include "core/kernels/constants.h"
#include "core/kernels/lang.h"

OBLONG_KERNELS_BEGIN

#define KS float
#define KS3 vec3
#define KFrame InvFrameF
#define KCubic CubicF
#define KResult InvResultF
#define KDOT dotF
#define KCROSS crossF
#define KFINITE finiteF
#define KCOPYSIGN copysignF
#define KCBRT cbrtF
// The inverter's quotients and roots need not be correctly rounded: what it returns is a
// claim that makePoint validates with a residual (core/kernels/curve_point.h), so the
// GPU takes its own float `/` and sqrt here instead of divF and sqrtF, whose correction
// loops, inlined at each inversion site, were 41 % of the intersection shader. On the CPU
// and on lavapipe both are IEEE's (the same bits); a GPU whose `/` or sqrt is not
// correctly rounded may invert to a neighbouring float: other claims, the same hits.
#ifdef __cplusplus
#define KLENGTH lengthF
#define KDIV divF
#define KSQRT sqrtF
#else
#define KLENGTH(v) sqrt(dotF(v, v))
#define KDIV(a, b) ((a) / (b))
#define KSQRT sqrt
#endif
#define K_DROP_EPS OBLONG_CUBIC_DROP_EPS_F
#define K_ROOT_TOL OBLONG_CUBIC_ROOT_TOL_F
#define K_TIE_EPS OBLONG_CUBIC_TIE_EPS_F
#define K_OUTSIDE_EPS OBLONG_NEWTON_OUTSIDE_EPS
#include "core/kernels/invert_scalar.h"

#ifdef __cplusplus
#define KS double
#define KS3 dvec3
#define KFrame InvFrameD
#define KCubic CubicD
#define KResult InvResultD
#define KDOT dotD
#define KCROSS crossD
#define KLENGTH lengthD
#define KFINITE finiteD
#define KCOPYSIGN copysignD
#define KCBRT cbrtD
#define KDIV(a, b) ((a) / (b))
#define KSQRT sqrt
#define K_DROP_EPS OBLONG_CUBIC_DROP_EPS_D
#define K_ROOT_TOL OBLONG_CUBIC_ROOT_TOL_D
#define K_TIE_EPS OBLONG_CUBIC_TIE_EPS_D
#define K_OUTSIDE_EPS OBLONG_NEWTON_OUTSIDE_EPS_D
#include "core/kernels/invert_scalar.h"
#endif

OBLONG_KERNELS_END

#endif
