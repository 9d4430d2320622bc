// Range-query strategies: time per query, bound looseness, memory and build time on a
// smooth 1024^2 map for rectangles of aspect ratio 1, 8, 64 at several areas
// (hypothesis and results: experiments/range_query/README.md, docs/range_query.md).
//
//   ./build-rq/bench_range_query --benchmark_min_time=0.2
//
// Counters per (strategy, aspect, side): ratio = mean (hi-lo)/(exact hi - exact lo) over
// rectangles with a non-zero exact range, p99 = its 99th percentile, excess = mean (hi-lo) - exact width (height
// units, map in [-1,1]), MB = structure size, build_ms = build time. The timed loop
// calls the virtual query(), as the traversal does. Every registered strategy is timed
// with its default parameters, plus rmip's parameter variants.
#include "strategies/range_query.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>

using namespace oblong;

namespace {

constexpr int kN = 1024;
constexpr int kRects = 4096;

// Smooth but detailed: a few octaves of sines plus a little white noise, deterministic.
std::shared_ptr<HeightMap> smoothMap(int n) {
  std::vector<float> t(size_t(n) * n);
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> noise(-1.0f, 1.0f);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = 2 * M_PI * i / n, y = 2 * M_PI * j / n;
      double h = 0.45 * std::sin(3 * x + 1.0) * std::cos(2 * y) + 0.25 * std::sin(11 * x + 7 * y) +
                 0.12 * std::sin(37 * x - 23 * y + 0.3) + 0.06 * std::cos(101 * x + 89 * y);
      t[size_t(j) * n + i] = float(h + 0.04 * noise(rng));
    }
  return std::make_shared<HeightMap>(n, n, std::move(t), "smooth1024");
}

const Displacement& disp() {
  static Displacement d = [] {
    Displacement x;
    x.map = smoothMap(kN);
    return x;
  }();
  return d;
}

struct Built {
  std::unique_ptr<RangeQuery> rq;
  double buildMs = 0;
};

struct Variant {
  std::string label, name, params;
};
// Every registered strategy (defaults), then rmip's compression and resolution variants.
const std::vector<Variant>& variants() {
  static const std::vector<Variant> v = [] {
    std::vector<Variant> out;
    for (const std::string& n : rangeQueryNames()) out.push_back({n, n, "{}"});
    if (RangeQueryRegistry::instance().has("rmip")) {
      out.push_back({"rmip_pairs_f32", "rmip", R"({"bits":32})"});
      out.push_back({"rmip_corners_c0", "rmip", R"({"layout":"corners","compression":0,"bits":32})"});
      out.push_back({"rmip_corners_c1", "rmip", R"({"layout":"corners","compression":1,"bits":32})"});
      out.push_back({"rmip_corners_c1_16", "rmip", R"({"layout":"corners","compression":1,"bits":16})"});
      out.push_back({"rmip_corners_c2", "rmip", R"({"layout":"corners","compression":2,"bits":32})"});
      out.push_back({"rmip_uncompressed", "rmip", R"({"layout":"corners","compression":99,"bits":32})"});
      out.push_back({"rmip_half_res", "rmip", R"({"resolution":512})"});
      out.push_back({"rmip_quarter_res", "rmip", R"({"resolution":256})"});
    }
    for (const char* n : {"minmax_mipmap", "safety_zones"})
      if (RangeQueryRegistry::instance().has(n)) out.push_back({std::string(n) + "_16", n, R"({"bits":16})"});
    return out;
  }();
  return v;
}

// One build per variant, kept for all rectangle sets (uncompressed rmip is ~1 GB).
Built& built(const Variant& v) {
  static std::map<std::string, Built> cache;
  auto it = cache.find(v.label);
  if (it != cache.end()) return it->second;
  ParamSet ps(nlohmann::json::parse(v.params), v.label);
  const auto t0 = std::chrono::steady_clock::now();
  auto rq = createRangeQuery(v.name, ps, {disp(), QueryNeeds::all(*disp().map)});
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return cache[v.label] = Built{std::move(rq), ms};
}

struct RectSet {
  std::vector<Rect> rects;
  std::vector<Interval> exact;
};

// Rectangles of area side^2 texels and the given aspect, random position (wrapping
// allowed) and orientation (long side along u or v).
const RectSet& rectSet(int aspect, int side) {
  static std::map<std::pair<int, int>, RectSet> cache;
  auto key = std::make_pair(aspect, side);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  RectSet s;
  std::mt19937 rng(aspect * 1000 + side);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float a = std::sqrt(float(aspect));
  for (int k = 0; k < kRects; ++k) {
    float w = side * a / kN, h = side / a / kN;
    if (k & 1) std::swap(w, h);
    const vec2 lo(u(rng), u(rng));
    s.rects.push_back({lo, lo + vec2(w, h)});
    // Exact range of the snapped sample range (what an exact strategy returns).
    const Displacement& d = disp();
    const dvec2 p = d.toSample(s.rects.back().lo), q = d.toSample(s.rects.back().hi);
    const SampleRange r{int(std::floor(p.x - 1e-5)), int(std::floor(p.y - 1e-5)), int(std::ceil(q.x + 1e-5)),
                        int(std::ceil(q.y + 1e-5))};
    s.exact.push_back(d.toHeight(bruteForceRange(*d.map, r)));
  }
  return cache[key] = std::move(s);
}


void BM_Query(benchmark::State& st, const Variant* v, int aspect, int side) {
  Built& b = built(*v);
  const RectSet& s = rectSet(aspect, side);
  const RangeQuery& rq = *b.rq;
  size_t n = 0;
  for (auto _ : st) {
    benchmark::DoNotOptimize(rq.query(s.rects[n], 0.0f));
    n = (n + 1) & (kRects - 1);
  }

  double ratio = 0, excess = 0;
  std::vector<double> ratios;
  for (size_t k = 0; k < s.rects.size(); ++k) {
    const Interval q = rq.query(s.rects[k], 0.0f), e = s.exact[k];
    if (!q.contains(e)) st.SkipWithError("bound does not contain the exact range");
    excess += q.width() - e.width();
    if (e.width() > 0) ratios.push_back(double(q.width()) / e.width()), ratio += ratios.back();
  }
  st.counters["ratio"] = ratios.empty() ? 1.0 : ratio / double(ratios.size());
  if (!ratios.empty()) {  // 99th percentile of (hi - lo) / exact range
    const size_t at = std::min(ratios.size() - 1, size_t(0.99 * double(ratios.size())));
    std::nth_element(ratios.begin(), ratios.begin() + ptrdiff_t(at), ratios.end());
    st.counters["p99"] = ratios[at];
  }
  st.counters["excess"] = excess / double(s.rects.size());
  st.counters["MB"] = double(rq.bytes()) / (1 << 20);
  st.counters["build_ms"] = b.buildMs;
}

// Build time of the default rmip on a 4096^2 map (bench_build times every structure).
void BM_BuildRmip4096(benchmark::State& st) {
  Displacement d;
  d.map = smoothMap(4096);
  size_t bytes = 0;
  for (auto _ : st) {
    ParamSet ps;
    auto rq = createRangeQuery("rmip", ps, {d, QueryNeeds::all(*d.map)});
    bytes = rq->bytes();
  }
  st.counters["MB"] = double(bytes) / (1 << 20);
}

// In main, not at static initialisation: the strategies register themselves in other
// translation units, whose initialisation order is unspecified.
void registerAll() {
  for (const Variant& v : variants())
    for (int aspect : {1, 8, 64})
      for (int side : {4, 16, 64, 256})
        benchmark::RegisterBenchmark(fmt::format("query/{}/aspect:{}/side:{}", v.label, aspect, side).c_str(),
                                     BM_Query, &v, aspect, side);
  benchmark::RegisterBenchmark("build/rmip/4096", BM_BuildRmip4096)->Iterations(1)->Unit(benchmark::kSecond);
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
