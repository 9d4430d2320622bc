#include "render/embree_scene.h"

#include "core/error.h"
#include "core/memory.h"
#include "render/cone_lod.h"
#include "traversal/prism.h"
#include "traversal/traversal.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <type_traits>

namespace oblong {

// `--baseline tessellated`, registered where it is implemented: no Intersector
// (createIntersector refuses it), EmbreeScene builds the micro-triangles instead.
OBLONG_REGISTER_BASELINE(kTessellatedBaseline,
                         [](ParamSet& params, const BaselineContext&) -> std::unique_ptr<Intersector> {
                           fail(params.where(), "the {} baseline is built by the scene (EmbreeScene)",
                                kTessellatedBaseline);
                         },
                         StrategyTraits{.summary = "the micro-triangles built and traced by Embree (the speed limit)",
                                        .builtByScene = true});

namespace {

bool monitor(void* user, ssize_t bytes, bool) {
  static_cast<std::atomic<int64_t>*>(user)->fetch_add(bytes);
  return true;
}

// Embree passes our context through to the user-geometry callbacks: the standard way
// to carry per-ray data (the traversal counters, the ray's level of detail) into them.
struct Context {
  RTCIntersectContext ctx;
  RayCounters* counters;
  float lod;
};

}  // namespace

namespace {

// A ray in the mesh's frame: the origin minus the frame's, rounded once (exact when the
// two are within a factor 2^29 of each other; the direction and t are unchanged).
Ray toFrame(const Ray& r, const dvec3& origin) {
  return Ray{vec3(dvec3(r.o) - origin), r.d, r.tmin, r.tmax, r.lod};
}

void userBounds(const RTCBoundsFunctionArguments* args) {
  const auto* ug = static_cast<const EmbreeUserGeometry*>(args->geometryUserPtr);
  AABB b = ug->intersector->bounds(args->primID);
  if (!b.isEmpty()) {  // into the world, padded for Embree's box test (framePad)
    BoxD w{dvec3(b.lo) + ug->origin, dvec3(b.hi) + ug->origin};
    w.pad(framePad(b, ug->origin));
    b = w.toFloatOutward();
  }
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
  const auto* ug = static_cast<const EmbreeUserGeometry*>(args->geometryUserPtr);
  const Intersector* is = ug->intersector;
  auto* ctx = reinterpret_cast<Context*>(args->context);
  RayCounters local;
  RayCounters& c = ctx->counters ? *ctx->counters : local;
  if constexpr (Occluded) {
    RTCRay* ray = reinterpret_cast<RTCRay*>(args->ray);
    const Ray r = toFrame(Ray{vec3(ray->org_x, ray->org_y, ray->org_z), vec3(ray->dir_x, ray->dir_y, ray->dir_z),
                              ray->tnear, ray->tfar, ctx->lod},
                          ug->origin);
    TriangleHit h;
    if (is->intersect(r, args->primID, h, c)) ray->tfar = -kInfinity;
  } else {
    RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
    const Ray r = toFrame(Ray{vec3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z),
                              vec3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z), rh->ray.tnear, rh->ray.tfar,
                              ctx->lod},
                          ug->origin);
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

// A pre-tessellated mesh's one primitive: the box of its micro-triangles, into the world
// and padded for Embree's box test as the prisms are.
void frameBounds(const RTCBoundsFunctionArguments* args) {
  const auto* fs = static_cast<const EmbreeFrameScene*>(args->geometryUserPtr);
  BoxD w{dvec3(fs->bounds.lo) + fs->origin, dvec3(fs->bounds.hi) + fs->origin};
  w.pad(framePad(fs->bounds, fs->origin));
  const AABB b = w.toFloatOutward();
  RTCBounds* o = args->bounds_o;
  o->lower_x = b.lo.x, o->lower_y = b.lo.y, o->lower_z = b.lo.z;
  o->upper_x = b.hi.x, o->upper_y = b.hi.y, o->upper_z = b.hi.z;
}

// The ray moved into the mesh's frame (toFrame, as for the traversal) and traced through
// its micro-triangles; a hit keeps the micro-triangle's primID and barycentrics, which
// EmbreeScene::intersect reads as for any triangle geometry.
template <bool Occluded>
void frameIntersect(const void* argsPtr) {
  using Args = std::conditional_t<Occluded, RTCOccludedFunctionNArguments, RTCIntersectFunctionNArguments>;
  const Args* args = static_cast<const Args*>(argsPtr);
  if (!args->valid[0]) return;
  const auto* fs = static_cast<const EmbreeFrameScene*>(args->geometryUserPtr);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  if constexpr (Occluded) {
    RTCRay* ray = reinterpret_cast<RTCRay*>(args->ray);
    const Ray r = toFrame(
        Ray{vec3(ray->org_x, ray->org_y, ray->org_z), vec3(ray->dir_x, ray->dir_y, ray->dir_z), ray->tnear, ray->tfar},
        fs->origin);
    RTCRay local = toRayHit(r).ray;
    rtcOccluded1(fs->scene, &ctx, &local);
    if (local.tfar < 0.0f) ray->tfar = -kInfinity;
  } else {
    RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
    const Ray r = toFrame(Ray{vec3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z),
                              vec3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z), rh->ray.tnear, rh->ray.tfar},
                          fs->origin);
    RTCRayHit local = toRayHit(r);
    rtcIntersect1(fs->scene, &ctx, &local);
    if (local.hit.geomID == RTC_INVALID_GEOMETRY_ID || !(local.ray.tfar < rh->ray.tfar)) return;
    rh->ray.tfar = local.ray.tfar;
    rh->hit = local.hit;
    rh->hit.geomID = args->geomID;
    rh->hit.instID[0] = args->context->instID[0];
  }
}

}  // namespace

std::string EmbreeScene::geometryName() const {
  if (tessellate_) return "tessellated";
  return traversalName_.empty() ? "embree triangles (no displaced mesh)" : traversalName_;
}

std::string EmbreeScene::geometryText() const {
  if (tessellate_)
    return fmt::format("pre-tessellated (baseline), {} base triangles, {} micro-triangles", baseTriangles_,
                       microTriangles_);
  return TraceBackend::geometryText();
}

nlohmann::json EmbreeScene::device() const {
  return {{"api", "embree"},
          {"version", fmt::format("{}.{}.{}", rtcGetDeviceProperty(device_, RTC_DEVICE_PROPERTY_VERSION_MAJOR),
                                  rtcGetDeviceProperty(device_, RTC_DEVICE_PROPERTY_VERSION_MINOR),
                                  rtcGetDeviceProperty(device_, RTC_DEVICE_PROPERTY_VERSION_PATCH))}};
}

std::vector<EmbreeScene::PrismCounts> EmbreeScene::prismCounts() const {
  std::vector<PrismCounts> out;
  for (const auto& g : geoms_)
    if (g && g->intersector)
      if (const auto* t = dynamic_cast<const TraversalIntersectorBase*>(g->intersector.get())) {
        PrismCounts c;
        c.mesh = g->mesh;
        for (const PrismParams& pp : t->mesh().params) c.built += pp.valid, c.wellPosed += pp.valid && pp.wellPosed;
        out.push_back(c);
      }
  return out;
}

nlohmann::json EmbreeScene::describe() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& g : geoms_)
    if (g && g->intersector) {
      nlohmann::json j = g->intersector->describe();
      j["mesh"] = g->mesh;
      out.push_back(std::move(j));
    }
  return out;
}

EmbreeScene::EmbreeScene(const Scene& scene, const AccelOptions& opts)
    : embreeBytes_(std::make_shared<std::atomic<int64_t>>(0)),
      tessellate_(opts.traversal.baseline == kTessellatedBaseline) {
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
  for (auto& g : geoms_)
    if (g && g->frame.scene) rtcReleaseScene(g->frame.scene), g->frame.scene = nullptr;
  cone_.reset();
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

  if (tessellate_) {  // no parameters of its own: any is an error, as for every baseline
    ParamSet params(opts.traversal.baselineParams, opts.traversal.where("strategies.baseline"));
    params.checkUnused();
  }
  if (tessellate_ && opts.traversal.lodPerRay)
    fail(scene.path, "the pre-tessellated baseline builds one surface: a level of detail per ray (--lod cone) "
                     "needs the traversal or --baseline bruteforce (or a fixed --lod)");
  if (opts.traversal.lodPerRay) cone_ = std::make_unique<ConeLod>(scene, device_);
  // The pre-tessellation baseline is refused before anything is built when its
  // micro-triangles, their buffers and Embree's BVH would not fit.
  std::vector<std::vector<TessellationPatchSize>> sizes(scene.meshes.size());
  if (tessellate_) {
    std::vector<TessellationEstimate> est;
    size_t largest = 0, displaced = 0;
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
      const SceneMesh& sm = scene.meshes[mi];
      if (!sm.displacement) continue;
      sizes[mi] = tessellationPatchSizes(sm.mesh, *sm.displacement);
      const TessellationEstimate e = summarizeTessellation(sizes[mi]);
      if (est.empty() || e.microTriangles > est[largest].microTriangles) largest = est.size(), displaced = mi;
      est.push_back(e);
    }
    if (!est.empty()) {
      const size_t peak = tessellationPeakBytes(est, size_t(tbb::this_task_arena::max_concurrency()));
      size_t tris = 0, geometry = 0, bvh = 0;
      for (const TessellationEstimate& e : est) tris += e.microTriangles, geometry += e.geometryBytes(), bvh += e.bvhBytes();
      const SceneMesh& sm = scene.meshes[displaced];
      checkFits(fmt::format("{}: meshes[{}] (map {})", scene.path, displaced, sm.displacement->map->name()),
                "--baseline tessellated", peak,
                "leave out --baseline tessellated: the traversal builds no micro-triangles (oblong info SCENE "
                "shows what it builds)",
                fmt::format("{} micro-triangles{}: {} of vertices, uvs and indices, {} of Embree BVH, the rest while "
                            "building",
                            tris, est.size() > 1 ? fmt::format(" in {} displaced meshes", est.size()) : "",
                            humanBytes(geometry), humanBytes(bvh)));
    }
  }

  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const SceneMesh& sm = scene.meshes[mi];
    const Mesh& mesh = sm.mesh;
    auto g = std::make_unique<Geometry>();
    g->mesh = int(mi);
    baseTriangles_ += mesh.triangles.size();
    if (!sm.displacement) {
      for (const vec3& p : mesh.positions) g->vertices.emplace_back(worldFloat(mesh, p), 0.0f);
      g->indices = mesh.triangles;
      g->uvs = mesh.hasUVs() ? mesh.uvs : std::vector<vec2>(mesh.positions.size(), vec2(0.0f));
    } else if (!tessellate_) {
      std::vector<DisplacedTriangle> tris(mesh.triangles.size());
      for (size_t ti = 0; ti < tris.size(); ++ti) tris[ti] = mesh.triangle(ti);
      g->intersector = createIntersector(opts.traversal, std::move(tris), *sm.displacement);
      traversalName_ = g->intersector->name();
      RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(geom, unsigned(g->intersector->size()));
      g->user = {g->intersector.get(), mesh.origin};
      rtcSetGeometryUserData(geom, &g->user);
      rtcSetGeometryBoundsFunction(geom, userBounds, nullptr);
      rtcSetGeometryIntersectFunction(geom, [](const RTCIntersectFunctionNArguments* a) { userIntersect<false>(a); });
      rtcSetGeometryOccludedFunction(geom, [](const RTCOccludedFunctionNArguments* a) { userIntersect<true>(a); });
      // Bounds change only after an edit (update()); refitting keeps the BVH's topology.
      rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_REFIT);
      rtcCommitGeometry(geom);
      const unsigned id = rtcAttachGeometry(scene_, geom);
      rtcReleaseGeometry(geom);
      if (geoms_.size() <= id) geoms_.resize(id + 1);
      geoms_[id] = std::move(g);
      continue;
    } else {
      std::vector<TessellationPatch> patches(mesh.triangles.size());
      tbb::parallel_for(size_t(0), mesh.triangles.size(), [&](size_t ti) {
        DisplacedTriangle T = mesh.triangle(ti);
        if (T.uvArea2 != 0.0f) patches[ti] = tessellatePatch(T, *sm.displacement, sizes[mi][ti]);
      });
      size_t nv = 0, nt = 0;
      for (const TessellationPatch& p : patches) nv += p.vertices.size(), nt += p.indices.size();
      g->vertices.reserve(nv + 1);  // + the padding vertex below
      g->uvs.reserve(nv);
      g->indices.reserve(nt);
      g->basePrim.reserve(nt);
      for (size_t ti = 0; ti < patches.size(); ++ti) {
        const uint32_t base = uint32_t(g->vertices.size());
        TessellationPatch& p = patches[ti];
        // In the mesh's frame, as built (frameIntersect moves the rays into it).
        g->vertices.insert(g->vertices.end(), p.vertices.begin(), p.vertices.end());
        g->uvs.insert(g->uvs.end(), p.uvs.begin(), p.uvs.end());
        for (const auto& t : p.indices) g->indices.push_back(t + base);
        g->basePrim.insert(g->basePrim.end(), p.indices.size(), uint32_t(ti));
        p = TessellationPatch();  // free as we go
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
    if (!g->basePrim.empty()) {
      // Micro-triangles: a scene of their own in the mesh's frame, traced through a
      // one-primitive user geometry of the world's scene (frameIntersect).
      EmbreeFrameScene& fs = g->frame;
      fs.scene = rtcNewScene(device_);
      rtcSetSceneFlags(fs.scene, RTC_SCENE_FLAG_ROBUST);
      rtcAttachGeometry(fs.scene, geom);
      rtcReleaseGeometry(geom);
      rtcCommitScene(fs.scene);
      fs.origin = mesh.origin;
      for (size_t v = 0; v + 1 < g->vertices.size(); ++v) fs.bounds.extend(vec3(g->vertices[v]));
      geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(geom, 1);
      rtcSetGeometryUserData(geom, &fs);
      rtcSetGeometryBoundsFunction(geom, frameBounds, nullptr);
      rtcSetGeometryIntersectFunction(geom, [](const RTCIntersectFunctionNArguments* a) { frameIntersect<false>(a); });
      rtcSetGeometryOccludedFunction(geom, [](const RTCOccludedFunctionNArguments* a) { frameIntersect<true>(a); });
      rtcCommitGeometry(geom);
    }
    const unsigned id = rtcAttachGeometry(scene_, geom);
    rtcReleaseGeometry(geom);
    if (geoms_.size() <= id) geoms_.resize(id + 1);
    geoms_[id] = std::move(g);
  }
  rtcCommitScene(scene_);
  if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw Error("embree: scene build failed");
  reach_ = sceneReach(scene);
  buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

EmbreeScene::UpdateTimes EmbreeScene::update(int mesh, const SampleRange& changed) {
  for (size_t id = 0; id < geoms_.size(); ++id) {
    Geometry* g = geoms_[id].get();
    if (!g || g->mesh != mesh) continue;
    if (!g->intersector) fail("update", "mesh {} is not traced as user geometry (pre-tessellated or plain)", mesh);
    const Intersector::Update u = g->intersector->update(changed);
    UpdateTimes t{u.structureSeconds, u.prismSeconds, 0.0, u.triangles.size()};
    const auto t0 = std::chrono::steady_clock::now();
    if (!u.triangles.empty()) {
      RTCGeometry geom = rtcGetGeometry(scene_, unsigned(id));
      rtcCommitGeometry(geom);
      rtcCommitScene(scene_);
    }
    t.bvhSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return t;
  }
  fail("update", "no displaced mesh {} in the scene", mesh);
}

EmbreeScene::~EmbreeScene() { release(); }

float EmbreeScene::coneLod(const Ray& r, const RayCone& c, float bias) const {
  return cone_ ? cone_->lod(r, c, bias) : 0.0f;
}

Hit EmbreeScene::intersect(const Ray& world, RayCounters* counters) const {
  const NearRay near = nearScene(world, reach_);
  Hit h;
  if (near.misses) return h;
  const Ray& r = near.ray;
  Context ctx;
  rtcInitIntersectContext(&ctx.ctx);
  ctx.counters = counters;
  ctx.lod = r.lod;
  RTCRayHit rh = toRayHit(r);
  rtcIntersect1(scene_, &ctx.ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  const Geometry& g = *geoms_[rh.hit.geomID];
  h.t = unshift(rh.ray.tfar, near.shift);
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

namespace {
// Rays in parallel (blocks of 32), each with fresh counters; returns the wall seconds.
template <typename PerRay>
double tracePerRay(size_t n, std::span<RayCounters> counters, const PerRay& perRay) {
  const auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 32), [&](const tbb::blocked_range<size_t>& b) {
    for (size_t i = b.begin(); i < b.end(); ++i) {
      RayCounters* c = counters.empty() ? nullptr : &counters[i];
      if (c) *c = RayCounters{};
      perRay(i, c);
    }
  });
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

double EmbreeScene::traceHits(RayKind, std::span<const Ray> rays, std::span<Hit> hits,
                              std::span<RayCounters> counters) const {
  return tracePerRay(rays.size(), counters, [&](size_t i, RayCounters* c) { hits[i] = intersect(rays[i], c); });
}

double EmbreeScene::traceOcclusion(RayKind, std::span<const Ray> rays, std::span<uint8_t> blocked,
                                   std::span<RayCounters> counters) const {
  return tracePerRay(rays.size(), counters,
                     [&](size_t i, RayCounters* c) { blocked[i] = occluded(rays[i], c) ? 1 : 0; });
}

bool EmbreeScene::occluded(const Ray& world, RayCounters* counters) const {
  const NearRay near = nearScene(world, reach_);
  if (near.misses) return false;
  const Ray& r = near.ray;
  Context ctx;
  rtcInitIntersectContext(&ctx.ctx);
  ctx.counters = counters;
  ctx.lod = r.lod;
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
