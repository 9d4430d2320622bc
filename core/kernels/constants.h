// The traversal's and the inverter's numerical constants, defined once for the CPU
// and the Vulkan shaders: the driver (core/kernels/ray_patch.h), traversal/traversal_mesh.h
// and the other kernels of core/kernels/. This header is
// both C++ and GLSL: plain #defines with literal values, nothing else. Change a value
// here and both sides change; a literal changed on one side only is caught by the
// CPU/GPU contract test ("[vulkan]", tests/vulkan_test.cpp: same hits and the same
// per-ray work on one-triangle scenes; docs/vulkan.md "The contract") wherever it changes
// a count or a hit.
//
// Literals: an unsuffixed literal is a double in C++ and a float in GLSL. In the shaders
// these constants are used in double expressions (or float ones where the CPU uses
// float), and glslang folds a float literal's conversion to double from the literal's
// own double value (the SPIR-V holds the double 1e-05, not the float 1e-05f), so both
// sides compute with the same values.
//
// Here: every tunable threshold and every value the driver's loop (written per language)
// uses. The kernels of this folder keep the rounding allowances of their own formulas
// beside the formula they bound (patch_math.h's root pads, prism.h's crossing tolerance,
// rect_bounds.h's norm bounds): one copy, compiled by both languages.
#ifndef OBLONG_TRAVERSAL_CONSTANTS_H
#define OBLONG_TRAVERSAL_CONSTANTS_H

// ---- the driver and TraversalMesh (core/kernels/ray_patch.h, traversal_mesh.h) ------

// Entries of the per-ray, per-prism stack of pieces / box ranges (the driver's g_st). A push
// that would overflow marches (or tests the cells of) the current piece instead: correct,
// just not hierarchical. Fixed-size so that RayPatch allocates nothing. OBLONG_TRAV_STACK
// is the CPU's array and the largest `stack_depth` a scene may ask for; the default uses
// OBLONG_TRAV_STACK_DEFAULT entries, which no ray of the paper-scale suite or the asteroid
// fills (0 overflows at 16, path-traced); the shaders' array holds OBLONG_TRAV_STACK_GPU
// entries (about 120 bytes each, in each invocation's local memory: 128 of them made
// every trace on an H200 lose the device, docs/vulkan.md), and the Vulkan path refuses a
// deeper stack_depth instead of running a different traversal.
#define OBLONG_TRAV_STACK 128
#define OBLONG_TRAV_STACK_DEFAULT 32
#ifndef OBLONG_TRAV_STACK_GPU  // CMake: OBLONG_GPU_STACK
#define OBLONG_TRAV_STACK_GPU 32
#endif

// Entries of the tfdm baseline's node stack (traversal/tfdm.cpp, shaders/tfdm.glsl): at
// most 4 roots plus 3 per level descended, and a root level is at most 30 (cell indices
// within ±2^29).
#define OBLONG_TFDM_STACK 96

// Rounding of the watertight micro-triangle test, relative to the magnitudes it works on
// (RayMargins::make: rayErr = this · (max|p| + max|o| + |a| + |b|), a few float ulps of
// |p − o|). Pads the boxes and inflates the prism so that they hold the triangle as that
// test sees it.
#define OBLONG_TRAV_RAY_ERR 1e-6

// rayErr enters the inflation of the prism (kb·, ks·) and the cell dilation ε (kxy·) twice
// (rayExtraB / rayExtraS, rpInit's ε): both ends of a ray point's error.
#define OBLONG_TRAV_RAY_ERR_FACTOR 2

// Absolute slack of ray parameters, in units of the box pad along the ray (tAbs =
// this · boxPad / |D|): float hit distances against double interval ends.
#define OBLONG_TRAV_T_ABS_PADS 8

// Relative slack of ray parameters (slack(t) = this · |t| + tAbs): intervals are
// compared with float hit distances and float tmin / tmax.
#define OBLONG_TRAV_SLACK_REL 1e-5

// Rounding of the dot products of the oriented box around the inflated prism (PrismOBB),
// relative to the magnitude of the points projected + 1: its build pads by this
// · (max |vertex| + 1), TraversalMesh::missesPrism's slab test per ray by this ·
// (max |o| + 1).
#define OBLONG_TRAV_OBB_ROUND 1e-12

// makePoint: safety factor on the residual bound (the error bounds kb, ks, kxy are
// first-order; 0.1 % more covers the second-order term while the point is accepted).
#define OBLONG_TRAV_RESIDUAL_SAFETY 1.001

// makePoint: a curve point is refused (inversion rejected, box fallback) when its
// barycentric error bound db.x + db.y, or its s error relative to the analysed s domain,
// reaches this: the first-order bounds are only trusted for small residuals.
#define OBLONG_TRAV_MAX_POINT_ERR 0.01

// makePoint: keeps the s test meaningful for an empty s domain (0.01 · 0 + this).
#define OBLONG_TRAV_TINY 1e-300

// Relative rounding allowance in sample units for what is computed in double: the curve
// point's uv pad (this · (1 + |uv|)) and the march's snapping of its rectangle and blocks
// to cells (startMarch: this · (1 + |lo| + |hi|)). snapCells, in float, allows 2^-22.
#define OBLONG_TRAV_SNAP_ETA 1e-9

// Cell indices are clamped to ±this before the conversion to int (snapCells, startMarch).
#define OBLONG_TRAV_SNAP_LIMIT 1e9

// The march's interval test (mayCross): ψ may vanish where |ψ| is within its variation
// plus this times the magnitude of its terms (quadraticRoots allows the coefficients a
// relative rounding of 1e-13 and pads its roots by 4 times its effect).
#define OBLONG_TRAV_PSI_ERR 5e-13

// pieceEnd: a piece is marched when the end points' pads exceed this fraction of the
// rectangle's longer side ("pads dominate": splitting cannot shrink it any further).
#define OBLONG_TRAV_PAD_DOMINANCE 0.25

// pieceEnd, inversion during traversal: a clipped end is inverted only when the box
// clip moved it by more than this fraction of the piece's ray interval (minGain), and by
// more than the ray interval in which the piece crosses this many cells along its
// rectangle's longer side: a smaller move seldom takes a cell off the rectangle (chosen
// when every re-projection was an inversion; with the claims, within ±0.5 % of none).
#define OBLONG_TRAV_MIN_GAIN 1e-3
#define OBLONG_TRAV_MIN_GAIN_CELLS 0.5

// Curve points claimed without an inversion (curvePointAt) are kept only when
// their pad (texels, both axes together) is at most this; else the point is inverted.
#define OBLONG_TRAV_CLAIM_PAD 0.05

// boxBegin: cell ranges of at most max(this, marching scale) cells per axis are tested
// cell by cell instead of split.
#define OBLONG_TRAV_MIN_BOX_CELLS 1

// Where ε exceeds this fraction of the marching scale (float rounding at a fine texel),
// pieces up to OBLONG_TRAV_WIDE_LEAF_EPS ε (samples) are leaves, subdivided as boxes down
// to blocks of OBLONG_TRAV_WIDE_BOX_CELLS cells per axis (wideLeaf). Chosen on the
// roof at 100² tiling (ε above a texel on many pieces): 342 steps per camera ray with marched leaves, 147
// with these (tfdm: 188).
#define OBLONG_TRAV_WIDE_EPS_REL 0.25
#define OBLONG_TRAV_WIDE_LEAF_EPS 8.0
#define OBLONG_TRAV_WIDE_BOX_CELLS 2

// ---- Newton (inversion/newton.h), float arithmetic as the traversal calls it -------------

// Step tolerance: converged when max(|du|, |dv|) <= tol and |ds| <= tol · (L + |s|)
// (NewtonOptions::tolerance; float default).
#define OBLONG_NEWTON_TOLERANCE 1e-5

// Iteration cap (NewtonOptions::maxIterations).
#define OBLONG_NEWTON_MAX_ITERATIONS 10

// Fallback to the cubic inverter when Newton's result lies outside T by more than this
// many barycentric units (float; or is not finite, or not converged).
#define OBLONG_NEWTON_OUTSIDE_EPS 1e-5

// Polishing Newton steps of the cubic fallback (inv::cubicSolve(X, T, this)).
#define OBLONG_NEWTON_FALLBACK_POLISH 1

// The same two thresholds in double arithmetic (invertD, precision "double").
#define OBLONG_NEWTON_TOLERANCE_D 1e-10
#define OBLONG_NEWTON_OUTSIDE_EPS_D 1e-9

// ---- the cubic inverter (inversion/cubic.h; core/kernels/invert_scalar.h) ----------------

// A leading coefficient is dropped when the root it carries lies beyond 1/this triangle
// sizes (rounding noise on a3 for coplanar normals then cannot create spurious roots).
#define OBLONG_CUBIC_DROP_EPS_F 1e-6
#define OBLONG_CUBIC_DROP_EPS_D 1e-12

// A candidate x is kept as a root when |f(x)| <= this · Σ|a_k||x|^k.
#define OBLONG_CUBIC_ROOT_TOL_F 1e-2
#define OBLONG_CUBIC_ROOT_TOL_D 1e-6

// Two roots whose distances outside T differ by at most this tie (the smaller |s| wins).
#define OBLONG_CUBIC_TIE_EPS_F 1e-5
#define OBLONG_CUBIC_TIE_EPS_D 1e-10

// 2π/3, the trigonometric form's step between roots.
#define OBLONG_TWO_PI_OVER_3 2.0943951023931954923

#endif
