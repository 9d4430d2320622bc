// The benchmarks' map at the size of real ones: a 16-bit-like relief in [0, 1], a few
// octaves of sines and a little noise quantised to 1/65535 as a 16-bit PNG or TIFF would
// load. Deterministic for a size (bench_build, bench_editing).
#pragma once

#include "core/heightmap.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

namespace oblong::bench {

inline std::shared_ptr<HeightMap> reliefMap(int n) {
  std::vector<float> t(size_t(n) * n);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 64), [&](const tbb::blocked_range<int>& rows) {
    std::mt19937 rng(uint32_t(rows.begin()) * 7919u + 1u);
    std::uniform_real_distribution<float> noise(-1.0f, 1.0f);
    for (int j = rows.begin(); j != rows.end(); ++j)
      for (int i = 0; i < n; ++i) {
        const double x = 2 * M_PI * i / n, y = 2 * M_PI * j / n;
        const double h = 0.45 * std::sin(3 * x + 1.0) * std::cos(2 * y) + 0.25 * std::sin(11 * x + 7 * y) +
                         0.12 * std::sin(37 * x - 23 * y + 0.3) + 0.06 * std::cos(101 * x + 89 * y) +
                         0.03 * noise(rng);
        t[size_t(j) * n + i] = float(std::round((0.5 + 0.5 * h / 0.95) * 65535.0) / 65535.0);
      }
  });
  return std::make_shared<HeightMap>(n, n, std::move(t), fmt::format("relief{}", n));
}

}  // namespace oblong::bench
