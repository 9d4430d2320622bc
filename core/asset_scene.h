// A mesh file given where a scene file is expected (docs/assets.md): the scene is built
// from the mesh and its material (OBJ+MTL `disp`, glTF's KHR_materials_displacement)
// or the command line's --displacement/--scale/--bias/--tiling, as the JSON scene that
// says the same, and goes through the scene parser, so every check of a scene file holds.
#pragma once

#include "core/scene.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace oblong {

// --displacement, --scale, --bias, --tiling as given (unset: the file's material, or
// oblong's defaults). scale and bias are oblong's: h = scale · (H + bias).
struct AssetFlags {
  std::string displacement;  // map file, relative to the current folder
  std::optional<double> scale, bias;
  std::string tiling;  // "T" or "TU,TV"
  bool any() const { return !displacement.empty() || scale || bias || !tiling.empty(); }
};

// Whether `path` names a mesh file rather than a JSON scene: by its extension, one that
// assimp reads (never .json).
bool isAssetPath(const std::string& path);

// The scene file that says what loadAsset builds (meshes[0] only, no camera or lights),
// with paths relative to the mesh file's folder. Warnings (unused material keys) go to
// stderr once, here.
nlohmann::json assetSceneJson(const std::string& path, const AssetFlags& flags = {});

// The scene of a mesh file: assetSceneJson parsed as a scene file at `path`, then a
// camera that frames the (displaced) mesh and one directional light. Errors are one line
// naming the file (the mesh, its .mtl, a flag) and the key or line.
Scene loadAsset(const std::string& path, const AssetFlags& flags = {});

}  // namespace oblong
