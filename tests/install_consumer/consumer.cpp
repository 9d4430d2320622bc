// Traces a displaced quad through Embree user geometry with oblong's intersector, built
// against the installed package: how another renderer uses oblong. The quad and its map
// are made in code; the canonical intersector and the brute-force oracle are created by
// name (so the package must register the strategies); each ray's hit through this
// program's own Embree scene must match the oracle's and oblong's EmbreeScene's.
// Prints one line and exits 0 when every ray agrees, 1 otherwise.
#include "core/heightmap.h"
#include "core/mesh.h"
#include "core/procedural.h"
#include "core/scene.h"
#include "render/embree_scene.h"
#include "traversal/intersector.h"
#include "traversal/strategy_catalog.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

using namespace oblong;

namespace {

// What the callbacks get: the intersector and its mesh's frame.
struct UserData {
  const Intersector* intersector;
  dvec3 origin;
};

void bounds(const RTCBoundsFunctionArguments* args) {
  const auto* u = static_cast<const UserData*>(args->geometryUserPtr);
  const AABB b = u->intersector->bounds(args->primID);
  RTCBounds* o = args->bounds_o;
  if (b.isEmpty()) {  // a triangle that cannot be displaced: Embree drops the primitive
    o->lower_x = o->lower_y = o->lower_z = kInfinity;
    o->upper_x = o->upper_y = o->upper_z = -kInfinity;
    return;
  }
  // Into the world, padded for Embree's ray/box test (intersector.h, framePad).
  const double pad = framePad(b, u->origin);
  const dvec3 lo = dvec3(b.lo) + u->origin - pad, hi = dvec3(b.hi) + u->origin + pad;
  o->lower_x = float(lo.x), o->lower_y = float(lo.y), o->lower_z = float(lo.z);
  o->upper_x = float(hi.x), o->upper_y = float(hi.y), o->upper_z = float(hi.z);
}

void intersect(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const auto* u = static_cast<const UserData*>(args->geometryUserPtr);
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  // The ray in the mesh's frame, the closest hit so far as its end.
  const Ray r{vec3(dvec3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z) - u->origin),
              vec3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z), rh->ray.tnear, rh->ray.tfar};
  TriangleHit h;
  RayCounters c;
  if (!u->intersector->intersect(r, args->primID, h, c) || !(h.t < rh->ray.tfar)) return;
  rh->ray.tfar = h.t;
  rh->hit.u = h.uv.x, rh->hit.v = h.uv.y;
  rh->hit.Ng_x = h.ng.x, rh->hit.Ng_y = h.ng.y, rh->hit.Ng_z = h.ng.z;
  rh->hit.primID = args->primID;
  rh->hit.geomID = args->geomID;
}

// The traversal and the oracle agree to the conformance suites' tolerance.
bool sameT(float a, float b) { return std::abs(a - b) <= 1e-5f * std::max(std::abs(a), 1e-3f); }

}  // namespace

int main() {
  try {
    // A 4x4-quad square in the xz-plane, displaced along +y by a procedural 64x64 map.
    Mesh mesh = quadMesh(1.0f, 0.0f, 4);
    finishMesh(mesh, MeshLoadOptions{.needUVs = true});
    Displacement disp;
    disp.map = std::make_shared<const HeightMap>(proceduralHeightMap(64, 64, 3));
    disp.scale = 0.25f;
    std::vector<DisplacedTriangle> tris;
    for (size_t i = 0; i < mesh.triangles.size(); ++i) tris.push_back(mesh.triangle(i));

    // By name, from the registries the package links whole.
    const std::unique_ptr<Intersector> canonical = createIntersector(TraversalConfig{}, tris, disp);
    TraversalConfig oracleConfig;
    oracleConfig.baseline = "bruteforce";
    const std::unique_ptr<Intersector> oracle = createIntersector(oracleConfig, tris, disp);
    const std::vector<std::string> ranges = strategyNames(StrategyKind::Range);
    std::printf("consumer: %s and %s; %zu range queries registered\n", canonical->name().c_str(),
                oracle->name().c_str(), ranges.size());

    RTCDevice device = rtcNewDevice(nullptr);
    RTCScene scene = rtcNewScene(device);
    UserData user{canonical.get(), mesh.origin};
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom, unsigned(canonical->size()));
    rtcSetGeometryUserData(geom, &user);
    rtcSetGeometryBoundsFunction(geom, bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom, intersect);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene);

    // oblong's own Embree scene of the same surface.
    Scene s;
    s.path = "<consumer>";
    s.meshes.push_back(SceneMesh{mesh, disp});
    const EmbreeScene reference(s, AccelOptions{});

    size_t rays = 0, hits = 0, wrong = 0;
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i) {
        // Oblique rays from above onto the square.
        const vec3 o(-1.5f + 3.0f * float(i) / 39.0f, 1.5f, -1.2f + 2.4f * float(j) / 39.0f);
        const vec3 d(0.31f, -1.0f, 0.17f + 0.01f * float(i % 7));
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh = toRayHit(Ray{o, d});
        rtcIntersect1(scene, &ctx, &rh);
        const bool hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;

        float best = kInfinity;  // the oracle: every triangle's micro-geometry
        for (uint32_t p = 0; p < oracle->size(); ++p) {
          TriangleHit h;
          RayCounters c;
          const Ray r{vec3(dvec3(o) - mesh.origin), d, 0.0f, best};
          if (oracle->intersect(r, p, h, c) && h.t < best) best = h.t;
        }
        const Hit ref = reference.intersect(Ray{o, d});
        ++rays;
        hits += hit;
        const bool ok = hit == (best < kInfinity) && hit == ref.valid() &&
                        (!hit || (sameT(rh.ray.tfar, best) && rh.ray.tfar == ref.t));
        if (!ok && wrong++ == 0)
          std::printf("consumer: ray (%d, %d): Embree user geometry %s t=%.9g, bruteforce t=%.9g, EmbreeScene t=%.9g\n",
                      i, j, hit ? "hit" : "miss", hit ? rh.ray.tfar : kInfinity, best, ref.t);
      }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    std::printf("consumer: %zu rays, %zu hits, %zu differ from bruteforce or EmbreeScene\n", rays, hits, wrong);
    return wrong == 0 && hits > rays / 2 ? 0 : 1;
  } catch (const Error& e) {
    std::printf("consumer: %s\n", e.what());
    return 1;
  }
}
