// The traversal tests' scenarios (displaced meshes, each with its map) and ray families,
// shared by the per-triangle conformance suite and the CPU/GPU parity tests.
#pragma once

#include "core/mesh.h"
#include "core/microgeometry.h"
#include "render/embree_scene.h"
#include "render/intersector.h"
#include "render/strategy_catalog.h"

#include <random>
#include <string>
#include <vector>

namespace oblong::test {

struct Scenario {
  std::string name;
  std::vector<DisplacedTriangle> tris;
  Displacement disp;
};

std::vector<DisplacedTriangle> trianglesOf(const Mesh& m);

Scenario tiledQuad();    // flat, high-frequency map tiled 4x4: deep hierarchies
Scenario torus();        // curved, odd map sizes, tiled (3,2)
Scenario coarseTorus();  // big curved triangles, strong displacement: large bulge / ε
Scenario sphere();       // sphere-like, normals converging to the centre
// Stiff cases: strongly twisted vertex normals, a sphere displaced towards its centre
// (normals converging within the shell), 10x tiling (tens of thousands of cells per
// triangle), a quad 1e4 away from the origin, and rotated, mirrored, negative uvs.
Scenario twisted();
Scenario deepSphere();
Scenario highTiling();
Scenario farAway();
Scenario rotatedUVs();
std::vector<Scenario> scenarios();       // tiledQuad, torus, coarseTorus, sphere
std::vector<Scenario> stiffScenarios();  // the five stiff cases

vec3 randomDir(std::mt19937& rng);

struct SurfacePoint {
  vec3 p, n;
  uint32_t prim;
};
SurfacePoint randomBasePoint(const Scenario& s, std::mt19937& rng);

struct RayCase {
  Ray r;
  int family;  // index into kFamilies
};
extern const char* const kFamilies[6];

// Closest hit over all triangles (AABB-filtered) with a given intersector.
bool closest(const Intersector& is, const Ray& r, TriangleHit& best);

// `count` rays of each family (camera, grazing, along ±N, inside the shell), plus
// non-unit and axis-aligned directions, far origins, and rays spawned from the
// oracle's hits of the camera rays (path-tracer continuations and shadow rays).
std::vector<RayCase> rayFamilies(const Scenario& s, const Intersector& bf, int count, uint32_t seed);

// What both conformance suites run: every registered combination (allCombinations(),
// so a new strategy is tested the day it registers), then the variants that change the
// traversal's shape (no inversion in traversal, marching scales, the RMIP driver with
// TFDM's mipmap and quad-tree splits, a tiny RMIP), then every registered exact baseline
// (exactBaselines(): tfdm, ...). Combinations with a slow reference strategy (ceres) run
// on every kSlowStride-th ray only.
struct ConformanceConfig {
  TraversalConfig config;
  bool slow = false;
};
constexpr int kSlowStride = 8;
std::vector<ConformanceConfig> conformanceConfigs();
std::string describe(const TraversalConfig& c);

// Watertightness: n rays from random points of the centre circle (radius 1, in the xz
// plane) of a closed displaced torus whose shell stays inside its tube, in random
// directions; returns how many found no hit (a leak).
// Rays from inside a closed torus that escape; with maxLod >= 0 each ray carries its
// own level of detail, uniform in [0, maxLod] (a per-ray LoD scene).
int torusLeaks(const EmbreeScene& accel, int n, unsigned seed = 3, float maxLod = -1.0f);

}  // namespace oblong::test
