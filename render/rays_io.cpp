#include "render/rays_io.h"

#include "core/error.h"
#include "core/input_file.h"
#include "core/memory.h"
#include "render/output.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdint>
#include <filesystem>
#include <iterator>
#include <cstring>
#include <fstream>
#include <sstream>

namespace oblong {

namespace {

constexpr const char* kRayHeader = "ox,oy,oz,dx,dy,dz,tmin,tmax";
constexpr const char* kHitHeader = "t,mesh,prim,u,v";
// A binary hit (rays_io.h): t, mesh, prim, u, v, 4 bytes each.
constexpr size_t kHitBytes = 20;
// The .bin files are the host's floats and integers as they are in memory.
static_assert(std::endian::native == std::endian::little, "the .bin ray and hit files are little-endian");

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::vector<std::string> splitCSV(const std::string& line) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    std::string f = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    while (!f.empty() && (f.back() == ' ' || f.back() == '\r' || f.back() == '\t')) f.pop_back();
    while (!f.empty() && (f.front() == ' ' || f.front() == '\t')) f.erase(f.begin());
    out.push_back(f);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

float parseFloat(const std::string& f, const std::string& where, const char* field) {
  // strtof accepts "inf"; std::from_chars for float needs GCC 11+ and also accepts it.
  if (f.empty()) fail(where, "empty field '{}'", field);
  char* end = nullptr;
  errno = 0;
  const float v = std::strtof(f.c_str(), &end);
  if (end != f.c_str() + f.size()) fail(where, "field '{}' is not a number: '{}'", field, excerpt(f));
  if (std::isnan(v)) fail(where, "field '{}' is NaN", field);
  return v;
}

// The traversal multiplies up to three coordinates in float, and Embree asserts on
// rays beyond ~1.8e18: origins stay within the scene's coordinate limit, and directions
// are not normalised (t is in units of |d|) but must be normalisable without overflow
// or underflow.
constexpr double kMinDirection = 1.0 / double(1ull << 40), kMaxDirection = double(1ull << 40);

// Ray files are read to the end: a FIFO would block, a device never ends.
void checkRegular(const std::string& path) { checkInputFile(path); }

}  // namespace

void checkRay(const Ray& r, const std::string& where) {
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(r.o[a]) || !std::isfinite(r.d[a])) fail(where, "ray origin and direction must be finite");
  for (int a = 0; a < 3; ++a)
    if (std::abs(r.o[a]) > kMaxCoordinate)
      fail(where, "ray origin ({}, {}, {}) is beyond the coordinate limit {:g} (2^40)", r.o.x, r.o.y, r.o.z,
           double(kMaxCoordinate));
  if (r.d == vec3(0.0f)) fail(where, "ray direction is zero");
  const double len = glm::length(dvec3(r.d));
  if (len < kMinDirection || len > kMaxDirection)
    fail(where, "ray direction ({}, {}, {}) has length {:g}: it must be within [2^-40, 2^40] to be normalisable",
         r.d.x, r.d.y, r.d.z, len);
  if (!std::isfinite(r.tmin) || std::isnan(r.tmax) || r.tmin > r.tmax)
    fail(where, "need finite tmin <= tmax (tmax may be inf), got [{}, {}]", r.tmin, r.tmax);
  if (r.tmin < 0.0f) fail(where, "tmin must be >= 0, got {}", r.tmin);
}

std::vector<Ray> readRays(const std::string& path) {
  checkRegular(path);
  std::vector<Ray> rays;
  if (endsWith(path, ".bin")) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) fail(path, "cannot open ray file");
    const std::streamsize size = f.tellg();
    if (size % 32 != 0) fail(path, "size {} bytes is not a multiple of 32 (8 float32 per ray)", size);
    f.seekg(0);
    std::vector<float> buf(size_t(size) / 4);
    if (!f.read(reinterpret_cast<char*>(buf.data()), size)) fail(path, "cannot read ray file");
    rays.resize(buf.size() / 8);
    for (size_t i = 0; i < rays.size(); ++i) {
      const float* x = &buf[8 * i];
      rays[i] = Ray{vec3(x[0], x[1], x[2]), vec3(x[3], x[4], x[5]), x[6], x[7]};
      checkRay(rays[i], fmt::format("{}: ray {}", path, i));
    }
    return rays;
  }
  std::ifstream f(path);
  if (!f) fail(path, "cannot open ray file");
  std::string line;
  if (!std::getline(f, line)) fail(path, "empty file; expected the header '{}'", kRayHeader);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != kRayHeader) fail(path, "line 1: expected the header '{}', got '{}'", kRayHeader, excerpt(line));
  static const char* names[8] = {"ox", "oy", "oz", "dx", "dy", "dz", "tmin", "tmax"};
  for (size_t lineNo = 2; std::getline(f, line); ++lineNo) {
    if (line.empty() || line == "\r") continue;
    const std::string where = fmt::format("{}: line {}", path, lineNo);
    const auto fields = splitCSV(line);
    if (fields.size() != 8) fail(where, "expected 8 fields, got {}", fields.size());
    float x[8];
    for (int k = 0; k < 8; ++k) x[k] = parseFloat(fields[k], where, names[k]);
    Ray r{vec3(x[0], x[1], x[2]), vec3(x[3], x[4], x[5]), x[6], x[7]};
    checkRay(r, where);
    rays.push_back(r);
  }
  return rays;
}

void checkTraceFits(const std::string& raysPath, const std::string& hitsPath) {
  checkRegular(raysPath);
  std::ifstream f(raysPath, std::ios::binary);
  if (!f) fail(raysPath, "cannot open ray file");
  size_t n = 0;
  if (endsWith(raysPath, ".bin")) {
    f.seekg(0, std::ios::end);
    n = size_t(std::max<std::streamoff>(0, f.tellg())) / 32;
  } else {
    // Lines, read in blocks: an upper bound (blank lines are skipped when read).
    std::vector<char> buf(size_t(1) << 20);
    size_t lines = 0;
    char last = '\n';
    while (f.read(buf.data(), std::streamsize(buf.size())) || f.gcount() > 0) {
      const size_t got = size_t(f.gcount());
      lines += size_t(std::count(buf.data(), buf.data() + got, '\n'));
      last = buf[got - 1];
    }
    lines += last != '\n';
    n = lines > 0 ? lines - 1 : 0;  // the header
  }
  // The rays twice (a .bin's buffer, or the vector growing as a CSV is read), their hits,
  // and the hits file's text: a .bin's records, or a CSV line of at most ~64 bytes in a
  // string that grows by doubling.
  const size_t perRay = 2 * sizeof(Ray) + sizeof(Hit) + (endsWith(hitsPath, ".bin") ? kHitBytes : 2 * 64);
  const size_t budget = structureBudgetBytes();
  checkFits(raysPath, fmt::format("tracing {} rays", n), n * perRay,
            fmt::format("at most {} rays fit: split the ray file", budget / perRay),
            fmt::format("the rays, their hits and the hits file: {} bytes per ray", perRay));
}

void writeRays(const std::string& path, const std::vector<Ray>& rays) {
  std::string out;
  if (endsWith(path, ".bin")) {
    out.resize(rays.size() * 8 * sizeof(float));
    for (size_t i = 0; i < rays.size(); ++i) {
      const Ray& r = rays[i];
      const float x[8] = {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax};
      std::memcpy(out.data() + i * sizeof x, x, sizeof x);
    }
  } else {
    out = std::string(kRayHeader) + "\n";
    for (const Ray& r : rays)
      fmt::format_to(std::back_inserter(out), "{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", r.o.x, r.o.y,
                     r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax);
  }
  writeTextOutput(path, out);
}

void writeHits(const std::string& path, const std::vector<Hit>& hits) {
  if (endsWith(path, ".bin")) {
    // The record of rays_io.h; a miss is Hit's default (t = inf, -1, -1, 0, 0).
    std::string out(hits.size() * kHitBytes, '\0');
    for (size_t i = 0; i < hits.size(); ++i) {
      const Hit h = hits[i].valid() ? hits[i] : Hit{};
      char* o = out.data() + i * kHitBytes;
      const int32_t mesh = h.mesh, prim = h.prim;
      std::memcpy(o, &h.t, 4);
      std::memcpy(o + 4, &mesh, 4);
      std::memcpy(o + 8, &prim, 4);
      std::memcpy(o + 12, &h.uv.x, 4);
      std::memcpy(o + 16, &h.uv.y, 4);
    }
    writeTextOutput(path, out);
    return;
  }
  std::string text = std::string(kHitHeader) + "\n";
  for (const Hit& h : hits) {
    if (!h.valid()) {
      text += "inf,,,,\n";
      continue;
    }
    // %.9g round-trips a float exactly.
    fmt::format_to(std::back_inserter(text), "{:.9g},{},{},{:.9g},{:.9g}\n", h.t, h.mesh, h.prim, h.uv.x, h.uv.y);
  }
  writeTextOutput(path, text);
}

std::vector<Hit> readHits(const std::string& path) {
  checkRegular(path);
  std::vector<Hit> hits;
  if (endsWith(path, ".bin")) {
    std::ifstream f(path, std::ios::binary | std::ios::ate);
    if (!f) fail(path, "cannot open hits file");
    const std::streamsize size = f.tellg();
    if (size % std::streamsize(kHitBytes) != 0)
      fail(path, "size {} bytes is not a multiple of {} (t, mesh, prim, u, v per ray)", size, kHitBytes);
    f.seekg(0);
    std::string buf(size_t(size), '\0');
    if (!f.read(buf.data(), size)) fail(path, "cannot read hits file");
    hits.resize(buf.size() / kHitBytes);
    for (size_t i = 0; i < hits.size(); ++i) {
      const char* x = buf.data() + i * kHitBytes;
      int32_t mesh, prim;
      Hit& h = hits[i];
      std::memcpy(&h.t, x, 4);
      std::memcpy(&mesh, x + 4, 4);
      std::memcpy(&prim, x + 8, 4);
      std::memcpy(&h.uv.x, x + 12, 4);
      std::memcpy(&h.uv.y, x + 16, 4);
      h.mesh = mesh, h.prim = prim;
      const bool miss = mesh == -1 && prim == -1 && h.t == kInfinity;
      if (!miss && (mesh < 0 || prim < 0 || !std::isfinite(h.t)))
        fail(path, "hit {}: t = {}, mesh = {}, prim = {} is neither a hit (finite t, mesh and prim >= 0) nor a "
                   "miss (inf, -1, -1)", i, h.t, mesh, prim);
    }
    return hits;
  }
  std::ifstream f(path);
  if (!f) fail(path, "cannot open hits file");
  std::string line;
  if (!std::getline(f, line) || line != kHitHeader) fail(path, "line 1: expected the header '{}'", kHitHeader);
  auto index = [](const std::string& field, const std::string& where, const char* name) {
    int v = -1;
    const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
    if (ec != std::errc() || end != field.data() + field.size() || v < 0)
      fail(where, "field '{}' is not an index >= 0: '{}'", name, excerpt(field));
    return v;
  };
  for (size_t lineNo = 2; std::getline(f, line); ++lineNo) {
    const std::string where = fmt::format("{}: line {}", path, lineNo);
    const auto fields = splitCSV(line);
    if (fields.size() != 5) fail(where, "expected 5 fields, got {}", fields.size());
    Hit h;
    if (fields[0].empty() || fields[0] == "inf") {
      hits.push_back(h);
      continue;
    }
    h.t = parseFloat(fields[0], where, "t");
    h.mesh = index(fields[1], where, "mesh");
    h.prim = index(fields[2], where, "prim");
    h.uv = vec2(parseFloat(fields[3], where, "u"), parseFloat(fields[4], where, "v"));
    hits.push_back(h);
  }
  return hits;
}

}  // namespace oblong
