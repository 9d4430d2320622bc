// The micro-geometry cell by cell (docs/design.md §1): the construction and the vertices
// are the CPU's own code (core/kernels/microcells.h), as is the watertight
// ray/micro-triangle test (core/kernels/microtri.h) and the heights (core/kernels/heights.h);
// here are the texel fetch, the choice of a level of detail per ray and the cell's loop. Every float and double operation is `precise` (SPIR-V
// NoContraction): no fused multiply-add, so the micro-vertices, edge functions and t come
// out as the CPU computes them, which both watertightness and CPU/GPU parity rely on.
// Needs the globals of prism.rint and traversal.glsl: g_tri, g_mesh, the ray (g_wr) and
// the closest hit (g_hit*).

#include "core/kernels/lang.h"
#include "core/kernels/microtri.h"
#include "core/kernels/texels.h"  // wrapIndex

// ---- height map (core/heightmap.h) --------------------------------------------------
// HeightMap::at of the ray's level (next 0) or of the next level's map: one fetch.
float levelAt(int next, int i, int j) {
  uint offset = next == 0 ? g_mesh.texelOffset : g_next.texelOffset;
  int W = next == 0 ? g_mesh.W : g_next.W, H = next == 0 ? g_mesh.H : g_next.H;
  int shift = next == 0 ? g_mesh.chunkShift : g_next.chunkShift;
  return texelAt(offset + uint(wrapIndex(j, H)) * uint(W) + uint(wrapIndex(i, W)), shift);
}
// Displacement::raw and lodHeight: the kernel (core/kernels/heights.h) on the ray's level
// g_mesh and the next one g_next; the ray's blend fraction g_blend is 0 unless it has a λ
// per ray.
#define Maps int
#include "core/kernels/heights.h"
float dispTexel(Maps m, int next, int i, int j) { return levelAt(next, i, j); }
float mapAt(int i, int j) { return dispLodHeight(0, i, j, g_blend); }
float dispRaw(Maps m, int i, int j) { return mapAt(i, j); }
// A λ per ray (PerRayLod::intersect, Displacement::blendOf): the record of level ⌊λ⌋
// (λ clamped to [0, last level]; NaN: 0) of scene mesh record `scene`, then, with that
// level in g_mesh, the next level and the fraction toward it. The caller loads g_mesh once
// (each load of a record is a copy of its every field in a shader).
uint levelRecord(uint scene, float rayLod) {
  float l = rayLod > 0.0 ? rayLod : 0.0;
  int k = int(min(floor(l), float(meshes[scene].lodLevels - 1)));
  return meshes[scene].lodFirst + uint(k);
}
void selectNext(float rayLod) {
  if (g_mesh.lodNext < 0) return;
  g_next = meshes[g_mesh.lodNext];
  if (rayLod > g_mesh.lod) g_blend = min(float(double(rayLod) - double(g_mesh.lod)), 1.0);
}
// Displacement::sampleToUV, toSample, microAtSample
vec2 sampleToUV(int i, int j) {
  return dispSampleToUV(double(i), double(j), g_mesh.tiling, g_mesh.W, g_mesh.H, double(g_mesh.sampleOffset));
}
dvec2 toSample(dvec2 uv) { return dispToSample(uv, g_mesh.tiling, g_mesh.W, g_mesh.H, double(g_mesh.sampleOffset)); }
float microAtSample(dvec2 s) { return dispMicroAt(0, s, g_mesh.scale, g_mesh.bias); }

// ---- MicroCells: the CPU's own code (core/kernels/microcells.h) ----------------------
#include "core/kernels/microcells.h"  // McHeights: int (the heights are the globals above)

float mcRaw(McHeights h, int i, int j) { return mapAt(i, j); }
float mcMicroAt(McHeights h, dvec2 s) { return microAtSample(s); }
bool mcGridCached(McHeights h, int i, int j, out McVertex v) {  // no cache: mcWorld computes it
  v.p = vec3(0.0);
  v.uv = vec2(0.0);
  return false;
}
vec2 mcGridUV(McHeights h, int i, int j) { return sampleToUV(i, j); }

void testMicro(McVertex v0, McVertex v1, McVertex v2);  // traversal.glsl

// MicroCells::cell, each micro-triangle tested as it is emitted (the CPU's order).
// Returns how many. An interior cell (four corners strictly inside T) is the fan of its
// corners (v00, v10, v11, v01): the CPU's two triangles (v00, v10, v11), (v00, v11, v01).
// One loop and one call site for the vertices and the test keep the inlined shader small.
int microCell(int i, int j) {
  if (TRI.uvArea2 == 0.0) return 0;
  bool interior = mcInterior(TRI.edges, i, j);
  int mask = interior ? 0 : mcClipMask(TRI.edges, i, j);
  int count = 0;
  for (int hf = 0; hf < (interior ? 1 : 2); ++hf) {
    int base = 0, m = 4;
    if (interior) {
      g_mcBuf[0] = mcGridPV(i, j, 0, 0);
      g_mcBuf[1] = mcGridPV(i + 1, j, 0, 0);
      g_mcBuf[2] = mcGridPV(i + 1, j + 1, 0, 0);
      g_mcBuf[3] = mcGridPV(i, j + 1, 0, 0);
    } else {
      m = mcHalf(TRI.edges, i, j, hf, mask, 0, base);
    }
    if (m < 3) continue;
    McVertex w[OBLONG_MC_POLY];
    for (int k = 0; k < m; ++k) w[k] = mcWorld(TRI.mc, TRI.edges, 0, g_mcBuf[base + k], mask);
    for (int k = 1; k + 1 < m; ++k) {
      testMicro(w[0], w[k], w[k + 1]);
      ++count;
    }
  }
  return count;
}

// ---- watertight ray / micro-triangle test: the CPU's own code (core/kernels/microtri.h) --
WatertightRay g_wr;

