#include "render/embree_scene.h"

#include "core/error.h"
#include "core/microgeometry.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <type_traits>
#include <cstring>
#include <unordered_map>

namespace oblong {

namespace {

bool monitor(void* user, ssize_t bytes, bool) {
  static_cast<std::atomic<int64_t>*>(user)->fetch_add(bytes);
  return true;
}

struct PosHash {
  size_t operator()(const vec3& p) const {
    uint32_t b[3];
    std::memcpy(b, &p, sizeof b);
    return (size_t(b[0]) * 73856093u) ^ (size_t(b[1]) * 19349663u) ^ (size_t(b[2]) * 83492791u);
  }
};
struct PosEq {
  bool operator()(const vec3& a, const vec3& b) const { return std::memcmp(&a, &b, sizeof a) == 0; }
};

// Micro-triangles of one base triangle with its vertices shared (exact position match).
struct Patch {
  std::vector<vec4> vertices;
  std::vector<vec2> uvs;
  std::vector<glm::uvec3> indices;
};

Patch tessellate(const DisplacedTriangle& T, const Displacement& d) {
  Patch out;
  std::unordered_map<vec3, uint32_t, PosHash, PosEq> index;
  auto vid = [&](const MicroVertex& v) {
    auto [it, fresh] = index.try_emplace(v.p, uint32_t(out.vertices.size()));
    if (fresh) {
      out.vertices.emplace_back(v.p, 0.0f);
      out.uvs.push_back(v.uv);
    }
    return it->second;
  };
  forEachMicroTriangle(T, d, [&](const MicroTriangle& m) {
    out.indices.emplace_back(vid(m.v[0]), vid(m.v[1]), vid(m.v[2]));
  });
  return out;
}

// Embree passes our context through to the user-geometry callbacks: the standard way
// to carry per-ray data (here the traversal counters) into them.
struct Context {
  RTCIntersectContext ctx;
  RayCounters* counters;
};

void userBounds(const RTCBoundsFunctionArguments* args) {
  const auto* is = static_cast<const Intersector*>(args->geometryUserPtr);
  const AABB b = is->bounds(args->primID);
  RTCBounds* o = args->bounds_o;
  if (b.isEmpty()) {
    // Non-finite bounds make Embree drop the primitive (undisplaceable triangle).
    o->lower_x = o->lower_y = o->lower_z = kInfinity;
    o->upper_x = o->upper_y = o->upper_z = -kInfinity;
    return;
  }
  o->lower_x = b.lo.x, o->lower_y = b.lo.y, o->lower_z = b.lo.z;
  o->upper_x = b.hi.x, o->upper_y = b.hi.y, o->upper_z = b.hi.z;
}

template <bool Occluded>
void userIntersect(const void* argsPtr) {
  // RTCIntersectFunctionNArguments and RTCOccludedFunctionNArguments share the layout
  // of the fields used here; rtcIntersect1 / rtcOccluded1 call with N = 1.
  using Args = std::conditional_t<Occluded, RTCOccludedFunctionNArguments, RTCIntersectFunctionNArguments>;
  const Args* args = static_cast<const Args*>(argsPtr);
  if (!args->valid[0]) return;
  const auto* is = static_cast<const Intersector*>(args->geometryUserPtr);
  auto* ctx = reinterpret_cast<Context*>(args->context);
  RayCounters local;
  RayCounters& c = ctx->counters ? *ctx->counters : local;
  if constexpr (Occluded) {
    RTCRay* ray = reinterpret_cast<RTCRay*>(args->ray);
    Ray r{vec3(ray->org_x, ray->org_y, ray->org_z), vec3(ray->dir_x, ray->dir_y, ray->dir_z), ray->tnear,
          ray->tfar};
    TriangleHit h;
    if (is->intersect(r, args->primID, h, c)) ray->tfar = -kInfinity;
  } else {
    RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
    Ray r{vec3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z), vec3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z),
          rh->ray.tnear, rh->ray.tfar};
    TriangleHit h;
    if (!is->intersect(r, args->primID, h, c) || !(h.t < rh->ray.tfar)) return;
    rh->ray.tfar = h.t;
    rh->hit.u = h.uv.x;  // user geometry: u, v carry the texture coordinates
    rh->hit.v = h.uv.y;
    rh->hit.Ng_x = h.ng.x, rh->hit.Ng_y = h.ng.y, rh->hit.Ng_z = h.ng.z;
    rh->hit.primID = args->primID;
    rh->hit.geomID = args->geomID;
    rh->hit.instID[0] = args->context->instID[0];
  }
}

}  // namespace

TraversalConfig traversalConfigOf(const Scene& scene) {
  TraversalConfig c;
  c.range = scene.range.name;
  c.rangeParams = scene.range.params;
  c.inverter = scene.inverter.name;
  c.inverterParams = scene.inverter.params;
  c.splitter = scene.splitter.name;
  c.splitterParams = scene.splitter.params;
  c.marchingScale = scene.marchingScale;
  c.inversionInTraversal = scene.inversionInTraversal;
  return c;
}

std::string EmbreeScene::geometryName() const { return tessellate_ ? "tessellated" : traversalName_; }

EmbreeScene::EmbreeScene(const Scene& scene, const AccelOptions& opts)
    : embreeBytes_(std::make_shared<std::atomic<int64_t>>(0)), tessellate_(opts.tessellate) {
  // A constructor that throws runs no destructor: release the device here (a bad
  // strategy name must not leak Embree's allocations).
  try {
    build(scene, opts);
  } catch (...) {
    release();
    throw;
  }
}

void EmbreeScene::release() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
  scene_ = nullptr;
  device_ = nullptr;
}

void EmbreeScene::build(const Scene& scene, const AccelOptions& opts) {
  const auto start = std::chrono::steady_clock::now();
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw Error("embree: cannot create device");
  rtcSetDeviceMemoryMonitorFunction(device_, monitor, embreeBytes_.get());
  scene_ = rtcNewScene(device_);
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);  // no cracks between shared edges

  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const SceneMesh& sm = scene.meshes[mi];
    const Mesh& mesh = sm.mesh;
    auto g = std::make_unique<Geometry>();
    g->mesh = int(mi);
    baseTriangles_ += mesh.triangles.size();
    if (!sm.displacement) {
      for (const vec3& p : mesh.positions) g->vertices.emplace_back(p, 0.0f);
      g->indices = mesh.triangles;
      g->uvs = mesh.hasUVs() ? mesh.uvs : std::vector<vec2>(mesh.positions.size(), vec2(0.0f));
    } else if (!opts.tessellate) {
      std::vector<DisplacedTriangle> tris(mesh.triangles.size());
      for (size_t ti = 0; ti < tris.size(); ++ti) tris[ti] = mesh.triangle(ti);
      g->intersector = createIntersector(opts.traversal, std::move(tris), *sm.displacement);
      traversalName_ = g->intersector->name();
      RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(geom, unsigned(g->intersector->size()));
      rtcSetGeometryUserData(geom, g->intersector.get());
      rtcSetGeometryBoundsFunction(geom, userBounds, nullptr);
      rtcSetGeometryIntersectFunction(geom, [](const RTCIntersectFunctionNArguments* a) { userIntersect<false>(a); });
      rtcSetGeometryOccludedFunction(geom, [](const RTCOccludedFunctionNArguments* a) { userIntersect<true>(a); });
      rtcCommitGeometry(geom);
      const unsigned id = rtcAttachGeometry(scene_, geom);
      rtcReleaseGeometry(geom);
      if (geoms_.size() <= id) geoms_.resize(id + 1);
      geoms_[id] = std::move(g);
      continue;
    } else {
      std::vector<Patch> patches(mesh.triangles.size());
      tbb::parallel_for(size_t(0), mesh.triangles.size(), [&](size_t ti) {
        DisplacedTriangle T = mesh.triangle(ti);
        if (T.uvArea2 != 0.0f) patches[ti] = tessellate(T, *sm.displacement);
      });
      for (size_t ti = 0; ti < patches.size(); ++ti) {
        const uint32_t base = uint32_t(g->vertices.size());
        Patch& p = patches[ti];
        g->vertices.insert(g->vertices.end(), p.vertices.begin(), p.vertices.end());
        g->uvs.insert(g->uvs.end(), p.uvs.begin(), p.uvs.end());
        for (const auto& t : p.indices) g->indices.push_back(t + base);
        g->basePrim.insert(g->basePrim.end(), p.indices.size(), uint32_t(ti));
        Patch().vertices.swap(p.vertices);  // free as we go
      }
      microTriangles_ += g->indices.size();
    }
    if (g->indices.empty()) continue;
    g->vertices.emplace_back(0.0f);  // padding: Embree may read 16 bytes past the last vertex
    RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, g->vertices.data(), 0,
                               sizeof(vec4), g->vertices.size() - 1);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, g->indices.data(), 0,
                               sizeof(glm::uvec3), g->indices.size());
    rtcCommitGeometry(geom);
    const unsigned id = rtcAttachGeometry(scene_, geom);
    rtcReleaseGeometry(geom);
    if (geoms_.size() <= id) geoms_.resize(id + 1);
    geoms_[id] = std::move(g);
  }
  rtcCommitScene(scene_);
  if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw Error("embree: scene build failed");
  buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

EmbreeScene::~EmbreeScene() { release(); }

Hit EmbreeScene::intersect(const Ray& r, RayCounters* counters) const {
  Context ctx;
  rtcInitIntersectContext(&ctx.ctx);
  ctx.counters = counters;
  RTCRayHit rh{};
  rh.ray.org_x = r.o.x, rh.ray.org_y = r.o.y, rh.ray.org_z = r.o.z;
  rh.ray.dir_x = r.d.x, rh.ray.dir_y = r.d.y, rh.ray.dir_z = r.d.z;
  rh.ray.tnear = r.tmin;
  rh.ray.tfar = r.tmax;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &ctx.ctx, &rh);
  Hit h;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  const Geometry& g = *geoms_[rh.hit.geomID];
  h.t = rh.ray.tfar;
  h.mesh = g.mesh;
  h.prim = g.basePrim.empty() ? int(rh.hit.primID) : int(g.basePrim[rh.hit.primID]);
  if (g.intersector) {
    h.uv = vec2(rh.hit.u, rh.hit.v);
    h.ng = vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    return h;
  }
  const glm::uvec3 tri = g.indices[rh.hit.primID];
  h.uv = (1.0f - rh.hit.u - rh.hit.v) * g.uvs[tri.x] + rh.hit.u * g.uvs[tri.y] + rh.hit.v * g.uvs[tri.z];
  const vec3 ng(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
  const float len = glm::length(ng);
  h.ng = len > 0 ? ng / len : vec3(0.0f);
  return h;
}

bool EmbreeScene::occluded(const Ray& r, RayCounters* counters) const {
  Context ctx;
  rtcInitIntersectContext(&ctx.ctx);
  ctx.counters = counters;
  RTCRay ray{};
  ray.org_x = r.o.x, ray.org_y = r.o.y, ray.org_z = r.o.z;
  ray.dir_x = r.d.x, ray.dir_y = r.d.y, ray.dir_z = r.d.z;
  ray.tnear = r.tmin;
  ray.tfar = r.tmax;
  ray.mask = 0xFFFFFFFFu;
  rtcOccluded1(scene_, &ctx.ctx, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

MemoryReport EmbreeScene::memory() const {
  size_t verts = 0, idx = 0, uvs = 0, prims = 0;
  MemoryReport traversal;
  for (const auto& g : geoms_) {
    if (!g) continue;
    if (g->intersector)
      for (const MemoryItem& m : g->intersector->memory()) {
        auto it = std::find_if(traversal.begin(), traversal.end(), [&](const MemoryItem& x) { return x.name == m.name; });
        if (it == traversal.end()) traversal.push_back(m);
        else it->bytes += m.bytes;
      }
    verts += g->vertices.capacity() * sizeof(vec4);
    idx += g->indices.capacity() * sizeof(glm::uvec3);
    uvs += g->uvs.capacity() * sizeof(vec2);
    prims += g->basePrim.capacity() * sizeof(uint32_t);
  }
  MemoryReport r{{"embree/bvh", size_t(std::max<int64_t>(0, embreeBytes_->load()))},
                 {"mesh/vertices", verts},
                 {"mesh/indices", idx},
                 {"mesh/uvs", uvs}};
  if (prims) r.push_back({"tessellated/base_prim", prims});
  r.insert(r.end(), traversal.begin(), traversal.end());
  return r;
}

}  // namespace oblong
