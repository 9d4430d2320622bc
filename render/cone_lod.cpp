// The ray-cone rule (cone_lod.h).
#include "render/cone_lod.h"

#include "core/error.h"
#include "render/embree_ray.h"

#include <glm/glm.hpp>

#include <cmath>

namespace oblong {

ConeLod::ConeLod(const Scene& scene, RTCDevice device) {
  if (device) {
    rtcRetainDevice(device);
    device_ = device;
  } else {
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw Error("embree: cannot create device");
  }
  base_ = rtcNewScene(device_);
  for (const SceneMesh& sm : scene.meshes) {
    if (!sm.displacement) continue;
    const Mesh& mesh = sm.mesh;
    const Displacement& d = *sm.displacement;
    const HeightMap& m = d.level0 ? *d.level0 : *d.map;
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), mesh.positions.size()));
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const vec3 p(mesh.world(i));
      v[3 * i] = p.x, v[3 * i + 1] = p.y, v[3 * i + 2] = p.z;
    }
    auto* idx = static_cast<glm::uvec3*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 sizeof(glm::uvec3), mesh.triangles.size()));
    std::vector<float> texel(mesh.triangles.size(), kInfinity);
    // Texels per uv unit, as Displacement::toSample maps them.
    const double texelsPerUV = double(m.width()) * d.tiling.x * double(m.height()) * d.tiling.y;
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      idx[t] = mesh.triangles[t];
      const DisplacedTriangle T = mesh.triangle(t);
      const double uvArea = 0.5 * std::abs(double(T.uvArea2)) * std::abs(texelsPerUV);
      if (uvArea > 0 && T.area > 0) texel[t] = float(std::sqrt(double(T.area) / uvArea));
    }
    rtcCommitGeometry(geom);
    const unsigned id = rtcAttachGeometry(base_, geom);
    rtcReleaseGeometry(geom);
    if (texel_.size() <= id) texel_.resize(id + 1);
    texel_[id] = std::move(texel);
  }
  rtcCommitScene(base_);
}

ConeLod::~ConeLod() {
  if (base_) rtcReleaseScene(base_);
  if (device_) rtcReleaseDevice(device_);
}

float ConeLod::lod(const Ray& r, const RayCone& c, float bias) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh = toRayHit(r);
  rtcIntersect1(base_, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0.0f;
  // The cone's width across the ray (the footprint's minor axis): no 1/cos for the
  // elongation along the surface, which over-blurs grazing views (docs/lod.md, measured).
  const float texel = texel_[rh.hit.geomID][rh.hit.primID];
  const float width = c.at(rh.ray.tfar * glm::length(r.d)).width;  // t in units of |d|
  const float l = bias + std::log2(width / texel);
  return l > 0.0f ? std::min(l, 64.0f) : 0.0f;  // NaN (an empty cone on a degenerate triangle): 0
}

}  // namespace oblong
