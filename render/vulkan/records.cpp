// The Vulkan path's upload records from a Scene (records.h). The per-triangle constants
// are taken from the CPU's own TraversalMesh (render/traversal/traversal_mesh.h), built
// by the same createIntersector call that EmbreeScene makes, so both paths start from
// identical numbers; the RMIP layers are the CPU traversal's own Rmip, copied as they are.
#include "render/vulkan/records.h"
#include "render/traversal/prism.h"

#include "core/error.h"
#include "render/traversal/traversal.h"
#include "render/vulkan/rmip_layout.h"
#include "render/vulkan/vulkan_scene.h"
#include "strategies/rmip.h"

#include <cmath>
#include <cstddef>

namespace oblong::vk {

using namespace vkgpu;

static_assert(sizeof(RayGpu) == 32 && sizeof(HitGpu) == 32 && sizeof(CountersGpu) == 32);
static_assert(sizeof(TriGpu) == 1192 && sizeof(TriGpu) % 8 == 0 && alignof(TriGpu) == 8);
static_assert(sizeof(MeshGpu) == 120 && sizeof(PushGpu) == 16);

namespace {

// MicroCells' edge order (core/microgeometry.cpp: uvLess, orient).
bool uvLess(const vec2& a, const vec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }
double orient(const dvec2& a, const dvec2& b, const dvec2& p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

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
  g.Pc = F.Pc, g.PX = F.PX, g.PY = F.PY, g.Nc = F.Nc, g.NX = F.NX, g.NY = F.NY;
  g.N13 = F.N(dvec2(1.0 / 3.0));
  g.p0d = F.p0, g.e1 = F.e1, g.e2 = F.e2, g.n0d = F.n0, g.f1 = F.f1, g.f2 = F.f2;
  const BoxD exact = Prism::exact(T, P.a, P.b).bounds();
  g.boxLo = exact.lo, g.boxHi = exact.hi;
  g.boxPadLo = tm.prismBoxes[i].lo, g.boxPadHi = tm.prismBoxes[i].hi;
  g.infPadLo = tm.inflatedBoxes[i].lo, g.infPadHi = tm.inflatedBoxes[i].hi;
  const PrismOBB& obb = tm.obbs[i];
  static_assert(PrismOBB::kAxes == 5);
  for (int k = 0; k < PrismOBB::kAxes; ++k) g.obbAxis[k] = obb.axis[k], g.obbLo[k] = obb.lo[k], g.obbHi[k] = obb.hi[k];
  g.obbValid = obb.valid();
  g.budgetPad = tm.budgetPad[i];
  g.bc = F.bc, g.bX = F.bX, g.bY = F.bY, g.sc = F.sc, g.sU = F.sU, g.sV = F.sV;
  g.sbLo = d.toSample(T.uvBox.lo) - dvec2(F.origin);
  g.sbHi = d.toSample(T.uvBox.hi) - dvec2(F.origin);
  dvec2 S[3];
  for (int k = 0; k < 3; ++k) S[k] = g.S[k] = d.toSample(T.t[k]);
  g.kb = P.kb, g.kxy = P.kxy, g.eps = P.eps;
  g.vertexErr = P.vertexErr, g.a = P.a, g.b = P.b, g.budget = tm.originBudget[i];
  g.maxP = maxAbsVertex(T), g.minNormalLength = T.minNormalLength;
  g.inflateB = P.inflateB, g.inflateS = P.inflateS, g.ks = P.ks;
  g.domainB = P.domainB, g.domainS0 = P.domainS0, g.domainS1 = P.domainS1;
  for (int k = 0; k < 3; ++k) g.p[k] = T.p[k], g.n[k] = T.n[k], g.t[k] = T.t[k];
  const glm::mat2& M = T.uvToBary;
  g.uvToBary = vec4(M[0][0], M[0][1], M[1][0], M[1][1]);
  for (int e = 0; e < 3; ++e) {  // MicroCells::MicroCells
    int A = e, B = (e + 1) % 3;
    if (uvLess(T.t[B], T.t[A])) std::swap(A, B);
    const int opp = 3 - A - B;
    g.edgeA[e] = A, g.edgeB[e] = B;
    g.edgeSigma[e] = orient(S[A], S[B], S[opp]) > 0 ? 1.0f : -1.0f;
  }
  g.uvArea2 = T.uvArea2;
  g.origin = F.origin;
  const CellRange& cr = tm.cells[i];
  g.cellLo = ivec2(cr.x0, cr.y0) - F.origin;
  g.cellHi = ivec2(cr.x1, cr.y1) - F.origin;
  return g;
}

}  // namespace

GpuRecords buildRecords(const Scene& scene, const AccelOptions& opts) {
  GpuRecords R;
  const TraversalConfig& cfg = opts.traversal;
  if (opts.tessellate || !cfg.baseline.empty())
    fail("--device vulkan", "runs the traversal only, not --baseline {}", opts.tessellate ? "tessellated" : cfg.baseline);
  if (cfg.range != "rmip" || cfg.inverter != "newton" || cfg.splitter != "midpoint2d")
    fail("--device vulkan", "runs the canonical configuration rmip+newton+midpoint2d only (asked for {}+{}+{})",
         cfg.range, cfg.inverter, cfg.splitter);
  // The shader's Newton is the default one (float, tolerance 1e-5, 10 iterations).
  if (!cfg.inverterParams.empty())
    fail("--device vulkan", "runs newton with its default parameters only (asked for {})", cfg.inverterParams.dump());

  // Host-side records, built with the CPU's own code (createIntersector).
  auto& tris = R.tris;
  auto& meshes = R.meshes;
  auto& texels = R.texels;
  auto& rmipData = R.rmipData;
  auto& rmipLayers = R.rmipLayers;
  auto& plainIndex = R.plainIndex;
  auto& plainUV = R.plainUV;
  auto& plainPos = R.plainPos;
  auto& aabbs = R.aabbs;
  meshes.assign(scene.meshes.size(), MeshGpu{});
  for (const SceneMesh& sm : scene.meshes) {
    R.meshTriangles.push_back(uint32_t(sm.mesh.triangles.size()));
    R.meshVertices.push_back(uint32_t(sm.mesh.positions.size()));
  }
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const SceneMesh& sm = scene.meshes[mi];
    const Mesh& mesh = sm.mesh;
    MeshGpu& m = meshes[mi];
    m.originX = mesh.origin.x, m.originY = mesh.origin.y, m.originZ = mesh.origin.z;
    R.baseTriangles += mesh.triangles.size();
    if (!sm.displacement) {
      m.indexOffset = uint32_t(plainIndex.size());
      m.vertexOffset = uint32_t(plainPos.size() / 3);
      for (const glm::uvec3& t : mesh.triangles) plainIndex.insert(plainIndex.end(), {t.x, t.y, t.z});
      for (size_t v = 0; v < mesh.positions.size(); ++v) {
        plainPos.insert(plainPos.end(), {mesh.positions[v].x, mesh.positions[v].y, mesh.positions[v].z});
        plainUV.push_back(mesh.hasUVs() ? mesh.uvs[v] : glm::vec2(0.0f));
      }
      continue;
    }
    const Displacement& d = *sm.displacement;
    std::vector<DisplacedTriangle> dts(mesh.triangles.size());
    for (size_t ti = 0; ti < dts.size(); ++ti) dts[ti] = mesh.triangle(ti);
    const auto is = createIntersector(cfg, dts, d);
    const auto* trav = dynamic_cast<const TraversalIntersectorBase*>(is.get());
    if (!trav) fail("--device vulkan", "internal: the canonical intersector is not a traversal");
    R.geometryName = is->name();
    const TraversalMesh& tm = trav->mesh();
    m.displaced = 1;
    m.triOffset = uint32_t(tris.size());
    m.texelOffset = uint32_t(texels.size());
    m.W = d.map->width(), m.H = d.map->height();
    m.scale = d.scale, m.bias = d.bias, m.tiling = d.tiling;
    m.sampleOffset = float(d.sampleOffset);  // 2^-(k+1): exact in float
    m.marchingScale = cfg.marchingScale;
    m.inversionInTraversal = cfg.inversionInTraversal;
    // The CPU traversal's own Rmip (built by createIntersector above), copied as it is.
    const auto* rmip = dynamic_cast<const Rmip*>(&trav->rangeQuery());
    if (!rmip) fail("--device vulkan", "internal: the canonical intersector's range query is not rmip");
    const RmipLayout L = RmipLayout::of(*rmip);
    m.rmipData = uint32_t(rmipData.size());
    m.rmipLayers = uint32_t(rmipLayers.size());
    m.rmipF = L.f, m.rmipW = L.rw, m.rmipH = L.rh, m.rmipP = L.P, m.rmipQ = L.Q, m.rmipWrap = L.wrap;
    m.rmipBits = L.bits, m.rmipFirst = L.p0, m.rmipBase = L.q.base, m.rmipStep = L.q.step;
    rmipData.insert(rmipData.end(), L.words.begin(), L.words.end());
    rmipLayers.insert(rmipLayers.end(), L.layers.begin(), L.layers.end());
    R.rmipBytes += L.bytes();
    texels.insert(texels.end(), d.map->texels().begin(), d.map->texels().end());
    R.texelBytes += d.map->bytes();
    for (size_t ti = 0; ti < tm.tris.size(); ++ti) {
      tris.push_back(makeTri(tm, ti));
      AABB b = is->bounds(uint32_t(ti));
      AabbGpu a;
      if (b.isEmpty()) {  // inactive (NaN min x): the triangle cannot be displaced
        a = {{std::nanf(""), 0, 0}, {0, 0, 0}};
      } else {
        // In the mesh's frame, padded as the CPU pads its world boxes (framePad).
        BoxD p{dvec3(b.lo), dvec3(b.hi)};
        p.pad(framePad(b, mesh.origin));
        b = p.toFloatOutward();
        a = {{b.lo.x, b.lo.y, b.lo.z}, {b.hi.x, b.hi.y, b.hi.z}};
      }
      aabbs.push_back(a);
    }
    R.triBytes += tm.tris.size() * sizeof(TriGpu);
    if (texels.size() > size_t(UINT32_MAX) || rmipData.size() > size_t(INT32_MAX))
      fail("--device vulkan", "the scene's maps exceed the 32-bit offsets of the GPU layout");
  }
  if (R.geometryName.empty()) R.geometryName = "rmip+newton+midpoint2d";

  return R;
}

}  // namespace oblong::vk
