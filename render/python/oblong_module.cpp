// The Python module `oblong` (docs/python.md): scenes loaded, rendered and traced through
// the command line's own steps (render/program.h, render/renderer.h, render/report.h,
// render/scene_info.h), so that the module accepts what `oblong` accepts, returns the
// same hits and fails with the same messages (oblong.Error, a ValueError). Arrays come
// back as numpy arrays; the GIL is released while a scene loads, builds, renders or
// traces.
#include "oblong_version.h"

#include "core/error.h"
#include "core/scene.h"
#include "core/stats.h"
#include "render/program.h"
#include "render/rays_io.h"
#include "render/renderer.h"
#include "render/report.h"
#include "render/scene_info.h"
#include "traversal/strategy_catalog.h"

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace py = pybind11;
using namespace oblong;

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// JSON (the --stats and info objects) as Python dicts, lists and numbers.
py::object toPython(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// A Python value as JSON, for load_dict. Far deeper than a scene may be (parseScene
// refuses it with its own message), the rest is cut off (null) to bound the recursion.
constexpr size_t kCutDepth = 1000;
nlohmann::json toJson(const py::handle& v, const std::string& path, const std::string& at, size_t depth) {
  if (depth > kCutDepth) return nullptr;
  const std::string where = path + (at.empty() ? "" : ": " + at);
  if (v.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::dict>(v)) {
    nlohmann::json o = nlohmann::json::object();
    for (const auto& [k, e] : v.cast<py::dict>()) {
      if (!py::isinstance<py::str>(k))
        fail(where, "a key that is not a string: {} (a scene is a JSON object)", py::repr(k).cast<std::string>());
      const std::string key = k.cast<std::string>();
      o[key] = toJson(e, path, at.empty() ? key : at + "." + key, depth + 1);
    }
    return o;
  }
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    nlohmann::json a = nlohmann::json::array();
    size_t i = 0;
    for (const auto& e : v) a.push_back(toJson(e, path, fmt::format("{}[{}]", at, i++), depth + 1));
    return a;
  }
  // Integers first (Python's and numpy's: __index__), then anything with __float__.
  if (py::hasattr(v, "__index__")) {
    const py::int_ i = py::reinterpret_steal<py::int_>(PyNumber_Index(v.ptr()));
    if (!i) throw py::error_already_set();
    if (i >= py::int_(0)) return i.cast<uint64_t>();
    return i.cast<int64_t>();
  }
  if (py::hasattr(v, "__float__")) return v.cast<double>();
  fail(where, "not a JSON value: {}", py::repr(v).cast<std::string>());
}

// A string flag as the command line reads it: an empty value is a mistake, not "unset".
std::string flagText(const py::object& v, const char* flag) {
  if (v.is_none()) return {};
  const std::string s = py::str(v).cast<std::string>();
  if (s.empty()) fail(flag, "empty value");
  return s;
}

StrategyFlags strategyFlags(const py::object& range, const py::object& inverter, const py::object& splitter,
                            const py::object& baseline, const py::object& marchingScale,
                            const py::object& inversionInTraversal, const py::object& step, const py::object& lod,
                            const py::object& lodBias) {
  StrategyFlags f;
  f.range = flagText(range, "--range");
  f.inverter = flagText(inverter, "--inverter");
  f.splitter = flagText(splitter, "--splitter");
  f.baseline = flagText(baseline, "--baseline");
  if (!marchingScale.is_none()) f.marchingScale = marchingScale.cast<double>();
  if (!inversionInTraversal.is_none()) f.inversionInTraversal = inversionInTraversal.cast<bool>();
  if (!step.is_none()) f.step = step.cast<double>();
  f.lod = flagText(lod, "--lod");
  if (!lodBias.is_none()) f.lodBias = lodBias.cast<float>();
  return f;
}

// A loaded scene; every render or trace builds its own structures for the strategies it
// is given (as one command line run does).
struct PyScene {
  std::shared_ptr<const Scene> scene;
  double loadSeconds = 0;

  // The scene a call traces: the loaded one, or a copy at the level of detail asked for.
  std::shared_ptr<const Scene> forCall(const StrategyFlags& flags, const std::string& perRay) const {
    if (!flags.changesLod()) {
      flags.checkLod(*scene, perRay);
      return scene;
    }
    auto copy = std::make_shared<Scene>(*scene);
    flags.applyLod(*copy, perRay);
    return copy;
  }
};

PyScene loadFrom(const std::function<Scene()>& load) {
  PyScene s;
  const auto start = Clock::now();
  {
    py::gil_scoped_release nogil;
    s.scene = std::make_shared<const Scene>(load());
  }
  s.loadSeconds = secondsSince(start);
  return s;
}

template <typename T>
py::array_t<T> array(std::vector<py::ssize_t> shape, const T* data) {
  py::array_t<T> a(shape);
  std::memcpy(a.mutable_data(), data, size_t(a.size()) * sizeof(T));
  return a;
}

py::array_t<float> image(const std::vector<float>& v, int w, int h) { return array<float>({h, w}, v.data()); }

// An n×3 array of rays' origins or directions.
py::array_t<double, py::array::c_style | py::array::forcecast> vectors(const py::object& v, const char* name) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
  if (!a) fail(name, "expected an array of shape (n, 3) of numbers");
  if (a.ndim() != 2 || a.shape(1) != 3) {
    std::string shape;
    for (py::ssize_t k = 0; k < a.ndim(); ++k) shape += fmt::format("{}{}", k ? ", " : "", a.shape(k));
    if (a.ndim() == 1) shape += ",";
    fail(name, "expected an array of shape (n, 3), got shape ({})", shape);
  }
  return a;
}

// tmin or tmax: one number for every ray, or one per ray.
std::vector<double> perRay(const py::object& v, const char* name, size_t n) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
  if (!a) fail(name, "expected a number or an array of shape (n,)");
  if (a.ndim() == 0) return std::vector<double>(n, *a.data());
  if (a.ndim() != 1 || size_t(a.shape(0)) != n)
    fail(name, "expected a number or an array of shape ({},), got {} dimension(s) of {} value(s)", n, a.ndim(),
         a.size());
  return std::vector<double>(a.data(), a.data() + n);
}

constexpr const char* kStrategyDoc = R"(
Strategy keywords (each as the command line's flag of the same name; None keeps the
scene's choice): range, inverter, splitter (names from range_queries(), inverters(),
splitters()), baseline (a name from baselines()), marching_scale, inversion_in_traversal,
step, lod ("off", "cone" or a number), lod_bias. device: "cpu" (Embree) or "vulkan".
threads: worker threads, 0 for all cores (--threads).)";

}  // namespace

PYBIND11_MODULE(oblong, m) {
  m.doc() =
      "oblong: ray tracing displaced triangle meshes without tessellation (docs/python.md).\n\n"
      "load(path) / load_dict(d) give a Scene; scene.render(...) and scene.trace(...) return\n"
      "dicts of numpy arrays and the --stats object; bad input raises oblong.Error with the\n"
      "command line's message.";
  m.attr("__version__") = OBLONG_VERSION;
  py::register_exception<Error>(m, "Error", PyExc_ValueError);

  m.def("range_queries", [] { return strategyNames(StrategyKind::Range); },
        "The registered range queries (what range= accepts).");
  m.def("inverters", [] { return strategyNames(StrategyKind::Inverter); },
        "The registered inverters (what inverter= accepts).");
  m.def("splitters", [] { return strategyNames(StrategyKind::Splitter); },
        "The registered splitters (what splitter= accepts).");
  m.def("baselines", [] { return baselineNames(); }, "The registered baselines (what baseline= accepts).");
  m.def("strategies", [] { return toPython(strategiesJson()); },
        "Every registered strategy with its summary and traits, as `oblong info --strategies --json`.");

  py::class_<PyScene>(m, "Scene", "A loaded scene (oblong.load, oblong.load_dict).")
      .def_property_readonly("path", [](const PyScene& s) { return s.scene->path; },
                             "The file it came from (\"<default>\" for the built-in scene).")
      .def_property_readonly("load_seconds", [](const PyScene& s) { return s.loadSeconds; })
      .def(
          "info",
          [](const PyScene& s, const py::object& range, const py::object& lod, bool text) {
            StrategyFlags flags;
            flags.range = flagText(range, "--range");
            flags.lod = flagText(lod, "--lod");
            nlohmann::json info;
            {
              py::gil_scoped_release nogil;
              const std::shared_ptr<const Scene> scene = s.forCall(flags, "");
              info = sceneInfo(*scene, flags.resolve(*scene).traversal);
            }
            if (text) return py::object(py::str(sceneInfoText(info)));
            return toPython(info);
          },
          py::arg("range") = py::none(), py::arg("lod") = py::none(), py::arg("text") = false,
          "What `oblong info [--range R] [--lod L]` prints, as a dict (scene, meshes: per mesh its size,\n"
          "map, needs, level of detail, the range query's describe() or the baseline, prisms and\n"
          "memory; displaced_meshes, total_bytes, peak_memory), or with text=True the printed text.")
      .def(
          "render",
          [](const PyScene& s, const py::object& size, int spp, const std::string& integrator, int maxDepth,
             const std::string& normals, const py::object& seed, int threads, const std::string& device,
             const py::object& range, const py::object& inverter, const py::object& splitter,
             const py::object& baseline, const py::object& marchingScale, const py::object& inversionInTraversal,
             const py::object& step, const py::object& lod, const py::object& lodBias) {
            const auto start = Clock::now();
            RenderFlags rf;
            if (!size.is_none() && !py::isinstance<py::str>(size)) {
              const auto wh = size.cast<std::vector<int64_t>>();
              if (wh.size() != 2) fail("--size", "expected (width, height), got {} values", wh.size());
              rf.size = fmt::format("{}x{}", wh[0], wh[1]);
            } else {
              rf.size = size.is_none() ? "" : flagText(size, "--size");
            }
            rf.spp = spp;
            rf.integrator = integrator;
            rf.maxDepth = maxDepth;
            rf.normals = normals;
            rf.seed = flagText(seed, "--seed");
            rf.threads = threads;
            const StrategyFlags flags = strategyFlags(range, inverter, splitter, baseline, marchingScale,
                                                      inversionInTraversal, step, lod, lodBias);
            RenderOptions opts = rf.options();
            std::shared_ptr<const Scene> scene;
            std::unique_ptr<TraceBackend> backend;
            AccelOptions accel;
            RenderResult res;
            nlohmann::json stats;
            {
              py::gil_scoped_release nogil;
              scene = s.forCall(flags, "");
              accel = flags.resolve(*scene);
              // Every AOV comes back as an array: a copy of each buffer.
              rf.sizeFor(*scene, opts, 44);
              Stats::reset();
              backend = makeBackend(*scene, accel, device, &opts);
              warnBoxOnly(*scene, *backend);
              res = render(*scene, *backend, opts);
              const RenderReport report{*scene, accel, *backend, opts, res, "", "", false, {}};  // no heat map
              stats = renderStats(report, {OBLONG_VERSION, threads, s.loadSeconds,
                                           s.loadSeconds + secondsSince(start)});
            }
            const AOVs& a = res.aov;
            const int w = a.color.width, h = a.color.height;
            py::dict out;
            out["color"] = array<float>({h, w, 3}, &a.color.pixels[0].x);
            out["depth"] = image(a.depth, w, h);
            out["normal"] = array<float>({h, w, 3}, &a.normal[0].x);
            out["steps"] = image(a.steps, w, h);
            out["range_queries"] = image(a.rangeQueries, w, h);
            out["inversions"] = image(a.inversions, w, h);
            out["cells_marched"] = image(a.cellsMarched, w, h);
            out["stats"] = toPython(stats);
            return out;
          },
          py::kw_only(), py::arg("size") = py::none(), py::arg("spp") = 1, py::arg("integrator") = "path",
          py::arg("max_depth") = 5, py::arg("normals") = "micro", py::arg("seed") = 0, py::arg("threads") = 0,
          py::arg("device") = "cpu", py::arg("range") = py::none(), py::arg("inverter") = py::none(),
          py::arg("splitter") = py::none(), py::arg("baseline") = py::none(), py::arg("marching_scale") = py::none(),
          py::arg("inversion_in_traversal") = py::none(), py::arg("step") = py::none(), py::arg("lod") = py::none(),
          py::arg("lod_bias") = py::none(),
          (std::string("Renders the scene as `oblong render` does and returns a dict of arrays, h×w for an\n"
                       "image of width w and height h:\n"
                       "  color (h, w, 3) float32, linear RGB; depth (h, w) float32, t of the first hit (inf:\n"
                       "  miss); normal (h, w, 3) float32 (0: miss); steps, range_queries, inversions,\n"
                       "  cells_marched (h, w) float32, the camera rays' counters averaged over the samples;\n"
                       "  stats: the --stats object (dict).\n"
                       "size: \"WxH\" or (w, h), default the scene's; spp, integrator (primary | ao | path),\n"
                       "max_depth, normals (micro | smooth), seed (an integer in [0, 2^64)) as the command line's\n"
                       "flags.") +
           kStrategyDoc)
              .c_str())
      .def(
          "trace",
          [](const PyScene& s, const py::object& origins, const py::object& directions, const py::object& tmin,
             const py::object& tmax, int threads, const std::string& device, const py::object& range,
             const py::object& inverter, const py::object& splitter, const py::object& baseline,
             const py::object& marchingScale, const py::object& inversionInTraversal, const py::object& step,
             const py::object& lod, const py::object& lodBias) {
            const auto start = Clock::now();
            if (threads < 0) fail("--threads", "must be >= 0, got {}", threads);
            const auto o = vectors(origins, "origins");
            const auto d = vectors(directions, "directions");
            const size_t n = size_t(o.shape(0));
            if (size_t(d.shape(0)) != n) fail("directions", "{} directions for {} origins", d.shape(0), n);
            const std::vector<double> t0 = perRay(tmin, "tmin", n), t1 = perRay(tmax, "tmax", n);
            const StrategyFlags flags = strategyFlags(range, inverter, splitter, baseline, marchingScale,
                                                      inversionInTraversal, step, lod, lodBias);
            std::vector<Ray> rays(n);
            for (size_t i = 0; i < n; ++i) {
              const double* oi = o.data(i, 0);
              const double* di = d.data(i, 0);
              rays[i] = Ray{vec3(float(oi[0]), float(oi[1]), float(oi[2])),
                            vec3(float(di[0]), float(di[1]), float(di[2])), float(t0[i]), float(t1[i])};
              checkRay(rays[i], fmt::format("ray {}", i));
            }
            std::vector<RayCounters> work;
            TraceResult res;
            nlohmann::json stats;
            {
              py::gil_scoped_release nogil;
              const std::shared_ptr<const Scene> scene = s.forCall(flags, "a rays file carries no ray cones");
              const AccelOptions accel = flags.resolve(*scene);
              Stats::reset();
              const std::unique_ptr<TraceBackend> backend = makeBackend(*scene, accel, device);
              warnBoxOnly(*scene, *backend);
              res = traceRays(*backend, rays, threads, nullptr, &work);
              const TraceReport report{*scene, accel, *backend, res, "", "", false};
              stats = traceStats(report, {OBLONG_VERSION, threads, s.loadSeconds, s.loadSeconds + secondsSince(start)});
            }
            const py::ssize_t N = py::ssize_t(n);
            py::array_t<float> t(N), uv({N, py::ssize_t(2)});
            py::array_t<int32_t> mesh(N), prim(N);
            auto tv = t.mutable_unchecked<1>();
            auto uvv = uv.mutable_unchecked<2>();
            auto mv = mesh.mutable_unchecked<1>();
            auto pv = prim.mutable_unchecked<1>();
            py::array_t<int64_t> counters[7] = {py::array_t<int64_t>(N), py::array_t<int64_t>(N),
                                                py::array_t<int64_t>(N), py::array_t<int64_t>(N),
                                                py::array_t<int64_t>(N), py::array_t<int64_t>(N),
                                                py::array_t<int64_t>(N)};
            int64_t* c[7];
            for (int k = 0; k < 7; ++k) c[k] = counters[k].mutable_data();
            for (py::ssize_t i = 0; i < N; ++i) {
              const Hit& h = res.hits[size_t(i)];
              // A miss as the hits file writes it: t inf, no mesh, no primitive.
              tv(i) = h.valid() ? h.t : kInfinity;
              mv(i) = h.valid() ? h.mesh : -1;
              pv(i) = h.valid() ? h.prim : -1;
              uvv(i, 0) = h.valid() ? h.uv.x : 0.0f;
              uvv(i, 1) = h.valid() ? h.uv.y : 0.0f;
              const RayCounters& w = work[size_t(i)];
              c[0][i] = w.boxes, c[1][i] = w.rangeQueries, c[2][i] = w.inversions, c[3][i] = w.cellsMarched;
              c[4][i] = w.microTriangles, c[5][i] = w.prisms, c[6][i] = w.steps();
            }
            py::dict out;
            out["t"] = t;
            out["mesh"] = mesh;
            out["prim"] = prim;
            out["uv"] = uv;
            // The names of the --stats ray_counters, per ray.
            const char* names[7] = {"boxes", "range_queries", "inversions", "cells_marched",
                                    "micro_triangles", "prisms", "steps"};
            for (int k = 0; k < 7; ++k) out[names[k]] = counters[k];
            out["stats"] = toPython(stats);
            return out;
          },
          py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
          py::arg("tmax") = std::numeric_limits<double>::infinity(), py::kw_only(), py::arg("threads") = 0,
          py::arg("device") = "cpu", py::arg("range") = py::none(), py::arg("inverter") = py::none(),
          py::arg("splitter") = py::none(), py::arg("baseline") = py::none(), py::arg("marching_scale") = py::none(),
          py::arg("inversion_in_traversal") = py::none(), py::arg("step") = py::none(), py::arg("lod") = py::none(),
          py::arg("lod_bias") = py::none(),
          (std::string("The first hit of every ray, as `oblong trace` finds it. origins, directions: arrays of\n"
                       "shape (n, 3) (any real dtype; traced as float32, as the ray files hold them); tmin,\n"
                       "tmax: numbers or arrays of shape (n,). Each ray is checked as the ray files' rays are\n"
                       "(oblong.Error \"ray i: ...\"). Returns a dict:\n"
                       "  t (n,) float32, in units of |d| (inf: miss); mesh, prim (n,) int32 (-1: miss);\n"
                       "  uv (n, 2) float32, texture coordinates of the hit before tiling (0: miss);\n"
                       "  boxes, range_queries, inversions, cells_marched, micro_triangles, prisms, steps\n"
                       "  (n,) int64, each ray's traversal work; stats: the --stats object (dict).") +
           kStrategyDoc)
              .c_str());

  m.def(
      "load",
      [](const py::object& path, const py::object& displacement, const py::object& scale, const py::object& bias,
         const py::object& tiling) {
        // The command line's mesh flags (--displacement, --scale, --bias, --tiling).
        AssetFlags flags;
        if (!displacement.is_none()) flags.displacement = py::str(displacement).cast<std::string>();
        if (!scale.is_none()) flags.scale = scale.cast<double>();
        if (!bias.is_none()) flags.bias = bias.cast<double>();
        if (!tiling.is_none()) {
          if (py::isinstance<py::sequence>(tiling) && !py::isinstance<py::str>(tiling)) {
            std::string t;
            for (const py::handle& x : tiling.cast<py::sequence>())
              t += (t.empty() ? "" : ",") + fmt::format("{}", x.cast<double>());
            flags.tiling = t.empty() ? "," : t;
          } else {
            flags.tiling = fmt::format("{}", tiling.cast<double>());
          }
        }
        if (path.is_none()) return loadFrom([flags] { return sceneFrom("", flags); });
        const std::string p = py::str(path).cast<std::string>();
        if (p.empty()) fail("scene", "empty file name (omit it for the built-in scene)");
        return loadFrom([p, flags] { return sceneFrom(p, flags); });
      },
      py::arg("path") = py::none(), py::kw_only(), py::arg("displacement") = py::none(),
      py::arg("scale") = py::none(), py::arg("bias") = py::none(), py::arg("tiling") = py::none(),
      "The scene file at path (JSON, docs/scene_format.md), or a mesh file with its material\n"
      "(docs/assets.md), or the built-in default scene when path is None. displacement, scale,\n"
      "bias, tiling (a number or (tu, tv)): the command line's --displacement, --scale, --bias,\n"
      "--tiling, for a mesh file only. Bad input raises oblong.Error with the command line's\n"
      "message.");
  m.def(
      "load_dict",
      [](const py::dict& d, const std::string& path) {
        if (path.empty()) fail("scene", "empty file name (omit it for the built-in scene)");
        nlohmann::json j = toJson(d, path, "", 1);
        return loadFrom([j = std::move(j), path] { return parseScene(j, path); });
      },
      py::arg("d"), py::arg("path") = "<dict>",
      "A scene from a dict in the scene file's schema (what json.load of a scene file gives).\n"
      "path names the scene in messages and is the file relative paths in it are relative to\n"
      "(its folder); with the path of the file the dict was read from, the errors are that file's.");
}
