// Scenes: meshes (optionally displaced), a camera, lights and the strategy choice by
// name. The JSON format is documented in docs/scene_format.md.
#pragma once

#include "core/kernels/constants.h"

#include "core/heightmap.h"
#include "core/mesh.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace oblong {

struct SceneMesh {
  Mesh mesh;
  std::optional<Displacement> displacement;  // none: a plain triangle mesh
  vec3 albedo{0.7f};
};

struct Camera {
  vec3 from{0.0f, 0.0f, 5.0f};
  vec3 to{0.0f};
  vec3 up{0.0f, 1.0f, 0.0f};
  float fovY = 40.0f;  // degrees
};

struct Light {
  enum class Type { Point, Directional } type = Type::Directional;
  vec3 position{0.0f};          // point lights
  vec3 direction{0.0f, -1.0f, 0.0f};  // directional lights: direction the light travels
  vec3 intensity{1.0f};
};

// A strategy chosen by name with its parameters (validated when it is created).
struct StrategyChoice {
  std::string name;
  nlohmann::json params = nlohmann::json::object();
  std::string where;  // "scene.json: strategies.range" for error messages
};

// Below this the work per ray grows without bound for no gain in exactness: marching
// rectangles smaller than a cell still tests whole cells.
constexpr float kMinMarchingScale = 1.0f / 64.0f;  // texels
// A scene's image (and --size): 2^26 pixels (8192 x 8192).
constexpr int64_t kMaxImagePixels = int64_t(1) << 26;

struct Scene {
  std::string path;  // file it came from ("<default>" for the built-in scene)
  std::vector<SceneMesh> meshes;
  Camera camera;
  std::vector<Light> lights;
  StrategyChoice range{"rmip", nlohmann::json::object(), "<default>: strategies.range"};
  StrategyChoice inverter{"newton", nlohmann::json::object(), "<default>: strategies.inverter"};
  StrategyChoice splitter{"midpoint2d", nlohmann::json::object(), "<default>: strategies.splitter"};
  // A baseline instead of the traversal ("" none; "tessellated", or a registered one).
  StrategyChoice baseline{"", nlohmann::json::object(), "<default>: strategies.baseline"};
  float marchingScale = 4.0f;        // texels: rectangles at most this size are marched
  bool inversionInTraversal = true;  // invert box intervals to tighten rectangles
  int stackDepth = OBLONG_TRAV_STACK_DEFAULT;  // entries of the traversal's stack it may use
  // Level of detail (docs/lod.md): none = off (full resolution, nothing built), or one
  // λ >= 0 for the whole scene, clamped per map to its last level. The meshes'
  // displacements are already at it (setLod).
  std::optional<float> lod;
  // "cone": a λ per ray from its ray cone (docs/lod.md, "A λ per ray"), the displacements
  // at level 0 and every level built by the intersectors; lodBias is added to each λ.
  bool lodCone = false;
  float lodBias = 0.0f;
  ivec2 imageSize{640, 480};
};

// Parses a scene file; every problem (missing file, malformed JSON, unknown key,
// wrong type, nonsense value, unknown strategy name) throws oblong::Error naming the
// file and the key.
Scene loadScene(const std::string& path);
Scene parseScene(const nlohmann::json& j, const std::string& path);

// Moves every displaced mesh to λ (none: full resolution), from its level-0 map; meshes
// sharing a map share the level built for them. Throws oblong::Error (naming `where`)
// for a negative or non-finite λ.
void setLod(Scene& scene, std::optional<float> lod, const std::string& where);
// A λ per ray (ray cones): every displaced mesh back at level 0, scene.lodCone set.
void setLodCone(Scene& scene);

// The built-in default scene: no data files (procedural map, generated meshes).
Scene defaultScene();

}  // namespace oblong
