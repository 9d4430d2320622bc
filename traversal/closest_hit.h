// The closest hit over micro-triangles (watertight test, traversal/microtri.h),
// shared by the traversal and the baselines.
#pragma once

#include "core/microgeometry.h"
#include "traversal/intersector.h"
#include "traversal/microtri.h"

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
  // The two micro-triangles of a cell inside T, corners q = (v00, v10, v11, v01):
  // (v00, v10, v11) then (v00, v11, v01), as MicroCells::cell emits them. The same as
  // test() on each, with the four corners transformed once.
  void testCell(const WatertightRay& R, const MicroVertex* const q[4], float tmin, float tmax) {
    const ShearedVertex s00 = shear(R, q[0]->p), s10 = shear(R, q[1]->p), s11 = shear(R, q[2]->p),
                        s01 = shear(R, q[3]->p);
    MicroHit mh;
    if (intersectSheared(R, s00, s10, s11, q[0]->p, q[1]->p, q[2]->p, tmin, std::min(tmax, t), mh) && (!found || mh.t < t))
      t = mh.t, found = true, tri = MicroTriangle{{*q[0], *q[1], *q[2]}}, h = mh;
    if (intersectSheared(R, s00, s11, s01, q[0]->p, q[2]->p, q[3]->p, tmin, std::min(tmax, t), mh) && (!found || mh.t < t))
      t = mh.t, found = true, tri = MicroTriangle{{*q[0], *q[2], *q[3]}}, h = mh;
  }
  void fill(TriangleHit& hit) const {
    hit.t = t;
    microHitAttributes(tri, h, hit.uv, hit.ng);
  }
};

}  // namespace oblong
