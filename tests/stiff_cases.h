// The stiff and extreme inversion cases (issue 3): named fixtures — a prepared base
// triangle, a height range, and the points to invert inside its bounding prism with
// their true (u, v, h) — plus the evaluation shared by tests/inversion_test.cpp and
// experiments/inversion (which prints the table recorded in docs/inversion.md).
// Later issues (traversal, splitters) can reuse the triangles: stiffCase("sliver_1e4").
#pragma once

#include "core/triangle.h"
#include "inversion/inverter.h"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace oblong::test {

// Which points of the prism a case inverts.
enum SampleMix : unsigned {
  kInterior = 1,  // (u,v) uniform in T, s uniform in [a,b]
  kBoundary = 2,  // prism corners, its 9 edges and its 3 side walls (on the surface)
  kExtremes = 4,  // the caps s = a, s = b and the height extremes h = hmin, h = hmax
  kAll = 7,
};

// One point X = P(u,v) + s·N(u,v) (in double, from T's float data), h = s·|N(u,v)|.
struct InversionSample {
  dvec3 X{0.0};
  double u = 0, v = 0, s = 0, h = 0;
  // More than one (u,v) in T (at any s) maps to X: an inverter, which knows only X and
  // T, cannot tell which one is meant (the prism folds over itself, or a second
  // displacement line through X starts in T with s outside [a,b]), or X is ill-posed
  // (the offset triangle through X nearly collapses: |det J(u,v,s)| < 1e-3 |det J(u,v,0)|,
  // a segment of uvs maps close to X). Any answer inside T that reproduces X counts as
  // correct.
  bool ambiguous = false;
};

struct StiffCase {
  std::string name;
  std::string what;         // one line: what is stiff about it
  DisplacedTriangle tri;    // prepared
  double hmin = 0, hmax = 0;
  unsigned mix = kAll;
  std::string knownIssue;   // expected failures and their cause ("" if none)

  // Prism caps: a = hmin<0 ? hmin/m : hmin, b = hmax>0 ? hmax/m : hmax (DESIGN inv. 2).
  double capLo() const;
  double capHi() const;
  // Deterministic points: nInterior random interior points plus the fixed sets of mix.
  std::vector<InversionSample> samples(int nInterior = 200, uint32_t seed = 1) const;
};

// The catalogue, in a fixed order. Names are stable identifiers.
const std::vector<StiffCase>& stiffCatalogue();
const StiffCase& stiffCase(std::string_view name);  // throws std::out_of_range

// Points in the prism of T over [hmin, hmax] (what StiffCase::samples uses).
std::vector<InversionSample> prismSamples(const DisplacedTriangle& T, double hmin, double hmax,
                                          unsigned mix, int nInterior, uint32_t seed);
// Number of (u,v,s) in T × [a,b] (barycentric slack eps) that map to X, from the roots
// of the cubic in double.
int preimageCount(const dvec3& X, const DisplacedTriangle& T, double a, double b, double eps = 1e-9);

// Error of a result against a reference (u, v, h): max(|Δu|, |Δv|, |Δh| / max(L, |h|))
// with L the longest edge of T: barycentric units (uv error relative to the uv
// triangle's size) and height relative to the triangle size or the height.
double inversionError(const InversionResultD& r, double u, double v, double h, double L);
double longestEdge(const DisplacedTriangle& T);

// Per-inverter statistics over a set of samples.
struct Evaluation {
  int n = 0;
  int converged = 0;
  double meanIterations = 0;
  int maxIterations = 0;
  double maxErrRef = 0;    // against the reference (where it converged; unambiguous samples)
  int refCompared = 0;     // samples compared against the reference
  double maxErrTruth = 0;  // against the constructed (u,v,h) (unambiguous samples)
  double maxOutside = 0;   // largest distance outside T (barycentric units; unambiguous samples)
  int ambiguous = 0;
  int failures = 0;        // not converged, outside T, or error above the limit
  int ambiguousFailures = 0;  // of which on ambiguous / ill-posed samples
  double convergenceRate() const { return n ? double(converged) / n : 0.0; }
};

struct EvalLimits {
  double err = 1e-6;      // error against the truth (or, ambiguous: reconstruction of X / L)
  double outside = 1e-9;  // barycentric slack for "inside T"
};
// Sums counts and takes maxima (for aggregating many triangles).
void accumulate(Evaluation& into, const Evaluation& e);

// Every displaceable triangle of a mesh file as a case named "<prefix>#<index>", with
// heights in ±relHeight × its longest edge and mix kAll. The asteroid of glmark2-data:
inline constexpr const char* kAsteroidPath = "/usr/share/glmark2/models/asteroid-low.3ds";
std::vector<StiffCase> meshCases(const std::string& path, const std::string& prefix, double relHeight);

// Random triangles ("synthetic#i"): vertices in [-1,1]³ (doubled area >= 0.05), each
// normal = normalize(face normal + 0.577 · random tangent vector), i.e. tilted up to ~45°
// in independent directions (twisted, unlike a smooth mesh), heights ±0.3 of the longest
// edge.
std::vector<StiffCase> randomCases(int n, uint32_t seed);

// The limits the tests assert for double and for the float API (docs/inversion.md).
EvalLimits doubleLimits();
EvalLimits floatLimits();

// Runs inv on every sample, through invertD (floatApi = false) or invert (true, X
// rounded to float). reference: the reference's double results per sample (may be null).
Evaluation evaluate(const Inverter& inv, bool floatApi, const StiffCase& c,
                    const std::vector<InversionSample>& samples,
                    const std::vector<InversionResultD>* reference, const EvalLimits& limits);

}  // namespace oblong::test
