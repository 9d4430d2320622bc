#version 460
// Closest hit of an undisplaced mesh (built-in triangle geometry): uv interpolated and
// the unit geometric normal (v1 − v0) × (v2 − v0), as EmbreeScene::intersect reports.
#define OBLONG_RECORDS_NO_TRIANGLES  // no double: no Float64 capability
#include "common.glsl"

layout(location = 0) rayPayloadInEXT PayloadGpu pl;
hitAttributeEXT vec2 bary;

vec3 plainVertex(uint v) { return vec3(plainPos[3 * v], plainPos[3 * v + 1], plainPos[3 * v + 2]); }

void main() {
  MeshGpu m = meshes[gl_InstanceCustomIndexEXT];
  uint k = m.indexOffset + 3u * uint(gl_PrimitiveID);
  uint i0 = m.vertexOffset + plainIndex[k], i1 = m.vertexOffset + plainIndex[k + 1u],
       i2 = m.vertexOffset + plainIndex[k + 2u];
  float u = bary.x, v = bary.y;
  vec2 uv = (1.0 - u - v) * plainUV[i0] + u * plainUV[i1] + v * plainUV[i2];
  vec3 p0 = plainVertex(i0), p1 = plainVertex(i1), p2 = plainVertex(i2);
  vec3 ng = cross(p1 - p0, p2 - p0);
  float len = length(ng);
  pl.t = gl_HitTEXT;
  pl.mesh = gl_InstanceCustomIndexEXT;
  pl.prim = gl_PrimitiveID;
  pl.u = uv.x;
  pl.v = uv.y;
  pl.ng = len > 0.0 ? ng / len : vec3(0.0);
}
