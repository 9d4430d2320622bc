#include "render/mesh_export.h"

#include "core/error.h"
#include "core/memory.h"
#include "core/microgeometry.h"
#include "render/output.h"
#include "render/tessellation.h"

#include <fcntl.h>
#include <unistd.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

namespace oblong {

// The records are written as the machine stores them.
static_assert(std::endian::native == std::endian::little, "the PLY body is written in the host's byte order");

namespace {

namespace fs = std::filesystem;

// Micro-triangles computed in parallel and written in order, at most this many at a
// time (60 bytes each); a base triangle with more is written as it is computed.
constexpr size_t kChunkTriangles = size_t(1) << 20;
constexpr size_t kMaxVertices = UINT32_MAX;  // PLY indices are uint32

// Header text must stay one line per comment.
std::string oneLine(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return s;
}

std::string lodText(const Displacement& d) {
  return d.lod == 0.0f && !d.level0 ? std::string("full resolution") : fmt::format("level of detail {:g}", d.lod);
}

// Buffered writes to a file descriptor, each checked; errors name the output.
class Writer {
 public:
  Writer(const std::string& file, const std::string& shown) : shown_(shown) {
    fd_ = ::open(file.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd_ < 0) fail(shown_, "cannot open for writing ({})", std::strerror(errno));
    buf_.reserve(kBuffer);
  }
  ~Writer() {
    if (fd_ >= 0) ::close(fd_);
  }
  void put(const void* data, size_t n) {
    const char* p = static_cast<const char*>(data);
    if (n >= kBuffer) {  // large blocks go out as they are
      flush();
      raw(p, n);
      return;
    }
    buf_.insert(buf_.end(), p, p + n);
    if (buf_.size() >= kBuffer) flush();
  }
  void flush() {
    raw(buf_.data(), buf_.size());
    buf_.clear();
  }
  void close() {
    flush();
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail(shown_, "write failed on close ({})", std::strerror(errno));
  }

 private:
  void raw(const char* p, size_t n) {
    while (n > 0) {
      const ssize_t w = ::write(fd_, p, n);
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) fail(shown_, "write failed ({})", w < 0 ? std::strerror(errno) : "no progress");
      p += w, n -= size_t(w);
    }
  }
  static constexpr size_t kBuffer = size_t(1) << 22;
  std::string shown_;
  int fd_ = -1;
  std::vector<char> buf_;
};

// One vertex record: x y z u v.
void putVertex(float* out, const vec3& p, const vec2& uv) {
  out[0] = p.x, out[1] = p.y, out[2] = p.z, out[3] = uv.x, out[4] = uv.y;
}

// Returns whether the float world positions merged two vertices distinct in the frame.
bool putMicro(float* out, const Mesh& mesh, const MicroTriangle& m) {
  vec3 w[3];
  for (int k = 0; k < 3; ++k) putVertex(out + 5 * k, w[k] = worldFloat(mesh, m.v[k].p), m.v[k].uv);
  for (int k = 0; k < 3; ++k) {
    const int l = (k + 1) % 3;
    if (w[k] == w[l] && m.v[k].p != m.v[l].p) return true;
  }
  return false;
}

struct Interrupted {};

void checkInterrupt(const std::atomic<bool>* interrupt) {
  if (interrupt && interrupt->load()) throw Interrupted{};
}

// The micro-triangles of one displaced mesh, base triangle by base triangle.
size_t writeDisplaced(Writer& w, const SceneMesh& sm, const ExportPlan::Part& part, const std::string& where,
                      const std::atomic<bool>* interrupt) {
  std::atomic<size_t> merged{0};
  const Mesh& mesh = sm.mesh;
  const Displacement& d = *sm.displacement;
  const std::vector<size_t>& counts = part.perTriangle;
  std::vector<float> chunk;
  std::vector<size_t> offset;
  auto mismatch = [&](size_t ti, size_t got) {
    fail(where, "internal error: base triangle {} has {} micro-triangles, {} were counted", ti, got, counts[ti]);
  };
  for (size_t a = 0; a < counts.size();) {
    checkInterrupt(interrupt);
    if (counts[a] > kChunkTriangles) {  // written as it is computed
      size_t n = 0;
      float rec[15];
      forEachMicroTriangle(mesh.triangle(a), d, [&](const MicroTriangle& m) {
        if ((n & (kChunkTriangles - 1)) == 0) checkInterrupt(interrupt);
        if (putMicro(rec, mesh, m)) merged.fetch_add(1, std::memory_order_relaxed);
        w.put(rec, sizeof rec);
        ++n;
      });
      if (n != counts[a]) mismatch(a, n);
      ++a;
      continue;
    }
    size_t b = a, total = 0;
    offset.clear();
    while (b < counts.size() && counts[b] <= kChunkTriangles && total + counts[b] <= kChunkTriangles)
      offset.push_back(total), total += counts[b++];
    chunk.resize(total * 15);
    std::vector<size_t> got(b - a, 0);
    tbb::parallel_for(a, b, [&](size_t ti) {
      float* out = chunk.data() + offset[ti - a] * 15;
      size_t& n = got[ti - a];
      forEachMicroTriangle(mesh.triangle(ti), d, [&](const MicroTriangle& m) {
        if (n < counts[ti] && putMicro(out + 15 * n, mesh, m)) merged.fetch_add(1, std::memory_order_relaxed);
        ++n;
      });
    });
    for (size_t ti = a; ti < b; ++ti)
      if (got[ti - a] != counts[ti]) mismatch(ti, got[ti - a]);
    w.put(chunk.data(), chunk.size() * sizeof(float));
    a = b;
  }
  return merged.load();
}

void writePlain(Writer& w, const Mesh& mesh) {
  float rec[15];
  for (const glm::uvec3& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k)
      putVertex(rec + 5 * k, worldFloat(mesh, mesh.positions[t[k]]), mesh.hasUVs() ? mesh.uvs[t[k]] : vec2(0.0f));
    w.put(rec, sizeof rec);
  }
}

// Where the output's bytes go first: the output's folder, or for a device the temporary
// folder (render/output.h writes through from a copy there).
fs::path stagingFolder(const std::string& path, bool& device) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  device = fs::exists(st) && !fs::is_regular_file(st) && !fs::is_directory(st);
  if (device) {
    const fs::path t = fs::temp_directory_path(ec);
    return ec ? fs::path("/tmp") : t;
  }
  const fs::path target = fs::exists(st) ? fs::canonical(path, ec) : fs::absolute(path, ec);
  return ec || !fs::path(target).has_parent_path() ? fs::path(".") : fs::path(target).parent_path();
}

}  // namespace

ExportPlan planExport(const Scene& scene) {
  ExportPlan plan;
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const SceneMesh& sm = scene.meshes[mi];
    ExportPlan::Part part;
    part.mesh = int(mi);
    part.displaced = sm.displacement.has_value();
    if (part.displaced) {
      part.perTriangle = microTriangleCounts(sm.mesh, *sm.displacement);
      for (size_t n : part.perTriangle) part.triangles += n;
      plan.microTriangles += part.triangles;
      ++plan.displacedMeshes;
    } else {
      part.triangles = sm.mesh.triangles.size();
      plan.plainTriangles += part.triangles;
      ++plan.plainMeshes;
    }
    plan.triangles += part.triangles;
    plan.parts.push_back(std::move(part));
  }
  return plan;
}

std::string exportHeader(const Scene& scene, const ExportPlan& plan) {
  std::string h = "ply\nformat binary_little_endian 1.0\n";
  h += oneLine(fmt::format("comment oblong export of {}: world coordinates, 3 vertices per triangle", scene.path)) + "\n";
  for (const ExportPlan::Part& p : plan.parts) {
    const SceneMesh& sm = scene.meshes[size_t(p.mesh)];
    h += oneLine(p.displaced ? fmt::format("comment meshes[{}]: {} micro-triangles of {} ({}, map {})", p.mesh,
                                           p.triangles, sm.mesh.name, lodText(*sm.displacement),
                                           sm.displacement->map->name())
                             : fmt::format("comment meshes[{}]: {} triangles of {} (plain)", p.mesh, p.triangles,
                                           sm.mesh.name)) +
         "\n";
  }
  h += fmt::format("element vertex {}\n", plan.vertices());
  h += "property float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\n";
  h += fmt::format("element face {}\n", plan.triangles);
  h += "property list uchar uint vertex_indices\nend_header\n";
  return h;
}

void checkExportFits(const Scene& scene, const ExportPlan& plan, const std::string& path) {
  const std::string what = fmt::format(
      "{} micro-triangles in {} displaced mesh{}{}", plan.microTriangles, plan.displacedMeshes,
      plan.displacedMeshes == 1 ? "" : "es",
      plan.plainMeshes ? fmt::format(" and {} triangles in {} plain mesh{}", plan.plainTriangles, plan.plainMeshes,
                                     plan.plainMeshes == 1 ? "" : "es")
                       : "");
  // What would fit: each level of detail has about a quarter of the micro-triangles of
  // the one below (up to each map's last level).
  float lod = 0.0f;
  for (const SceneMesh& sm : scene.meshes)
    if (sm.displacement) lod = std::max(lod, sm.displacement->lod);
  auto coarser = [&](double factor) {
    if (plan.microTriangles == 0) return std::string("export fewer or smaller meshes");
    const double levels = std::ceil(std::log(factor) / std::log(4.0));
    return fmt::format("a coarser level of detail has about 4x fewer micro-triangles per level: try --lod {:g}",
                       std::floor(lod) + std::max(1.0, levels));
  };
  if (plan.vertices() > kMaxVertices)
    fail(scene.path, "the export needs {} vertices ({}, 3 each), more than a PLY file's uint32 indices address ({}); {}",
         plan.vertices(), what, kMaxVertices, coarser(double(plan.vertices()) / double(kMaxVertices)));
  const size_t bytes = exportHeader(scene, plan).size() + plan.bodyBytes();
  bool device = false;
  const fs::path folder = stagingFolder(path, device);
  std::error_code ec;
  const fs::space_info space = fs::space(folder, ec);
  if (!ec && bytes > space.available)
    fail(scene.path, "the export needs {} ({}, {} bytes each) but folder '{}' has {} free; {}, or write elsewhere",
         humanBytes(bytes), what, ExportPlan::kBytesPerTriangle, folder.string(), humanBytes(space.available),
         coarser(double(bytes) / double(std::max<uintmax_t>(1, space.available))));
  // A device is written through from a copy read back into memory (render/output.h).
  if (device)
    checkFits(scene.path, fmt::format("writing the export through to {}", path), bytes,
              coarser(double(bytes) / double(std::max<size_t>(1, structureBudgetBytes()))) +
                  ", or write to a file",
              what);
}

std::string exportMergedWarning(const std::string& path, const ExportPlan& plan, const ExportMerged& merged) {
  if (merged.triangles == 0) return "";
  return fmt::format(
      "warning: {}: float world positions merge vertices of {} of {} micro-triangles (meshes[{}] reaches {:.3g}, "
      "where floats are {:g} apart): the file is coarser than the surface oblong traces in the mesh's frame; move "
      "the scene nearer the origin to export it",
      path, merged.triangles, plan.microTriangles, merged.mesh, merged.farthest, merged.spacing);
}

bool writeExport(const Scene& scene, const ExportPlan& plan, const std::string& path,
                 const std::atomic<bool>* interrupt, ExportMerged* merged) {
  ExportMerged found;
  try {
    writeOutput(path, [&](const std::string& tmp) {
      found = ExportMerged{};
      Writer w(tmp, path);
      const std::string header = exportHeader(scene, plan);
      w.put(header.data(), header.size());
      for (const ExportPlan::Part& p : plan.parts) {
        const SceneMesh& sm = scene.meshes[size_t(p.mesh)];
        if (p.displaced) {
          const size_t n = writeDisplaced(w, sm, p, fmt::format("{}: meshes[{}]", scene.path, p.mesh), interrupt);
          if (n > 0 && found.triangles == 0) {
            found.mesh = p.mesh;
            for (size_t v = 0; v < sm.mesh.positions.size(); ++v) {
              const dvec3 x = glm::abs(sm.mesh.world(v));
              found.farthest = std::max({found.farthest, x.x, x.y, x.z});
            }
            const float f = float(found.farthest);
            found.spacing = double(std::nextafter(f, kInfinity)) - double(f);
          }
          found.triangles += n;
        } else
          writePlain(w, sm.mesh);
      }
      // Triangle k is vertices 3k, 3k+1, 3k+2.
      unsigned char face[ExportPlan::kFaceBytes];
      face[0] = 3;
      for (size_t k = 0; k < plan.triangles; ++k) {
        if ((k & 0xFFFFF) == 0) checkInterrupt(interrupt);
        const uint32_t v[3] = {uint32_t(3 * k), uint32_t(3 * k + 1), uint32_t(3 * k + 2)};
        std::memcpy(face + 1, v, sizeof v);
        w.put(face, sizeof face);
      }
      w.close();
    });
  } catch (const Interrupted&) {
    return false;
  }
  if (merged) *merged = found;
  return true;
}

}  // namespace oblong
