#include "core/mesh_check.h"

#include "core/error.h"

#include <assimp/Importer.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace oblong {

namespace {

// assimp 5.2 reads a node hierarchy with one recursive call per level (glTF's
// ImportNode, COLLADA's ReadSceneNode, FBX's scopes, X's frames, the post-processing
// steps, aiNode's destructor), and glTF through RapidJSON's recursive parser: a file of
// 20 000 nested nodes, a few hundred KiB, overflows the stack (exit 139). The nesting is
// measured here without recursion, before assimp reads the file. A GLB's chunk lengths
// are allocated by assimp before it reads them, so they must fit in the file.

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower((unsigned char)c));
  return ext;
}

// As core/ply_check.cpp: assimp picks a reader by the extension, and by the content when
// the extension is none it knows.
bool readAs(const std::string& ext, std::initializer_list<const char*> exts, bool magic,
            const Assimp::Importer& importer) {
  for (const char* e : exts)
    if (ext == e) return true;
  return magic && (ext.empty() || !importer.IsExtensionSupported(ext));
}

[[noreturn]] void tooDeep(const std::string& path, const std::string& what, uint64_t depth) {
  fail(path, "cannot load mesh ({} nested {} levels deep; at most {} are supported, as assimp reads each level "
             "recursively)",
       what, depth, kMaxMeshNesting);
}

uint32_t le32(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | (unsigned char)s[at + size_t(k)];
  return v;
}
uint64_t le64(const std::string& s, size_t at) { return uint64_t(le32(s, at)) | uint64_t(le32(s, at + 4)) << 32; }

// ---- glTF: JSON nesting and the node graph (children of nodes[]), read by a SAX pass.

struct GltfSax {
  enum Role : uint8_t { kOther, kRoot, kNodes, kNode, kChildren };
  struct Frame {
    bool array;
    Role role;
    size_t node = 0;
    size_t count = 0;  // elements so far (arrays)
    std::string key;   // the last key (objects)
  };
  std::vector<Frame> stack;
  size_t maxDepth = 0;
  size_t nodeCount = 0;
  std::unordered_map<std::string, size_t> nodeIds;                 // glTF 1.0: nodes is an object
  std::vector<std::pair<size_t, size_t>> edges;                    // parent, child index
  std::vector<std::pair<size_t, std::string>> namedEdges;          // parent, child id (glTF 1.0)

  // Where the value that starts now sits in its parent.
  void slot(std::string* key, size_t* index) {
    Frame& p = stack.back();
    if (p.array) *index = p.count++;
    else *key = p.key;
  }
  bool start(bool array) {
    Role role = kOther;
    size_t node = 0;
    if (stack.empty()) {
      role = array ? kOther : kRoot;
    } else {
      std::string key;
      size_t index = 0;
      slot(&key, &index);
      const Frame& p = stack.back();
      if (p.role == kRoot && key == "nodes") {
        role = kNodes;
      } else if (p.role == kNodes && !array) {
        role = kNode;
        if (p.array) {
          node = index;
        } else {
          node = nodeIds.try_emplace(key, nodeIds.size()).first->second;
        }
        nodeCount = std::max(nodeCount, node + 1);
      } else if (p.role == kNode && key == "children" && array) {
        role = kChildren;
        node = p.node;
      }
    }
    stack.push_back({array, role, node, 0, {}});
    maxDepth = std::max(maxDepth, stack.size());
    return true;
  }
  bool end() {
    stack.pop_back();
    return true;
  }
  bool index(uint64_t v) {
    if (!stack.empty()) {
      std::string key;
      size_t i = 0;
      slot(&key, &i);
      if (stack.back().role == kChildren && v < (uint64_t(1) << 32)) edges.emplace_back(stack.back().node, size_t(v));
    }
    return true;
  }
  bool other() {
    if (!stack.empty()) {
      std::string key;
      size_t i = 0;
      slot(&key, &i);
    }
    return true;
  }

  // nlohmann::json's SAX interface.
  bool null() { return other(); }
  bool boolean(bool) { return other(); }
  bool number_integer(int64_t v) { return v >= 0 ? index(uint64_t(v)) : other(); }
  bool number_unsigned(uint64_t v) { return index(v); }
  bool number_float(double, const std::string&) { return other(); }
  bool string(std::string& s) {
    if (!stack.empty() && stack.back().role == kChildren) namedEdges.emplace_back(stack.back().node, s);
    return other();
  }
  bool binary(nlohmann::json::binary_t&) { return other(); }
  bool start_object(size_t) { return start(false); }
  bool key(std::string& k) {
    stack.back().key = k;
    return true;
  }
  bool end_object() { return end(); }
  bool start_array(size_t) { return start(true); }
  bool end_array() { return end(); }
  bool parse_error(size_t, const std::string&, const nlohmann::detail::exception&) { return false; }
};

void checkGltfJson(const std::string& path, std::string_view json) {
  GltfSax sax;
  // Malformed JSON is assimp's to report; what was read up to the error is still checked
  // (RapidJSON recurses into it before it finds the error).
  nlohmann::json::sax_parse(json.begin(), json.end(), &sax, nlohmann::json::input_format_t::json, false);
  if (sax.maxDepth > size_t(kMaxMeshNesting)) tooDeep(path, "glTF JSON arrays and objects", sax.maxDepth);

  const size_t n = sax.nodeCount;
  std::vector<std::vector<uint32_t>> children(n);
  for (const auto& [p, c] : sax.edges)
    if (c < n) children[p].push_back(uint32_t(c));
  for (const auto& [p, id] : sax.namedEdges)
    if (auto it = sax.nodeIds.find(id); it != sax.nodeIds.end()) children[p].push_back(uint32_t(it->second));

  // Levels below each node (itself included) and the copies assimp makes of its subtree,
  // by an iterative depth-first search; a node among its own descendants is refused
  // (assimp would recurse forever).
  enum : uint8_t { kNew, kOpen, kDone };
  std::vector<uint8_t> state(n, kNew);
  std::vector<uint64_t> levels(n, 0), copies(n, 0);
  std::vector<std::pair<uint32_t, size_t>> dfs;
  for (size_t root = 0; root < n; ++root) {
    if (state[root] != kNew) continue;
    dfs.emplace_back(uint32_t(root), 0);
    state[root] = kOpen;
    while (!dfs.empty()) {
      auto& [v, next] = dfs.back();
      if (next < children[v].size()) {
        const uint32_t c = children[v][next++];
        if (state[c] == kOpen) fail(path, "cannot load mesh (glTF node {} is among its own descendants)", c);
        if (state[c] == kNew) {
          state[c] = kOpen;
          dfs.emplace_back(c, 0);
        }
        continue;
      }
      uint64_t l = 0, k = 1;
      for (uint32_t c : children[v]) l = std::max(l, levels[c]), k = std::min(kMaxMeshNodeCopies + 1, k + copies[c]);
      levels[v] = l + 1;
      copies[v] = k;
      state[v] = kDone;
      dfs.pop_back();
    }
  }
  for (size_t v = 0; v < n; ++v) {
    if (levels[v] > uint64_t(kMaxMeshNesting)) tooDeep(path, fmt::format("glTF nodes (from node {})", v), levels[v]);
    if (copies[v] > kMaxMeshNodeCopies)
      fail(path, "cannot load mesh (glTF node {} stands for more than {} nodes once every node used by several "
                 "parents is copied for each, as assimp does)",
           v, kMaxMeshNodeCopies);
  }
}

// GLB: 2.0 has a 12-byte header and chunks (length, type, data); 1.0 (KHR_binary_glTF) a
// 20-byte header with the JSON's length. Returns the JSON.
std::optional<std::string> glbJson(const std::string& path, const std::string& file) {
  const uint64_t size = file.size();
  if (size < 12) return std::nullopt;
  const uint32_t version = le32(file, 4), length = le32(file, 8);
  if (length > size)
    fail(path, "cannot load mesh (GLB header claims {} bytes, the file has {})", length, size);
  if (version == 1) {
    if (size < 20) return std::nullopt;
    const uint32_t scene = le32(file, 12);
    if (scene > size - 20)
      fail(path, "cannot load mesh (GLB header claims {} bytes of JSON, the file has {} after the header)", scene,
           size - 20);
    return file.substr(20, scene);
  }
  if (version != 2) return std::nullopt;
  std::optional<std::string> json;
  for (uint64_t at = 12; at + 8 <= size;) {
    const uint32_t chunk = le32(file, size_t(at));
    std::string type = file.substr(size_t(at + 4), 4);
    for (char& c : type)
      if (!std::isprint((unsigned char)c)) c = '?';
    if (chunk > size - at - 8)
      fail(path, "cannot load mesh (GLB chunk '{}' at byte {} claims {} bytes, the file has {} after its header)",
           type, at, chunk, size - at - 8);
    if (!json && at == 12) json = file.substr(size_t(at + 8), chunk);
    at += 8 + uint64_t(chunk);
  }
  return json;
}

// ---- XML (COLLADA, X3D, AMF, Ogre, Irrlicht): the nesting of <node> elements (COLLADA's
// and Irrlicht's hierarchies), and of all other elements.

struct XmlDepth {
  size_t nodes = 0, others = 0;
};

XmlDepth xmlDepth(const std::string& s) {
  XmlDepth depth, maxDepth;
  const size_t n = s.size();
  // The element's name without a namespace prefix.
  auto isNode = [&](size_t from) {
    size_t e = from;
    while (e < n && !std::isspace((unsigned char)s[e]) && s[e] != '/' && s[e] != '>') ++e;
    const size_t colon = s.rfind(':', e);
    const size_t b = colon != std::string::npos && colon >= from ? colon + 1 : from;
    return e - b == 4 && s.compare(b, 4, "node") == 0;
  };
  for (size_t i = 0; (i = s.find('<', i)) != std::string::npos;) {
    auto skipTo = [&](const char* end, size_t from) {
      const size_t e = s.find(end, from);
      return e == std::string::npos ? n : e + std::strlen(end);
    };
    if (s.compare(i, 4, "<!--") == 0) {
      i = skipTo("-->", i + 4);
    } else if (s.compare(i, 9, "<![CDATA[") == 0) {
      i = skipTo("]]>", i + 9);
    } else if (i + 1 < n && s[i + 1] == '?') {
      i = skipTo("?>", i + 2);
    } else if (i + 1 < n && s[i + 1] == '!') {  // <!DOCTYPE ... [ ... ]>
      int brackets = 0;
      for (i += 2; i < n && !(s[i] == '>' && brackets <= 0); ++i) brackets += s[i] == '[' ? 1 : s[i] == ']' ? -1 : 0;
      ++i;
    } else if (i + 1 < n && s[i + 1] == '/') {
      size_t& d = isNode(i + 2) ? depth.nodes : depth.others;
      d -= d > 0;
      i = skipTo(">", i + 2);
    } else {
      char quote = 0;
      size_t j = i + 1;
      for (; j < n; ++j) {
        const char c = s[j];
        if (quote) quote = c == quote ? 0 : quote;
        else if (c == '"' || c == '\'') quote = c;
        else if (c == '>') break;
      }
      if (j >= n) break;
      if (s[j - 1] != '/') {
        if (isNode(i + 1)) maxDepth.nodes = std::max(maxDepth.nodes, ++depth.nodes);
        else maxDepth.others = std::max(maxDepth.others, ++depth.others);
      }
      i = j + 1;
    }
  }
  return maxDepth;
}

// ---- Text formats with braces (X, ASCII FBX, OpenGEX): scope nesting. Strings, and
// comments of each (';' FBX, '//' and '#' X, '//' and '/* */' OpenGEX), are skipped.
size_t braceDepth(const std::string& s) {
  size_t depth = 0, maxDepth = 0;
  const size_t n = s.size();
  for (size_t i = 0; i < n; ++i) {
    const char c = s[i];
    if (c == '"') {
      while (++i < n && s[i] != '"')
        if (s[i] == '\\') ++i;
    } else if (c == ';' || c == '#' || (c == '/' && i + 1 < n && s[i + 1] == '/')) {
      while (i < n && s[i] != '\n') ++i;
    } else if (c == '/' && i + 1 < n && s[i + 1] == '*') {
      const size_t e = s.find("*/", i + 2);
      i = e == std::string::npos ? n : e + 1;
    } else if (c == '{') {
      maxDepth = std::max(maxDepth, ++depth);
    } else if (c == '}') {
      depth -= depth > 0;
    }
  }
  return maxDepth;
}

// ---- Binary FBX: records (end offset, property count, property bytes, name length,
// name, properties, nested records ended by a null record); 64-bit fields from 7500 on.
size_t fbxDepth(const std::string& s) {
  const uint64_t n = s.size();
  if (n < 27) return 0;
  const bool wide = le32(s, 23) >= 7500;
  const uint64_t head = wide ? 25 : 13;
  std::vector<uint64_t> ends;  // end offsets of the records we are inside
  size_t maxDepth = 0;
  for (uint64_t at = 27; at + head <= n;) {
    if (!ends.empty() && at >= ends.back()) {
      at = ends.back();
      ends.pop_back();
      continue;
    }
    const uint64_t end = wide ? le64(s, size_t(at)) : le32(s, size_t(at));
    const uint64_t props = wide ? le64(s, size_t(at + 16)) : le32(s, size_t(at + 8));
    const uint64_t nameLength = (unsigned char)s[size_t(at + head - 1)];
    if (end == 0) {  // null record: the end of a nested list, or of the file
      if (ends.empty()) break;
      at = ends.back();
      ends.pop_back();
      continue;
    }
    if (end <= at || end > n || (!ends.empty() && end > ends.back())) break;  // malformed: assimp reports it
    const uint64_t nested = at + head + nameLength + props;
    if (nested < end) {
      ends.push_back(end);
      maxDepth = std::max(maxDepth, ends.size());
      at = nested;
    } else {
      at = end;
    }
  }
  return maxDepth;
}

}  // namespace

void checkMeshNesting(const std::string& path, const Assimp::Importer& importer) {
  const std::string ext = lowerExtension(path);
  char head[32] = {};
  size_t got = 0;
  {
    std::ifstream in(path, std::ios::binary);
    in.read(head, sizeof head);
    got = size_t(std::max<std::streamsize>(0, in.gcount()));
  }
  const std::string_view start(head, got);
  size_t first = start.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;  // a UTF-8 byte order mark
  while (first < got && std::isspace((unsigned char)head[first])) ++first;
  const char lead = first < got ? head[first] : '\0';

  if (readAs(ext, {".glb", ".gltf"}, start.substr(0, 4) == "glTF", importer) && start.substr(0, 4) == "glTF") {
    const std::string file = readAll(path);
    if (const auto json = glbJson(path, file)) checkGltfJson(path, *json);
  } else if (readAs(ext, {".gltf"}, lead == '{', importer) && lead == '{') {
    checkGltfJson(path, readAll(path));
  } else if (lead == '<') {
    // Any XML: none of assimp's other readers accepts a file that starts with '<'.
    const XmlDepth d = xmlDepth(readAll(path));
    if (d.nodes > size_t(kMaxMeshNesting)) tooDeep(path, "XML <node> elements", d.nodes);
    if (d.others > size_t(kMaxMeshNesting)) tooDeep(path, "XML elements (other than <node>)", d.others);
  } else if (readAs(ext, {".fbx"}, start.substr(0, 18) == "Kaydara FBX Binary", importer) &&
             start.substr(0, 18) == "Kaydara FBX Binary") {
    if (const size_t d = fbxDepth(readAll(path)); d > size_t(kMaxMeshNesting)) tooDeep(path, "FBX records", d);
  } else if (ext == ".fbx" || ext == ".ogex" ||
             (readAs(ext, {".x"}, start.substr(0, 4) == "xof ", importer) && got >= 12 && start.substr(8, 4) == "txt ")) {
    if (const size_t d = braceDepth(readAll(path)); d > size_t(kMaxMeshNesting)) tooDeep(path, "scopes ({ })", d);
  }
}

namespace {

// Whole unsigned integers of `text` (not part of a word, a float or a signed number)
// following `keyword` and spaces; an empty keyword takes every such integer. Yields
// (value, line) pairs, values saturated at 2^63.
template <typename F>
void countsAfter(const std::string& text, std::string_view keyword, F&& each) {
  const auto word = [](char c) { return std::isalnum((unsigned char)c) || c == '_' || c == '.' || c == '-' || c == '+' || c == '*'; };
  size_t line = 1;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\n') ++line;
    size_t at = i;
    if (!keyword.empty()) {
      if (text.compare(i, keyword.size(), keyword) != 0 || (i > 0 && word(text[i - 1]))) continue;
      at = i + keyword.size();
      if (at >= text.size() || (text[at] != ' ' && text[at] != '\t')) continue;
      while (at < text.size() && (text[at] == ' ' || text[at] == '\t')) ++at;
    } else if (!std::isdigit((unsigned char)text[i]) || (i > 0 && word(text[i - 1]))) {
      continue;
    }
    size_t end = at;
    uint64_t v = 0;
    while (end < text.size() && std::isdigit((unsigned char)text[end])) {
      v = v > (uint64_t(1) << 59) ? uint64_t(1) << 63 : v * 10 + uint64_t(text[end] - '0');
      ++end;
    }
    if (end == at || (end < text.size() && (word(text[end]) || text[end] == 'e' || text[end] == 'E'))) {
      if (keyword.empty()) i = std::max(i, end);
      continue;
    }
    each(v, line);
    if (keyword.empty()) i = end - 1;
  }
}

}  // namespace

namespace {

// assimp reads `nan`, `inf` and `1e999` in an OBJ as 0 (a texture coordinate of 0 made
// a triangle of zero uv area, or traced another one wrongly) and drops a face whose index
// is past the vertices without a word: both are errors naming the line.
void checkObjNumbers(const std::string& path, const std::string& text) {
  uint64_t count[3] = {};  // v, vt, vn defined so far
  const char* what[3] = {"vertex position", "texture coordinate", "normal"};
  struct Far {
    uint64_t index = 0;
    size_t line = 0;
    std::string key;
  } far[3];  // the largest positive index of each kind (it may name a later element)
  // Split by hand: an OBJ may have millions of lines.
  const auto next = [](std::string_view& rest) {
    const size_t a = rest.find_first_not_of(" \t\r");
    if (a == std::string_view::npos) return rest = {}, std::string_view{};
    const size_t b = std::min(rest.find_first_of(" \t\r", a), rest.size());
    const std::string_view t = rest.substr(a, b - a);
    rest.remove_prefix(b);
    return t;
  };
  size_t n = 0;
  for (size_t at = 0; at < text.size();) {
    const size_t eol = std::min(text.find('\n', at), text.size());
    std::string_view rest(text.data() + at, eol - at);
    at = eol + 1, ++n;
    const std::string_view key = next(rest);
    const int kind = key == "v" ? 0 : key == "vt" ? 1 : key == "vn" ? 2 : -1;
    if (kind >= 0) {
      ++count[kind];
      for (std::string_view t; !(t = next(rest)).empty();) {
        const std::string tok(t.substr(0, 64));
        char* end = nullptr;
        const double d = std::strtod(tok.c_str(), &end);
        if (end == tok.c_str()) break;  // a word ends the numbers (a comment, say): assimp's to judge
        if (!std::isfinite(d))
          fail(path, "line {}: {}: non-finite {} '{}'", n, key, what[kind], tok.substr(0, 40));
      }
    } else if (key == "f" || key == "l" || key == "p") {
      for (std::string_view t; !(t = next(rest)).empty();) {
        size_t from = 0;
        for (int k = 0; k < 3 && from <= t.size(); ++k) {
          const size_t slash = std::min(t.find('/', from), t.size());
          const std::string idx(t.substr(from, std::min<size_t>(slash - from, 24)));
          from = slash + 1;
          if (idx.empty()) continue;
          char* end = nullptr;
          const long long i = std::strtoll(idx.c_str(), &end, 10);
          if (*end != '\0') break;
          if (i == 0) fail(path, "line {}: {}: index 0 (OBJ indices start at 1)", n, key);
          // A negative index counts back from the last element defined so far.
          if (i < 0 && uint64_t(-(i + 1)) + 1 > count[k])
            fail(path, "line {}: {}: {} index {} reaches before the first of the {} defined so far", n, key,
                 what[k], idx, count[k]);
          if (i > 0 && uint64_t(i) > far[k].index) far[k] = {uint64_t(i), n, std::string(key)};
        }
      }
    }
  }
  for (int k = 0; k < 3; ++k)
    if (far[k].index > count[k])
      fail(path, "line {}: {}: {} index {} is past the file's {} {}s", far[k].line, far[k].key, what[k],
           far[k].index, count[k], what[k]);
}

}  // namespace

void checkMeshCounts(const std::string& path, const Assimp::Importer& importer) {
  const std::string ext = lowerExtension(path);
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    char head[16] = {};
    in.read(head, sizeof head);
    text.assign(head, size_t(std::max<std::streamsize>(0, in.gcount())));
  }
  const std::string_view start(text);
  const bool off = readAs(ext, {".off"}, start.find("OFF") < 4, importer);
  const bool ase = readAs(ext, {".ase", ".ask"}, start.substr(0, 1) == "*", importer);
  const bool ac3d = readAs(ext, {".ac", ".acc", ".ac3d"}, start.substr(0, 4) == "AC3D", importer);
  const bool x = readAs(ext, {".x"}, start.substr(0, 4) == "xof ", importer) && start.substr(8, 4) == "txt ";
  const bool nff = readAs(ext, {".nff", ".enff"}, false, importer);
  const bool obj = readAs(ext, {".obj"}, false, importer);
  if (!(off || ase || ac3d || x || nff || obj)) return;
  text = readAll(path);
  const uint64_t size = text.size();
  const auto bounded = [&](std::string_view what) {
    return [&, what](uint64_t v, size_t line) {
      if (v > size)
        fail(path, "cannot load mesh ({}{}{}{} claims more elements than this {}-byte file can hold)",
             line > 0 ? fmt::format("line {}: ", line) : "", what, what.empty() ? "" : " ", v, size);
    };
  };
  if (off) {
    // The header: OFF (or COFF, NOFF, ...), then the vertex, face and edge counts.
    const size_t at = text.find("OFF");
    std::istringstream in(text.substr(at == std::string::npos ? 0 : at + 3, 256));
    uint64_t counts[2] = {};
    std::string tok;
    for (int k = 0; k < 2 && in >> tok;)
      if (tok[0] == '#') std::getline(in, tok);
      else if (std::all_of(tok.begin(), tok.end(), [](char c) { return std::isdigit((unsigned char)c); }))
        counts[k++] = tok.size() > 18 ? uint64_t(1) << 63 : std::stoull(tok);
      else break;
    for (uint64_t c : counts) bounded("the OFF header's count")(c, 0);
  }
  if (ase)
    for (const char* k : {"*MESH_NUMVERTEX", "*MESH_NUMFACES", "*MESH_NUMTVERTEX", "*MESH_NUMTVFACES",
                          "*MESH_NUMCVERTEX", "*MESH_NUMCVFACES", "*MESH_NUMBONE", "*MATERIAL_COUNT", "*NUMSUBMTLS"})
      countsAfter(text, k, bounded(k));
  if (ac3d)
    for (const char* k : {"numvert", "numsurf", "kids", "refs"}) countsAfter(text, k, bounded(k));
  if (obj) checkObjNumbers(path, text);
  if (x) countsAfter(text, "", bounded(""));  // counts are untagged; indices are below them
  if (nff)
    countsAfter(text, "tess", [&](uint64_t v, size_t line) {
      if (v > uint64_t(kMaxNffTess))
        fail(path, "cannot load mesh (line {}: tess {}: at most {} is supported, a sphere of 20·4^tess triangles)",
             line, v, kMaxNffTess);
    });
}

}  // namespace oblong
