// What both intersection shaders (prism.rint: the canonical traversal; tfdm.rint: the
// tfdm baseline) do around their traversal, as EmbreeScene's user-geometry callback does
// around Intersector::intersect: the mesh, level and triangle of this prism, the ray in
// the mesh's frame, and at the end the ray's counters and the hit, kept only when
// strictly closer than the current one.

// beginPrism: false for a triangle that cannot be displaced (no hit, no counters).
bool beginPrism() {
  uint ray = pc.rayOffset + gl_LaunchIDEXT.x;
  uint record = gl_InstanceCustomIndexEXT;
  bool perRay = meshes[record].lodLevels > 0;
  float rayLod = perRay ? rays[ray].lod : 0.0;
  if (perRay) record = levelRecord(record, rayLod);
  g_mesh = meshes[record];
  g_blend = 0.0;
  if (perRay) selectNext(rayLod);
  g_tri = int(g_mesh.triOffset) + gl_PrimitiveID;
  if (TRI.valid == 0) return false;
  // The mesh's frame: the world origin minus the frame's in double, rounded once (the
  // instance transform is the identity), as EmbreeScene's callbacks compute it. The
  // rounded float passes through an xor with g_mesh.zero (0) because initPatch widens it
  // back to double, and lavapipe's compiler folds double(float(x)) into x: the shader
  // then traced the unrounded origin (measured: 4614 of 7168 rays bit-identical to the
  // CPU on the tiled quad moved by (12345.678, -271.828, 3.3); 7168 with the xor).
  dvec3 origin = dvec3(packDouble2x32(g_mesh.originBits[0]), packDouble2x32(g_mesh.originBits[1]),
                       packDouble2x32(g_mesh.originBits[2]));
  precise dvec3 o = dvec3(gl_WorldRayOriginEXT) - origin;
  vec3 of = uintBitsToFloat(floatBitsToUint(vec3(o)) ^ uvec3(g_mesh.zero));
  initPatch(of, gl_WorldRayDirectionEXT, gl_RayTminEXT, gl_RayTmaxEXT);
  return true;
}

void endPrism(bool found) {
  uint ray = pc.rayOffset + gl_LaunchIDEXT.x;
  atomicAdd(counters[ray].prisms, 1);
  atomicAdd(counters[ray].boxes, g_boxes);
  atomicAdd(counters[ray].rangeQueries, g_rangeQueries);
  atomicAdd(counters[ray].inversions, g_inversions);
  atomicAdd(counters[ray].cellsMarched, g_cells);
  atomicAdd(counters[ray].microTriangles, g_microTris);
  atomicAdd(counters[ray].boxOnlyPrisms, g_boxOnly ? 1 : 0);
  // Embree's callback keeps a hit only when strictly closer than the current one.
  if (!found || !(g_hitT < gl_RayTmaxEXT)) return;
  // microHitAttributes (traversal/microtri.h).
  precise vec2 uv = g_hb.x * g_hv0.uv + g_hb.y * g_hv1.uv + g_hb.z * g_hv2.uv;
  // The normal unnormalised: the closest-hit stage normalises it, once per ray.
  precise vec3 n = crossF(g_hv1.p - g_hv0.p, g_hv2.p - g_hv0.p);
  attr.uv = uv;
  attr.ng = n;
  reportIntersectionEXT(g_hitT, 0u);
}
