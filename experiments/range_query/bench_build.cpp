// Range-query build time at the size of real maps, side by side in one run, against the
// machine's memory bandwidth measured by the same program (docs/range_query.md, "Build").
//
//   ./build/bench_build                       # 4096^2 and 8192^2, every structure
//   ./build/bench_build --benchmark_filter=4096
//
// Each build/<structure>/<side> benchmark builds the structure from a map already in
// memory (loading is reported separately by `oblong render --stats`: load_seconds), with
// every TBB thread. Counters: MB = the structure's bytes, GBps = (map bytes read +
// structure bytes written) / time, texels_per_s. bandwidth/read and bandwidth/copy time a
// plain sum and a memcpy over 1 GiB with the same threads: the ceiling such a pass meets.
#include "tests/fixtures/relief_map.h"
#include "strategies/range_query.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <cstring>
#include <map>
#include <random>

using namespace oblong;

namespace {

// One map per size, generated once.
std::shared_ptr<HeightMap> reliefMap(int n) {
  static std::map<int, std::shared_ptr<HeightMap>> cache;
  auto& m = cache[n];
  if (!m) m = bench::reliefMap(n);
  return m;
}

struct Structure {
  std::string label, name, params;
};
const std::vector<Structure>& structures() {
  static const std::vector<Structure> s = {
      {"rmip", "rmip", "{}"},  // the default: layout pairs, 16-bit
      {"rmip_pairs_f32", "rmip", R"({"bits":32})"},
      {"minmax_mipmap_16", "minmax_mipmap", R"({"bits":16})"},
      {"minmax_mipmap", "minmax_mipmap", "{}"},
      {"rmip_corners_c1_f32", "rmip", R"({"layout":"corners","compression":1,"bits":32})"},
  };
  return s;
}

void BM_Build(benchmark::State& st, const Structure* s, int n) {
  Displacement d;
  d.map = reliefMap(n);
  size_t bytes = 0;
  for (auto _ : st) {
    ParamSet ps(nlohmann::json::parse(s->params), "bench");
    auto rq = createRangeQuery(s->name, ps, {d, QueryNeeds::all(*d.map)});
    bytes = rq->bytes();
    benchmark::DoNotOptimize(rq.get());
  }
  const double moved = double(d.map->bytes() + bytes);
  st.counters["MB"] = double(bytes) / (1 << 20);
  st.counters["GBps"] = benchmark::Counter(moved * st.iterations() / 1e9, benchmark::Counter::kIsRate);
  st.counters["texels_per_s"] = benchmark::Counter(double(n) * n * st.iterations(), benchmark::Counter::kIsRate);
}

constexpr size_t kBandwidthBytes = size_t(1) << 30;

void BM_BandwidthRead(benchmark::State& st) {
  std::vector<float> a(kBandwidthBytes / sizeof(float), 1.0f);
  for (auto _ : st) {
    const double sum = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, a.size(), size_t(1) << 16), 0.0,
        [&](const tbb::blocked_range<size_t>& r, double acc) {
          float s = 0.0f;
          for (size_t i = r.begin(); i != r.end(); ++i) s += a[i];
          return acc + s;
        },
        [](double x, double y) { return x + y; });
    benchmark::DoNotOptimize(sum);
  }
  st.counters["GBps"] = benchmark::Counter(double(kBandwidthBytes) * st.iterations() / 1e9, benchmark::Counter::kIsRate);
}

void BM_BandwidthCopy(benchmark::State& st) {
  std::vector<char> a(kBandwidthBytes, 1), b(kBandwidthBytes, 0);
  for (auto _ : st) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, a.size(), size_t(1) << 20), [&](const tbb::blocked_range<size_t>& r) {
      std::memcpy(b.data() + r.begin(), a.data() + r.begin(), r.size());
    });
    benchmark::DoNotOptimize(b.data());
  }
  // Read + write.
  st.counters["GBps"] =
      benchmark::Counter(2.0 * double(kBandwidthBytes) * st.iterations() / 1e9, benchmark::Counter::kIsRate);
}

const int reg = [] {
  benchmark::RegisterBenchmark("bandwidth/read", BM_BandwidthRead)->Unit(benchmark::kMillisecond)->UseRealTime();
  benchmark::RegisterBenchmark("bandwidth/copy", BM_BandwidthCopy)->Unit(benchmark::kMillisecond)->UseRealTime();
  for (int n : {4096, 8192})
    for (const Structure& s : structures())
      benchmark::RegisterBenchmark(fmt::format("build/{}/{}", s.label, n).c_str(), BM_Build, &s, n)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->MinTime(1.0);
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
