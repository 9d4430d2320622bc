// Error against run time of the inverters (docs/inversion.md), and the stiff-case report.
//
//   bench_inversion --stiff-report        markdown table: per stiff case and inverter,
//                                         convergence, iterations, errors, failures
//   bench_inversion --errors=FILE.csv     accuracy of every variant on every dataset
//   bench_inversion [benchmark flags]     Google Benchmark: ns per inversion of every
//                                         variant on every dataset
//
// Datasets: "asteroid" (every triangle of glmark2's asteroid-low.3ds, heights ±0.25 of
// its longest edge, 8 interior points plus the boundary and extreme sets per triangle),
// "stiff" (the cases of tests/fixtures/stiff_cases.h except translated_*), "far_from_origin"
// (translated_1e4, translated_1e6) and "synthetic" (randomCases(150, 11): twisted
// normals). Reference: ceres (invertD). Error:
// max(|Δu|, |Δv|, |Δh| / max(L, |h|)) (tests/fixtures/stiff_cases.h), over the samples where the
// reference converged and the point has a single preimage. Build with -DOBLONG_STATS=OFF
// for timings (run.sh does).
#include "inversion/ceres.h"
#include "inversion/cubic.h"
#include "inversion/newton.h"
#include "tests/fixtures/stiff_cases.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <type_traits>
#include <memory>

using namespace oblong;
using namespace oblong::test;

namespace {

struct Variant {
  std::string label;     // e.g. "newton float tol=1e-5"
  std::string inverter;  // registry name
  nlohmann::json params;
  bool floatApi;         // invert() (float in, float out) or invertD()
};

std::vector<Variant> variants() {
  std::vector<Variant> v;
  v.push_back({"ceres double", "ceres", nlohmann::json::object(), false});
  for (double t : {1e-10, 1e-6})
    v.push_back({fmt::format("newton double tol={:g}", t), "newton", {{"precision", "double"}, {"tolerance", t}}, false});
  // Fixed step counts (tolerance 0) without the cubic fallback: pure Newton at fixed cost.
  for (int k : {2, 3, 4})
    v.push_back({fmt::format("newton double it={}", k), "newton",
                 {{"precision", "double"}, {"tolerance", 0.0}, {"max_iterations", k}, {"fallback", "none"}}, false});
  for (double t : {1e-5, 1e-4, 1e-3})
    v.push_back({fmt::format("newton float tol={:g}", t), "newton", {{"precision", "float"}, {"tolerance", t}}, true});
  for (int k : {2, 3, 4})
    v.push_back({fmt::format("newton float it={}", k), "newton",
                 {{"precision", "float"}, {"tolerance", 0.0}, {"max_iterations", k}, {"fallback", "none"}}, true});
  v.push_back({"newton double tol=1e-10 no-fallback", "newton",
               {{"precision", "double"}, {"tolerance", 1e-10}, {"fallback", "none"}}, false});
  v.push_back({"newton float tol=1e-5 no-fallback", "newton",
               {{"precision", "float"}, {"tolerance", 1e-5}, {"fallback", "none"}}, true});
  for (int p : {1, 0}) {
    v.push_back({fmt::format("cubic double polish={}", p), "cubic", {{"precision", "double"}, {"polish", p}}, false});
    v.push_back({fmt::format("cubic float polish={}", p), "cubic", {{"precision", "float"}, {"polish", p}}, true});
  }
  // Every registered inverter with its defaults, through both entry points (a new
  // inverter is benchmarked without an edit here).
  for (const std::string& name : inverterNames()) {
    v.push_back({name + " defaults, double API", name, nlohmann::json::object(), false});
    v.push_back({name + " defaults, float API", name, nlohmann::json::object(), true});
  }
  return v;
}

std::unique_ptr<Inverter> make(const Variant& v) {
  ParamSet ps(v.params, "bench_inversion: " + v.label);
  return createInverter(v.inverter, ps);
}

struct Sample {
  dvec3 X;
  vec3 Xf;
  int tri;
  bool ambiguous;
};

struct Dataset {
  std::string name;
  std::vector<StiffCase> cases;
  std::vector<Sample> samples;
  std::vector<InversionResultD> ref;
};

std::vector<Dataset> datasets() {
  std::vector<Dataset> out;
  out.push_back({"asteroid", meshCases(kAsteroidPath, "asteroid", 0.25), {}, {}});
  std::vector<StiffCase> stiff, far;
  for (const StiffCase& c : stiffCatalogue()) (c.name.rfind("translated", 0) == 0 ? far : stiff).push_back(c);
  out.push_back({"stiff", stiff, {}, {}});
  out.push_back({"far_from_origin", far, {}, {}});
  out.push_back({"synthetic", randomCases(150, 11), {}, {}});
  CeresInverter ceres;
  for (Dataset& d : out) {
    for (size_t i = 0; i < d.cases.size(); ++i)
      for (const InversionSample& x : d.cases[i].samples(d.name == "asteroid" || d.name == "synthetic" ? 8 : 200, uint32_t(i + 1)))
        d.samples.push_back({x.X, vec3(x.X), int(i), x.ambiguous});
    for (const Sample& s : d.samples) d.ref.push_back(ceres.invertD(s.X, d.cases[s.tri].tri));
  }
  return out;
}

template <typename Inv>
void runBench(benchmark::State& state, const Inv& inv, const Dataset& d, bool floatApi) {
  const size_t n = d.samples.size();
  size_t i = 0;
  for (auto _ : state) {
    const Sample& s = d.samples[i];
    if constexpr (std::is_same_v<Inv, Inverter>) {  // any other registered inverter
      if (floatApi) benchmark::DoNotOptimize(inv.invert(s.Xf, d.cases[s.tri].tri));
      else benchmark::DoNotOptimize(inv.invertD(s.X, d.cases[s.tri].tri));
    } else if (floatApi) {
      benchmark::DoNotOptimize(inv.invertFast(s.Xf, d.cases[s.tri].tri));
    } else {
      benchmark::DoNotOptimize(inv.invertFastD(s.X, d.cases[s.tri].tri));
    }
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}

void registerBenchmarks(const std::vector<Dataset>& ds, const std::vector<std::shared_ptr<Inverter>>& invs,
                        const std::vector<Variant>& vs) {
  for (const Dataset& d : ds)
    for (size_t k = 0; k < vs.size(); ++k) {
      const Inverter* inv = invs[k].get();
      const bool f = vs[k].floatApi;
      const std::string name = d.name + "/" + vs[k].label;
      auto fn = [inv, &d, f](benchmark::State& st) {
        if (auto* p = dynamic_cast<const Newton*>(inv)) return runBench(st, *p, d, f);
        if (auto* p = dynamic_cast<const Cubic*>(inv)) return runBench(st, *p, d, f);
        if (auto* p = dynamic_cast<const CeresInverter*>(inv)) return runBench(st, *p, d, f);
        return runBench(st, *inv, d, f);  // through the virtual entry points
      };
      benchmark::RegisterBenchmark(name.c_str(), fn);
    }
}

// Accuracy of every variant on every dataset.
void writeErrors(const std::string& path, const std::vector<Dataset>& ds,
                 const std::vector<std::shared_ptr<Inverter>>& invs, const std::vector<Variant>& vs) {
  std::ofstream f(path);
  f << "dataset,variant,inverter,precision,samples,compared,converged_rate,mean_iterations,max_iterations,"
       "mean_err,median_err,p99_err,max_err,outside_T\n";
  for (const Dataset& d : ds)
    for (size_t k = 0; k < vs.size(); ++k) {
      std::vector<double> err;
      int conv = 0, maxIt = 0, outside = 0;
      double itSum = 0;
      for (size_t i = 0; i < d.samples.size(); ++i) {
        const Sample& s = d.samples[i];
        const DisplacedTriangle& T = d.cases[s.tri].tri;
        InversionResultD r;
        if (vs[k].floatApi) {
          const InversionResult q = invs[k]->invert(s.Xf, T);
          r = {dvec2(q.bary), dvec2(q.uv), double(q.h), q.converged, q.iterations};
        } else {
          r = invs[k]->invertD(s.X, T);
        }
        conv += r.converged;
        itSum += r.iterations;
        maxIt = std::max(maxIt, r.iterations);
        outside += !(r.outside() <= (vs[k].floatApi ? 1e-4 : 1e-9));
        if (s.ambiguous || !d.ref[i].converged) continue;
        const double e = inversionError(r, d.ref[i].bary.x, d.ref[i].bary.y, d.ref[i].h, longestEdge(T));
        err.push_back(std::isfinite(e) ? e : 1e300);
      }
      std::sort(err.begin(), err.end());
      double mean = 0;
      for (double e : err) mean += std::min(e, 1.0);
      const size_t m = err.size();
      f << fmt::format("{},{},{},{},{},{},{:.6f},{:.4f},{},{:.3e},{:.3e},{:.3e},{:.3e},{}\n", d.name, vs[k].label,
                       vs[k].inverter, vs[k].floatApi ? "float" : "double", d.samples.size(), m,
                       double(conv) / d.samples.size(), itSum / d.samples.size(), maxIt, m ? mean / m : 0.0,
                       m ? err[m / 2] : 0.0, m ? err[std::min(m - 1, size_t(0.99 * m))] : 0.0,
                       m ? err[m - 1] : 0.0, outside);
    }
}

std::string sci(double x) { return x == 0 ? "0" : fmt::format("{:.1e}", x); }

void stiffReport() {
  CeresInverter ceres;
  struct Row {
    std::string label;
    std::unique_ptr<Inverter> inv;
    bool floatApi;
  };
  std::vector<Row> rows;
  auto add = [&](std::string label, std::string name, nlohmann::json j, bool f) {
    ParamSet ps(j, label);
    rows.push_back({label, createInverter(name, ps), f});
  };
  add("newton (double)", "newton", {{"precision", "double"}}, false);
  add("newton (double, no fallback)", "newton", {{"precision", "double"}, {"fallback", "none"}}, false);
  add("newton (float)", "newton", nlohmann::json::object(), true);
  add("newton (float, no fallback)", "newton", {{"fallback", "none"}}, true);
  add("cubic (double)", "cubic", {{"precision", "double"}}, false);
  add("cubic (float)", "cubic", nlohmann::json::object(), true);
  add("ceres (double)", "ceres", nlohmann::json::object(), false);

  fmt::print("Limits: double err <= {:g}, outside T <= {:g}; float err <= {:g}, outside T <= {:g}\n\n",
             doubleLimits().err, doubleLimits().outside, floatLimits().err, floatLimits().outside);
  fmt::print("| case | inverter | n | converged | iters mean / max | max err vs ceres | max err vs truth | "
             "max outside T | ambiguous | failures (on ambiguous) |\n");
  fmt::print("|---|---|---|---|---|---|---|---|---|---|\n");
  auto printRow = [&](const std::string& name, const std::string& label, const Evaluation& e) {
    fmt::print("| {} | {} | {} | {:.2f}% | {:.2f} / {} | {} | {} | {} | {} | {} ({}) |\n", name, label, e.n,
               100.0 * e.convergenceRate(), e.meanIterations, e.maxIterations, sci(e.maxErrRef),
               sci(e.maxErrTruth), sci(e.maxOutside), e.ambiguous, e.failures, e.ambiguousFailures);
  };
  for (const StiffCase& c : stiffCatalogue()) {
    const auto samples = c.samples();
    std::vector<InversionResultD> ref;
    for (const auto& x : samples) ref.push_back(ceres.invertD(x.X, c.tri));
    for (const Row& r : rows)
      printRow(c.name, r.label, evaluate(*r.inv, r.floatApi, c, samples, &ref, r.floatApi ? floatLimits() : doubleLimits()));
  }
  // The asteroid and the random twisted triangles, aggregated over their triangles.
  auto aggregate = [&](const std::string& label, const std::vector<StiffCase>& cases, int nInterior) {
    std::vector<Evaluation> agg(rows.size());
    for (size_t i = 0; i < cases.size(); ++i) {
      const auto samples = cases[i].samples(nInterior, uint32_t(i + 1));
      std::vector<InversionResultD> ref;
      for (const auto& x : samples) ref.push_back(ceres.invertD(x.X, cases[i].tri));
      for (size_t k = 0; k < rows.size(); ++k)
        accumulate(agg[k], evaluate(*rows[k].inv, rows[k].floatApi, cases[i], samples, &ref,
                                    rows[k].floatApi ? floatLimits() : doubleLimits()));
    }
    for (size_t k = 0; k < rows.size(); ++k) printRow(fmt::format(fmt::runtime(label), cases.size()), rows[k].label, agg[k]);
  };
  aggregate("asteroid ({} triangles)", meshCases(kAsteroidPath, "asteroid", 0.25), 8);
  aggregate("synthetic twisted ({} triangles)", randomCases(150, 11), 8);
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--stiff-report") == 0) {
      stiffReport();
      return 0;
    }
  std::string errorsPath;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--errors=", 9) == 0) errorsPath = argv[i] + 9;
    else args.push_back(argv[i]);
  }
  const auto vs = variants();
  std::vector<std::shared_ptr<Inverter>> invs;
  for (const Variant& v : vs) invs.push_back(make(v));
  const auto ds = datasets();
  if (!errorsPath.empty()) {
    writeErrors(errorsPath, ds, invs, vs);
    return 0;
  }
  int n = int(args.size());
  benchmark::Initialize(&n, args.data());
  registerBenchmarks(ds, invs, vs);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
