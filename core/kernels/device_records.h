// Layouts and binding indices shared by the Vulkan host code (render/vulkan/*.cpp) and
// the GLSL shaders (render/vulkan/shaders/), as in nvpro-samples' host_device.h: one
// definition, so the two sides cannot drift. Buffers use the scalar block layout
// (VK_EXT_scalar_block_layout, core in Vulkan 1.2): C++ and GLSL then place members
// identically as long as every struct is ordered doubles first, then 4-byte members,
// and its size is a multiple of 8 (checked by static_asserts in
// render/vulkan/records.cpp and render/vulkan/runner.cpp).
#ifndef OBLONG_VULKAN_SHARED_H
#define OBLONG_VULKAN_SHARED_H

// A shader that defines OBLONG_RECORDS_NO_TRIANGLES before including this (the ray
// generation, miss and closest-hit stages) sees no TriGpu and no double: its SPIR-V then
// declares no Float64 capability.
#ifndef OBLONG_RECORDS_NO_TRIANGLES
#include "core/kernels/curve_point.h"  // ClaimBounds
#include "core/kernels/microcells.h"   // McEdges, McTri
#include "core/kernels/patch_math.h"   // PatchFrame
#include "core/kernels/rect_bounds.h"  // BoxFrameF
#endif

#ifdef __cplusplus
#include <glm/glm.hpp>

#include <cstdint>
namespace oblong::vkgpu {
using shared::BoxFrameF;
using shared::ClaimBounds;
using shared::McEdges;
using shared::McTri;
using shared::PatchFrame;
using glm::dvec2;
using glm::dvec3;
using glm::ivec2;
using glm::ivec4;
using glm::uvec2;
using glm::vec2;
using glm::vec3;
using glm::vec4;
using uint = uint32_t;
#endif

// Descriptor set 0.
#define OBLONG_BIND_TLAS 0         // accelerationStructureEXT
#define OBLONG_BIND_RAYS 1         // RayGpu[]      (input)
#define OBLONG_BIND_HITS 2         // HitGpu[]      (output)
#define OBLONG_BIND_COUNTERS 3     // CountersGpu[] (output, per ray)
#define OBLONG_BIND_TRIANGLES 4    // TriGpu[]      (displaced triangles, all meshes)
#define OBLONG_BIND_MESHES 5       // MeshGpu[]     (indexed by the instance's custom index)
#define OBLONG_BIND_TEXELS 6       // float[] x OBLONG_CHUNKS (height maps, raw texels, row-major)
#define OBLONG_BIND_RMIP_DATA 7    // uint[] x OBLONG_CHUNKS  (RMIP entries: Rmip::words())
#define OBLONG_BIND_RMIP_LAYERS 8  // ivec4[]       (per layer: offset, nx, shiftX, shiftY)
#define OBLONG_BIND_PLAIN_INDEX 9  // uint[]        (plain meshes: 3 vertex indices a triangle)
#define OBLONG_BIND_PLAIN_UV 10    // vec2[]        (plain meshes: uv per vertex)
#define OBLONG_BIND_PLAIN_POS 11   // float[]       (plain meshes: xyz per vertex)
#define OBLONG_BIND_COUNT 12
// The texels and the RMIP words are each split over up to OBLONG_CHUNKS buffers of
// 2^MeshGpu::chunkShift elements, so that no buffer exceeds the device's
// maxStorageBufferRange (128 MiB on lavapipe: a 16384^2 map takes 8 of them).
#define OBLONG_CHUNKS 16

// Hit kinds of the SBT: hit group 0 = displaced prisms (procedural), 1 = plain triangles.
#define OBLONG_HITGROUP_PRISM 0
#define OBLONG_HITGROUP_TRIANGLES 1

// The traversal's constants (stack size, slacks, Newton's tolerance, ...) are in
// core/kernels/constants.h, shared with the CPU traversal and inversion/newton.h.

// One ray: the CPU's Ray (lod < 0: none; read by a mesh with a λ per ray only).
struct RayGpu {
  vec3 o;
  vec3 d;
  float tmin;
  float tmax;
  float lod;
  float pad;
};

// First hit of one ray (mesh = -1: miss).
struct HitGpu {
  float t;
  int mesh;
  int prim;
  float u, v;  // texture coordinates of the hit (before tiling)
  vec3 ng;     // unit geometric normal of the hit (micro-)triangle
};

// Per-ray work, the CPU's RayCounters (summed over the prisms a ray enters).
struct CountersGpu {
  int prisms, boxes, rangeQueries, inversions, cellsMarched, microTriangles;
  int boxOnlyPrisms;  // prisms traversed by projection-free box subdivision
  int pad;
};

#ifndef OBLONG_RECORDS_NO_TRIANGLES
// One displaced base triangle: DisplacedTriangle, its PrismParams, LocalFrame and what
// MicroCells reads (traversal/traversal_mesh.h, psi.h, core/kernels/microcells.h),
// precomputed on the host by the very code the CPU runs.
struct TriGpu {
  PatchFrame F;             // LocalFrame (the driver's g_F)
  ClaimBounds claim;        // PrismParams' bounds on the claims' errors (the driver's g_claim)
  dvec3 N13;                // F.N(1/3, 1/3) (the driver's dirLocal)
  dvec3 boxLo, boxHi;       // exact prism box, unpadded (Prism::exact(T, a, b).bounds())
  dvec3 boxPadLo, boxPadHi; // TraversalMesh::prismBoxes (padded for origins within budget)
  dvec3 infPadLo, infPadHi; // TraversalMesh::inflatedBoxes (padded likewise; missesPrism)
  dvec3 obbAxis[5];          // TraversalMesh::obbs (PrismOBB: kAxes slabs; missesPrism)
  double obbLo[5], obbHi[5];
  dvec2 sbLo, sbHi;         // T's uv box in local sample coordinates
  McEdges edges;            // MicroCells' edges (T's vertices in absolute sample coordinates: edges.S)
  dvec2 eps;                // PrismParams: the cell dilation ε
  double vertexErr, a, b, budget, budgetPad, maxP;  // budgetPad: TraversalMesh::budgetPad
  double inflateB, inflateS;
  // TraversalMesh::texFrames (the boxes' frame: axes, and the anchor Pc of its float
  // box frame, `box` below), texPrismBoxes (unpadded) and texPrismMag.
  dvec3 texAxis[3];
  dvec3 tPc;
  dvec3 texBoxLo, texBoxHi;
  double texMag, pad2;
  McTri mc;                 // MicroCells' triangle (DisplacedTriangle in float, scale and bias)
  BoxFrameF box;            // TraversalMesh::texFrames' float box frame (anchored at tPc)
  float uvArea2, pad0;
  ivec2 origin;             // LocalFrame::origin
  ivec2 cellLo, cellHi;     // T's cells, local (cellsOverlapping − origin)
  int valid, wellPosed;
  int obbValid, pad1;       // PrismOBB::valid()
};
#endif

// One mesh of the scene (the TLAS instance's custom index).
struct MeshGpu {
  // Mesh::origin, each double as its two 32-bit words, low first (packDouble2x32): the
  // record holds no double, so the stages that read it need no Float64. The instances'
  // transforms are the identity (a double origin is not a float transform): displaced
  // prisms' boxes are in the world, and the intersection shader moves the world ray into
  // the frame as EmbreeScene's callbacks do.
  uvec2 originBits[3];
  uint triOffset;   // first TriGpu of this mesh (displaced)
  uint texelOffset; // first texel of its height map
  int W, H;         // map size
  float scale, bias;
  vec2 tiling;
  uint rmipData, rmipLayers;  // offsets into the RMIP buffers (data: 32-bit words)
  int rmipF, rmipW, rmipH, rmipP, rmipQ, rmipWrap;  // Rmip: downsample, pixels, top layers, wrap stored
  int rmipBits, rmipFirst;     // Rmip::bits() (16: one word per entry, 32: two), firstLayer()
  float rmipBase, rmipStep;    // Rmip::quantizer() (bits 16)
  float marchingScale;
  int inversionInTraversal;  // TraversalConfig::inversionInTraversal
  int stackDepth;            // TraversalConfig::stackDepth
  int pad0;
  int displaced;
  int chunkShift;   // log2 of the elements per texel / RMIP buffer (OBLONG_CHUNKS)
  uint indexOffset;  // plain: first index (3 per triangle)
  uint vertexOffset; // plain: first vertex
  float sampleOffset;  // Displacement::sampleOffset: uv 0 is at sample -sampleOffset (LoD)
  // A λ per ray (docs/lod.md): a scene mesh's record has lodLevels > 0 and its levels'
  // records at lodFirst + k (after the scene's meshes); a ray at λ reads level ⌊λ⌋'s.
  // A level's record: its λ (= k) and its next level's record (-1: the last level).
  int lodLevels;
  uint lodFirst;
  int lodNext;
  float lod;
  // Always 0 (the record is zero-initialised): prism.rint rounds the ray into the frame
  // through it, a value the shader compiler cannot see.
  int zero;
  // The intersector this record was built for: OBLONG_METHOD_CANONICAL (the rmip* fields
  // are its Rmip) or OBLONG_METHOD_TFDM (the rmip* fields hold tfdm's min-max pyramid:
  // rmipLayers one row per stored level, rmipBits, rmipBase and rmipStep its codes;
  // tfStored the number of stored levels).
  int method;
  int tfStored;
  int pad1, pad2;  // a size that is a multiple of 8
};

#define OBLONG_METHOD_CANONICAL 0
#define OBLONG_METHOD_TFDM 1

// Intersection -> closest-hit attributes (displaced prisms).
struct HitAttrGpu {
  vec2 uv;
  vec3 ng;
};

// Payload of traceRayEXT.
struct PayloadGpu {
  float t;
  int mesh;
  int prim;
  float u, v;
  vec3 ng;
};

struct PushGpu {
  uint rayOffset;
  uint rayCount;
  uint anyHit;  // occlusion rays: stop at the first hit (gl_RayFlagsTerminateOnFirstHitEXT)
  uint pad;
};

#ifdef __cplusplus
}  // namespace oblong::vkgpu
#endif

#endif
