#version 460
// Miss: the payload keeps mesh = -1 (set by the ray generation shader).
#define OBLONG_RECORDS_NO_TRIANGLES  // no double: no Float64 capability
#include "common.glsl"

layout(location = 0) rayPayloadInEXT PayloadGpu pl;

void main() { pl.mesh = -1; }
