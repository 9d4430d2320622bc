#include "core/mesh.h"

#include "core/error.h"

#include <assimp/Importer.hpp>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <glm/gtc/matrix_inverse.hpp>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <unordered_map>

// Debian's libassimp 5.2.4 is built with its internal checks (ai_assert) on, and the
// default handler aborts the process: a malformed PLY face list, for one, ends in
// "ai_assert failure in TriangulateProcess.cpp(238)" and SIGABRT (found by
// tests/fuzz/fuzz_files.cpp; docs/bad_input.md). The library calls this function
// through its PLT, so the definition here takes its place; the exception it throws is
// caught by Importer::ReadFile (its catch-all exception region), which then returns no
// scene and an error string, and loadMesh reports one line. (The library's own
// setAiAssertHandler is not exported.)
namespace Assimp {
void aiAssertViolation(const char* failedExpression, const char* file, int line) {
  throw std::runtime_error(fmt::format("assimp internal check failed: {} ({}:{})", failedExpression, file, line));
}
}  // namespace Assimp

namespace oblong {

DisplacedTriangle Mesh::triangle(size_t i) const {
  DisplacedTriangle t;
  const glm::uvec3& f = triangles[i];
  for (int k = 0; k < 3; ++k) {
    t.p[k] = positions[f[k]];
    t.n[k] = normals[f[k]];
    t.t[k] = hasUVs() ? uvs[f[k]] : vec2(0.0f);
  }
  t.prepare();  // the caller decides what to do with an undisplaceable triangle
  return t;
}

size_t Mesh::bytes() const {
  return positions.size() * sizeof(vec3) + normals.size() * sizeof(vec3) + uvs.size() * sizeof(vec2) +
         triangles.size() * sizeof(glm::uvec3) + inputTriangle.size() * sizeof(uint32_t);
}

namespace {

// Exact float equality of positions. +0 and -0 compare equal, so they must hash equal.
struct PositionHash {
  size_t operator()(const vec3& p) const {
    size_t h = 0;
    for (int a = 0; a < 3; ++a) {
      const uint32_t bits = std::bit_cast<uint32_t>(p[a] + 0.0f);  // -0 + 0 = +0
      h = h * 0x9E3779B97F4A7C15ull + bits;
    }
    return h ^ (h >> 29);
  }
};

bool isZeroOrBad(const vec3& n) {
  const float l2 = glm::dot(n, n);
  return !(l2 > 0.0f) || !std::isfinite(l2);
}

// Area-weighted vertex normals: the unnormalised cross product of each triangle (twice
// its area) is summed per distinct position, so vertices split at uv seams (same
// position, different uv) get one normal. Double accumulation keeps big meshes exact
// enough. Vertices whose sum vanishes get a zero vector; `used` marks vertices of at
// least one non-degenerate triangle (for them a zero normal is an error).
std::vector<vec3> smoothNormals(const Mesh& m, std::vector<bool>& used) {
  std::unordered_map<vec3, uint32_t, PositionHash> group;
  std::vector<uint32_t> groupOf(m.positions.size());
  for (size_t v = 0; v < m.positions.size(); ++v)
    groupOf[v] = group.try_emplace(m.positions[v], uint32_t(group.size())).first->second;
  std::vector<dvec3> sum(group.size(), dvec3(0.0));
  used.assign(m.positions.size(), false);
  for (const glm::uvec3& f : m.triangles) {
    const dvec3 p0(m.positions[f[0]]), p1(m.positions[f[1]]), p2(m.positions[f[2]]);
    const dvec3 c = glm::cross(p1 - p0, p2 - p0);
    if (c == dvec3(0.0)) continue;
    for (int k = 0; k < 3; ++k) {
      sum[groupOf[f[k]]] += c;
      used[f[k]] = true;
    }
  }
  std::vector<vec3> n(m.positions.size());
  for (size_t v = 0; v < n.size(); ++v) {
    const dvec3 s = sum[groupOf[v]];
    const double l = glm::length(s);
    n[v] = l > 0.0 ? vec3(s / l) : vec3(0.0f);
  }
  return n;
}

// Replaces zero or non-finite normals by smooth ones; errors if that still leaves a
// zero normal on a vertex of a non-degenerate triangle (its triangles' normals cancel).
// Vertices only used by degenerate triangles get +z: those triangles are never
// displaced (prepare() rejects them), the normal just has to be unit length.
void fixNormals(Mesh& m) {
  std::vector<size_t> bad;
  for (size_t v = 0; v < m.normals.size(); ++v)
    if (isZeroOrBad(m.normals[v])) bad.push_back(v);
    else m.normals[v] = glm::normalize(m.normals[v]);
  if (bad.empty()) return;
  std::vector<bool> used;
  const std::vector<vec3> smooth = smoothNormals(m, used);
  for (size_t v : bad) {
    if (!isZeroOrBad(smooth[v])) {
      m.normals[v] = smooth[v];
    } else if (!used[v]) {
      m.normals[v] = vec3(0.0f, 0.0f, 1.0f);
    } else {
      const vec3& p = m.positions[v];
      fail(m.name, "vertex {} at ({}, {}, {}) has a zero normal (the normals of its triangles cancel)", v, p.x,
           p.y, p.z);
    }
  }
}

// PLY files are checked here before assimp reads them, because assimp 5.2.4/5.2.5
// (Debian bookworm) trusts the header: a truncated binary file is read past its end
// (garbage indices, then a crash in post-processing), a truncated ASCII file loads as a
// partial mesh, and a 200-byte header claiming 3e8 vertices makes it allocate 3.5 GiB
// before it notices. So the header is parsed the way assimp parses it
// (code/AssetLib/Ply/PlyParser.cpp, IOStreamBuffer::getNextLine) and the data is walked:
// every element must fit in the file as assimp will read it, and every list count must
// fit in what follows it. Where assimp would read a well-formed header differently from
// the PLY specification, the file is refused rather than misread.

bool isLineEnd(int c) { return c == '\r' || c == '\n' || c == '\0' || c == '\f'; }  // assimp's IsLineEnd

// Random reads of a file through a 1 MiB window (the walks below read sequentially).
class FileWindow {
 public:
  explicit FileWindow(const std::string& path) : in_(path, std::ios::binary) {
    in_.seekg(0, std::ios::end);
    size_ = fileSize_ = in_ ? uint64_t(in_.tellg()) : 0;
  }
  uint64_t size() const { return size_; }
  uint64_t fileSize() const { return fileSize_; }
  // Reads as if the file ended with one more '\n' (the copy assimp will be given).
  void appendLineEnd() { size_ = fileSize_ + 1; }
  int at(uint64_t i) {  // -1 past the end
    if (i >= size_) return -1;
    if (i >= fileSize_) return '\n';
    if (i < start_ || i >= start_ + buf_.size()) fill(i);
    return (unsigned char)buf_[size_t(i - start_)];
  }
  void read(uint64_t i, unsigned char* dst, size_t n) {  // the caller checked i + n <= size()
    for (size_t k = 0; k < n; ++k) dst[k] = (unsigned char)at(i + k);
  }

 private:
  void fill(uint64_t i) {
    buf_.resize(size_t(std::min<uint64_t>(1 << 20, fileSize_ - i)));
    in_.clear();
    in_.seekg(std::streamoff(i));
    in_.read(buf_.data(), std::streamsize(buf_.size()));
    buf_.resize(size_t(std::max<std::streamsize>(0, in_.gcount())));
    start_ = i;
    if (buf_.empty()) buf_.push_back('\0');  // unreadable: reads as a line end
  }
  std::ifstream in_;
  uint64_t size_ = 0, fileSize_ = 0, start_ = 0;
  std::vector<char> buf_;
};

// assimp's IOStreamBuffer::getNextLine: one line end is skipped before a line, one after
// it; at the end of the file it fails and leaves its buffer as it was (the PLY reader
// then parses the previous line again), and a last line without a line end overwrites
// the start of the buffer only.
class AssimpLines {
 public:
  explicit AssimpLines(FileWindow& f) : f_(f) {}
  bool next() {
    const uint64_t n = f_.size();
    if (pos_ >= n) return false;
    if (isLineEnd(f_.at(pos_))) {
      while (pos_ < n && f_.at(pos_) != '\n') ++pos_;
      if (++pos_ >= n) return false;
    }
    size_t i = 0;
    for (int c; !isLineEnd(c = f_.at(pos_));) {
      put(i++, char(c));
      if (++pos_ >= n) return false;
    }
    put(i, '\n');
    ++pos_;
    ++number_;
    return true;
  }
  // The buffer up to its first line end: what the parser sees.
  std::string_view line() const {
    size_t e = 0;
    while (e < buf_.size() && !isLineEnd((unsigned char)buf_[e])) ++e;
    return std::string_view(buf_).substr(0, e);
  }
  uint64_t pos() const { return pos_; }
  size_t number() const { return number_; }  // lines read so far
  void clearBuffer() { buf_.clear(); }

 private:
  void put(size_t i, char c) {
    if (i >= buf_.size()) buf_.resize(i + 1);
    buf_[i] = c;
  }
  FileWindow& f_;
  uint64_t pos_ = 0;
  size_t number_ = 0;
  std::string buf_;
};

// assimp's SkipSpaces / TokenMatch on one line (the line end is the end of the view).
struct Cursor {
  std::string_view s;
  size_t i = 0;
  bool skipSpaces() {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    return i < s.size();
  }
  bool tokenMatch(std::string_view t) {
    if (s.compare(i, t.size(), t) != 0) return false;
    const size_t e = i + t.size();
    if (e < s.size() && s[e] != ' ' && s[e] != '\t') return false;
    i = std::min(s.size(), e + 1);  // exactly one separator
    return true;
  }
};

std::vector<std::string_view> tokens(std::string_view s) {
  std::vector<std::string_view> t;
  for (size_t i = 0; i < s.size();) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    const size_t b = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t') ++i;
    if (i > b) t.push_back(s.substr(b, i - b));
  }
  return t;
}

enum class PlyKind : uint8_t { Invalid, Int, UInt, Float };
struct PlyType {
  PlyKind kind = PlyKind::Invalid;
  uint8_t size = 0;  // bytes in a binary file
};
// The type names assimp knows (the PLY specification's, and "double64").
PlyType plyType(std::string_view t) {
  static const std::pair<const char*, PlyType> kTypes[] = {
      {"char", {PlyKind::Int, 1}},    {"int8", {PlyKind::Int, 1}},     {"uchar", {PlyKind::UInt, 1}},
      {"uint8", {PlyKind::UInt, 1}},  {"short", {PlyKind::Int, 2}},    {"int16", {PlyKind::Int, 2}},
      {"ushort", {PlyKind::UInt, 2}}, {"uint16", {PlyKind::UInt, 2}},  {"int", {PlyKind::Int, 4}},
      {"int32", {PlyKind::Int, 4}},   {"uint", {PlyKind::UInt, 4}},    {"uint32", {PlyKind::UInt, 4}},
      {"float", {PlyKind::Float, 4}}, {"float32", {PlyKind::Float, 4}}, {"double", {PlyKind::Float, 8}},
      {"float64", {PlyKind::Float, 8}}, {"double64", {PlyKind::Float, 8}}};
  for (const auto& [name, type] : kTypes)
    if (t == name) return type;
  return {};
}
// assimp's ParseDataType at the cursor (no spaces skipped before it).
PlyType plyTypeAt(Cursor& c) {
  size_t e = c.i;
  while (e < c.s.size() && c.s[e] != ' ' && c.s[e] != '\t') ++e;
  const PlyType t = plyType(c.s.substr(c.i, e - c.i));
  if (t.kind != PlyKind::Invalid) c.i = std::min(c.s.size(), e + 1);
  return t;
}

struct PlyProperty {
  PlyType type;       // a scalar's type, or a list's item type
  PlyType countType;  // a list's count type; Invalid for a scalar
  bool list() const { return countType.kind != PlyKind::Invalid; }
};
struct PlyElement {
  std::string name;   // shown in messages
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
  std::string assimpStops;  // spec only: where assimp's property list ends early
};
bool sameLayout(const PlyElement& a, const PlyElement& b) {
  if (a.count != b.count || a.properties.size() != b.properties.size()) return false;
  for (size_t k = 0; k < a.properties.size(); ++k) {
    const PlyProperty &p = a.properties[k], &q = b.properties[k];
    if (p.type.kind != q.type.kind || p.type.size != q.type.size || p.countType.kind != q.countType.kind ||
        p.countType.size != q.countType.size)
      return false;
  }
  return true;
}

std::string shownName(std::string_view s) {
  std::string r;
  for (char c : s.substr(0, 40)) r += (c >= 0x21 && c < 0x7f) ? c : '?';
  return r.empty() ? "?" : r;
}

// assimp's strtoul10 / strtol10 (wrapping), then the cast to unsigned int of a list count.
uint32_t assimpUInt(std::string_view t) {
  uint32_t v = 0;
  for (size_t i = 0; i < t.size() && t[i] >= '0' && t[i] <= '9'; ++i) v = v * 10 + uint32_t(t[i] - '0');
  return v;
}
// A list count as assimp reads it; nullopt when the value is negative or no count at all
// (assimp casts it to unsigned int: about 4e9 entries, or undefined for a float).
std::optional<uint64_t> listCount(std::string_view t, PlyKind kind) {
  if (kind == PlyKind::UInt) return assimpUInt(t);
  if (kind == PlyKind::Int) {
    const bool neg = !t.empty() && t[0] == '-';
    const uint32_t v = assimpUInt(t.substr(!t.empty() && (t[0] == '-' || t[0] == '+') ? 1 : 0));
    const int32_t s = neg ? int32_t(0u - v) : int32_t(v);
    if (s < 0) return std::nullopt;
    return uint64_t(s);
  }
  const std::string z(t);
  char* end = nullptr;
  const double d = std::strtod(z.c_str(), &end);
  if (!(d >= 0.0 && d < 4294967296.0)) return std::nullopt;
  return uint64_t(d);
}
std::optional<uint64_t> listCount(const unsigned char* b, PlyType t, bool bigEndian) {
  unsigned char x[8];
  for (size_t k = 0; k < t.size; ++k) x[k] = b[bigEndian ? t.size - 1 - k : k];
  if (t.kind == PlyKind::Float) {
    double d;
    if (t.size == 4) {
      float f;
      std::memcpy(&f, x, 4);
      d = f;
    } else {
      std::memcpy(&d, x, 8);
    }
    if (!(d >= 0.0 && d < 4294967296.0)) return std::nullopt;
    return uint64_t(d);
  }
  uint64_t u = 0;
  for (size_t k = 0; k < t.size; ++k) u |= uint64_t(x[k]) << (8 * k);
  if (t.kind == PlyKind::Int && (u >> (8 * t.size - 1)) != 0) return std::nullopt;  // negative
  return u;
}

// A value assimp parses whole as its type (else it reads a prefix, or 0, and then the
// rest of the line from the wrong place): integers in 32 bits, unsigned ones without a
// sign; floats in decimal (or nan/inf).
bool plyNumber(std::string_view t, PlyKind kind) {
  size_t i = 0;
  const bool neg = !t.empty() && t[0] == '-';
  if (kind != PlyKind::UInt && i < t.size() && (t[i] == '-' || t[i] == '+')) ++i;
  if (kind != PlyKind::Float) {
    if (i == t.size() || t.size() - i > 10) return false;
    uint64_t v = 0;
    for (; i < t.size(); ++i) {
      if (t[i] < '0' || t[i] > '9') return false;
      v = v * 10 + uint64_t(t[i] - '0');
    }
    return kind == PlyKind::UInt ? v <= 0xFFFFFFFFull : v <= (neg ? 0x80000000ull : 0x7FFFFFFFull);
  }
  if (i == t.size() || t.find_first_of("xXpP") != std::string_view::npos) return false;
  const std::string z(t);
  char* end = nullptr;
  std::strtod(z.c_str(), &end);
  return end == z.c_str() + z.size();
}

// What checkPly found: assimp may have to read a copy with `insert` inserted at `at`.
struct PlyCheck {
  bool patch = false;
  uint64_t at = 0;
  const char* insert = "";
};

struct PlyHeader {
  enum Format { Ascii, BinaryLE, BinaryBE, Unknown } format = Unknown;
  std::vector<PlyElement> assimp, spec;  // as assimp reads the header, as the specification does
  bool malformed = false;                // not a header by the specification
  std::string misread;                   // how assimp would misread a well-formed header
  uint64_t dataStart = 0;                // byte after the end_header line's line end
};

// Parses the header as assimp 5.2 does (PLY::DOM::ParseHeader, Element::ParseElement,
// Property::ParseProperty), and by the specification alongside, to tell where they
// differ. Leaves L after the end_header line.
PlyHeader parsePlyHeader(AssimpLines& L, const std::string& path) {
  PlyHeader h;
  if (!L.next() || !L.next()) return h;  // magic, format: assimp reports what is wrong
  {
    Cursor c{L.line()};
    c.skipSpaces();
    if (!c.tokenMatch("format")) return h;
    if (c.tokenMatch("ascii")) h.format = PlyHeader::Ascii;
    else if (c.s.compare(c.i, 7, "binary_") == 0)
      h.format = c.i + 7 < c.s.size() && (c.s[c.i + 7] == 'b' || c.s[c.i + 7] == 'B') ? PlyHeader::BinaryBE
                                                                                   : PlyHeader::BinaryLE;
    else return h;
    const auto t = tokens(L.line());
    static const char* kFormats[] = {"ascii", "binary_little_endian", "binary_big_endian"};
    if (t.size() != 3 || t[1] != kFormats[h.format]) h.malformed = true;
  }
  L.clearBuffer();  // assimp reads the magic and format lines into buffers of their own
  bool have = L.next();
  while (have) {
    const std::string_view line = L.line();
    const auto t = tokens(line);
    if (!t.empty() && t[0] == "end_header") break;
    if (t.empty() || t[0] != "element") {
      // "comment TextureFile ..." is an element without entries to assimp: no data.
      if (t.empty() || (t[0] != "comment" && t[0] != "obj_info")) h.malformed = true;
      have = L.next();
      continue;
    }
    // "element NAME COUNT"; assimp parses the count only after the names it knows, and
    // reads the digits at the start of any other name instead.
    Cursor c{line};
    c.skipSpaces();
    c.tokenMatch("element");
    PlyElement a, s;
    s.name = a.name = shownName(t.size() > 1 ? t[1] : "");
    bool known = false;
    if (c.skipSpaces())
      for (const char* k : {"vertex", "face", "tristrips", "edge", "material"})
        if (c.tokenMatch(k)) {
          known = true;
          break;
        }
    const bool texture = !known && c.tokenMatch("TextureFile");
    const bool assimpElement = c.skipSpaces();
    if (assimpElement && !texture) a.count = assimpUInt(c.s.substr(c.i));
    if (t.size() == 3 && t[2].size() <= 19 &&
        std::all_of(t[2].begin(), t[2].end(), [](char ch) { return ch >= '0' && ch <= '9'; }))
      s.count = std::stoull(std::string(t[2]));
    else h.malformed = true;
    // Property lines follow; assimp's list ends at the first line it cannot parse as one.
    bool assimpOpen = assimpElement && !texture;
    if (!assimpOpen) s.assimpStops = "at once";
    have = L.next();
    while (have) {
      const std::string_view pl = L.line();
      const auto pt = tokens(pl);
      if (pt.empty() || pt[0] == "comment") {  // the specification skips these
        if (assimpOpen) s.assimpStops = pt.empty() ? "at a blank line" : "at a comment line";
        assimpOpen = false;
        have = L.next();
        continue;
      }
      if (pt[0] != "property") break;
      const bool list = pt.size() > 1 && pt[1] == "list";
      const size_t need = list ? 5 : 3;
      if (pt.size() != need) h.malformed = true;
      PlyProperty p;
      if (list && pt.size() > 3) p = {plyType(pt[3]), plyType(pt[2])};
      else if (!list && pt.size() > 1) p = {plyType(pt[1]), {}};
      if (pt.size() >= need - 1 && (p.type.kind == PlyKind::Invalid || (list && !p.list())))
        fail(path, "cannot load mesh (PLY property type '{}' of element '{}' is not one assimp reads)",
             shownName(list && !p.list() ? pt[2] : pt[need - 2]), s.name);
      s.properties.push_back(p);
      if (assimpOpen) {  // assimp's ParseProperty, exactly
        Cursor q{pl};
        PlyProperty ap;
        bool ok = q.skipSpaces() && q.tokenMatch("property") && q.skipSpaces();
        if (ok && q.tokenMatch("list")) {
          ap.countType = plyTypeAt(q);
          ok = ap.countType.kind != PlyKind::Invalid && q.skipSpaces();
        }
        if (ok) ap.type = plyTypeAt(q);
        ok = ok && ap.type.kind != PlyKind::Invalid && q.skipSpaces();
        if (ok) a.properties.push_back(ap);
        else s.assimpStops = fmt::format("at 'property {}'", shownName(pt.size() > 1 ? pt[1] : ""));
        assimpOpen = ok;
      }
      have = L.next();
    }
    if (s.count > 0 && s.properties.empty())
      fail(path, "cannot load mesh (PLY element '{}' declares {} entries but no properties)", s.name, s.count);
    if (assimpElement) {
      // Such an element has no data to assimp either, but it allocates its entries.
      if (a.count > 0 && a.properties.empty())
        fail(path, "cannot load mesh (assimp 5.2 would misread this PLY header: it reads element '{}' with {} entries "
                   "but no properties)",
             a.name, a.count);
      h.assimp.push_back(a);
    }
    h.spec.push_back(s);
  }
  // assimp's header loop ends only at an end_header line; at the end of the file it keeps
  // parsing its last line again (e.g. "end_header" without a line end, then stale text).
  if (!have) fail(path, "cannot load mesh (PLY header without an end_header line as assimp reads lines: it would "
                        "loop forever)");
  h.dataStart = L.pos();
  if (h.malformed) return h;
  // A difference matters only when assimp reads data after it.
  for (size_t k = 0; k < h.spec.size(); ++k) {
    if (k < h.assimp.size() && sameLayout(h.assimp[k], h.spec[k])) continue;
    bool harmless = true;
    for (size_t j = k; j < h.assimp.size(); ++j) harmless = harmless && h.assimp[j].count == 0;
    if (harmless) break;
    const PlyElement& s = h.spec[k];
    if (k >= h.assimp.size()) h.misread = fmt::format("it does not read the line of element '{}'", s.name);
    else if (s.count > 0xFFFFFFFFull)
      h.misread = fmt::format("element '{}' has {} entries, more than it counts (2^32 - 1)", s.name, s.count);
    else if (h.assimp[k].count != s.count)
      h.misread = fmt::format("it reads the count of element '{}' as {}, not {} (it reads counts only after the "
                              "names vertex, face, tristrips, edge and material)",
                              s.name, h.assimp[k].count, s.count);
    else
      h.misread = fmt::format("its list of the properties of element '{}' ends {}", s.name, s.assimpStops);
    break;
  }
  return h;
}

[[noreturn]] void plyShort(const std::string& path, const PlyElement& e, uint64_t done, const std::string& detail) {
  fail(path, "cannot load mesh (PLY header declares {} {} elements but the file ends after {} of them{})", e.count,
       e.name, done, detail);
}

// Binary data: every byte assimp will read must be in the file.
void checkPlyBinary(FileWindow& f, const std::string& path, const PlyHeader& h, uint64_t start) {
  const bool be = h.format == PlyHeader::BinaryBE;
  uint64_t at = start;
  const uint64_t n = f.size();
  for (const PlyElement& e : h.assimp) {
    uint64_t fixed = 0;
    bool lists = false;
    for (const PlyProperty& p : e.properties) {
      fixed += p.list() ? p.countType.size : p.type.size;
      lists = lists || p.list();
    }
    if (e.count == 0 || fixed == 0) continue;
    const uint64_t left = n - at;
    if (e.count > left / fixed)
      fail(path, "cannot load mesh (PLY header declares {} {} elements of {}{} bytes but the file holds only {} bytes "
                 "for them)",
           e.count, e.name, lists ? "at least " : "", fixed, left);
    if (!lists) {
      at += e.count * fixed;
      continue;
    }
    for (uint64_t i = 0; i < e.count; ++i)
      for (const PlyProperty& p : e.properties) {
        if (!p.list()) {
          at += p.type.size;
          if (at > n) plyShort(path, e, i, "");
          continue;
        }
        unsigned char b[8];
        if (n - at < p.countType.size) plyShort(path, e, i, "");
        f.read(at, b, p.countType.size);
        at += p.countType.size;
        const auto c = listCount(b, p.countType, be);
        if (!c)
          fail(path, "cannot load mesh (PLY {} {}: its list count is negative or not a count)", e.name, i);
        if (*c > (n - at) / p.type.size)
          plyShort(path, e, i, fmt::format(" (entry {}'s list of {} needs {} bytes, the file holds {} more)", i, *c,
                                           *c * p.type.size, n - at));
        at += *c * p.type.size;
      }
  }
}

// ASCII data as assimp reads it (ElementInstanceList::ParseInstanceList): one entry
// per line (at the end of the file it parses its last line again), one value per scalar
// property, a count and that many values per list property. A well-formed header's data
// must match it; for a malformed one (assimp's reading is then the only one there is),
// only what bounds memory is required: list counts that fit their line, and entry counts
// that the file's values can cover (assimp allocates all entries up front).
void checkPlyAscii(FileWindow& f, AssimpLines& L, const std::string& path, const PlyHeader& h) {
  if (h.malformed) {
    uint64_t values = 0;
    bool inValue = false;
    for (uint64_t i = h.dataStart; i < f.size(); ++i) {
      const int c = f.at(i);
      const bool sep = c == ' ' || c == '\t' || isLineEnd(c);
      values += !sep && !inValue;
      inValue = !sep;
    }
    for (const PlyElement& e : h.assimp) {
      const uint64_t need = e.count * e.properties.size();
      if (need > values)
        fail(path, "cannot load mesh (PLY header declares {} {} elements but the file holds only {} more values)",
             e.count, e.name, values);
      values -= need;
    }
  }
  bool have = L.next();
  for (const PlyElement& e : h.assimp) {
    if (e.count == 0) continue;
    bool again = false;  // the last line parsed again
    for (uint64_t i = 0; i < e.count && !(again && !have); ++i) {
      if (!have) {
        if (!h.malformed) plyShort(path, e, i, "");
        again = true;
      }
      const auto t = tokens(L.line());
      const size_t line = L.number();
      size_t k = 0;
      for (const PlyProperty& p : e.properties) {
        if (k >= t.size()) {
          if (h.malformed) break;  // assimp reads zeros for the rest
          fail(path, "cannot load mesh (PLY {} {} (line {}) has {} values, fewer than its properties need)",
               e.name, i, line, t.size());
        }
        const PlyKind kind = p.list() ? p.countType.kind : p.type.kind;
        if (!h.malformed && !plyNumber(t[k], kind))
          fail(path, "cannot load mesh (PLY {} {} (line {}): '{}' is not a number of its type)", e.name, i,
               line, shownName(t[k]));
        if (!p.list()) {
          ++k;
          continue;
        }
        const auto c = listCount(t[k], kind);
        if (!c || *c > t.size() - k - 1)
          fail(path,
               "cannot load mesh (PLY {} {} (line {}): list count '{}' is more than the {} values after it)",
               e.name, i, line, shownName(t[k]), t.size() - k - 1);
        for (size_t j = k + 1; !h.malformed && j <= k + *c; ++j)
          if (!plyNumber(t[j], p.type.kind))
            fail(path, "cannot load mesh (PLY {} {} (line {}): '{}' is not a number of its type)", e.name, i,
                 line, shownName(t[j]));
        k += 1 + size_t(*c);
      }
      if (have) have = L.next();
    }
  }
}

// Before assimp reads a PLY file: the header must end (assimp loops forever on a PLY
// header without an `end_header` line; found by tests/fuzz/fuzz_files.cpp), assimp must
// read it as the specification does, and the data must hold what the header declares.
// assimp reads a file as PLY when its extension is .ply, or when the extension is not
// one of its own and the file starts with "ply".
PlyCheck checkPly(const std::string& path, const Assimp::Importer& importer) {
  namespace fs = std::filesystem;
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::ifstream in(path, std::ios::binary);
  std::string head(1 << 20, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(std::max<std::streamsize>(0, in.gcount())));
  in.close();
  // assimp skips leading line breaks before the magic ("\nply" hangs too); be stricter.
  const size_t start = std::min(head.size(), head.find_first_not_of(" \t\r\n\v\f"));
  const bool plyMagic = head.compare(start, 3, "ply") == 0 || head.compare(start, 3, "PLY") == 0;
  const bool asPly = ext == ".ply" || (plyMagic && (ext.empty() || !importer.IsExtensionSupported(ext)));
  if (!asPly || !plyMagic) return {};  // without the magic, assimp's PLY reader stops at once
  // assimp hangs on "end_headerX" or "comment end_header" too: the first word must be it.
  bool ended = false;
  for (size_t line = 0; line < head.size() && !ended;) {
    size_t k = line;
    while (k < head.size() && (head[k] == ' ' || head[k] == '\t')) ++k;
    ended = head.compare(k, 10, "end_header") == 0 &&
            (k + 10 == head.size() || head[k + 10] == ' ' || head[k + 10] == '\t' || head[k + 10] == '\r' ||
             head[k + 10] == '\n');
    const size_t next = head.find_first_of("\r\n", line);
    if (next == std::string::npos) break;
    line = next + 1;
  }
  if (!ended) fail(path, "cannot load mesh (PLY header without an end_header line in its first MiB)");

  FileWindow f(path);
  AssimpLines L(f);
  const PlyHeader h = parsePlyHeader(L, path);
  if (h.format == PlyHeader::Unknown) return {};  // assimp reports it
  if (!h.misread.empty()) fail(path, "cannot load mesh (assimp 5.2 would misread this PLY header: {})", h.misread);
  PlyCheck r;
  if (h.format == PlyHeader::Ascii) {
    // A last line without a line end is parsed over what the buffer held before (its
    // digits could run on into the previous line's): assimp gets a copy that ends in one.
    if (f.size() > h.dataStart && !isLineEnd(f.at(f.size() - 1))) {
      r = {true, f.size(), "\n"};
      f.appendLineEnd();
    }
    checkPlyAscii(f, L, path, h);
    return r;
  }
  // assimp drops a '\n' at the start of the binary data (meant for a header that ends in
  // "\r\n"), also when it is the data's first byte after "end_header\n": every value
  // would then be read one byte off. Such a file is given to assimp as a copy whose
  // header ends in "\r\n".
  uint64_t data = h.dataStart;
  if (f.at(data) == '\n') {
    if (f.at(data - 1) == '\n') r = {true, data - 1, "\r"};
    else ++data;  // "\r\n" (or another line end before the '\n')
  }
  checkPlyBinary(f, path, h, data);
  return r;
}

// Importers of assimp 5.2 that store v' = 1 - v for a file's v (their formats put v = 0
// at the image's top, as oblong's maps do): glTF's and glTF2's for one (glTF2Importer.cpp,
// "Flip Y coords"), and those that convert from DirectX's convention. Unconditional in
// each (checked in the 5.2.5 sources); NFF and MDL flip in some variants only, and are
// left alone.
bool importerFlipsV(const Assimp::Importer& importer) {
  const int index = importer.GetPropertyInteger("importerIndex", -1);
  const aiImporterDesc* d = index >= 0 ? importer.GetImporterInfo(size_t(index)) : nullptr;
  if (!d || !d->mName) return false;
  static const char* const kFlipping[] = {"glTF2 Importer",          "glTF Importer",
                                          "Direct3D XFile Importer", "Quake II Mesh Importer",
                                          "Doom 3 / MD5 Mesh Importer", "Milkshape 3D Importer",
                                          "Quick3D Importer",        "Irrlicht Mesh Reader",
                                          "Unreal Mesh Importer",    "Ogre3D Mesh Importer"};
  for (const char* name : kFlipping)
    if (std::strcmp(d->mName, name) == 0) return true;
  return false;
}

// The v before assimp's v' = 1 - v in float. For v in [0.5, 2] that is 1 - v' exactly;
// below 0.5 the subtraction rounded, and every float v with 1 - v == v' is as likely. The
// one with the fewest significant decimal digits is taken, so that v written as decimal
// text (hand-made and generated files, tests) comes back exactly; else 1 - v'.
float unflipV(float flipped) {
  const float naive = 1.0f - flipped;
  const double c = 1.0 - double(flipped);  // exact
  if (!std::isfinite(flipped) || c == 0.0) return naive;
  const double e = std::floor(std::log10(std::abs(c)));
  for (int digits = 1; digits <= 9; ++digits) {
    const double step = std::pow(10.0, e - digits + 1), k0 = std::round(c / step);
    float best = naive;
    double bestErr = kInfinity;
    for (double k = k0 - 1; k <= k0 + 1; ++k) {
      const float v = float(k * step);
      if (1.0f - v == flipped && std::abs(double(v) - c) < bestErr) best = v, bestErr = std::abs(double(v) - c);
    }
    if (bestErr < kInfinity) return best;
  }
  return naive;
}

}  // namespace

void computeSmoothNormals(Mesh& m) {
  m.normals.assign(m.positions.size(), vec3(0.0f));
  fixNormals(m);
}

void transformMesh(Mesh& m, const glm::mat4& transform) {
  const glm::mat3 l(transform);
  const float det = glm::determinant(l);
  if (!(det != 0.0f) || !std::isfinite(det)) fail(m.name, "transform is singular or not finite");
  const glm::mat3 normalMatrix = glm::inverseTranspose(l);
  for (vec3& p : m.positions) {
    const vec4 q = transform * vec4(p, 1.0f);
    p = vec3(q) / q.w;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      fail(m.name, "transform produces a non-finite position");
  }
  for (vec3& n : m.normals) n = glm::normalize(normalMatrix * n);
  // A mirroring transform flips the geometric normal (cross product) against the vertex
  // normals; swapping two indices keeps the winding consistent with the normals.
  if (det < 0.0f)
    for (glm::uvec3& f : m.triangles) std::swap(f[1], f[2]);
}

void finishMesh(Mesh& m, const MeshLoadOptions& opts) {
  if (m.triangles.empty()) fail(m.name, "mesh has no triangles");
  if (m.normals.size() != m.positions.size() || (!m.uvs.empty() && m.uvs.size() != m.positions.size()))
    fail(m.name, "mesh has {} positions but {} normals and {} uvs", m.positions.size(), m.normals.size(),
         m.uvs.size());
  if (opts.needUVs && m.uvs.empty()) fail(m.name, "mesh has no texture coordinates (needed for displacement)");
  for (const glm::uvec3& f : m.triangles)
    for (int k = 0; k < 3; ++k)
      if (f[k] >= m.positions.size()) fail(m.name, "triangle uses vertex {} of {}", f[k], m.positions.size());

  if (m.inputTriangle.size() != m.triangles.size()) {
    m.inputTriangle.resize(m.triangles.size());
    std::iota(m.inputTriangle.begin(), m.inputTriangle.end(), 0u);
  }
  if (opts.smoothNormals) std::fill(m.normals.begin(), m.normals.end(), vec3(0.0f));  // fixNormals fills them

  // Degenerate before the transform, with the same exact (double) test as the smooth
  // normals, so that a vertex used only by such triangles never needs a normal.
  enum : uint8_t { kOk = 0, kZeroArea, kZeroUVArea };
  std::vector<uint8_t> why(m.triangles.size(), kOk);
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const glm::uvec3& f = m.triangles[i];
    const dvec3 p0(m.positions[f[0]]), p1(m.positions[f[1]]), p2(m.positions[f[2]]);
    if (glm::cross(p1 - p0, p2 - p0) == dvec3(0.0)) why[i] = kZeroArea;
  }
  fixNormals(m);
  if (opts.transform != glm::mat4(1.0f)) transformMesh(m, opts.transform);

  // After the transform, with the float quantities the renderer uses (DisplacedTriangle).
  size_t zeroArea = 0, zeroUV = 0, first = m.triangles.size();
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    if (why[i] == kOk) {
      const DisplacedTriangle T = m.triangle(i);  // prepare()d
      if (!std::isfinite(T.area))
        fail(m.name, "triangle {}: its area overflows a float (coordinates too large)", i);
      if (!(T.area > 0.0f)) why[i] = kZeroArea;
      else if (opts.needUVs && T.uvArea2 == 0.0f) why[i] = kZeroUVArea;
      else if (opts.needUVs && !(T.minNormalLength > 1e-6f)) {
        const glm::uvec3& f = m.triangles[i];
        fail(m.name,
             "triangle {}: its vertex normals cancel inside the triangle (vertices {}, {}, {}): the "
             "displacement direction is undefined there",
             i, f[0], f[1], f[2]);
      }
    }
    if (why[i] == kZeroArea) ++zeroArea;
    if (why[i] == kZeroUVArea) ++zeroUV;
    if (why[i] != kOk && first == m.triangles.size()) first = i;
  }
  const size_t skipped = zeroArea + zeroUV, total = m.triangles.size();
  const std::string detail =
      zeroUV ? fmt::format("zero area: {}, zero uv area: {}", zeroArea, zeroUV) : fmt::format("zero area: {}", zeroArea);
  if (skipped == total) fail(m.name, "all {} triangles are degenerate ({})", total, detail);
  if (skipped > 0) {
    size_t k = 0;
    for (size_t i = 0; i < total; ++i)
      if (why[i] == kOk) {
        m.triangles[k] = m.triangles[i];
        m.inputTriangle[k++] = m.inputTriangle[i];
      }
    m.triangles.resize(k);
    m.inputTriangle.resize(k);
    m.skippedTriangles += skipped;
  }
  // The traversal multiplies up to three coordinates in float (kMaxCoordinate).
  for (const glm::uvec3& f : m.triangles)
    for (int c = 0; c < 3; ++c) {
      const vec3& p = m.positions[f[c]];
      if (!(std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) <= kMaxCoordinate))
        fail(m.name, "vertex {} at ({}, {}, {}){} lies beyond the supported coordinate range (|x|, |y|, |z| <= 2^40 = "
                     "{:.4g})",
             f[c], p.x, p.y, p.z, opts.transform != glm::mat4(1.0f) ? " after the transform" : "", kMaxCoordinate);
    }
  if (skipped > 0 && opts.warn)
    fmt::print(stderr, "oblong: warning: {}: skipped {} of {} triangles as degenerate ({}; first: triangle {})\n",
               m.name, skipped, total, detail, first);
}

Mesh loadMesh(const std::string& path, const MeshLoadOptions& opts) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "file not found");
  if (!fs::is_regular_file(path, ec)) fail(path, "not a regular file");

  Assimp::Importer importer;
  const PlyCheck ply = checkPly(path, importer);
  // ValidateDataStructure: indices out of range and the like become an error instead of
  // reaching the post-processing steps.
  constexpr unsigned kFlags = aiProcess_ValidateDataStructure | aiProcess_Triangulate |
                              aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices |
                              aiProcess_SortByPType;
  const aiScene* scene = nullptr;
  if (ply.patch) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    std::string copy = text.str();
    copy.insert(size_t(std::min<uint64_t>(ply.at, copy.size())), ply.insert);
    scene = importer.ReadFileFromMemory(copy.data(), copy.size(), kFlags, "ply");
  } else {
    scene = importer.ReadFile(path, kFlags);
  }
  if (!scene) {
    std::string err = importer.GetErrorString();
    // ReadFileFromMemory names the copy AI_MEMORYIO_MAGIC_FILENAME + ".ply".
    const std::string_view copyName = "$$$___magic___$$$.ply";
    for (size_t at; ply.patch && (at = err.find(copyName)) != std::string::npos;)
      err.replace(at, copyName.size(), "the file");
    // One line: assimp's messages sometimes end with a newline.
    std::replace(err.begin(), err.end(), '\n', ' ');
    while (!err.empty() && err.back() == ' ') err.pop_back();
    fail(path, "cannot load mesh ({})", err.empty() ? "unknown error" : err);
  }

  Mesh m;
  m.name = path;
  bool allUVs = true;
  const bool flippedV = importerFlipsV(importer);
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* am = scene->mMeshes[mi];
    // SortByPType separates points and lines, which are of no use to a ray tracer of
    // surfaces: they are dropped here (and below, face by face) rather than with
    // AI_CONFIG_PP_SBP_REMOVE, which turns a file of lines into an opaque
    // "No meshes remaining" error.
    if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || am->mNumFaces == 0) continue;
    if (!am->HasTextureCoords(0)) allUVs = false;
    const uint32_t base = uint32_t(m.positions.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        fail(path, "non-finite vertex position ({}, {}, {})", p.x, p.y, p.z);
      m.positions.emplace_back(p.x, p.y, p.z);
      // A missing normal is stored as zero and filled in by fixNormals.
      m.normals.push_back(am->HasNormals() ? vec3(am->mNormals[v].x, am->mNormals[v].y, am->mNormals[v].z)
                                           : vec3(0.0f));
      if (am->HasTextureCoords(0)) {
        const aiVector3D& t = am->mTextureCoords[0][v];
        if (!std::isfinite(t.x) || !std::isfinite(t.y))
          fail(path, "non-finite texture coordinate ({}, {})", t.x, t.y);
        m.uvs.emplace_back(t.x, flippedV ? unflipV(t.y) : t.y);
      } else {
        m.uvs.emplace_back(0.0f);
      }
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      m.triangles.emplace_back(base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]);
    }
  }
  if (m.triangles.empty()) fail(path, "mesh has no triangles");
  if (!allUVs) {
    if (opts.needUVs) fail(path, "mesh has no texture coordinates (needed for displacement)");
    m.uvs.clear();  // partial uvs are useless without displacement
  }
  finishMesh(m, opts);
  return m;
}

}  // namespace oblong
