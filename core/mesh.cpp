#include "core/mesh.h"

#include "core/error.h"
#include "core/input_file.h"
#include "core/mesh_check.h"
#include "core/ply_check.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <glm/gtc/matrix_inverse.hpp>
#include <pthread.h>
#include <sys/stat.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
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
// least one non-degenerate triangle (for them a zero normal is an error), `largest` gives
// each the normal of its own largest triangle.
std::vector<vec3> smoothNormals(const Mesh& m, std::vector<bool>& used, std::vector<vec3>& largest) {
  std::unordered_map<vec3, uint32_t, PositionHash> group;
  std::vector<uint32_t> groupOf(m.positions.size());
  for (size_t v = 0; v < m.positions.size(); ++v)
    groupOf[v] = group.try_emplace(m.positions[v], uint32_t(group.size())).first->second;
  std::vector<dvec3> sum(group.size(), dvec3(0.0)), big(m.positions.size(), dvec3(0.0));
  used.assign(m.positions.size(), false);
  for (const glm::uvec3& f : m.triangles) {
    const dvec3 p0(m.positions[f[0]]), p1(m.positions[f[1]]), p2(m.positions[f[2]]);
    const dvec3 c = glm::cross(p1 - p0, p2 - p0);
    if (c == dvec3(0.0)) continue;
    for (int k = 0; k < 3; ++k) {
      sum[groupOf[f[k]]] += c;
      used[f[k]] = true;
      if (glm::length(c) > glm::length(big[f[k]])) big[f[k]] = c;
    }
  }
  largest.resize(m.positions.size());
  for (size_t v = 0; v < big.size(); ++v) largest[v] = used[v] ? vec3(glm::normalize(big[v])) : vec3(0.0f);
  std::vector<vec3> n(m.positions.size());
  for (size_t v = 0; v < n.size(); ++v) {
    const dvec3 s = sum[groupOf[v]];
    const double l = glm::length(s);
    n[v] = l > 0.0 ? vec3(s / l) : vec3(0.0f);
  }
  return n;
}

// Replaces zero or non-finite normals by smooth ones; errors if that still leaves a
// zero normal on a vertex of a non-degenerate triangle (its triangles' normals cancel)
// of a mesh to be displaced (the normal is the displacement's direction). On a plain
// mesh the normal only shades: such a vertex takes the normal of its largest triangle,
// and the count is returned (an exported micro-mesh has them where slivers along a base
// triangle's edge fold back on each other). Vertices only used by degenerate triangles
// get +z: those triangles are never displaced (prepare() rejects them), the normal just
// has to be unit length.
size_t fixNormals(Mesh& m, bool displaced = true) {
  std::vector<size_t> bad;
  for (size_t v = 0; v < m.normals.size(); ++v)
    if (isZeroOrBad(m.normals[v])) bad.push_back(v);
    else m.normals[v] = glm::normalize(m.normals[v]);
  if (bad.empty()) return 0;
  std::vector<bool> used;
  std::vector<vec3> largest;
  const std::vector<vec3> smooth = smoothNormals(m, used, largest);
  size_t cancelled = 0;
  for (size_t v : bad) {
    if (!isZeroOrBad(smooth[v])) {
      m.normals[v] = smooth[v];
    } else if (!used[v]) {
      m.normals[v] = vec3(0.0f, 0.0f, 1.0f);
    } else if (!displaced && !isZeroOrBad(largest[v])) {
      m.normals[v] = largest[v];
      ++cancelled;
    } else {
      const vec3& p = m.positions[v];
      fail(m.name, "vertex {} at ({}, {}, {}) has a zero normal (the normals of its triangles cancel)", v, p.x,
           p.y, p.z);
    }
  }
  return cancelled;
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

// Every file a mesh pulls in (an OBJ's material library, a glTF's buffers) goes through
// this: one that exists but is not a regular file is refused, since assimp's fopen would
// block on a FIFO (in Exists as well as Open) and read a device forever. The refusal is
// kept for loadMesh to report; missing files are left to assimp as before.
class RegularFilesOnly : public Assimp::DefaultIOSystem {
 public:
  bool Exists(const char* file) const override { return allowed(file) && DefaultIOSystem::Exists(file); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    Assimp::IOStream* s = allowed(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
    if (s && std::find(opened_.begin(), opened_.end(), file) == opened_.end()) opened_.emplace_back(file);
    return s;
  }
  const std::string& refused() const { return refused_; }
  const std::vector<std::string>& opened() const { return opened_; }

 private:
  bool allowed(const char* file) const {
    struct stat st;
    if (!file || ::stat(file, &st) != 0 || S_ISREG(st.st_mode)) return true;
    if (refused_.empty()) refused_ = file;
    return false;
  }
  mutable std::string refused_;
  std::vector<std::string> opened_;
};

// assimp recurses once per level of a file's nesting (checkMeshNesting bounds the levels
// of the formats it can measure). The load runs on a thread of its own with a stack that
// holds kMaxMeshNesting levels many times over, whichever thread calls and however large
// the sanitizers make the frames.
constexpr size_t kLoaderStack = size_t(64) << 20;

template <typename F>
auto onLargeStack(F&& f) -> decltype(f()) {
  using R = decltype(f());
  struct Job {
    F* f;
    std::optional<R> result;
    std::exception_ptr error;
  } job{&f, {}, {}};
  void* (*run)(void*) = [](void* p) -> void* {
    Job& j = *static_cast<Job*>(p);
    try {
      j.result.emplace((*j.f)());
    } catch (...) {
      j.error = std::current_exception();
    }
    return nullptr;
  };
  pthread_attr_t attr;
  pthread_t thread;
  bool started = pthread_attr_init(&attr) == 0;
  if (started) {
    started = pthread_attr_setstacksize(&attr, kLoaderStack) == 0 && pthread_create(&thread, &attr, run, &job) == 0;
    pthread_attr_destroy(&attr);
  }
  if (!started) return f();  // no thread to be had: load on this one
  pthread_join(thread, nullptr);
  if (job.error) std::rethrow_exception(job.error);
  return std::move(*job.result);
}

// recentreMesh over the triangles whose `skip` entry is 0 (all of them: skip null).
void recentre(Mesh& m, const std::vector<uint8_t>* skip) {
  dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (size_t i = 0; i < m.triangles.size(); ++i)
    if (!skip || !(*skip)[i])
      for (int c = 0; c < 3; ++c) {
        const dvec3 w = m.world(m.triangles[i][c]);
        lo = glm::min(lo, w), hi = glm::max(hi, w);
      }
  if (!(lo.x <= hi.x)) return;
  // min and max move exactly with the mesh, and so does their mean wherever it is exact
  // in double (float coordinates: whenever lo and hi are within a factor 2^29 of each
  // other, or one is 0). Not rounded to float: a float centre rounds differently at
  // different offsets, and the positions with it.
  const dvec3 centre = 0.5 * (lo + hi);
  for (vec3& p : m.positions) p = roundToFloat(m.origin + dvec3(p) - centre);
  m.origin = centre;
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
  // The translation goes to the frame's origin (in double), not into the positions: a
  // mesh moved far away keeps the float positions (and so the micro-geometry) it has at
  // the origin.
  const vec3 translation(transform[3]);
  if (!std::isfinite(translation.x) || !std::isfinite(translation.y) || !std::isfinite(translation.z))
    fail(m.name, "transform produces a non-finite position");
  for (vec3& p : m.positions) {
    p = l * p;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      fail(m.name, "transform produces a non-finite position");
  }
  m.origin += dvec3(translation);
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
  const size_t cancelled = fixNormals(m, opts.needUVs);
  if (cancelled > 0 && opts.warn)
    eprint("oblong: warning: {}: {} vertices whose triangles' normals cancel are shaded with the normal of their "
           "largest triangle\n",
           m.name, cancelled);
  if (opts.transform != glm::mat4(1.0f)) transformMesh(m, opts.transform);
  // The frame comes before the float checks, which must see the positions the renderer
  // uses (rounded into the frame). Its box is over the triangles the exact test kept:
  // which ones the float checks drop depends on the frame, and the frame must depend on
  // the mesh only, not on where it sits.
  recentre(m, &why);

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
      const vec3 p(m.world(f[c]));
      if (!(std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) <= kMaxCoordinate))
        fail(m.name, "vertex {} at ({}, {}, {}){} lies beyond the supported coordinate range (|x|, |y|, |z| <= 2^40 = "
                     "{:.4g})",
             f[c], p.x, p.y, p.z, opts.transform != glm::mat4(1.0f) ? " after the transform" : "", kMaxCoordinate);
    }
  if (skipped > 0 && opts.warn)
    eprint("oblong: warning: {}: skipped {} of {} triangles as degenerate ({}; first: triangle {})\n",
               m.name, skipped, total, detail, first);
}

void recentreMesh(Mesh& m) { recentre(m, nullptr); }

namespace {

Mesh loadMeshHere(const std::string& path, const MeshLoadOptions& opts) {
  Assimp::Importer importer;
  auto* io = new RegularFilesOnly;
  importer.SetIOHandler(io);  // the importer owns it
  const PlyCheck ply = checkPly(path, importer);
  checkMeshNesting(path, importer);
  checkMeshCounts(path, importer);
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
  if (!io->refused().empty()) fail(path, "{}: not a regular file", io->refused());
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
  for (const std::string& f : io->opened())
    if (!sameFile(f, path)) m.files.push_back(f);
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

}  // namespace

Mesh loadMesh(const std::string& path, const MeshLoadOptions& opts) {
  checkInputFile(path);
  return onLargeStack([&] { return loadMeshHere(path, opts); });
}

}  // namespace oblong
