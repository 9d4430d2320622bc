// Scene files (docs/scene_format.md). Every error is one line "FILE: key.path: problem"
// (unknown keys: "FILE: unknown key 'key.path'"), so a typo in a long scene is found at
// once. Keys are checked before any mesh or map is loaded.
#include "core/scene.h"

#include "core/error.h"
#include "core/input_file.h"
#include "core/lod.h"
#include "core/procedural.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

namespace oblong {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// A JSON value in an error message: ASCII only (no raw newline can break the one-line
// rule), invalid UTF-8 replaced, at most ~60 characters.
std::string shown(const json& v) {
  std::string s = v.dump(-1, ' ', /*ensure_ascii=*/true, json::error_handler_t::replace);
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}
// An object key in an error message: as is when it is short printable ASCII.
std::string shownKey(const std::string& k) {
  const bool plain = k.size() <= 60 && std::all_of(k.begin(), k.end(), [](char c) { return c >= 0x20 && c < 0x7f; });
  if (plain) return k;
  const std::string q = shown(json(k));  // "..."-quoted and escaped
  return q.size() >= 2 && q.front() == '"' ? q.substr(1, q.size() - (q.back() == '"' ? 2 : 1)) : q;
}

// Reads one JSON object; remembers where it is for error messages.
class Reader {
 public:
  Reader(const json& j, std::string file, std::string key) : j_(j), file_(std::move(file)), key_(std::move(key)) {
    if (!j_.is_object()) error("must be an object, got {}", shown(j_));
  }

  template <typename... Args>
  [[noreturn]] void error(fmt::format_string<Args...> f, Args&&... args) const {
    fail(file_, "{}: {}", key_.empty() ? "(top level)" : key_, fmt::format(f, std::forward<Args>(args)...));
  }
  template <typename... Args>
  [[noreturn]] void errorAt(const std::string& k, fmt::format_string<Args...> f, Args&&... args) const {
    fail(file_, "{}: {}", path(k), fmt::format(f, std::forward<Args>(args)...));
  }

  std::string path(const std::string& k) const { return key_.empty() ? k : key_ + "." + k; }
  const std::string& file() const { return file_; }
  bool has(const std::string& k) const { return j_.contains(k); }
  const json& at(const std::string& k) const { return j_.at(k); }

  const json& value() const { return j_; }
  const std::string& key() const { return key_; }

  void allowOnly(std::initializer_list<const char*> keys) const {
    const std::set<std::string> ok(keys.begin(), keys.end());
    for (const auto& [k, v] : j_.items())
      if (!ok.count(k)) fail(file_, "unknown key '{}'", path(shownKey(k)));
  }
  void require(const std::string& k) const {
    if (!has(k)) errorAt(k, "missing (required)");
  }

  Reader object(const std::string& k) const { return Reader(j_.at(k), file_, path(k)); }

  float number(const std::string& k, float def) const {
    if (!has(k)) return def;
    return toNumber(j_.at(k), path(k));
  }
  std::string string(const std::string& k) const {
    const json& v = j_.at(k);
    if (!v.is_string() || v.get<std::string>().empty()) errorAt(k, "must be a non-empty string, got {}", shown(v));
    return v.get<std::string>();
  }
  bool boolean(const std::string& k, bool def) const {
    if (!has(k)) return def;
    if (!j_.at(k).is_boolean()) errorAt(k, "must be true or false, got {}", shown(j_.at(k)));
    return j_.at(k).get<bool>();
  }
  int positiveInt(const std::string& k, int def) const {
    if (!has(k)) return def;
    return toPositiveInt(j_.at(k), path(k), 1 << 20);
  }
  // A positive integer (all components equal) or an array of n positive integers, each
  // at most `max`.
  std::vector<int> intOrArray(const std::string& k, size_t n, int def, int max) const {
    if (!has(k)) return std::vector<int>(n, def);
    const json& v = j_.at(k);
    if (v.is_number()) return std::vector<int>(n, toPositiveInt(v, path(k), max));
    if (!v.is_array() || v.size() != n) errorAt(k, "must be a positive integer or an array of {}, got {}", n, shown(v));
    std::vector<int> r;
    for (size_t i = 0; i < n; ++i) r.push_back(toPositiveInt(v[i], fmt::format("{}[{}]", path(k), i), max));
    return r;
  }
  // Exactly n finite numbers.
  std::vector<float> numbers(const std::string& k, size_t n) const {
    const json& v = j_.at(k);
    if (!v.is_array() || v.size() != n) errorAt(k, "must be an array of {} numbers, got {}", n, shown(v));
    std::vector<float> r;
    for (size_t i = 0; i < n; ++i) r.push_back(toNumber(v[i], fmt::format("{}[{}]", path(k), i)));
    return r;
  }
  vec3 vector3(const std::string& k, const vec3& def) const {
    if (!has(k)) return def;
    const auto a = numbers(k, 3);
    return {a[0], a[1], a[2]};
  }
  // A number (all components equal) or an array of n numbers.
  std::vector<float> numberOrArray(const std::string& k, size_t n, float def) const {
    if (!has(k)) return std::vector<float>(n, def);
    if (j_.at(k).is_number()) return std::vector<float>(n, number(k, def));
    if (!j_.at(k).is_array()) errorAt(k, "must be a number or an array of {} numbers, got {}", n, shown(j_.at(k)));
    return numbers(k, n);
  }

 private:
  float toNumber(const json& v, const std::string& where) const {
    if (!v.is_number()) fail(file_, "{}: must be a number, got {}", where, shown(v));
    const double d = v.get<double>();
    if (!std::isfinite(d) || std::abs(d) > std::numeric_limits<float>::max())
      fail(file_, "{}: must be a finite number within float's range (|x| <= {:g}), got {}", where,
           std::numeric_limits<float>::max(), shown(v));
    // Rounding to float must not turn a nonzero value into 0 (or a subnormal): the
    // checks after it would blame a value that was not given.
    if (d != 0.0 && std::abs(d) < std::numeric_limits<float>::min())
      fail(file_, "{}: {} is too small for a float: give 0 or a magnitude of at least {:g}", where, shown(v),
           std::numeric_limits<float>::min());
    return float(d);
  }
  int toPositiveInt(const json& v, const std::string& where, int max) const {
    // Unsigned values beyond int64 would wrap in get<int64_t>(): compare as unsigned.
    const bool ok = v.is_number_unsigned() ? v.get<uint64_t>() >= 1 && v.get<uint64_t>() <= uint64_t(max)
                    : v.is_number_integer() ? v.get<int64_t>() >= 1 && v.get<int64_t>() <= max
                                            : false;
    if (!ok) fail(file_, "{}: must be a positive integer (at most {}), got {}", where, max, shown(v));
    return int(v.get<int64_t>());
  }

  const json& j_;
  std::string file_, key_;
};

// Arrays of objects ("lights", "meshes").
const json& array(const Reader& r, const std::string& k) {
  const json& v = r.at(k);
  if (!v.is_array()) r.errorAt(k, "must be an array, got {}", shown(v));
  return v;
}

ivec2 parseImage(const Reader& r) {
  r.allowOnly({"width", "height"});
  const ivec2 size{r.positiveInt("width", 640), r.positiveInt("height", 480)};
  if (int64_t(size.x) * size.y > kMaxImagePixels)
    r.error("{}x{} pixels is more than the supported 2^26 (8192x8192)", size.x, size.y);
  return size;
}

Camera parseCamera(const Reader& r) {
  r.allowOnly({"from", "to", "up", "fov"});
  Camera c;
  c.from = r.vector3("from", c.from);
  c.to = r.vector3("to", c.to);
  c.up = r.vector3("up", c.up);
  c.fovY = r.number("fov", c.fovY);
  for (const char* k : {"from", "to"}) {
    const vec3& p = k[0] == 'f' ? c.from : c.to;
    if (!(std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) <= kMaxCoordinate))
      r.errorAt(k, "[{}, {}, {}] lies beyond the supported coordinate range (|x|, |y|, |z| <= 2^40 = {:.4g})", p.x, p.y,
                p.z, kMaxCoordinate);
  }
  if (!(c.fovY > 0.0f && c.fovY < 180.0f)) r.errorAt("fov", "must lie in (0, 180) degrees, got {}", c.fovY);
  const vec3 d = c.to - c.from;
  if (!(glm::length(d) > 0.0f)) r.error("'from' and 'to' coincide: no view direction");
  if (!(glm::length(c.up) > 0.0f)) r.errorAt("up", "is the zero vector");
  // sin of the angle between up and the view direction: the camera basis needs it > 0.
  if (!(glm::length(glm::cross(glm::normalize(d), glm::normalize(c.up))) > 1e-4f))
    r.errorAt("up", "is parallel to the view direction");
  return c;
}

Light parseLight(const Reader& r) {
  r.require("type");
  const std::string type = r.string("type");
  Light L;
  if (type == "directional") {
    r.allowOnly({"type", "direction", "intensity"});
    r.require("direction");
    L.type = Light::Type::Directional;
    const vec3 d = r.vector3("direction", L.direction);
    if (!(glm::length(d) > 0.0f)) r.errorAt("direction", "is the zero vector");
    L.direction = glm::normalize(d);
  } else if (type == "point") {
    r.allowOnly({"type", "position", "intensity"});
    r.require("position");
    L.type = Light::Type::Point;
    L.position = r.vector3("position", L.position);
  } else {
    r.errorAt("type", "unknown light type '{}' (known: directional, point)", type);
  }
  const auto I = r.numberOrArray("intensity", 3, 1.0f);
  for (float x : I)
    if (x < 0.0f) r.errorAt("intensity", "must not be negative");
  L.intensity = vec3(I[0], I[1], I[2]);
  return L;
}

// Scale, then rotate, then translate; or a full row-major affine "matrix".
glm::mat4 parseTransform(const Reader& r) {
  r.allowOnly({"translate", "rotate", "scale", "matrix"});
  if (r.has("matrix")) {
    if (r.has("translate") || r.has("rotate") || r.has("scale"))
      r.errorAt("matrix", "cannot be combined with translate/rotate/scale");
    const auto a = r.numbers("matrix", 16);
    glm::mat4 m;
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 4; ++col) m[col][row] = a[size_t(row * 4 + col)];  // glm is column-major
    // Normals and displacement directions are only meaningful under affine maps.
    if (a[12] != 0.0f || a[13] != 0.0f || a[14] != 0.0f || a[15] != 1.0f) r.errorAt("matrix", "last row must be 0 0 0 1 (affine transforms only)");
    const float det = glm::determinant(glm::mat3(m));
    if (!(std::abs(det) > 0.0f) || !std::isfinite(det)) r.errorAt("matrix", "is singular");
    return m;
  }
  const auto s = r.numberOrArray("scale", 3, 1.0f);
  for (float x : s)
    if (x == 0.0f) r.errorAt("scale", "must not be zero (the transform would be singular)");
  glm::mat4 m = glm::scale(glm::mat4(1.0f), vec3(s[0], s[1], s[2]));
  if (r.has("rotate")) {
    const auto a = r.numbers("rotate", 4);
    const vec3 axis(a[1], a[2], a[3]);
    if (!(glm::length(axis) > 0.0f)) r.errorAt("rotate", "axis is the zero vector");
    m = glm::rotate(glm::mat4(1.0f), glm::radians(a[0]), glm::normalize(axis)) * m;
  }
  const vec3 t = r.vector3("translate", vec3(0.0f));
  return glm::translate(glm::mat4(1.0f), t) * m;
}

// Map files shared between meshes: one load per (file, flip_v).
using MapCache = std::map<std::pair<std::string, bool>, std::shared_ptr<const HeightMap>>;

// Relative paths are relative to the scene file's folder.
std::string resolve(const std::string& sceneFile, const std::string& p) {
  const fs::path fp(p);
  if (fp.is_absolute()) return fp.lexically_normal().string();
  return (fs::path(sceneFile).parent_path() / fp).lexically_normal().string();
}

Displacement parseDisplacement(const Reader& r, MapCache& cache) {
  r.allowOnly({"map", "scale", "bias", "tiling", "flip_v"});  // = kDisplacementKeys
  r.require("map");
  Displacement d;
  const std::string file = resolve(r.file(), r.string("map"));
  const bool flip = r.boolean("flip_v", false);
  d.scale = r.number("scale", 1.0f);
  if (d.scale == 0.0f) r.errorAt("scale", "must not be zero (leave out 'displacement' for a flat mesh)");
  d.bias = r.number("bias", 0.0f);
  const auto t = r.numberOrArray("tiling", 2, 1.0f);
  if (!(t[0] > 0.0f && t[1] > 0.0f)) r.errorAt("tiling", "must be positive, got [{}, {}]", t[0], t[1]);
  d.tiling = vec2(t[0], t[1]);
  // The same file by another spelling ("a/../m.png") is still one map.
  std::error_code ec;
  fs::path canon = fs::weakly_canonical(file, ec);
  auto& slot = cache[{ec ? file : canon.string(), flip}];
  if (!slot) {
    try {
      slot = std::make_shared<const HeightMap>(HeightMap::load(file, flip));
    } catch (const Error& e) {
      r.errorAt("map", "{}", e.what());
    }
  }
  d.map = slot;
  return d;
}

const std::initializer_list<const char*> kMeshKeys = {"file",   "shape",       "transform",
                                                      "albedo", "displacement", "normals"};
const std::initializer_list<const char*> kDisplacementKeys = {"map", "scale", "bias", "tiling", "flip_v"};
const std::initializer_list<const char*> kTransformKeys = {"translate", "rotate", "scale", "matrix"};

// Keys each shape type accepts (besides "type").
const std::map<std::string, std::vector<std::string>> kShapeKeys = {
    {"plane", {"type", "size", "segments", "uv"}},
    {"sphere", {"type", "radius", "segments"}},
    {"torus", {"type", "major_radius", "minor_radius", "segments"}},
};
constexpr int kMaxSegments = 1 << 14;           // per direction
constexpr int64_t kMaxShapeQuads = int64_t(1) << 22;  // ~8M triangles

void checkShapeKeys(const Reader& r) {
  r.require("type");
  const std::string type = r.string("type");
  const auto it = kShapeKeys.find(type);
  if (it == kShapeKeys.end()) r.errorAt("type", "unknown shape '{}' (known: plane, sphere, torus)", shownKey(type));
  std::set<std::string> ok(it->second.begin(), it->second.end());
  for (const auto& [k, v] : r.value().items())
    if (!ok.count(k)) fail(r.file(), "unknown key '{}' (a {} takes {})", r.path(shownKey(k)), type,
                           fmt::join(std::vector<std::string>(it->second.begin() + 1, it->second.end()), ", "));
}

// A procedural mesh (docs/scene_format.md, "Shapes"). Its name in errors is
// "<procedural TYPE>".
Mesh parseShape(const Reader& r) {
  checkShapeKeys(r);
  const std::string type = r.string("type");
  auto segments = [&](int du, int dv, int minU, int minV) {
    const auto n = r.intOrArray("segments", 2, 0, kMaxSegments);
    const ivec2 seg = r.has("segments") ? ivec2(n[0], n[1]) : ivec2(du, dv);
    if (seg.x < minU || seg.y < minV) r.errorAt("segments", "a {} needs at least [{}, {}], got [{}, {}]", type, minU, minV, seg.x, seg.y);
    if (int64_t(seg.x) * seg.y > kMaxShapeQuads)
      r.errorAt("segments", "[{}, {}] is more than the supported {} quads", seg.x, seg.y, kMaxShapeQuads);
    return seg;
  };
  if (type == "plane") {
    const auto size = r.numberOrArray("size", 2, 2.0f);
    if (!(size[0] > 0.0f && size[1] > 0.0f)) r.errorAt("size", "must be positive, got [{}, {}]", size[0], size[1]);
    const ivec2 seg = segments(1, 1, 1, 1);
    vec2 uv0(0.0f), uv1(1.0f);
    if (r.has("uv")) {
      const auto uv = r.numbers("uv", 4);
      uv0 = vec2(uv[0], uv[1]), uv1 = vec2(uv[2], uv[3]);
      if (!(uv0.x < uv1.x && uv0.y < uv1.y)) r.errorAt("uv", "must be [u0, v0, u1, v1] with u0 < u1 and v0 < v1");
    }
    return planeMesh(vec2(size[0], size[1]), seg, uv0, uv1);
  }
  if (type == "sphere") {
    const float radius = r.number("radius", 1.0f);
    if (!(radius > 0.0f)) r.errorAt("radius", "must be positive, got {}", radius);
    const ivec2 seg = segments(64, 32, 3, 2);
    return sphereMesh(radius, seg.x, seg.y);
  }
  // torus
  const float R = r.number("major_radius", 1.0f), rr = r.number("minor_radius", 0.4f);
  if (!(rr > 0.0f && rr < R)) r.error("needs 0 < minor_radius < major_radius, got {} and {}", rr, R);
  const ivec2 seg = segments(48, 24, 3, 3);
  return torusMesh(R, rr, seg.x, seg.y);
}

// Limits that keep a displaced mesh within what floats and the integer sample grid can
// represent (docs/design.md §3 invariant 6): finite heights, sample coordinates within ±2^30.
void checkDisplacement(const Reader& r, const Mesh& mesh, const Displacement& d) {
  const Interval raw = d.map->range();
  const double lo = double(d.scale) * (double(raw.lo) + d.bias), hi = double(d.scale) * (double(raw.hi) + d.bias);
  const float flo = float(lo), fhi = float(hi);
  if (!std::isfinite(flo) || !std::isfinite(fhi) || !std::isfinite(raw.lo + d.bias) || !std::isfinite(raw.hi + d.bias))
    r.errorAt("displacement.scale", "heights scale * (H + bias) overflow a float for the map's H in [{}, {}]", raw.lo,
              raw.hi);
  vec2 maxUV(0.0f);
  for (const glm::uvec3& f : mesh.triangles)
    for (int k = 0; k < 3; ++k) maxUV = glm::max(maxUV, glm::abs(mesh.uvs[f[k]]));
  // Displaced points p + h·n (n unit) stay within kMaxCoordinate, as the traversal needs.
  double maxP = 0.0;
  for (const glm::uvec3& f : mesh.triangles)
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) maxP = std::max(maxP, std::abs(mesh.world(f[k])[a]));
  const double maxH = std::max(std::abs(lo), std::abs(hi));
  if (!(maxP + maxH <= double(kMaxCoordinate)))
    r.errorAt("displacement.scale",
              "displaced points reach {:.4g} (positions up to {:.4g}, heights up to {:.4g}: map {} with H in [{}, {}], "
              "scale {}, bias {}), beyond the supported coordinate range 2^40 = {:.4g}",
              maxP + maxH, maxP, maxH, d.map->name(), raw.lo, raw.hi, d.scale, d.bias, kMaxCoordinate);
  const double su = double(maxUV.x) * d.tiling.x * d.map->width(), sv = double(maxUV.y) * d.tiling.y * d.map->height();
  constexpr double kMaxSample = double(1 << 30);
  if (!(su < kMaxSample && sv < kMaxSample))
    r.errorAt("displacement.tiling",
              "uvs up to ({}, {}) times tiling ({}, {}) times the map size {}x{} reach sample {:.3g}: more than the "
              "supported 2^30",
              maxUV.x, maxUV.y, d.tiling.x, d.tiling.y, d.map->width(), d.map->height(), std::max(su, sv));
}

SceneMesh parseMesh(const Reader& r, MapCache& cache) {
  r.allowOnly(kMeshKeys);
  if (r.has("file") && r.has("shape")) r.error("give either 'file' or 'shape', not both");
  if (!r.has("shape") && !r.has("file")) r.errorAt("file", "missing (required, unless the mesh is a 'shape')");
  SceneMesh sm;
  MeshLoadOptions opts;
  if (r.has("transform")) opts.transform = parseTransform(r.object("transform"));
  if (r.has("normals")) {
    const std::string n = r.string("normals");
    if (n != "file" && n != "smooth") r.errorAt("normals", "must be \"file\" or \"smooth\", got {}", shown(json(n)));
    opts.smoothNormals = n == "smooth";
  }
  sm.albedo = r.vector3("albedo", sm.albedo);
  for (int a = 0; a < 3; ++a)
    if (!(sm.albedo[a] >= 0.0f && sm.albedo[a] <= 1.0f)) r.errorAt("albedo", "components must lie in [0, 1]");
  if (r.has("displacement")) {
    opts.needUVs = true;
    sm.displacement = parseDisplacement(r.object("displacement"), cache);
  }
  if (r.has("shape")) {
    const Reader sr = r.object("shape");
    sm.mesh = parseShape(sr);
    try {
      finishMesh(sm.mesh, opts);
    } catch (const Error& e) {
      r.errorAt("shape", "{}", e.what());
    }
  } else {
    const std::string file = resolve(r.file(), r.string("file"));
    try {
      sm.mesh = loadMesh(file, opts);
    } catch (const Error& e) {
      r.errorAt("file", "{}", e.what());
    }
  }
  if (sm.displacement) checkDisplacement(r, sm.mesh, *sm.displacement);
  return sm;
}

// Key check of a mesh entry without loading anything, so that a typo in the last mesh
// is reported before the first (slow) mesh load.
void checkMeshKeys(const Reader& r) {
  r.allowOnly(kMeshKeys);
  if (r.has("transform")) r.object("transform").allowOnly(kTransformKeys);
  if (r.has("displacement")) r.object("displacement").allowOnly(kDisplacementKeys);
  if (r.has("shape")) checkShapeKeys(r.object("shape"));
}

// strategies.NAME: {"name": ..., params...}; the parameters are checked by the strategy.
void parseStrategy(const Reader& st, const std::string& slot, StrategyChoice& out) {
  if (!st.has(slot)) return;
  const Reader r = st.object(slot);
  r.require("name");
  out.name = r.string("name");
  out.params = json::object();
  for (const auto& [k, v] : r.value().items())
    if (k != "name") out.params[k] = v;  // validated by the strategy itself
  out.where = r.file() + ": " + r.key();
}

}  // namespace

namespace {

// Nesting depth, measured without recursion: copying or printing a value recurses, so a
// document nested 100 000 deep would overflow the stack there.
constexpr size_t kMaxDepth = 64;
size_t depthOf(const json& j) {
  size_t deepest = 0;
  std::vector<std::pair<const json*, size_t>> stack{{&j, 1}};
  while (!stack.empty()) {
    const auto [v, d] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, d);
    if (d > kMaxDepth) break;
    if (v->is_structured())
      for (const auto& child : *v) stack.emplace_back(&child, d + 1);
  }
  return deepest;
}

Scene parseSceneImpl(const json& j, const std::string& path) {
  if (depthOf(j) > kMaxDepth) fail(path, "nested deeper than {} levels", kMaxDepth);
  const Reader top(j, path, "");
  top.allowOnly({"image", "camera", "lights", "meshes", "strategies"});
  Scene s;
  s.path = path;
  if (top.has("image")) s.imageSize = parseImage(top.object("image"));
  if (top.has("camera")) s.camera = parseCamera(top.object("camera"));
  if (top.has("lights")) {
    const json& lights = array(top, "lights");
    for (size_t i = 0; i < lights.size(); ++i) s.lights.push_back(parseLight(Reader(lights[i], path, fmt::format("lights[{}]", i))));
  }
  if (top.has("strategies")) {
    const Reader st = top.object("strategies");
    st.allowOnly({"range", "inverter", "splitter", "baseline", "marching_scale", "inversion_in_traversal",
                  "stack_depth", "lod", "lod_bias"});
    parseStrategy(st, "range", s.range);
    parseStrategy(st, "inverter", s.inverter);
    parseStrategy(st, "splitter", s.splitter);
    parseStrategy(st, "baseline", s.baseline);
    s.marchingScale = st.number("marching_scale", s.marchingScale);
    if (!(s.marchingScale >= kMinMarchingScale))
      st.errorAt("marching_scale", "must be positive (texels) and >= {} (smaller only multiplies the work), got {}",
                 kMinMarchingScale, s.marchingScale);
    s.inversionInTraversal = st.boolean("inversion_in_traversal", s.inversionInTraversal);
    if (st.has("stack_depth")) {
      const json& v = st.at("stack_depth");
      if (!v.is_number_integer() || v.get<int64_t>() < 2 || v.get<int64_t>() > OBLONG_TRAV_STACK)
        st.errorAt("stack_depth", "must be an integer from 2 to {} (entries), got {}", OBLONG_TRAV_STACK, shown(v));
      s.stackDepth = int(v.get<int64_t>());
    }
    if (st.has("lod")) {
      const json& v = st.at("lod");
      if (v.is_string() && v.get<std::string>() == "off") s.lod.reset();
      else if (v.is_string() && v.get<std::string>() == "cone") s.lod.reset(), s.lodCone = true;
      else if (v.is_number() && std::isfinite(v.get<double>()) && v.get<double>() >= 0.0)
        s.lod = float(std::min(v.get<double>(), 64.0));  // no map has more levels; clamped per map anyway
      else st.errorAt("lod", "must be \"off\", \"cone\" or a level of detail >= 0 (a number), got {}", shown(v));
    }
    if (st.has("lod_bias")) {
      const json& v = st.at("lod_bias");
      if (!v.is_number() || !std::isfinite(v.get<double>()) || std::abs(v.get<double>()) > 64.0)
        st.errorAt("lod_bias", "must be a number of levels in [-64, 64], got {}", shown(v));
      s.lodBias = float(v.get<double>());
    }
  }
  top.require("meshes");
  const json& meshes = array(top, "meshes");
  if (meshes.empty()) top.errorAt("meshes", "is empty: a scene needs at least one mesh");
  std::vector<Reader> entries;
  for (size_t i = 0; i < meshes.size(); ++i) {
    entries.emplace_back(meshes[i], path, fmt::format("meshes[{}]", i));
    checkMeshKeys(entries.back());
  }
  MapCache cache;
  for (const Reader& r : entries) s.meshes.push_back(parseMesh(r, cache));
  if (s.lod) setLod(s, s.lod, path + ": strategies.lod");
  return s;
}

// nlohmann::json keeps the last of duplicate keys silently; a scene file with two
// "scale"s is a mistake to report, by key path. Tracks the open objects and arrays
// through the parser's events.
class DuplicateKeys {
 public:
  explicit DuplicateKeys(std::string file) : file_(std::move(file)) {}
  bool operator()(json::parse_event_t event, const json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start: open_.push_back({true, {}, {}, 0}); break;
      case json::parse_event_t::array_start: open_.push_back({false, {}, {}, 0}); break;
      case json::parse_event_t::key: {
        Open& o = open_.back();
        o.key = parsed.get<std::string>();
        if (!o.keys.insert(o.key).second) fail(file_, "duplicate key '{}'", path());
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!open_.empty()) open_.pop_back();
        [[fallthrough]];
      case json::parse_event_t::value:
        if (!open_.empty() && !open_.back().object) ++open_.back().index;
        break;
    }
    return true;
  }

 private:
  struct Open {
    bool object;
    std::set<std::string> keys;
    std::string key;  // objects: the current key
    size_t index;     // arrays: the current element
  };
  std::string path() const {
    std::string p;
    for (const Open& o : open_) {
      if (!o.object) {
        p += fmt::format("[{}]", o.index);
        continue;
      }
      if (!p.empty()) p += '.';
      p += shownKey(o.key);
    }
    return p;
  }
  std::string file_;
  std::vector<Open> open_;
};

// Every error is one line, whatever a file name or a library message contains.
[[noreturn]] void rethrowOneLine(const Error& e) {
  std::string msg = e.what();
  for (char& c : msg)
    if (c == '\n' || c == '\r') c = ' ';
  throw Error(msg);
}

}  // namespace

Scene parseScene(const json& j, const std::string& path) {
  try {
    return parseSceneImpl(j, path);
  } catch (const Error& e) {
    rethrowOneLine(e);
  }
}

namespace {
// What a file that is not JSON is, when its first bytes say so (an image or a binary
// mesh given as the scene): nullptr otherwise.
const char* knownBinaryKind(const std::string& path) {
  char head[12] = {};
  std::ifstream f(path, std::ios::binary);
  f.read(head, sizeof head);
  const std::string_view h(head, size_t(std::max<std::streamsize>(0, f.gcount())));
  const auto starts = [&](std::string_view m) { return h.substr(0, m.size()) == m; };
  if (starts("\x89PNG")) return "a PNG image";
  if (starts("\xFF\xD8\xFF")) return "a JPEG image";
  if (starts("\x76\x2f\x31\x01")) return "an OpenEXR image";
  if (starts(std::string_view("II*\0", 4)) || starts(std::string_view("MM\0*", 4))) return "a TIFF image";
  if (starts("#?RADIANCE") || starts("#?RGBE")) return "a Radiance HDR image";
  if (starts("GIF8")) return "a GIF image";
  if (starts("PF\n") || starts("Pf\n")) return "a PFM image";
  if (starts("BM")) return "a BMP image";
  if (starts("ply\n") || starts("ply\r")) return "a PLY mesh whose name does not end in .ply";
  if (starts("glTF")) return "a GLB mesh whose name does not end in .glb";
  return nullptr;
}
}  // namespace

Scene loadScene(const std::string& path) {
  try {
    checkInputFile(path);
    std::ifstream in(path);
    if (!in) fail(path, "cannot open file");
    json j;
    DuplicateKeys duplicates(path);
    try {
      // Comments are allowed: scene files are written by hand.
      j = json::parse(
          in, [&](int, json::parse_event_t event, json& parsed) { return duplicates(event, parsed); }, true,
          /*ignore_comments=*/true);
    } catch (const json::exception& e) {  // parse_error, or out_of_range for 1e400
      if (const char* kind = knownBinaryKind(path))
        fail(path, "is {}, not a scene (a JSON scene file, or a mesh file such as .obj, .ply or .gltf; a "
                   "displacement map goes in meshes[].displacement.map, or after --displacement with a mesh file)",
             kind);
      fail(path, "malformed JSON: {}", e.what());
    }
    return parseSceneImpl(j, path);
  } catch (const Error& e) {
    rethrowOneLine(e);
  }
}

void setLod(Scene& scene, std::optional<float> lod, const std::string& where) {
  if (lod && !(std::isfinite(*lod) && *lod >= 0.0f))
    fail(where, "must be \"off\" or a level of detail >= 0, got {}", *lod);
  std::map<const HeightMap*, Displacement> built;  // level-0 map -> the displacement at λ
  for (SceneMesh& sm : scene.meshes) {
    if (!sm.displacement) continue;
    Displacement& d = *sm.displacement;
    const Displacement base = atLevel0(d);
    if (!lod) {
      d = base;
      continue;
    }
    auto it = built.find(base.map.get());
    if (it == built.end()) it = built.emplace(base.map.get(), atLod(base, *lod)).first;
    // Same map, own scale, bias and tiling.
    const Displacement& shared = it->second;
    d.map = shared.map, d.level0 = shared.level0, d.lod = shared.lod, d.sampleOffset = shared.sampleOffset;
  }
  scene.lod = lod;
  scene.lodCone = false;
}

void setLodCone(Scene& scene) {
  setLod(scene, std::nullopt, "lod");
  scene.lodCone = true;
}

}  // namespace oblong
