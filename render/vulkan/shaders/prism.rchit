#version 460
// Closest hit of a displaced prism: the intersection shader already computed the hit's
// texture coordinates and micro-triangle normal.
#define OBLONG_RECORDS_NO_TRIANGLES  // no double: no Float64 capability
#include "common.glsl"

layout(location = 0) rayPayloadInEXT PayloadGpu pl;
hitAttributeEXT HitAttrGpu attr;

void main() {
  pl.t = gl_HitTEXT;
  pl.mesh = gl_InstanceCustomIndexEXT;
  pl.prim = gl_PrimitiveID;
  pl.u = attr.uv.x;
  pl.v = attr.uv.y;
  pl.ng = attr.ng;
}
