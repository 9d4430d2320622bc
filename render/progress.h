// What a long run is doing, on stderr: the phase (loading, building, rendering,
// writing) with its elapsed time, and during rendering a bar with elapsed time and
// ETA, as pbrt-v4 and Mitsuba 3 show. On a terminal the status line is redrawn in place
// and cleared when the run ends, so errors and warnings stay one line each. With
// `always` it also goes to a file or pipe (a cluster job's log) as plain lines: one
// per phase and one per tenth of the render.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace oblong {

enum class ProgressMode { Auto, Always, Never };
ProgressMode parseProgressMode(const std::string& name);  // auto | always | never

class Progress {
 public:
  // Starts the clock; draws nothing until the first phase.
  explicit Progress(ProgressMode mode);
  ~Progress();  // clears the terminal line
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // A new phase; `total` > 0 makes it a counted one (pixels), advanced by add().
  void phase(const std::string& what, int64_t total = 0);
  void add(int64_t n) { done_ += n; }
  // Removes the status line (before printing the summary or an error).
  void clear();
  double elapsed() const;

 private:
  void loop();
  void draw();
  std::string line() const;

  bool tty_ = false, plain_ = false;
  std::chrono::steady_clock::time_point start_, phaseStart_;
  std::string phase_;
  int64_t total_ = 0;
  std::atomic<int64_t> done_{0};
  int plainTenths_ = 0;
  bool drawn_ = false;
  mutable std::mutex m_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace oblong
