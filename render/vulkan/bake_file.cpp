// The baked scene file (bake_file.h). Needs only the C++ runtime, nlohmann::json and
// header-only fmt: oblong_vkbench reads it on machines without the CPU libraries.
#include "render/vulkan/bake_file.h"

#include "core/error.h"

#include <nlohmann/json.hpp>

#include <cstring>
#include <fstream>
#include <map>
#include <type_traits>

namespace oblong::vk {

using namespace vkgpu;

namespace {

constexpr char kMagic[8] = {'O', 'B', 'L', 'G', 'B', 'A', 'K', 'E'};
constexpr size_t kHeaderBytes = 32, kEntryBytes = 40, kNameBytes = 16;

struct Entry {
  std::string name;
  uint64_t offset = 0, bytes = 0, checksum = 0;
};

template <typename T>
void put(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <typename T>
T get(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// Arrays are stored as byte planes: byte k of every element, then byte k+1 (an element
// of `elem` bytes). The same bytes, transposed; a compressor then finds the runs that the
// records' neighbouring values share in their high bytes (the prism records of a
// 51 200-triangle mesh: xz -3 takes 22 MiB as they lie in memory, 17 MiB as planes).
void toPlanes(const char* in, size_t bytes, size_t elem, char* out) {
  const size_t n = bytes / elem;
  for (size_t i = 0; i < n; ++i)
    for (size_t k = 0; k < elem; ++k) out[k * n + i] = in[i * elem + k];
}
void fromPlanes(const char* in, size_t bytes, size_t elem, char* out) {
  const size_t n = bytes / elem;
  for (size_t k = 0; k < elem; ++k)
    for (size_t i = 0; i < n; ++i) out[i * elem + k] = in[k * n + i];
}

nlohmann::json vec(const vec3& v) { return {v.x, v.y, v.z}; }
vec3 vec(const nlohmann::json& j) { return vec3(j.at(0).get<float>(), j.at(1).get<float>(), j.at(2).get<float>()); }

}  // namespace

uint64_t checksum64(const void* data, size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  uint64_t h = 0xcbf29ce484222325ULL;
  constexpr uint64_t prime = 0x100000001b3ULL;
  size_t i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = (h ^ w) * prime;
  }
  uint64_t tail = 0;
  if (bytes > i) std::memcpy(&tail, p + i, bytes - i);  // empty arrays may have no data pointer
  h = (h ^ tail) * prime;
  return (h ^ uint64_t(bytes)) * prime;
}

uint64_t writeBake(const std::string& path, const BakedScene& b, const std::string& shown) {
  const std::string& name = shown.empty() ? path : shown;
  const GpuRecords& R = b.records;
  nlohmann::json meta;
  meta["format"] = "oblong baked scene";
  meta["version"] = kBakeVersion;
  meta["sizes"] = {{"TriGpu", sizeof(TriGpu)}, {"MeshGpu", sizeof(MeshGpu)}, {"RayGpu", sizeof(RayGpu)}};
  meta["scene"] = b.scene;
  meta["oblong_version"] = b.version;
  meta["geometry"] = R.geometryName;
  meta["base_triangles"] = R.baseTriangles;
  meta["bytes"] = {{"triangles", R.triBytes}, {"rmip_layers", R.rmipBytes}, {"height_maps", R.texelBytes}};
  meta["camera"] = {{"from", vec(b.camera.from)}, {"to", vec(b.camera.to)}, {"up", vec(b.camera.up)}, {"fov", b.camera.fovY}};
  meta["image"] = {{"width", b.image.x}, {"height", b.image.y}};
  meta["lights"] = nlohmann::json::array();
  for (const Light& l : b.lights)
    meta["lights"].push_back({{"type", l.type == Light::Type::Directional ? "directional" : "point"},
                              {"position", vec(l.position)},
                              {"direction", vec(l.direction)},
                              {"intensity", vec(l.intensity)}});
  meta["albedo"] = nlohmann::json::array();
  for (const vec3& a : b.albedo) meta["albedo"].push_back(vec(a));
  meta["sky"] = vec(b.sky);
  meta["max_depth"] = b.maxDepth;
  const std::string metaText = meta.dump();

  struct Part {
    const char* name;
    const void* data;
    size_t bytes, elem;
  };
  auto part = [](const char* name, const auto& v) {
    const size_t elem = sizeof(typename std::decay_t<decltype(v)>::value_type);
    return Part{name, v.data(), v.size() * elem, elem};
  };
  const Part parts[] = {{"meta", metaText.data(), metaText.size(), 1},
                        part("tris", R.tris),
                        part("meshes", R.meshes),
                        part("mesh_triangles", R.meshTriangles),
                        part("mesh_vertices", R.meshVertices),
                        part("texels", R.texels),
                        part("rmip_words", R.rmipData),
                        part("rmip_layers", R.rmipLayers),
                        part("plain_index", R.plainIndex),
                        part("plain_uv", R.plainUV),
                        part("plain_pos", R.plainPos),
                        part("aabbs", R.aabbs),
                        part("rays", b.rays)};
  const uint32_t n = uint32_t(std::size(parts));
  std::string table;
  uint64_t offset = kHeaderBytes + n * kEntryBytes;
  for (const Part& p : parts) {
    char name[kNameBytes] = {};
    std::strncpy(name, p.name, kNameBytes - 1);
    table.append(name, kNameBytes);
    put(table, offset);
    put(table, uint64_t(p.bytes));
    put(table, checksum64(p.data, p.bytes));
    offset += (p.bytes + 7) / 8 * 8;  // 8-byte aligned sections
  }
  std::string header(kMagic, 8);
  put(header, kBakeVersion);
  put(header, n);
  put(header, offset);
  put(header, checksum64(table.data(), table.size()));
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) fail(name, "cannot open for writing");
  f.write(header.data(), std::streamsize(header.size()));
  f.write(table.data(), std::streamsize(table.size()));
  const char zeros[8] = {};
  std::vector<char> planes;
  for (const Part& p : parts) {
    planes.resize(p.bytes);
    if (p.bytes) toPlanes(static_cast<const char*>(p.data), p.bytes, p.elem, planes.data());
    if (p.bytes) f.write(planes.data(), std::streamsize(p.bytes));
    f.write(zeros, std::streamsize((8 - p.bytes % 8) % 8));
  }
  f.close();
  if (!f) fail(name, "write failed (No space left on device, or the device failed)");
  return offset;
}

BakedScene readBake(const std::string& path) {
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f) fail(path, "cannot open baked scene");
  const auto size = uint64_t(f.tellg());
  f.seekg(0);
  const char* const bake = "bake one with `oblong bake SCENE -o FILE.oblg`";
  char head[kHeaderBytes] = {};
  f.read(head, std::streamsize(std::min<uint64_t>(size, kHeaderBytes)));
  if (size < sizeof kMagic || std::memcmp(head, kMagic, sizeof kMagic) != 0)
    fail(path, "not an oblong baked scene (no OBLGBAKE header); {}", bake);
  if (size < kHeaderBytes) fail(path, "truncated: {} bytes, shorter than the {}-byte header", size, kHeaderBytes);
  const auto version = get<uint32_t>(head + 8), n = get<uint32_t>(head + 12);
  const auto fileBytes = get<uint64_t>(head + 16), tableSum = get<uint64_t>(head + 24);
  if (version != kBakeVersion)
    fail(path, "baked scene format version {}, this program reads version {}; {}", version, kBakeVersion, bake);
  if (size < fileBytes) fail(path, "truncated: {} bytes, the header says {}", size, fileBytes);
  if (size > fileBytes) fail(path, "{} bytes, the header says {}: not one baked scene", size, fileBytes);
  if (n == 0 || n > 1024 || kHeaderBytes + uint64_t(n) * kEntryBytes > size)
    fail(path, "corrupt header: {} sections", n);
  std::string table(size_t(n) * kEntryBytes, '\0');
  f.read(table.data(), std::streamsize(table.size()));
  if (!f || checksum64(table.data(), table.size()) != tableSum) fail(path, "corrupt section table (checksum mismatch)");
  std::map<std::string, Entry> entries;
  for (uint32_t i = 0; i < n; ++i) {
    const char* e = table.data() + size_t(i) * kEntryBytes;
    Entry en{std::string(e, strnlen(e, kNameBytes)), get<uint64_t>(e + 16), get<uint64_t>(e + 24), get<uint64_t>(e + 32)};
    if (en.offset > size || en.bytes > size - en.offset)
      fail(path, "corrupt section '{}': bytes {}..{} beyond the file's {}", en.name, en.offset, en.offset + en.bytes, size);
    entries[en.name] = en;
  }
  auto section = [&](const char* name, auto& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    const auto it = entries.find(name);
    if (it == entries.end()) fail(path, "no section '{}'", name);
    const Entry& e = it->second;
    if (e.bytes % sizeof(T) != 0)
      fail(path, "section '{}': {} bytes is not a whole number of {}-byte elements", name, e.bytes, sizeof(T));
    v.resize(size_t(e.bytes / sizeof(T)));
    std::vector<char> planes(size_t(e.bytes));
    f.seekg(std::streamoff(e.offset));
    if (e.bytes) f.read(planes.data(), std::streamsize(e.bytes));
    if (!f) fail(path, "read error in section '{}'", name);
    if (e.bytes) fromPlanes(planes.data(), size_t(e.bytes), sizeof(T), reinterpret_cast<char*>(v.data()));
    if (checksum64(v.data(), e.bytes) != e.checksum) fail(path, "section '{}' is corrupt (checksum mismatch)", name);
  };
  std::string metaText;
  section("meta", metaText);
  BakedScene b;
  GpuRecords& R = b.records;
  try {
    const nlohmann::json meta = nlohmann::json::parse(metaText);
    const auto& sz = meta.at("sizes");
    if (sz.at("TriGpu").get<size_t>() != sizeof(TriGpu) || sz.at("MeshGpu").get<size_t>() != sizeof(MeshGpu) ||
        sz.at("RayGpu").get<size_t>() != sizeof(RayGpu))
      fail(path, "baked with other GPU record sizes ({}) than this program's; {}", sz.dump(), bake);
    b.scene = meta.at("scene").get<std::string>();
    b.version = meta.value("oblong_version", "");
    R.geometryName = meta.at("geometry").get<std::string>();
    R.baseTriangles = meta.at("base_triangles").get<uint64_t>();
    R.triBytes = meta.at("bytes").at("triangles").get<uint64_t>();
    R.rmipBytes = meta.at("bytes").at("rmip_layers").get<uint64_t>();
    R.texelBytes = meta.at("bytes").at("height_maps").get<uint64_t>();
    const auto& c = meta.at("camera");
    b.camera.from = vec(c.at("from")), b.camera.to = vec(c.at("to")), b.camera.up = vec(c.at("up"));
    b.camera.fovY = c.at("fov").get<float>();
    b.image = ivec2(meta.at("image").at("width").get<int>(), meta.at("image").at("height").get<int>());
    for (const auto& l : meta.at("lights")) {
      Light L;
      L.type = l.at("type").get<std::string>() == "point" ? Light::Type::Point : Light::Type::Directional;
      L.position = vec(l.at("position")), L.direction = vec(l.at("direction")), L.intensity = vec(l.at("intensity"));
      b.lights.push_back(L);
    }
    for (const auto& a : meta.at("albedo")) b.albedo.push_back(vec(a));
    b.sky = vec(meta.at("sky"));
    b.maxDepth = meta.at("max_depth").get<int>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, "corrupt metadata: {}", e.what());
  }
  section("tris", R.tris);
  section("meshes", R.meshes);
  section("mesh_triangles", R.meshTriangles);
  section("mesh_vertices", R.meshVertices);
  section("texels", R.texels);
  section("rmip_words", R.rmipData);
  section("rmip_layers", R.rmipLayers);
  section("plain_index", R.plainIndex);
  section("plain_uv", R.plainUV);
  section("plain_pos", R.plainPos);
  section("aabbs", R.aabbs);
  section("rays", b.rays);
  // The offsets the shaders follow stay inside the arrays (a consistent file).
  const size_t nm = R.meshes.size();
  if (R.meshTriangles.size() != nm || R.meshVertices.size() != nm || b.albedo.size() != nm ||
      R.aabbs.size() != R.tris.size())
    fail(path, "inconsistent sections: {} meshes, {} / {} / {} per-mesh entries, {} prisms, {} boxes", nm,
         R.meshTriangles.size(), R.meshVertices.size(), b.albedo.size(), R.tris.size(), R.aabbs.size());
  for (size_t i = 0; i < nm; ++i) {
    const MeshGpu& m = R.meshes[i];
    const uint64_t nt = R.meshTriangles[i];
    const bool ok = m.displaced ? m.triOffset + nt <= R.tris.size() && m.texelOffset + uint64_t(m.W) * uint64_t(m.H) <=
                                                                            R.texels.size() &&
                                      m.rmipData <= R.rmipData.size() && m.rmipLayers <= R.rmipLayers.size()
                                : m.indexOffset + 3 * nt <= R.plainIndex.size() &&
                                      m.vertexOffset + uint64_t(R.meshVertices[i]) <= R.plainUV.size();
    if (!ok) fail(path, "inconsistent sections: mesh {} points outside the arrays", i);
  }
  return b;
}

}  // namespace oblong::vk
