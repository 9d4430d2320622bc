// Mesh files as scenes (asset_scene.h, docs/assets.md). The material is read here (assimp
// does not expose MTL's `disp -mm` or glTF's KHR_materials_displacement), turned into the
// JSON scene that says the same and parsed as a scene file: one set of checks for both.
#include "core/asset_scene.h"

#include "core/error.h"
#include "core/input_file.h"
#include "core/mesh.h"

#include <assimp/Importer.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace oblong {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower((unsigned char)c));
  return s;
}

std::string extensionOf(const std::string& path) { return lower(fs::path(path).extension().string()); }

// What oblong takes from a file's material (or the flags), in the scene file's terms,
// and where each value came from, for error messages.
struct Material {
  std::string name;  // "" none
  std::string map;   // relative to the mesh file's folder; "" none
  double scale = 1.0, bias = 0.0;
  std::array<double, 2> tiling{1.0, 1.0};
  bool flipV = false;
  std::optional<std::array<double, 3>> albedo;
  std::string mapWhere, scaleWhere, biasWhere, tilingWhere, albedoWhere;
  // Compares what reaches the scene (for "several materials differ").
  bool sameAs(const Material& o) const {
    return map == o.map && scale == o.scale && bias == o.bias && tiling == o.tiling && albedo == o.albedo;
  }
};

// One material for the whole mesh file: the first that displaces, else the first; the
// others that differ from it are named in a warning.
Material pickMaterial(const std::string& path, const std::vector<Material>& used) {
  const auto chosen = std::find_if(used.begin(), used.end(), [](const Material& m) { return !m.map.empty(); });
  const Material& pick = chosen != used.end() ? *chosen : used.front();
  std::vector<std::string> others;
  // By identity, not name: two materials of one name may differ.
  for (const Material& m : used)
    if (&m != &pick && !m.sameAs(pick))
      others.push_back(m.name == pick.name ? "another '" + m.name + "'" : "'" + m.name + "'");
  if (!others.empty())
    eprint("oblong: warning: {}: oblong applies one material to a whole mesh file: '{}'; not used: {} (write a "
           "scene file with one mesh file per material)\n",
           path, pick.name, fmt::join(others, ", "));
  return pick;
}

// ---- OBJ + MTL ---------------------------------------------------------------------

std::vector<std::string> tokens(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> t;
  for (std::string w; in >> w;) t.push_back(w);
  return t;
}

std::optional<double> number(const std::string& s) {
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used != s.size() || !std::isfinite(v)) return std::nullopt;
    return v;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The text after a keyword, trimmed (file names may contain spaces).
std::string restOf(const std::string& line, const std::string& key) {
  std::string r = line.substr(line.find(key) + key.size());
  const size_t a = r.find_first_not_of(" \t");
  const size_t b = r.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : r.substr(a, b - a + 1);
}

struct MtlLine {
  std::string key;  // as written
  std::vector<std::string> args;
  std::string text;  // the line
  int line;
};
struct MtlMaterial {
  std::string name, file;
  std::vector<MtlLine> lines;
  int line = 0;  // of its newmtl
};

// The materials of one .mtl file by name.
std::map<std::string, MtlMaterial> readMtl(const std::string& file) {
  checkInputFile(file);
  std::ifstream in(file);
  if (!in) fail(file, "cannot open file");
  std::map<std::string, MtlMaterial> out;
  MtlMaterial* cur = nullptr;
  std::string text;
  for (int n = 1; std::getline(in, text); ++n) {
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const std::vector<std::string> t = tokens(text);
    if (t.empty() || t[0][0] == '#') continue;
    if (t[0] == "newmtl") {
      const std::string name = restOf(text, "newmtl");
      if (name.empty()) fail(file, "line {}: newmtl: no material name", n);
      if (const auto it = out.find(name); it != out.end())
        eprint("oblong: warning: {}: line {}: newmtl {}: defined again (first at line {}); this definition is used\n",
               file, n, name, it->second.line);
      cur = &out[name];
      *cur = MtlMaterial{name, file, {}, n};
      continue;
    }
    if (!cur) fail(file, "line {}: {}: before any newmtl", n, t[0]);
    cur->lines.push_back({t[0], std::vector<std::string>(t.begin() + 1, t.end()), text, n});
  }
  return out;
}

// The mtllib files and the used material names (in order of first use) of an OBJ.
struct ObjMaterials {
  std::vector<std::string> libs;  // as resolved against the OBJ's folder
  std::vector<std::string> used;
};
ObjMaterials scanObj(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail(path, "cannot open file");
  ObjMaterials r;
  const fs::path dir = fs::path(path).parent_path();
  std::string text;
  while (std::getline(in, text)) {
    const size_t a = text.find_first_not_of(" \t");
    if (a == std::string::npos || (text[a] != 'm' && text[a] != 'u')) continue;
    const bool lib = text.compare(a, 7, "mtllib ") == 0 || text.compare(a, 7, "mtllib\t") == 0;
    const bool use = text.compare(a, 7, "usemtl ") == 0 || text.compare(a, 7, "usemtl\t") == 0;
    if (lib) {
      const std::string rest = restOf(text.substr(a), "mtllib");
      // One name with spaces, or several names.
      std::vector<std::string> names{rest};
      if (!fs::exists(dir / rest)) names = tokens(rest);
      for (const std::string& n : names) r.libs.push_back((dir / n).lexically_normal().string());
    } else if (use) {
      const std::string name = restOf(text.substr(a), "usemtl");
      if (std::find(r.used.begin(), r.used.end(), name) == r.used.end()) r.used.push_back(name);
    }
  }
  return r;
}

// A texture map statement: [options] file. `used` options are returned; the others are
// collected in `ignored` (named in the warning) or refused when they would move the map.
struct MapStatement {
  std::string file;
  std::optional<std::array<double, 2>> mm;  // base, gain
  std::optional<std::array<double, 2>> s;   // u, v scale
  std::vector<std::string> ignored;
};
MapStatement parseMap(const MtlMaterial& m, const MtlLine& l) {
  MapStatement st;
  const auto& a = l.args;
  auto bad = [&](const std::string& what) { fail(m.file, "line {}: {}: {}", l.line, l.key, what); };
  auto numbersAt = [&](size_t i, size_t most) {
    std::vector<double> v;
    while (i + v.size() < a.size() && v.size() < most) {
      const auto x = number(a[i + v.size()]);
      if (!x) break;
      v.push_back(*x);
    }
    return v;
  };
  size_t i = 0;
  while (i < a.size() && a[i].size() > 1 && a[i][0] == '-' && !number(a[i])) {
    const std::string opt = a[i];
    if (opt == "-mm") {
      const auto v = numbersAt(i + 1, 2);
      if (v.size() != 2) bad(fmt::format("-mm needs two numbers (base gain), got '{}'", l.text));
      st.mm = std::array<double, 2>{v[0], v[1]};
      i += 3;
    } else if (opt == "-s" || opt == "-o" || opt == "-t") {
      const auto v = numbersAt(i + 1, 3);
      if (v.empty()) bad(fmt::format("{} needs one to three numbers (u [v [w]]), got '{}'", opt, l.text));
      if (opt == "-s") {
        st.s = std::array<double, 2>{v[0], v.size() > 1 ? v[1] : 1.0};
      } else if (std::any_of(v.begin(), v.end(), [](double x) { return x != 0.0; })) {
        bad(fmt::format("{} {} is not supported (oblong maps uv times tiling only; write a scene file with the "
                        "uvs changed)",
                        opt, opt == "-o" ? "(a texture offset)" : "(turbulence)"));
      }
      i += 1 + v.size();
    } else if (opt == "-clamp" || opt == "-blendu" || opt == "-blendv" || opt == "-cc" || opt == "-imfchan" ||
               opt == "-type") {
      if (i + 1 >= a.size()) bad(fmt::format("{} needs a value, got '{}'", opt, l.text));
      const std::string v = lower(a[i + 1]);
      if (opt == "-clamp" && v == "on") bad("-clamp on is not supported (oblong repeats the map: wrap addressing)");
      if (opt == "-imfchan" && v != "r" && v != "l" && v != "m")
        st.ignored.push_back("-imfchan " + a[i + 1] + " (oblong uses the map's first channel)");
      else if (opt != "-clamp" && opt != "-imfchan")
        st.ignored.push_back(opt + " " + a[i + 1]);
      i += 2;
    } else if (opt == "-bm" || opt == "-boost" || opt == "-texres") {
      const auto v = numbersAt(i + 1, 1);
      if (v.empty()) bad(fmt::format("{} needs a number, got '{}'", opt, l.text));
      st.ignored.push_back(opt);
      i += 2;
    } else {
      bad(fmt::format("unknown option '{}'", opt));
    }
  }
  for (; i < a.size(); ++i) st.file += (st.file.empty() ? "" : " ") + a[i];
  if (st.file.empty()) bad("no file name");
  return st;
}

std::string where(const std::string& file, int line, const std::string& key) {
  return fmt::format("{}: line {}: {}", file, line, key);
}

// The MTL material's values, and a warning naming every key oblong does not use.
Material fromMtl(const MtlMaterial& m, const fs::path& objDir, const AssetFlags& flags) {
  Material r;
  r.name = m.name;
  r.flipV = true;  // OBJ's v = 0 is the image's bottom
  std::vector<std::string> unused;
  auto note = [&](const std::string& k) {
    if (std::find(unused.begin(), unused.end(), k) == unused.end()) unused.push_back(k);
  };
  for (const MtlLine& l : m.lines) {
    const std::string k = lower(l.key);
    if (k == "kd") {
      std::vector<double> v;
      for (const std::string& s : l.args) {
        const auto x = number(s);
        if (!x) fail(m.file, "line {}: Kd: expected r [g b] numbers, got '{}'", l.line, l.text);
        v.push_back(*x);
      }
      if (v.size() != 1 && v.size() != 3) fail(m.file, "line {}: Kd: expected r [g b] numbers, got '{}'", l.line, l.text);
      r.albedo = std::array<double, 3>{v[0], v.size() > 1 ? v[1] : v[0], v.size() > 1 ? v[2] : v[0]};
      r.albedoWhere = where(m.file, l.line, "Kd");
    } else if (k == "disp" || k == "map_disp") {
      const MapStatement st = parseMap(m, l);
      if (!flags.displacement.empty()) {
        note(l.key + " (replaced by --displacement)");
        continue;
      }
      const fs::path mtlDir = fs::path(m.file).parent_path();
      r.map = (mtlDir / st.file).lexically_normal().lexically_relative(objDir.lexically_normal()).string();
      if (r.map.empty() || fs::path(st.file).is_absolute()) r.map = fs::path(st.file).is_absolute() ? st.file : (mtlDir / st.file).string();
      const std::string w = where(m.file, l.line, l.key);
      r.mapWhere = w;
      if (st.mm) {
        const double base = (*st.mm)[0], gain = (*st.mm)[1];
        if (gain == 0.0) fail(m.file, "line {}: {}: -mm gain 0 makes every height the same (base {})", l.line, l.key, base);
        r.scale = gain;
        r.bias = base / gain;  // base + gain·H = gain·(H + base/gain)
      }
      r.scaleWhere = r.biasWhere = w + (st.mm ? " -mm" : "");
      if (st.s) {
        if (!((*st.s)[0] > 0.0 && (*st.s)[1] > 0.0))
          fail(m.file, "line {}: {}: -s must be positive, got {} {}", l.line, l.key, (*st.s)[0], (*st.s)[1]);
        r.tiling = *st.s;
      }
      r.tilingWhere = w + (st.s ? " -s" : "");
      for (const std::string& o : st.ignored) note(l.key + " " + o);
    } else if (k == "map_kd") {
      note(l.key + " (oblong's albedo is a constant: Kd)");
    } else if (k == "bump" || k == "map_bump" || k == "norm" || k == "map_norm") {
      note(l.key + " (bump and normal maps are not used: oblong shades the displaced geometry)");
    } else {
      note(l.key);
    }
  }
  if (!unused.empty())
    eprint("oblong: warning: {}: material '{}': not used by oblong: {}\n", m.file, m.name, fmt::join(unused, ", "));
  return r;
}

std::optional<Material> objMaterial(const std::string& path, const AssetFlags& flags) {
  const ObjMaterials refs = scanObj(path);
  if (refs.used.empty()) return std::nullopt;
  std::map<std::string, MtlMaterial> all;
  bool missingLib = false;  // warned once for the file, not again per material
  for (const std::string& lib : refs.libs) {
    if (!fs::exists(lib)) {
      missingLib = true;
      eprint("oblong: warning: {}: mtllib {}: file not found; its materials are not used\n", path, lib);
      continue;
    }
    for (auto& [name, m] : readMtl(lib)) all.emplace(name, std::move(m));  // the first library's wins
  }
  std::vector<Material> used;
  for (const std::string& name : refs.used) {
    const auto it = all.find(name);
    if (it == all.end()) {
      if (!missingLib)
        eprint("oblong: warning: {}: usemtl {}: no such material in {}\n", path, name,
             refs.libs.empty() ? std::string("(no mtllib)") : fmt::format("{}", fmt::join(refs.libs, ", ")));
      continue;
    }
    used.push_back(fromMtl(it->second, fs::path(path).parent_path(), flags));
  }
  if (used.empty()) return std::nullopt;
  return pickMaterial(path, used);
}

// ---- glTF / GLB --------------------------------------------------------------------

json readGltfJson(const std::string& path, bool glb) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open file");
  std::string text;
  if (glb) {
    // 12-byte header (magic, version, length), then the JSON chunk (length, type, data).
    char head[20];
    if (!in.read(head, 20)) fail(path, "not a GLB file (shorter than its 20-byte header)");
    uint32_t magic, version, chunkLength, chunkType;
    std::memcpy(&magic, head, 4);
    std::memcpy(&version, head + 4, 4);
    std::memcpy(&chunkLength, head + 12, 4);
    std::memcpy(&chunkType, head + 16, 4);
    if (magic != 0x46546C67u) fail(path, "not a GLB file (no 'glTF' magic)");
    if (version != 2) fail(path, "GLB version {} (oblong reads glTF 2.0)", version);
    if (chunkType != 0x4E4F534Au) fail(path, "GLB: the first chunk is not JSON");
    const uintmax_t size = fs::file_size(path);
    if (uintmax_t(chunkLength) > size - 20) fail(path, "GLB: JSON chunk of {} bytes, the file holds {} after it", chunkLength, size - 20);
    text.resize(chunkLength);
    if (!in.read(text.data(), std::streamsize(chunkLength))) fail(path, "GLB: cannot read the JSON chunk");
  } else {
    std::ostringstream s;
    s << in.rdbuf();
    text = s.str();
  }
  // Nesting is bounded while parsing (as for scene files): copying or printing a value
  // recurses, and a value nested 100 000 deep overflowed the stack in an error message.
  constexpr int kMaxDepth = 64;
  const auto bounded = [&](int depth, json::parse_event_t, json&) {
    if (depth > kMaxDepth) fail(path, "malformed glTF: nested deeper than {} levels", kMaxDepth);
    return true;
  };
  try {
    return json::parse(text, bounded);
  } catch (const json::exception& e) {
    fail(path, "malformed glTF JSON: {}", e.what());
  }
}

std::string shown(const json& v) {
  std::string s = v.dump(-1, ' ', true, json::error_handler_t::replace);
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

// Percent-decoding of a relative URI (glTF image uris).
std::string decodeUri(const std::string& path, const std::string& key, const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] != '%') {
      out += uri[i];
      continue;
    }
    const auto hex = [](char c) { return std::isxdigit((unsigned char)c) ? std::stoi(std::string(1, c), nullptr, 16) : -1; };
    if (i + 2 >= uri.size() || hex(uri[i + 1]) < 0 || hex(uri[i + 2]) < 0)
      fail(path, "{}: malformed URI {}", key, shown(uri));
    out += char(hex(uri[i + 1]) * 16 + hex(uri[i + 2]));
    i += 2;
  }
  return out;
}

const json& element(const std::string& path, const json& doc, const char* array, const json& index,
                    const std::string& key) {
  const size_t n = doc.contains(array) && doc[array].is_array() ? doc[array].size() : 0;
  if (!index.is_number_unsigned() || index.get<uint64_t>() >= n)
    fail(path, "{}: {} out of range (the file has {} {})", key, shown(index), n, array);
  return doc[array][index.get<size_t>()];
}

double gltfNumber(const std::string& path, const json& obj, const char* k, double def, const std::string& key) {
  if (!obj.contains(k)) return def;
  if (!obj[k].is_number() || !std::isfinite(obj[k].get<double>()))
    fail(path, "{}.{}: must be a finite number, got {}", key, k, shown(obj[k]));
  // Heights are floats: a double beyond their range would become infinite unannounced.
  if (std::abs(obj[k].get<double>()) > double(std::numeric_limits<float>::max()))
    fail(path, "{}.{}: {} is beyond a float's range (|x| <= {:g})", key, k, shown(obj[k]),
         double(std::numeric_limits<float>::max()));
  return obj[k].get<double>();
}

// The material's values; every key oblong does not use is named in one warning line.
Material fromGltfMaterial(const std::string& path, const json& doc, size_t index, const AssetFlags& flags) {
  const std::string mkey = fmt::format("materials[{}]", index);
  const json& mat = doc["materials"][index];
  if (!mat.is_object()) fail(path, "{}: must be an object, got {}", mkey, shown(mat));
  Material r;
  r.name = mat.contains("name") && mat["name"].is_string() ? mat["name"].get<std::string>() : mkey;
  r.flipV = false;  // glTF's v = 0 is the image's top, as oblong's maps
  std::vector<std::string> unused;
  for (const auto& [k, v] : mat.items()) {
    if (k == "name") continue;
    if (k == "pbrMetallicRoughness" && v.is_object()) {
      for (const auto& [pk, pv] : v.items()) {
        if (pk != "baseColorFactor") {
          unused.push_back("pbrMetallicRoughness." + pk + (pk == "baseColorTexture" ? " (oblong's albedo is a constant: baseColorFactor)" : ""));
          continue;
        }
        const std::string key = mkey + ".pbrMetallicRoughness.baseColorFactor";
        if (!pv.is_array() || pv.size() != 4 || !std::all_of(pv.begin(), pv.end(), [](const json& x) { return x.is_number(); }))
          fail(path, "{}: must be an array of 4 numbers, got {}", key, shown(pv));
        r.albedo = std::array<double, 3>{pv[0].get<double>(), pv[1].get<double>(), pv[2].get<double>()};
        r.albedoWhere = path + ": " + key;
      }
      continue;
    }
    if (k == "extensions" && v.is_object()) {
      for (const auto& [ek, ev] : v.items())
        if (ek != "KHR_materials_displacement") unused.push_back("extensions." + ek);
      continue;
    }
    unused.push_back(k + (k == "normalTexture" ? " (oblong shades the displaced geometry)" : ""));
  }
  if (mat.contains("extensions") && mat["extensions"].is_object() && mat["extensions"].contains("KHR_materials_displacement")) {
    const std::string dkey = mkey + ".extensions.KHR_materials_displacement";
    const json& d = mat["extensions"]["KHR_materials_displacement"];
    if (!d.is_object()) fail(path, "{}: must be an object, got {}", dkey, shown(d));
    for (const auto& [k, v] : d.items())
      if (k != "displacementGeometryTexture" && k != "displacementGeometryFactor" && k != "displacementGeometryOffset")
        unused.push_back("KHR_materials_displacement." + k);
    const double factor = gltfNumber(path, d, "displacementGeometryFactor", 1.0, dkey);
    const double offset = gltfNumber(path, d, "displacementGeometryOffset", 0.0, dkey);
    if (!flags.displacement.empty()) {
      unused.push_back("KHR_materials_displacement (replaced by --displacement)");
    } else if (!d.contains("displacementGeometryTexture")) {
      unused.push_back("KHR_materials_displacement without displacementGeometryTexture (a constant height: "
                       "not displaced)");
    } else if (factor == 0.0) {
      unused.push_back("KHR_materials_displacement with displacementGeometryFactor 0 (not displaced)");
    } else {
      const std::string tkey = dkey + ".displacementGeometryTexture";
      const json& t = d["displacementGeometryTexture"];
      // The draft's textureInfo {index, texCoord}; its first form was the bare index.
      json index = t;
      if (t.is_object()) {
        if (!t.contains("index")) fail(path, "{}.index: missing (required)", tkey);
        index = t["index"];
        if (t.contains("texCoord") && !(t["texCoord"].is_number_unsigned() && t["texCoord"].get<uint64_t>() == 0))
          fail(path, "{}.texCoord: {} is not supported (oblong displaces with TEXCOORD_0)", tkey, shown(t["texCoord"]));
        for (const auto& [k, v] : t.items())
          if (k != "index" && k != "texCoord") unused.push_back("displacementGeometryTexture." + k);
      }
      const json& texture = element(path, doc, "textures", index, tkey + (t.is_object() ? ".index" : ""));
      const std::string texKey = fmt::format("textures[{}]", index.get<size_t>());
      if (!texture.is_object() || !texture.contains("source"))
        fail(path, "{}.source: missing (oblong needs the image)", texKey);
      if (texture.contains("sampler")) {
        const json& sampler = element(path, doc, "samplers", texture["sampler"], texKey + ".sampler");
        for (const char* w : {"wrapS", "wrapT"})
          if (sampler.is_object() && sampler.contains(w) && sampler[w] != json(10497))
            unused.push_back(fmt::format("samplers[{}].{} {} (oblong repeats the map)", texture["sampler"].get<size_t>(), w,
                                         shown(sampler[w])));
      }
      const json& image = element(path, doc, "images", texture["source"], texKey + ".source");
      const std::string iKey = fmt::format("images[{}]", texture["source"].get<size_t>());
      if (image.is_object() && image.contains("uri") && !image["uri"].is_string())
        fail(path, "{}.uri: must be a file name (a string), got {}", iKey, shown(image["uri"]));
      if (!image.is_object() || !image.contains("uri"))
        fail(path, "{}: an image inside the file (bufferView) is not supported: store the map as an image file "
             "next to it and give its uri", iKey);
      const std::string uri = image["uri"].get<std::string>();
      if (uri.empty()) fail(path, "{}.uri: is empty: give the displacement map's file name", iKey);
      if (uri.rfind("data:", 0) == 0)
        fail(path, "{}.uri: a data URI is not supported: store the map as an image file next to it", iKey);
      if (uri.find("://") != std::string::npos) fail(path, "{}.uri: {}: only relative file names are supported", iKey, shown(uri));
      r.map = decodeUri(path, iKey + ".uri", uri);
      r.mapWhere = path + ": " + iKey + ".uri";
      // height = factor · H + offset = factor · (H + offset / factor)
      r.scale = factor;
      r.bias = offset / factor;
      if (std::abs(offset / factor) > double(std::numeric_limits<float>::max()))
        fail(path, "{}: displacementGeometryOffset / displacementGeometryFactor = {:g} is beyond a float's range",
             dkey, offset / factor);
      r.scaleWhere = path + ": " + dkey + ".displacementGeometryFactor";
      r.biasWhere = path + ": " + dkey + ".displacementGeometryOffset";
      r.tilingWhere = path + ": " + dkey;
    }
  }
  if (!unused.empty())
    eprint("oblong: warning: {}: {} '{}': not used by oblong: {}\n", path, mkey, r.name, fmt::join(unused, ", "));
  return r;
}

std::optional<Material> gltfMaterial(const std::string& path, bool glb, const AssetFlags& flags) {
  const json doc = readGltfJson(path, glb);
  if (!doc.is_object()) fail(path, "malformed glTF: the top level is not an object");
  // The materials the meshes' primitives use, in order of first use.
  std::vector<size_t> used;
  if (doc.contains("meshes") && doc["meshes"].is_array())
    for (size_t i = 0; i < doc["meshes"].size(); ++i) {
      const json& mesh = doc["meshes"][i];
      if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
      for (size_t j = 0; j < mesh["primitives"].size(); ++j) {
        const json& p = mesh["primitives"][j];
        if (!p.is_object() || !p.contains("material")) continue;
        element(path, doc, "materials", p["material"], fmt::format("meshes[{}].primitives[{}].material", i, j));
        const size_t m = p["material"].get<size_t>();
        if (std::find(used.begin(), used.end(), m) == used.end()) used.push_back(m);
      }
    }
  if (used.empty()) return std::nullopt;
  std::vector<Material> mats;
  for (size_t m : used) mats.push_back(fromGltfMaterial(path, doc, m, flags));
  return pickMaterial(path, mats);
}

// ---- flags -------------------------------------------------------------------------

std::array<double, 2> parseTiling(const std::string& s) {
  std::vector<double> v;
  std::string part;
  std::istringstream in(s);
  while (std::getline(in, part, ',')) {
    const auto x = number(part);
    if (!x || !(*x > 0.0)) v.clear(), v.push_back(-1.0);
    if (v.size() == 1 && v[0] < 0.0) break;
    v.push_back(*x);
  }
  if (v.empty() || v.size() > 2 || v[0] < 0.0 || (!s.empty() && s.back() == ','))
    fail("--tiling", "expected T or TU,TV (positive numbers), got '{}'", s);
  return {v[0], v.size() > 1 ? v[1] : v[0]};
}

// A path relative to the current folder as seen from the mesh file's folder, so that the
// scene's "relative to the scene file" rule finds it.
std::string fromMeshFolder(const std::string& file, const fs::path& meshDir) {
  const fs::path f(file);
  if (f.is_absolute()) return f.string();
  const fs::path rel = f.lexically_normal().lexically_relative(meshDir.lexically_normal());
  if (!rel.empty() && (meshDir / rel).lexically_normal() == f.lexically_normal()) return rel.string();
  std::error_code ec;
  const fs::path abs = fs::absolute(f, ec);
  return ec ? file : abs.string();
}

// Where a key of the scene built here came from, for error messages.
struct Sources {
  std::vector<std::pair<std::string, std::string>> keys;  // scene key -> replacement
};

json buildJson(const std::string& path, const AssetFlags& flags, Sources& src) {
  const std::string ext = extensionOf(path);
  const fs::path dir = fs::path(path).parent_path();
  if (flags.scale && !(std::isfinite(*flags.scale) && *flags.scale != 0.0))
    fail("--scale", "must be a non-zero finite number, got {}", *flags.scale);
  if (flags.bias && !std::isfinite(*flags.bias)) fail("--bias", "must be a finite number, got {}", *flags.bias);
  const std::optional<std::array<double, 2>> tiling =
      flags.tiling.empty() ? std::nullopt : std::optional(parseTiling(flags.tiling));

  std::optional<Material> mat;
  if (ext == ".obj") mat = objMaterial(path, flags);
  else if (ext == ".gltf" || ext == ".glb") mat = gltfMaterial(path, ext == ".glb", flags);
  Material m = mat ? *mat : Material{};
  if (!mat) m.flipV = !(ext == ".gltf" || ext == ".glb" || ext == ".x");  // docs/scene_format.md, Texture coordinates
  if (!flags.displacement.empty()) {
    m.map = fromMeshFolder(flags.displacement, dir);
    m.mapWhere = "--displacement";
    m.scale = 1.0, m.bias = 0.0, m.tiling = {1.0, 1.0};
    m.scaleWhere = m.biasWhere = m.tilingWhere = "--displacement";
  }
  if (m.map.empty()) {
    for (const auto& [given, name] : {std::pair{bool(flags.scale), "--scale"}, {bool(flags.bias), "--bias"},
                                      {tiling.has_value(), "--tiling"}})
      if (given) fail(name, "{} has no displacement map to apply it to (give --displacement MAP)", path);
  }
  if (flags.scale) m.scale = *flags.scale, m.scaleWhere = "--scale";
  if (flags.bias) m.bias = *flags.bias, m.biasWhere = "--bias";
  if (tiling) m.tiling = *tiling, m.tilingWhere = "--tiling";

  json mesh = {{"file", fs::path(path).filename().string()}};
  src.keys.emplace_back("meshes[0].file", "");
  if (m.albedo) {
    mesh["albedo"] = {(*m.albedo)[0], (*m.albedo)[1], (*m.albedo)[2]};
    src.keys.emplace_back("meshes[0].albedo", m.albedoWhere);
  }
  if (!m.map.empty()) {
    mesh["displacement"] = {{"map", m.map}, {"scale", m.scale}, {"bias", m.bias},
                            {"tiling", {m.tiling[0], m.tiling[1]}}, {"flip_v", m.flipV}};
    src.keys.emplace_back("meshes[0].displacement.map", m.mapWhere);
    src.keys.emplace_back("meshes[0].displacement.scale", m.scaleWhere);
    src.keys.emplace_back("meshes[0].displacement.bias", m.biasWhere);
    src.keys.emplace_back("meshes[0].displacement.tiling", m.tilingWhere);
  }
  return json{{"meshes", json::array({mesh})}};
}

// A camera that sees the whole displaced mesh from the front (+z), a little above and to
// the right, and a light from over the camera's shoulder.
void frame(Scene& s) {
  dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  double maxH = 0.0;
  for (const SceneMesh& sm : s.meshes) {
    for (const glm::uvec3& f : sm.mesh.triangles)
      for (int k = 0; k < 3; ++k) lo = glm::min(lo, sm.mesh.world(f[k])), hi = glm::max(hi, sm.mesh.world(f[k]));
    if (sm.displacement) {
      const Interval H = sm.displacement->map->range();
      const double d = sm.displacement->scale;
      maxH = std::max({maxH, std::abs(d * (H.lo + sm.displacement->bias)), std::abs(d * (H.hi + sm.displacement->bias))});
    }
  }
  const dvec3 centre = 0.5 * (lo + hi);
  double radius = 0.5 * glm::length(hi - lo) + maxH;
  if (!(radius > 0.0)) radius = 1.0;
  const dvec3 dir = glm::normalize(dvec3(0.35, 0.45, 1.0));
  const double fov = 40.0;
  const double dist = 1.1 * radius / std::sin(glm::radians(fov / 2.0));
  s.camera = Camera{vec3(centre + dist * dir), vec3(centre), vec3(0.0f, 1.0f, 0.0f), float(fov)};
  s.lights = {Light{Light::Type::Directional, vec3(0.0f), glm::normalize(vec3(-0.5f, -0.8f, -0.9f)), vec3(2.5f)}};
}

}  // namespace

bool isAssetPath(const std::string& path) {
  const std::string ext = extensionOf(path);
  if (ext.size() < 2 || ext == ".json") return false;
  return Assimp::Importer().IsExtensionSupported(ext);
}

json assetSceneJson(const std::string& path, const AssetFlags& flags) {
  Sources src;
  checkInputFile(path);
  return buildJson(path, flags, src);
}

Scene loadAsset(const std::string& path, const AssetFlags& flags) {
  checkInputFile(path);
  Sources src;
  const json j = buildJson(path, flags, src);
  Scene s;
  try {
    s = parseScene(j, path);
  } catch (const Error& e) {
    // "PATH: meshes[0].KEY: problem" names a key that is not in any file: name where the
    // value came from instead.
    const std::string msg = e.what();
    for (const auto& [key, repl] : src.keys) {
      const std::string prefix = path + ": " + key;
      if (msg.rfind(prefix, 0) != 0) continue;
      const std::string rest = msg.substr(prefix.size());  // ": problem", or "[i]: problem" of an array
      if (rest.rfind(": ", 0) == 0) throw Error(repl.empty() ? rest.substr(2) : repl + rest);
      if (rest.rfind("[", 0) == 0 && !repl.empty()) throw Error(repl + " " + rest);
    }
    throw;
  }
  frame(s);
  return s;
}

}  // namespace oblong
