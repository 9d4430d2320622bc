// Scene files (docs/scene_format.md). Every error is one line "FILE: key.path: problem"
// (unknown keys: "FILE: unknown key 'key.path'"), so a typo in a long scene is found at
// once. Keys are checked before any mesh or map is loaded.
#include "core/scene.h"

#include "core/error.h"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

namespace oblong {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Reads one JSON object; remembers where it is for error messages.
class Reader {
 public:
  Reader(const json& j, std::string file, std::string key) : j_(j), file_(std::move(file)), key_(std::move(key)) {
    if (!j_.is_object()) error("must be an object, got {}", j_.dump());
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

  void allowOnly(std::initializer_list<const char*> keys) const {
    const std::set<std::string> ok(keys.begin(), keys.end());
    for (const auto& [k, v] : j_.items())
      if (!ok.count(k)) fail(file_, "unknown key '{}'", path(k));
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
    if (!v.is_string() || v.get<std::string>().empty()) errorAt(k, "must be a non-empty string, got {}", v.dump());
    return v.get<std::string>();
  }
  bool boolean(const std::string& k, bool def) const {
    if (!has(k)) return def;
    if (!j_.at(k).is_boolean()) errorAt(k, "must be true or false, got {}", j_.at(k).dump());
    return j_.at(k).get<bool>();
  }
  int positiveInt(const std::string& k, int def) const {
    if (!has(k)) return def;
    const json& v = j_.at(k);
    if (!v.is_number_integer() || v.get<int64_t>() <= 0 || v.get<int64_t>() > (1 << 20))
      errorAt(k, "must be a positive integer (at most 2^20), got {}", v.dump());
    return int(v.get<int64_t>());
  }
  // Exactly n finite numbers.
  std::vector<float> numbers(const std::string& k, size_t n) const {
    const json& v = j_.at(k);
    if (!v.is_array() || v.size() != n) errorAt(k, "must be an array of {} numbers, got {}", n, v.dump());
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
    if (!j_.at(k).is_array()) errorAt(k, "must be a number or an array of {} numbers, got {}", n, j_.at(k).dump());
    return numbers(k, n);
  }

 private:
  float toNumber(const json& v, const std::string& where) const {
    if (!v.is_number()) fail(file_, "{}: must be a number, got {}", where, v.dump());
    const double d = v.get<double>();
    if (!std::isfinite(d) || std::abs(d) > std::numeric_limits<float>::max())
      fail(file_, "{}: must be a finite number, got {}", where, v.dump());
    return float(d);
  }

  const json& j_;
  std::string file_, key_;
};

// Arrays of objects ("lights", "meshes").
const json& array(const Reader& r, const std::string& k) {
  const json& v = r.at(k);
  if (!v.is_array()) r.errorAt(k, "must be an array, got {}", v.dump());
  return v;
}

ivec2 parseImage(const Reader& r) {
  r.allowOnly({"width", "height"});
  return {r.positiveInt("width", 640), r.positiveInt("height", 480)};
}

Camera parseCamera(const Reader& r) {
  r.allowOnly({"from", "to", "up", "fov"});
  Camera c;
  c.from = r.vector3("from", c.from);
  c.to = r.vector3("to", c.to);
  c.up = r.vector3("up", c.up);
  c.fovY = r.number("fov", c.fovY);
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
  r.allowOnly({"map", "scale", "bias", "tiling", "flip_v"});
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

SceneMesh parseMesh(const Reader& r, MapCache& cache) {
  r.allowOnly({"file", "transform", "albedo", "displacement"});
  r.require("file");
  SceneMesh sm;
  const std::string file = resolve(r.file(), r.string("file"));
  MeshLoadOptions opts;
  if (r.has("transform")) opts.transform = parseTransform(r.object("transform"));
  sm.albedo = r.vector3("albedo", sm.albedo);
  for (int a = 0; a < 3; ++a)
    if (!(sm.albedo[a] >= 0.0f && sm.albedo[a] <= 1.0f)) r.errorAt("albedo", "components must lie in [0, 1]");
  if (r.has("displacement")) {
    opts.needUVs = true;
    sm.displacement = parseDisplacement(r.object("displacement"), cache);
  }
  try {
    sm.mesh = loadMesh(file, opts);
  } catch (const Error& e) {
    r.errorAt("file", "{}", e.what());
  }
  return sm;
}

// Key check of a mesh entry without loading anything, so that a typo in the last mesh
// is reported before the first (slow) mesh load.
void checkMeshKeys(const Reader& r) {
  r.allowOnly({"file", "transform", "albedo", "displacement"});
  if (r.has("transform")) r.object("transform").allowOnly({"translate", "rotate", "scale", "matrix"});
  if (r.has("displacement")) r.object("displacement").allowOnly({"map", "scale", "bias", "tiling", "flip_v"});
}

}  // namespace

Scene parseScene(const json& j, const std::string& path) {
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
    st.allowOnly({"range"});
    if (st.has("range")) {
      const Reader r = st.object("range");
      r.require("name");
      s.range.name = r.string("name");
      s.range.params = json::object();
      for (const auto& [k, v] : j.at("strategies").at("range").items())
        if (k != "name") s.range.params[k] = v;  // validated by the strategy itself
      s.range.where = path + ": strategies.range";
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
  return s;
}

Scene loadScene(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "file not found");
  if (!fs::is_regular_file(path, ec)) fail(path, "not a regular file");
  std::ifstream in(path);
  if (!in) fail(path, "cannot open file");
  json j;
  try {
    // Comments are allowed: scene files are written by hand.
    j = json::parse(in, nullptr, true, /*ignore_comments=*/true);
  } catch (const json::exception& e) {  // parse_error, or out_of_range for 1e400
    fail(path, "malformed JSON: {}", e.what());
  }
  return parseScene(j, path);
}

}  // namespace oblong
