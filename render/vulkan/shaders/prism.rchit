#version 460
// Closest hit of a displaced prism: the intersection shader already computed the hit's
// texture coordinates and its micro-triangle's normal, unnormalised; normalised here
// (microHitAttributes, traversal/microtri.h), once per ray rather than in the
// intersection shader at every closer hit.
#define OBLONG_RECORDS_NO_TRIANGLES  // no double: no Float64 capability
#include "common.glsl"
#include "core/kernels/lang.h"  // divF, sqrtF: no double

layout(location = 0) rayPayloadInEXT PayloadGpu pl;
hitAttributeEXT HitAttrGpu attr;

void main() {
  pl.t = gl_HitTEXT;
  pl.mesh = gl_InstanceCustomIndexEXT;
  pl.prim = gl_PrimitiveID;
  pl.u = attr.uv.x;
  pl.v = attr.uv.y;
  precise vec3 n = attr.ng;
  precise float len = lengthF(n);
  // One call site of divF for the three (each call inlines its correction).
  vec3 ng = vec3(0.0);
  for (int k = 0; k < 3 && len > 0.0; ++k) ng[k] = divF(n[k], len);
  pl.ng = ng;
}
