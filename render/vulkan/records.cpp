// The Vulkan path's upload records from a Scene (records.h). The per-triangle constants
// are taken from the CPU's own TraversalMesh (traversal/traversal_mesh.h), built
// by the same createIntersector call that EmbreeScene makes, so both paths start from
// identical numbers; the RMIP layers are the CPU traversal's own Rmip, copied as they are.
#include "render/vulkan/records.h"
#include "traversal/prism.h"

#include "core/error.h"
#include "core/scene.h"
#include "render/accel_options.h"
#include "traversal/lod_per_ray.h"
#include "traversal/strategy_catalog.h"
#include "traversal/tfdm_view.h"
#include "traversal/traversal.h"
#include "render/vulkan/rmip_layout.h"
#include "strategies/rmip.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>

namespace oblong::vk {

using namespace vkgpu;

static_assert(sizeof(RayGpu) == 40 && sizeof(HitGpu) == 32 && sizeof(CountersGpu) == 32);
static_assert(sizeof(TriGpu) == 1560 && sizeof(TriGpu) % 8 == 0 && alignof(TriGpu) == 8);
static_assert(sizeof(MeshGpu) == 176 && sizeof(PushGpu) == 16);

namespace {

void appendTriangles(GpuRecords& R, MeshGpu& m, const TraversalMesh& tm, const Intersector& boxes, const Mesh& mesh);

// The GPU record of one displaced triangle from the CPU's TraversalMesh.
TriGpu makeTri(const TraversalMesh& tm, size_t i) {
  TriGpu g{};
  const DisplacedTriangle& T = tm.tris[i];
  const PrismParams& P = tm.params[i];
  const Displacement& d = tm.disp;
  g.valid = P.valid;
  g.wellPosed = P.wellPosed;
  if (!P.valid) return g;
  const LocalFrame& F = tm.frames[i];
  g.F = F;
  g.claim = shared::ClaimBounds{P.domainB, P.domainS0, P.domainS1, P.kb, P.ks, P.kxy};
  g.N13 = F.N(dvec2(1.0 / 3.0));
  const BoxD exact = Prism::exact(T, P.a, P.b).bounds();
  g.boxLo = exact.lo, g.boxHi = exact.hi;
  g.boxPadLo = tm.prismBoxes[i].lo, g.boxPadHi = tm.prismBoxes[i].hi;
  g.infPadLo = tm.inflatedBoxes[i].lo, g.infPadHi = tm.inflatedBoxes[i].hi;
  const PrismOBB& obb = tm.obbs[i];
  static_assert(PrismOBB::kAxes == 5);
  for (int k = 0; k < PrismOBB::kAxes; ++k) g.obbAxis[k] = obb.axis[k], g.obbLo[k] = obb.lo[k], g.obbHi[k] = obb.hi[k];
  g.obbValid = obb.valid();
  g.budgetPad = tm.budgetPad[i];
  g.sbLo = d.toSample(T.uvBox.lo) - dvec2(F.origin);
  g.sbHi = d.toSample(T.uvBox.hi) - dvec2(F.origin);
  const MicroCells cells(T, d);
  g.edges = cells.kernelEdges();
  g.mc = cells.kernelTri();
  g.eps = P.eps;
  g.vertexErr = P.vertexErr, g.a = P.a, g.b = P.b, g.budget = tm.originBudget[i];
  g.maxP = maxAbsVertex(T);
  g.inflateB = P.inflateB, g.inflateS = P.inflateS;
  const TextureFrame& X = tm.texFrames[i];
  for (int k = 0; k < 3; ++k) g.texAxis[k] = X.axis[k];
  g.tPc = X.Pc;
  g.box = X.box;
  g.texBoxLo = tm.texPrismBoxes[i].lo, g.texBoxHi = tm.texPrismBoxes[i].hi;
  g.texMag = tm.texPrismMag[i];
  g.uvArea2 = T.uvArea2;
  g.origin = F.origin;
  const CellRange& cr = tm.cells[i];
  g.cellLo = ivec2(cr.x0, cr.y0) - F.origin;
  g.cellHi = ivec2(cr.x1, cr.y1) - F.origin;
  return g;
}

// Appends one traversal's records to R and sets m's offsets into them: its map's texels,
// the CPU traversal's own Rmip (copied as it is), its triangles, and their boxes from
// `boxes` (the intersector Embree would take them from) in the mesh's frame.
void appendTraversal(GpuRecords& R, MeshGpu& m, const Intersector& is, const Intersector& boxes, const Mesh& mesh) {
  const auto* trav = dynamic_cast<const TraversalIntersectorBase*>(&is);
  if (!trav) fail("--device vulkan", "internal: the canonical intersector is not a traversal");
  const TraversalMesh& tm = trav->mesh();
  const Displacement& d = tm.disp;
  m.triOffset = uint32_t(R.tris.size());
  m.W = d.map->width(), m.H = d.map->height();
  m.sampleOffset = float(d.sampleOffset);  // 2^-(k+1): exact in float
  // A band of a λ per ray reads its own level's structure (and the next level's, which
  // has a record of its own).
  const RangeQuery* rq = &trav->rangeQuery();
  if (const auto* band = dynamic_cast<const LodBandQuery*>(rq)) rq = &band->fine();
  const auto* rmip = dynamic_cast<const Rmip*>(rq);
  if (!rmip) fail("--device vulkan", "internal: the canonical intersector's range query is not rmip");
  const RmipLayout L = RmipLayout::of(*rmip);
  // Each mesh's entries start on a 128-byte boundary, so that its 4 x 4 tiles of entries
  // (core/kernels/rmip_query.h) stay whole lines.
  R.rmipData.resize((R.rmipData.size() + 31) / 32 * 32, 0u);
  m.rmipData = uint32_t(R.rmipData.size());
  m.rmipLayers = uint32_t(R.rmipLayers.size());
  m.rmipF = L.f, m.rmipW = L.rw, m.rmipH = L.rh, m.rmipP = L.P, m.rmipQ = L.Q, m.rmipWrap = L.wrap;
  m.rmipBits = L.bits, m.rmipFirst = L.p0, m.rmipBase = L.q.base, m.rmipStep = L.q.step;
  R.rmipData.insert(R.rmipData.end(), L.words.begin(), L.words.end());
  R.rmipLayers.insert(R.rmipLayers.end(), L.layers.begin(), L.layers.end());
  R.rmipBytes += L.bytes();
  appendTriangles(R, m, tm, boxes, mesh);
}

// The "tfdm" baseline's records: its map's texels, its min-max pyramid as the CPU stores
// it (in the RMIP buffers: one layer-table row per level, MeshGpu::method), its
// triangles and their boxes.
void appendTfdm(GpuRecords& R, MeshGpu& m, const Intersector& is, const Mesh& mesh) {
  const auto* tf = dynamic_cast<const TfdmIntersector*>(&is);
  if (!tf) fail("--device vulkan", "internal: the tfdm intersector has no view");
  const TfdmView v = tf->view();
  const TraversalMesh& tm = *v.mesh;
  if (v.worldBoxes) fail("--device vulkan", "runs tfdm with boxes in the texture frame only (asked for boxes: world)");
  if (!v.folds)
    fail("--device vulkan",
         "runs tfdm only where a node above the stored levels is the union of at most 64 stored nodes; this {}x{} "
         "map stores levels 0..{} and its triangles' roots reach level {}, which the CPU answers with a "
         "minmax_mipmap",
         tm.disp.map->width(), tm.disp.map->height(), v.dims.size() - 1, v.topLevel);
  m.triOffset = uint32_t(R.tris.size());
  m.W = tm.disp.map->width(), m.H = tm.disp.map->height();
  m.sampleOffset = float(tm.disp.sampleOffset);
  m.rmipData = uint32_t(R.rmipData.size());
  m.rmipLayers = uint32_t(R.rmipLayers.size());
  m.rmipBits = v.bits, m.rmipBase = v.base, m.rmipStep = v.step;
  m.tfStored = int(v.dims.size());
  const size_t perNode = v.bits == 16 ? 1 : 2;
  size_t first = 0;
  for (size_t L = 0; L < v.dims.size(); ++L) {
    const size_t nodes = size_t(v.dims[L].x) * size_t(v.dims[L].y);
    R.rmipLayers.push_back(glm::ivec4(int(first), v.dims[L].x, v.dims[L].y, 0));
    R.rmipData.insert(R.rmipData.end(), v.words[L], v.words[L] + nodes * perNode);
    first += nodes;
  }
  if (first > size_t(INT32_MAX)) fail("--device vulkan", "tfdm's pyramid exceeds the 32-bit offsets of the GPU layout");
  R.rmipBytes += first * perNode * sizeof(uint32_t);
  appendTriangles(R, m, tm, is, mesh);
}

void appendCanonical(GpuRecords& R, MeshGpu& m, const Intersector& is, const Mesh& mesh) {
  appendTraversal(R, m, is, is, mesh);
}

// The traversals the Vulkan path runs, keyed by the kernel that chooses them
// (vulkanIntersectorKernel: a baseline's trait, else the range query's): the records'
// method (MeshGpu::method, which selects the runner's intersection shader) and how their
// records are made. A new GPU traversal is a row here and its shader in the runner's
// table (runner.cpp, kPrograms).
struct GpuMethod {
  std::string_view kernel;
  int method;
  void (*append)(GpuRecords&, MeshGpu&, const Intersector&, const Mesh&);
};
constexpr GpuMethod kMethods[] = {
    {"core/kernels/rmip_query.h", OBLONG_METHOD_CANONICAL, appendCanonical},
    {"core/kernels/tfdm.h", OBLONG_METHOD_TFDM, appendTfdm},
};

const GpuMethod& methodFor(const TraversalConfig& cfg) {
  const std::string kernel = vulkanIntersectorKernel(cfg);
  for (const GpuMethod& M : kMethods)
    if (M.kernel == kernel) return M;
  fail("--device vulkan", "internal: no GPU traversal for the kernel '{}' ({})", kernel,
       cfg.baseline.empty() ? cfg.range : cfg.baseline);
}

// Appends the map's texels and the triangles of `tm` with their boxes from `boxes`.
void appendTriangles(GpuRecords& R, MeshGpu& m, const TraversalMesh& tm, const Intersector& boxes, const Mesh& mesh) {
  const Displacement& d = tm.disp;
  m.texelOffset = uint32_t(R.texels.size());
  R.texels.insert(R.texels.end(), d.map->texels().begin(), d.map->texels().end());
  R.texelBytes += d.map->bytes();
  for (size_t ti = 0; ti < tm.tris.size(); ++ti) {
    R.tris.push_back(makeTri(tm, ti));
    AABB b = boxes.bounds(uint32_t(ti));
    AabbGpu a;
    if (b.isEmpty()) {  // inactive (NaN min x): the triangle cannot be displaced
      a = {{std::nanf(""), 0, 0}, {0, 0, 0}};
    } else {
      // In the world, padded and rounded outward as the CPU's world boxes (userBounds).
      BoxD p{dvec3(b.lo) + mesh.origin, dvec3(b.hi) + mesh.origin};
      p.pad(framePad(b, mesh.origin));
      b = p.toFloatOutward();
      a = {{b.lo.x, b.lo.y, b.lo.z}, {b.hi.x, b.hi.y, b.hi.z}};
    }
    R.aabbs.push_back(a);
  }
  R.triBytes += tm.tris.size() * sizeof(TriGpu);
}

}  // namespace

GpuRecords buildRecords(const Scene& scene, const AccelOptions& opts, nlohmann::json* describe) {
  GpuRecords R;
  if (describe) *describe = nlohmann::json::array();
  const TraversalConfig& cfg = opts.traversal;
  // What runs here is what the strategies' traits name a Vulkan kernel for.
  if (const auto missing = missingVulkanKernels(cfg); !missing.empty())
    fail("--device vulkan", "no Vulkan kernel for {} (what runs there: {})", fmt::join(missing, ", "),
         vulkanCoverage());
  const GpuMethod& method = methodFor(cfg);
  // The shader's Newton is the default one (float, tolerance 1e-5, 10 iterations).
  if (method.method == OBLONG_METHOD_CANONICAL && !cfg.inverterParams.empty())
    fail("--device vulkan", "runs newton with its default parameters only (asked for {})", cfg.inverterParams.dump());

  // Host-side records, built with the CPU's own code (createIntersector).
  auto& meshes = R.meshes;
  auto& plainIndex = R.plainIndex;
  auto& plainUV = R.plainUV;
  auto& plainPos = R.plainPos;
  std::vector<MeshGpu> levels;  // a λ per ray: the levels' records, after the scene's meshes
  meshes.assign(scene.meshes.size(), MeshGpu{});
  for (const SceneMesh& sm : scene.meshes) {
    R.meshTriangles.push_back(uint32_t(sm.mesh.triangles.size()));
    R.meshVertices.push_back(uint32_t(sm.mesh.positions.size()));
  }
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const SceneMesh& sm = scene.meshes[mi];
    const Mesh& mesh = sm.mesh;
    MeshGpu& m = meshes[mi];
    for (int k = 0; k < 3; ++k) {
      const auto w = std::bit_cast<std::array<uint32_t, 2>>(mesh.origin[k]);  // low word first (little-endian)
      m.originBits[k] = glm::uvec2(w[0], w[1]);
    }
    m.method = method.method;
    R.baseTriangles += mesh.triangles.size();
    if (!sm.displacement) {
      m.indexOffset = uint32_t(plainIndex.size());
      m.vertexOffset = uint32_t(plainPos.size() / 3);
      for (const glm::uvec3& t : mesh.triangles) plainIndex.insert(plainIndex.end(), {t.x, t.y, t.z});
      for (size_t v = 0; v < mesh.positions.size(); ++v) {
        // In the world, rounded once, as EmbreeScene's triangles.
        const vec3 p(mesh.world(v));
        plainPos.insert(plainPos.end(), {p.x, p.y, p.z});
        plainUV.push_back(mesh.hasUVs() ? mesh.uvs[v] : glm::vec2(0.0f));
      }
      continue;
    }
    const Displacement& d = *sm.displacement;
    std::vector<DisplacedTriangle> dts(mesh.triangles.size());
    for (size_t ti = 0; ti < dts.size(); ++ti) dts[ti] = mesh.triangle(ti);
    const auto is = createIntersector(cfg, dts, d);
    R.geometryName = is->name();
    if (describe) {
      nlohmann::json j = is->describe();
      j["mesh"] = int(mi);
      describe->push_back(std::move(j));
    }
    m.displaced = 1;
    m.scale = d.scale, m.bias = d.bias, m.tiling = d.tiling;
    m.marchingScale = cfg.marchingScale;
    m.inversionInTraversal = cfg.inversionInTraversal;
    if (cfg.stackDepth > OBLONG_TRAV_STACK_GPU)
      fail("--device vulkan", "strategies.stack_depth {} is deeper than the shaders' stack ({} entries)", cfg.stackDepth,
           OBLONG_TRAV_STACK_GPU);
    m.stackDepth = cfg.stackDepth;
    m.lodNext = -1;
    if (const auto* perRay = dynamic_cast<const PerRayLod*>(is.get())) {
      // A λ per ray: one record per level (its map, RMIP and triangles), after the
      // scene's meshes; the mesh's own record points to them, and its boxes (level 0's
      // range of AABBs) are the union over the levels, as on the CPU.
      const MeshGpu common = m;
      const auto first = uint32_t(scene.meshes.size() + levels.size());
      const auto K = perRay->levels() - 1;
      for (size_t k = 0; k <= K; ++k) {
        MeshGpu L = common;
        appendTraversal(R, L, perRay->band(k), *is, mesh);
        L.lod = float(k);
        L.lodNext = k < K ? int(first + k + 1) : -1;
        levels.push_back(L);
      }
      m = levels[first - scene.meshes.size()];
      m.lodLevels = int(K + 1), m.lodFirst = first, m.lodNext = -1;
    } else {
      method.append(R, m, *is, mesh);
    }
    if (R.texels.size() > size_t(UINT32_MAX) || R.rmipData.size() > size_t(INT32_MAX))
      fail("--device vulkan", "the scene's maps exceed the 32-bit offsets of the GPU layout");
  }
  if (R.geometryName.empty()) R.geometryName = "rmip+newton+midpoint2d";
  // The levels' records have no geometry of their own (no bottom level).
  meshes.insert(meshes.end(), levels.begin(), levels.end());
  R.meshTriangles.resize(meshes.size(), 0);
  R.meshVertices.resize(meshes.size(), 0);

  return R;
}

}  // namespace oblong::vk
