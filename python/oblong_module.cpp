// The Python module `oblong` (docs/python.md): scenes loaded, rendered and traced through
// the command line's own steps (render/program.h, render/renderer.h, render/report.h,
// render/scene_info.h), so that the module accepts what `oblong` accepts, returns the
// same hits and fails with the same messages (oblong.Error, a ValueError). Arrays come
// back as numpy arrays; the GIL is released while a scene loads, builds, renders or
// traces.
#include "oblong_version.h"

#include "core/error.h"
#include "core/memory.h"
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
#include <cctype>
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

// Keyword values as the binding reads them. A value of the wrong type is a TypeError
// naming the keyword and the type expected (pybind11's own cast names neither); an
// exception raised by the value's own __float__ or __index__ goes through unchanged.
std::string typeName(const py::handle& v) { return py::str(py::type::of(v).attr("__name__")).cast<std::string>(); }

// The value as the message shows it: its repr, cut short.
std::string shown(const py::handle& v) {
  std::string r;
  try {
    r = py::repr(v).cast<std::string>();
  } catch (const py::error_already_set&) {
    r = "<unprintable>";
  }
  if (r.size() > 60) r = r.substr(0, 57) + "...";
  return r;
}

[[noreturn]] void wrongType(const char* name, const char* expected, const py::handle& v) {
  throw py::type_error(fmt::format("{}: expected {}, got {} {}", name, expected, typeName(v), shown(v)));
}

bool isNumber(const py::handle& v) {
  const PyNumberMethods* nb = Py_TYPE(v.ptr())->tp_as_number;
  return nb && (nb->nb_float || nb->nb_index) && !py::isinstance<py::str>(v) && !py::isinstance<py::bytes>(v);
}

double numberArg(const py::handle& v, const char* name) {
  if (!isNumber(v)) wrongType(name, "a number", v);
  const double x = PyFloat_AsDouble(v.ptr());
  if (x == -1.0 && PyErr_Occurred()) throw py::error_already_set();
  return x;
}

int64_t int64Arg(const py::handle& v, const char* name) {
  if (!PyIndex_Check(v.ptr())) wrongType(name, "an integer", v);
  const py::object i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
  if (!i) throw py::error_already_set();
  int overflow = 0;
  const long long x = PyLong_AsLongLongAndOverflow(i.ptr(), &overflow);
  if (x == -1 && PyErr_Occurred()) throw py::error_already_set();
  if (overflow) fail(name, "{} is out of range", shown(i));
  return x;
}

int intArg(const py::handle& v, const char* name) {
  const int64_t x = int64Arg(v, name);
  if (x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max())
    fail(name, "{} is out of range (at most {} in magnitude)", x, std::numeric_limits<int>::max());
  return int(x);
}

bool boolArg(const py::handle& v, const char* name) {
  // Python's bool and numpy's: a 0/1 integer or a string is a mistake, as on the command line.
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  const std::string t = typeName(v);
  if (t == "bool_" || t == "bool") {
    const int b = PyObject_IsTrue(v.ptr());
    if (b < 0) throw py::error_already_set();
    return b != 0;
  }
  wrongType(name, "a bool", v);
}

// A string keyword: an empty one is a mistake, as on the command line (`--range ''`).
std::string strArg(const py::handle& v, const char* name) {
  if (!py::isinstance<py::str>(v)) wrongType(name, "a str", v);
  const std::string s = v.cast<std::string>();
  if (s.empty()) fail(name, "empty value");
  return s;
}

// A file name: a str or an os.PathLike (pathlib.Path); "" for None.
std::string pathArg(const py::handle& v, const char* name) {
  if (v.is_none()) return {};
  if (!py::isinstance<py::str>(v) && !py::isinstance<py::bytes>(v) && !py::hasattr(v, "__fspath__"))
    wrongType(name, "a str or an os.PathLike", v);
  const py::object p = py::module_::import("os").attr("fsdecode")(v);
  return p.cast<std::string>();
}

// An optional string flag: None keeps the scene's choice.
std::string flagArg(const py::handle& v, const char* name) { return v.is_none() ? std::string() : strArg(v, name); }

// The module's keywords, each the command line's flag of the same name (`max_depth` is
// `--max-depth`).
const std::vector<std::string> kFlagKeywords = {
    "range", "inverter", "splitter", "baseline", "marching_scale", "inversion_in_traversal", "step", "lod",
    "lod_bias", "size", "spp", "integrator", "max_depth", "normals", "seed", "threads", "device",
    "displacement", "scale", "bias", "tiling"};

bool isKeywordValue(const std::string& w) {
  if (w == "cone" || w == "off" || w == "cpu" || w == "vulkan") return true;
  for (StrategyKind k : {StrategyKind::Range, StrategyKind::Inverter, StrategyKind::Splitter})
    for (const std::string& n : strategyNames(k))
      if (n == w) return true;
  for (const std::string& n : baselineNames())
    if (n == w) return true;
  return false;
}

// The command line's message as Python says it: a flag becomes its keyword, `WHERE:` at
// the start (`--spp: must be >= 1` is `spp: must be >= 1`) and `kw=` or `kw='value'`
// inside (`--baseline fixedstep` is `baseline='fixedstep'`). Other text is kept.
std::string pythonMessage(const std::string& m) {
  auto word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; };
  std::string out;
  size_t i = 0;
  while (i < m.size()) {
    // Not inside a path or a quoted value (a scene's unknown key '--range' stays as given).
    const bool starts = m.compare(i, 2, "--") == 0 &&
                        (i == 0 || (!word(m[i - 1]) && std::strchr("/.'\"", m[i - 1]) == nullptr));
    if (!starts) {
      out += m[i++];
      continue;
    }
    size_t e = i + 2;
    while (e < m.size() && (std::islower(static_cast<unsigned char>(m[e])) || m[e] == '-')) ++e;
    std::string kw = m.substr(i + 2, e - i - 2);
    std::replace(kw.begin(), kw.end(), '-', '_');
    if (std::find(kFlagKeywords.begin(), kFlagKeywords.end(), kw) == kFlagKeywords.end() ||
        (e < m.size() && word(m[e]))) {
      out += m.substr(i, e - i);
      i = e;
      continue;
    }
    if (i == 0 && m.compare(e, 1, ":") == 0) {
      out += kw;
      i = e;
      continue;
    }
    // A value after the flag: a strategy's name, cone, off, cpu or vulkan.
    size_t v = e + 1;
    while (v < m.size() && word(m[v])) ++v;
    if (e < m.size() && m[e] == ' ' && v > e + 1 && isKeywordValue(m.substr(e + 1, v - e - 1))) {
      out += fmt::format("{}='{}'", kw, m.substr(e + 1, v - e - 1));
      i = v;
    } else {
      out += kw + "=";
      i = e;
    }
  }
  return out;
}

// A Python value as JSON, for load_dict. Bounded as a scene file is: at most the scene
// parser's 64 levels of nesting and at most kMaxValues values in all, so that a list
// that contains itself, or a list of the same list twice taken 30 times over (2^30
// values from 30 small objects), is refused at once instead of being copied for minutes.
constexpr size_t kMaxDepth = 64;  // parseScene's limit, with its message
constexpr size_t kMaxValues = size_t(1) << 20;
struct JsonBudget {
  std::string path;
  size_t values = 0;
};
nlohmann::json toJson(const py::handle& v, JsonBudget& b, const std::string& at, size_t depth) {
  const auto where = [&] { return b.path + (at.empty() ? "" : ": " + at); };
  if (depth > kMaxDepth) fail(b.path, "nested deeper than {} levels", kMaxDepth);
  if (++b.values > kMaxValues)
    fail(b.path, "more than {} values (a scene holds far fewer; is a list or dict inside itself?)", kMaxValues);
  if (v.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::dict>(v)) {
    nlohmann::json o = nlohmann::json::object();
    // A copy of the items: a value's __float__ may change the dict while it is read.
    for (const py::handle item : py::list(v.attr("items")())) {
      const py::handle k = item[py::int_(0)], e = item[py::int_(1)];
      if (!py::isinstance<py::str>(k))
        fail(where(), "a key that is not a string: {} (a scene is a JSON object)", shown(k));
      const std::string key = k.cast<std::string>();
      o[key] = toJson(e, b, at.empty() ? key : at + "." + key, depth + 1);
    }
    return o;
  }
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    nlohmann::json a = nlohmann::json::array();
    const py::tuple items(py::reinterpret_borrow<py::object>(v));  // a copy, as for a dict
    for (size_t i = 0; i < items.size(); ++i) a.push_back(toJson(items[i], b, fmt::format("{}[{}]", at, i), depth + 1));
    return a;
  }
  // Integers first (Python's and numpy's: __index__), then anything with __float__.
  if (PyIndex_Check(v.ptr())) {
    const py::object i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    if (!i) throw py::error_already_set();
    int overflow = 0;
    const long long x = PyLong_AsLongLongAndOverflow(i.ptr(), &overflow);
    if (x == -1 && PyErr_Occurred()) throw py::error_already_set();
    if (!overflow) return x >= 0 ? nlohmann::json(uint64_t(x)) : nlohmann::json(int64_t(x));
    if (overflow > 0) {
      const unsigned long long u = PyLong_AsUnsignedLongLong(i.ptr());
      if (!PyErr_Occurred()) return uint64_t(u);
      PyErr_Clear();
    }
    // Beyond 64 bits: a double, as a JSON file's number is read.
    const double d = PyLong_AsDouble(i.ptr());
    if (d == -1.0 && PyErr_Occurred()) {
      PyErr_Clear();
      fail(where(), "an integer beyond a double: {}", shown(v));
    }
    return d;
  }
  if (isNumber(v)) {
    const double x = PyFloat_AsDouble(v.ptr());
    if (x == -1.0 && PyErr_Occurred()) throw py::error_already_set();
    return x;
  }
  fail(where(), "not a JSON value: {}", shown(v));
}

StrategyFlags strategyFlags(const py::object& range, const py::object& inverter, const py::object& splitter,
                            const py::object& baseline, const py::object& marchingScale,
                            const py::object& inversionInTraversal, const py::object& step, const py::object& lod,
                            const py::object& lodBias) {
  StrategyFlags f;
  f.range = flagArg(range, "range");
  f.inverter = flagArg(inverter, "inverter");
  f.splitter = flagArg(splitter, "splitter");
  f.baseline = flagArg(baseline, "baseline");
  if (!marchingScale.is_none()) f.marchingScale = numberArg(marchingScale, "marching_scale");
  if (!inversionInTraversal.is_none()) f.inversionInTraversal = boolArg(inversionInTraversal, "inversion_in_traversal");
  if (!step.is_none()) f.step = numberArg(step, "step");
  // "off", "cone" or a level (a number, written as Python writes it).
  if (lod.is_none()) {
  } else if (isNumber(lod) && !py::isinstance<py::bool_>(lod)) {
    f.lod = py::str(lod).cast<std::string>();
  } else if (py::isinstance<py::str>(lod)) {
    f.lod = strArg(lod, "lod");
  } else {
    wrongType("lod", "\"off\", \"cone\" or a number", lod);
  }
  if (!lodBias.is_none()) f.lodBias = float(numberArg(lodBias, "lod_bias"));
  return f;
}

// A keyword the call does not have: one line naming it and the ones it has (pybind11's
// own message prints every signature).
void checkNoOthers(const char* call, const py::args& args, size_t positional, const py::kwargs& kwargs,
                   const std::vector<const char*>& known) {
  std::string names;
  for (const char* k : known) names += fmt::format("{}{}", names.empty() ? "" : ", ", k);
  if (!args.empty())
    throw py::type_error(fmt::format("{}() takes {} positional argument{} ({} more given); the rest are keywords: {}",
                                     call, positional, positional == 1 ? "" : "s", args.size(), names));
  for (const auto& [k, v] : kwargs) {
    const std::string key = py::str(k).cast<std::string>();
    std::string hint;
    const py::list close = py::module_::import("difflib").attr("get_close_matches")(key, py::cast(known), 1);
    if (!close.empty()) hint = fmt::format(" (did you mean '{}'?)", close[0].cast<std::string>());
    throw py::type_error(fmt::format("{}() got an unexpected keyword argument '{}'{}; its keywords: {}", call, key,
                                     hint, names));
  }
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

// The Scene a method is called on. Scene.__new__(Scene) (pickling, copy.copy) makes an
// instance that no load filled in: its methods must not read it.
const PyScene& loaded(const py::handle& self) {
  if (py::isinstance<PyScene>(self)) {
    const auto v_h = reinterpret_cast<py::detail::instance*>(self.ptr())
                         ->get_value_and_holder(py::detail::get_type_info(typeid(PyScene)), false);
    if (v_h && v_h.holder_constructed() && v_h.value_ptr() && v_h.value_ptr<PyScene>()->scene)
      return *v_h.value_ptr<PyScene>();
  }
  throw py::value_error(
      "this Scene was not loaded (Scene.__new__ makes an empty one): make scenes with oblong.load(path) or "
      "oblong.load_dict(d)");
}

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

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

// An array of doubles made of anything numpy reads as one. A MemoryError (or an
// exception of the caller's own objects) goes through; any other failure is `expected`.
Doubles doubles(const py::handle& v, const char* name, const char* expected) {
  try {
    return Doubles(py::reinterpret_borrow<py::object>(v));
  } catch (py::error_already_set& e) {
    if (e.matches(PyExc_MemoryError)) throw;
    fail(name, "{}", expected);
  }
}

std::string shapeText(const py::array& a) {
  std::string shape;
  for (py::ssize_t k = 0; k < a.ndim(); ++k) shape += fmt::format("{}{}", k ? ", " : "", a.shape(k));
  if (a.ndim() == 1) shape += ",";
  return shape;
}

// The number of rays an array of origins or directions holds, read without converting
// it (a broadcast array of 1e8 rows is 48 bytes until it is copied); 0 when only the
// conversion can tell.
size_t rayCount(const py::handle& v, const char* name) {
  if (py::isinstance<py::array>(v)) {
    const auto a = py::reinterpret_borrow<py::array>(v);
    if (a.ndim() != 2 || a.shape(1) != 3) fail(name, "expected an array of shape (n, 3), got shape ({})", shapeText(a));
    return size_t(a.shape(0));
  }
  const Py_ssize_t n = PyObject_Length(v.ptr());
  if (n < 0) PyErr_Clear();
  return n < 0 ? 0 : size_t(n);
}

// An n×3 array of rays' origins or directions.
Doubles vectors(const py::object& v, const char* name) {
  const Doubles a = doubles(v, name, "expected an array of shape (n, 3) of numbers");
  if (a.ndim() != 2 || a.shape(1) != 3) fail(name, "expected an array of shape (n, 3), got shape ({})", shapeText(a));
  return a;
}

// tmin or tmax: one number for every ray, or one per ray.
std::vector<double> perRay(const py::object& v, const char* name, size_t n) {
  const Doubles a = doubles(v, name, "expected a number or an array of shape (n,)");
  if (a.ndim() == 0) return std::vector<double>(n, *a.data());
  if (a.ndim() != 1 || size_t(a.shape(0)) != n)
    fail(name, "expected a number or an array of shape ({},), got {} dimension(s) of {} value(s)", n, a.ndim(),
         a.size());
  return std::vector<double>(a.data(), a.data() + n);
}

// What trace holds per ray at its peak: the origins and directions as doubles, tmin and
// tmax as given and as doubles, the rays, their hits and counters, and the arrays
// returned (t, mesh, prim, uv and seven counters).
constexpr size_t kTraceBytesPerRay = 6 * sizeof(double) + 4 * sizeof(double) + sizeof(Ray) + sizeof(Hit) +
                                     sizeof(RayCounters) + 3 * 4 + 2 * 4 + 7 * 8;

// Refuses, before anything is converted or allocated, a trace of more rays than the
// memory budget (core/memory.h, OBLONG_MEMORY_LIMIT) holds, saying how many would fit.
void checkTraceFits(size_t n) {
  if (n == 0) return;
  const size_t budget = structureBudgetBytes();
  const size_t fit = budget / kTraceBytesPerRay;
  const size_t bytes = n > std::numeric_limits<size_t>::max() / kTraceBytesPerRay ? std::numeric_limits<size_t>::max()
                                                                                    : n * kTraceBytesPerRay;
  checkFits("origins", fmt::format("tracing {} rays", n), bytes,
            fmt::format("at most {} rays fit: trace them in batches of that many", fit),
            fmt::format("{} bytes per ray", kTraceBytesPerRay));
}

constexpr const char* kStrategyDoc = R"(
Strategy keywords (each the command line's flag of the same name; None keeps the
scene's choice): range, inverter, splitter (names from range_queries(), inverters(),
splitters()), baseline (a name from baselines()), marching_scale, inversion_in_traversal,
step, lod ("off", "cone" or a number), lod_bias. device: "cpu" (Embree) or "vulkan".
threads: worker threads, 0 for all cores.)";

const std::vector<const char*> kStrategyKeywords = {
    "range", "inverter", "splitter", "baseline", "marching_scale", "inversion_in_traversal", "step", "lod", "lod_bias"};

std::vector<const char*> keywords(std::vector<const char*> own, bool strategies) {
  if (strategies) own.insert(own.end(), kStrategyKeywords.begin(), kStrategyKeywords.end());
  return own;
}

}  // namespace

PYBIND11_MODULE(oblong, m) {
  // The arrays are numpy's: without numpy every call would fail later with a bare
  // ModuleNotFoundError; most often it is another interpreter than the one built for.
  try {
    py::module_::import("numpy");
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
    const py::module_ sys = py::module_::import("sys");
    // pybind11 turns an exception out of the module's initialisation into an ImportError
    // with its text.
    throw std::runtime_error(
        fmt::format("oblong needs numpy, which {} (Python {}) cannot import ({}): the module is built for Debian's "
                    "/usr/bin/python3, which has numpy (python3-numpy); run it with /usr/bin/python3, or install "
                    "numpy for this interpreter (docs/python.md)",
                    py::str(sys.attr("executable")).cast<std::string>(),
                    py::module_::import("platform").attr("python_version")().cast<std::string>(), e.what()));
  }

  m.doc() =
      "oblong: ray tracing displaced triangle meshes without tessellation (docs/python.md).\n\n"
      "load(path) / load_dict(d) give a Scene; scene.render(...) and scene.trace(...) return\n"
      "dicts of numpy arrays and the stats dict; bad input raises oblong.Error with the\n"
      "command line's message, its flags named as the keywords.";
  m.attr("__version__") = OBLONG_VERSION;
  // Kept for the process's life: the translator below raises it.
  static const auto* error = new py::exception<Error>(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(error->ptr(), pythonMessage(e.what()).c_str());
    }
  });

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
      .def_property_readonly("path", [](const py::handle& self) { return loaded(self).scene->path; },
                             "The file it came from (\"<default>\" for the built-in scene).")
      .def_property_readonly("load_seconds", [](const py::handle& self) { return loaded(self).loadSeconds; })
      .def(
          "info",
          [](const py::handle& self, const py::object& range, const py::object& lod, const py::object& text,
             const py::args& args, const py::kwargs& kwargs) {
            checkNoOthers("Scene.info", args, 3, kwargs, {"range", "lod", "text"});
            const PyScene& s = loaded(self);
            StrategyFlags flags;
            flags.range = flagArg(range, "range");
            flags.lod = strategyFlags(py::none(), py::none(), py::none(), py::none(), py::none(), py::none(),
                                      py::none(), lod, py::none())
                            .lod;
            const bool asText = boolArg(text, "text");
            nlohmann::json info;
            {
              py::gil_scoped_release nogil;
              const std::shared_ptr<const Scene> scene = s.forCall(flags, "");
              info = sceneInfo(*scene, flags.resolve(*scene).traversal);
            }
            if (asText) return py::object(py::str(sceneInfoText(info)));
            return toPython(info);
          },
          py::arg("range") = py::none(), py::arg("lod") = py::none(), py::arg("text") = false,
          "What `oblong info [--range R] [--lod L]` prints, as a dict (scene, meshes: per mesh its size,\n"
          "map, needs, level of detail, the range query's describe() or the baseline, prisms and\n"
          "memory; displaced_meshes, total_bytes, peak_memory), or with text=True the printed text.")
      .def(
          "render",
          [](const py::handle& self, const py::args& args, const py::object& size, const py::object& sppArg,
             const py::object& integratorArg, const py::object& maxDepthArg, const py::object& normalsArg,
             const py::object& seed, const py::object& threadsArg, const py::object& deviceArg,
             const py::object& range, const py::object& inverter, const py::object& splitter,
             const py::object& baseline, const py::object& marchingScale, const py::object& inversionInTraversal,
             const py::object& step, const py::object& lod, const py::object& lodBias, const py::kwargs& kwargs) {
            checkNoOthers("Scene.render", args, 0, kwargs,
                          keywords({"size", "spp", "integrator", "max_depth", "normals", "seed", "threads", "device"},
                                   true));
            const PyScene& s = loaded(self);
            const auto start = Clock::now();
            RenderFlags rf;
            if (size.is_none()) {
            } else if (py::isinstance<py::str>(size)) {
              rf.size = strArg(size, "size");
            } else if (py::isinstance<py::sequence>(size) && !py::isinstance<py::bytes>(size)) {
              std::vector<int64_t> wh;
              for (const py::handle x : py::tuple(size)) wh.push_back(int64Arg(x, "size"));
              if (wh.size() != 2) fail("size", "expected (width, height), got {} values", wh.size());
              rf.size = fmt::format("{}x{}", wh[0], wh[1]);
            } else {
              wrongType("size", "\"WxH\" or (width, height)", size);
            }
            rf.spp = intArg(sppArg, "spp");
            rf.integrator = strArg(integratorArg, "integrator");
            rf.maxDepth = intArg(maxDepthArg, "max_depth");
            rf.normals = strArg(normalsArg, "normals");
            // An integer in [0, 2^64), checked as --seed is.
            if (py::isinstance<py::str>(seed)) rf.seed = strArg(seed, "seed");
            else if (PyIndex_Check(seed.ptr()) && !py::isinstance<py::bool_>(seed)) rf.seed = py::str(py::int_(seed)).cast<std::string>();
            else wrongType("seed", "an integer", seed);
            rf.threads = intArg(threadsArg, "threads");
            const std::string device = strArg(deviceArg, "device");
            const int threads = rf.threads;
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
              const RenderReport report{*scene, accel, *backend, opts, res, "", "", false, {}, {}};  // no heat map
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
          py::arg("size") = py::none(), py::arg("spp") = 1, py::arg("integrator") = "path",
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
                       "Keywords only. size: \"WxH\" or (w, h), default the scene's; spp, integrator\n"
                       "(primary | ao | path), max_depth, normals (micro | smooth), seed (an integer in\n"
                       "[0, 2^64)) as the command line's flags.") +
           kStrategyDoc)
              .c_str())
      .def(
          "trace",
          [](const py::handle& self, const py::object& origins, const py::object& directions, const py::object& tmin,
             const py::object& tmax, const py::args& args, const py::object& threadsArg, const py::object& deviceArg,
             const py::object& range, const py::object& inverter, const py::object& splitter,
             const py::object& baseline, const py::object& marchingScale, const py::object& inversionInTraversal,
             const py::object& step, const py::object& lod, const py::object& lodBias, const py::kwargs& kwargs) {
            checkNoOthers("Scene.trace", args, 4, kwargs,
                          keywords({"origins", "directions", "tmin", "tmax", "threads", "device"}, true));
            const PyScene& s = loaded(self);
            const auto start = Clock::now();
            const int threads = intArg(threadsArg, "threads");
            if (threads < 0) fail("threads", "must be >= 0, got {}", threads);
            const std::string device = strArg(deviceArg, "device");
            // The count first: a broadcast array is copied when converted.
            const size_t count = rayCount(origins, "origins");
            checkTraceFits(std::max(count, rayCount(directions, "directions")));
            const auto o = vectors(origins, "origins");
            const auto d = vectors(directions, "directions");
            const size_t n = size_t(o.shape(0));
            if (size_t(d.shape(0)) != n) fail("directions", "{} directions for {} origins", d.shape(0), n);
            if (count == 0) checkTraceFits(n);
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
          py::arg("tmax") = std::numeric_limits<double>::infinity(), py::arg("threads") = 0,
          py::arg("device") = "cpu", py::arg("range") = py::none(), py::arg("inverter") = py::none(),
          py::arg("splitter") = py::none(), py::arg("baseline") = py::none(), py::arg("marching_scale") = py::none(),
          py::arg("inversion_in_traversal") = py::none(), py::arg("step") = py::none(), py::arg("lod") = py::none(),
          py::arg("lod_bias") = py::none(),
          (std::string("The first hit of every ray, as `oblong trace` finds it. origins, directions: arrays of\n"
                       "shape (n, 3) (any real dtype; traced as float32, as the ray files hold them); tmin,\n"
                       "tmax: numbers or arrays of shape (n,). Each ray is checked as the ray files' rays are\n"
                       "(oblong.Error \"ray i: ...\"); more rays than the memory budget holds are refused\n"
                       "first. Returns a dict:\n"
                       "  t (n,) float32, in units of |d| (inf: miss); mesh, prim (n,) int32 (-1: miss);\n"
                       "  uv (n, 2) float32, texture coordinates of the hit before tiling (0: miss);\n"
                       "  boxes, range_queries, inversions, cells_marched, micro_triangles, prisms, steps\n"
                       "  (n,) int64, each ray's traversal work; stats: the --stats object (dict).\n"
                       "The keywords after tmax are keywords only.") +
           kStrategyDoc)
              .c_str());

  m.def(
      "load",
      [](const py::object& path, const py::args& args, const py::object& displacement, const py::object& scale,
         const py::object& bias, const py::object& tiling, const py::kwargs& kwargs) {
        checkNoOthers("load", args, 1, kwargs, {"path", "displacement", "scale", "bias", "tiling"});
        // The command line's mesh flags (--displacement, --scale, --bias, --tiling).
        AssetFlags flags;
        if (!displacement.is_none()) {
          flags.displacement = pathArg(displacement, "displacement");
          if (flags.displacement.empty()) fail("displacement", "empty value");
        }
        if (!scale.is_none()) flags.scale = numberArg(scale, "scale");
        if (!bias.is_none()) flags.bias = numberArg(bias, "bias");
        if (!tiling.is_none()) {
          if (isNumber(tiling)) {
            flags.tiling = fmt::format("{}", numberArg(tiling, "tiling"));
          } else if (py::isinstance<py::sequence>(tiling) && !py::isinstance<py::str>(tiling) &&
                     !py::isinstance<py::bytes>(tiling)) {
            std::string t;
            for (const py::handle x : py::tuple(tiling)) {
              if (!t.empty()) t += ',';
              t += fmt::format("{}", numberArg(x, "tiling"));
            }
            flags.tiling = t.empty() ? "," : t;
          } else {
            wrongType("tiling", "a number or (tu, tv)", tiling);
          }
        }
        if (path.is_none()) return loadFrom([flags] { return sceneFrom("", flags); });
        const std::string p = pathArg(path, "path");
        if (p.empty()) fail("scene", "empty file name (omit it for the built-in scene)");
        return loadFrom([p, flags] { return sceneFrom(p, flags); });
      },
      py::arg("path") = py::none(), py::arg("displacement") = py::none(), py::arg("scale") = py::none(),
      py::arg("bias") = py::none(), py::arg("tiling") = py::none(),
      "The scene file at path (JSON, docs/scene_format.md), or a mesh file with its material\n"
      "(docs/assets.md), or the built-in default scene when path is None. displacement, scale,\n"
      "bias, tiling (a number or (tu, tv)), keywords only: the command line's --displacement,\n"
      "--scale, --bias, --tiling, for a mesh file only. Bad input raises oblong.Error with the\n"
      "command line's message.");
  m.def(
      "load_dict",
      [](const py::object& d, const py::object& pathArgument, const py::args& args, const py::kwargs& kwargs) {
        checkNoOthers("load_dict", args, 2, kwargs, {"d", "path"});
        if (!py::isinstance<py::dict>(d)) wrongType("d", "a dict (a scene in the scene file's schema)", d);
        const std::string path = pathArg(pathArgument, "path");
        if (path.empty()) fail("scene", "empty file name (omit it for the built-in scene)");
        JsonBudget budget{path};
        nlohmann::json j = toJson(d, budget, "", 1);
        return loadFrom([j = std::move(j), path] { return parseScene(j, path); });
      },
      py::arg("d"), py::arg("path") = "<dict>",
      "A scene from a dict in the scene file's schema (what json.load of a scene file gives).\n"
      "path names the scene in messages and is the file relative paths in it are relative to\n"
      "(its folder); with the path of the file the dict was read from, the errors are that file's.\n"
      "At most 64 levels of nesting and 2^20 values, as a scene file.");
}
