#version 460
// Miss: the payload keeps mesh = -1 (set by the ray generation shader).
#include "common.glsl"

layout(location = 0) rayPayloadInEXT PayloadGpu pl;

void main() { pl.mesh = -1; }
