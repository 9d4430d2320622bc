#include "core/ply_check.h"

#include "core/error.h"

#include <assimp/Importer.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string_view>
#include <vector>

namespace oblong {

namespace {

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
}  // namespace

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
  // assimp takes the magic in any case ("pLy" too: found by the fuzzer, it hung on one).
  auto lower = [&](size_t i) { return i < head.size() ? char(std::tolower((unsigned char)head[i])) : '\0'; };
  const bool plyMagic = lower(start) == 'p' && lower(start + 1) == 'l' && lower(start + 2) == 'y';
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

}  // namespace oblong
