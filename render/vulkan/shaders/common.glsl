// Declarations shared by the ray tracing stages: extensions, the shared layouts
// (core/kernels/device_records.h) and the descriptor set.
#extension GL_EXT_ray_tracing : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require

#include "core/kernels/device_records.h"

layout(set = 0, binding = OBLONG_BIND_TLAS) uniform accelerationStructureEXT tlas;
layout(set = 0, binding = OBLONG_BIND_RAYS, scalar) readonly buffer Rays { RayGpu rays[]; };
layout(set = 0, binding = OBLONG_BIND_HITS, scalar) writeonly buffer Hits { HitGpu hits[]; };
layout(set = 0, binding = OBLONG_BIND_COUNTERS, scalar) buffer Counters { CountersGpu counters[]; };
#ifndef OBLONG_RECORDS_NO_TRIANGLES
layout(set = 0, binding = OBLONG_BIND_TRIANGLES, scalar) readonly buffer Tris { TriGpu tris[]; };
#endif
layout(set = 0, binding = OBLONG_BIND_MESHES, scalar) readonly buffer Meshes { MeshGpu meshes[]; };
layout(set = 0, binding = OBLONG_BIND_TEXELS, scalar) readonly buffer Texels { float v[]; } texelChunks[OBLONG_CHUNKS];
layout(set = 0, binding = OBLONG_BIND_RMIP_DATA, scalar) readonly buffer RmipData { uint v[]; } rmipChunks[OBLONG_CHUNKS];
layout(set = 0, binding = OBLONG_BIND_RMIP_LAYERS, scalar) readonly buffer RmipLayers { ivec4 rmipLayers[]; };
layout(set = 0, binding = OBLONG_BIND_PLAIN_INDEX, scalar) readonly buffer PlainIndex { uint plainIndex[]; };
layout(set = 0, binding = OBLONG_BIND_PLAIN_UV, scalar) readonly buffer PlainUV { vec2 plainUV[]; };
layout(set = 0, binding = OBLONG_BIND_PLAIN_POS, scalar) readonly buffer PlainPos { float plainPos[]; };

layout(push_constant, scalar) uniform Push { PushGpu pc; };

// Element idx of the chunked texels / RMIP words (chunks of 2^shift elements; rays of one
// subgroup may read different chunks).
float texelAt(uint idx, int shift) {
  return texelChunks[nonuniformEXT(idx >> uint(shift))].v[idx & ((1u << uint(shift)) - 1u)];
}
uint rmipWordAt(uint idx, int shift) {
  return rmipChunks[nonuniformEXT(idx >> uint(shift))].v[idx & ((1u << uint(shift)) - 1u)];
}
