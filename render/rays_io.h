// Ray and hit files for `oblong trace`, so that anything outside the project can check
// the hits:
//   rays: CSV with header `ox,oy,oz,dx,dy,dz,tmin,tmax` (one ray a line), or a `.bin`
//         file of 8 little-endian float32 per ray in the same order;
//   hits: CSV with header `t,mesh,prim,u,v`; a miss is `inf,,,,`; prim is the index of
//         the base triangle in the mesh as loaded, (u,v) the texture coordinates of
//         the hit before tiling; or, for a `.bin` name (as the rays), 20 bytes per ray
//         in the rays' order: t (float32), mesh, prim (int32), u, v (float32), all
//         little-endian; a miss is t = inf, mesh = prim = -1, u = v = 0.
#pragma once

#include "core/math.h"
#include "render/trace_backend.h"  // Hit

#include <string>
#include <vector>

namespace oblong {

// Throws oblong::Error naming the file (and line) on any problem: missing file, wrong
// header, wrong field count, non-numeric or non-finite values (tmax may be inf),
// zero direction, tmin > tmax, a .bin size not a multiple of 32 bytes.
std::vector<Ray> readRays(const std::string& path);
// One ray as readRays checks it (finite, within the coordinate limit, a normalisable
// direction, 0 <= tmin <= tmax); throws oblong::Error naming `where`.
void checkRay(const Ray& r, const std::string& where);
// Throws oblong::Error naming the ray file, before it is read, when `oblong trace` of it
// would hold more than the memory budget (core/memory.h): the rays, their hits and the
// hits file's text for `hitsPath`, per ray; the rays counted without parsing them (a
// .bin's size over 32 bytes, a CSV's lines after the header).
void checkTraceFits(const std::string& raysPath, const std::string& hitsPath);
void writeRays(const std::string& path, const std::vector<Ray>& rays);  // by extension
// CSV, or binary for a name ending in .bin (as writeRays and readRays).
void writeHits(const std::string& path, const std::vector<Hit>& hits);
// t, mesh, prim, uv only; throws oblong::Error naming the file (and line or hit) on a
// malformed file.
std::vector<Hit> readHits(const std::string& path);

}  // namespace oblong
