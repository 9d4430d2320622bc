// The closest hit over micro-triangles (watertight test, render/traversal/microtri.h),
// shared by the traversal and the baselines.
#pragma once

#include "core/microgeometry.h"
#include "render/intersector.h"
#include "render/traversal/microtri.h"

#include <algorithm>

namespace oblong {

// Closest hit over micro-triangles, shared by the traversal and the baselines.
struct ClosestHit {
  float t = kInfinity;
  bool found = false;
  MicroTriangle tri{};
  MicroHit h{};

  void test(const WatertightRay& R, const MicroTriangle& m, float tmin, float tmax) {
    MicroHit mh;
    // Closed range [tmin, min(tmax, t)], then strict: the first of equal-t hits wins.
    if (intersectMicro(R, m.v[0].p, m.v[1].p, m.v[2].p, tmin, std::min(tmax, t), mh) && (!found || mh.t < t)) {
      t = mh.t, found = true, tri = m, h = mh;
    }
  }
  void fill(TriangleHit& hit) const {
    hit.t = t;
    microHitAttributes(tri, h, hit.uv, hit.ng);
  }
};

}  // namespace oblong
