// What `oblong render` and `oblong trace` print and write with `--stats`, on every device:
// one writer over the trace backend (render/trace_backend.h), so that the CPU and Vulkan
// summaries and statistics files have the same lines and fields (docs/render.md, "What
// oblong render prints" and "--stats out.json").
//
// Memory, one convention on every device: the console prints bytes in binary units
// (humanBytes, core/memory.h: "47.2 KiB", "3.88 MiB"), the statistics files hold integer bytes
// ("memory": bytes per structure, "memory_total"; addMemoryJson).
#pragma once

#include "core/scene.h"
#include "render/accel_options.h"
#include "render/figures.h"
#include "render/renderer.h"
#include "render/trace_backend.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace oblong {

// The process's peak resident memory (getrusage).
size_t peakMemoryBytes();
// The worker threads TBB runs with for --threads `requested` (0: all cores).
int threadsUsed(int requested);

// The requested strategies (`--stats` "config") and the scene's level of detail ("lod").
nlohmann::json configJson(const AccelOptions& opts, const Scene& scene);

// What every statistics file records about the run itself.
struct RunInfo {
  std::string version;  // `git describe` of the source tree (OBLONG_VERSION)
  int threadsRequested = 0;
  double loadSeconds = 0, totalSeconds = 0;
};

struct RenderReport {
  const Scene& scene;
  const AccelOptions& accel;
  const TraceBackend& backend;
  const RenderOptions& opts;
  const RenderResult& res;
  std::string out, heatmap;
  bool defaultOut = false;  // -o not given
  HeatMapScale heat;        // the heat map's colour scale (with a heat map)
  FalseColourResult heatFile;  // what the heat map's file holds
};
// The configuration built, its memory, the summary line, the partial and heat-map lines.
void printRenderSummary(const RenderReport& r);
nlohmann::json renderStats(const RenderReport& r, const RunInfo& run);

struct TraceReport {
  const Scene& scene;
  const AccelOptions& accel;
  const TraceBackend& backend;
  const TraceResult& res;
  std::string raysPath, out;
  bool defaultOut = false;  // -o not given
};
// One line: rays, hits, geometry (and device), time, Mrays/s, steps per ray, memory.
void printTraceSummary(const TraceReport& r);
nlohmann::json traceStats(const TraceReport& r, const RunInfo& run);

}  // namespace oblong
