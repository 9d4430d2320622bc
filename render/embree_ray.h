// A ray as Embree takes it: shared by the Embree scenes (render/embree_scene.h,
// render/cone_lod.h) without either including the other.
#pragma once

#include "core/math.h"

#include <embree3/rtcore.h>

namespace oblong {

// A ray as Embree takes it, no hit yet.
inline RTCRayHit toRayHit(const Ray& r) {
  RTCRayHit rh{};
  rh.ray.org_x = r.o.x, rh.ray.org_y = r.o.y, rh.ray.org_z = r.o.z;
  rh.ray.dir_x = r.d.x, rh.ray.dir_y = r.d.y, rh.ray.dir_z = r.d.z;
  rh.ray.tnear = r.tmin;
  rh.ray.tfar = r.tmax;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

}  // namespace oblong
