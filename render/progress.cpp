#include "render/progress.h"

#include "core/error.h"

#include <fmt/core.h>

#include <unistd.h>

#include <cstdio>

namespace oblong {

ProgressMode parseProgressMode(const std::string& name) {
  if (name == "auto") return ProgressMode::Auto;
  if (name == "always") return ProgressMode::Always;
  if (name == "never") return ProgressMode::Never;
  fail("--progress", "unknown mode '{}' (auto | always | never)", name);
}

namespace {
std::string seconds(double s) {
  if (s < 60) return fmt::format("{:.1f} s", s);
  const int m = int(s / 60);
  if (m < 60) return fmt::format("{}m{:02d}s", m, int(s) % 60);
  return fmt::format("{}h{:02d}m", m / 60, m % 60);
}
}  // namespace

Progress::Progress(ProgressMode mode) : start_(std::chrono::steady_clock::now()), phaseStart_(start_) {
  const bool terminal = ::isatty(2);
  tty_ = mode != ProgressMode::Never && terminal;
  plain_ = mode == ProgressMode::Always && !terminal;
  if (tty_ || plain_) thread_ = std::thread([this] { loop(); });
}

Progress::~Progress() {
  if (thread_.joinable()) {
    {
      std::lock_guard<std::mutex> l(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  clear();
}

double Progress::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::phase(const std::string& what, int64_t total) {
  std::lock_guard<std::mutex> l(m_);
  phase_ = what;
  total_ = total;
  done_ = 0;
  plainTenths_ = 0;
  phaseStart_ = std::chrono::steady_clock::now();
  if (plain_) {
    eprint("  [{:>7}] {}\n", seconds(elapsed()), what);
    std::fflush(stderr);
  }
  if (tty_) draw();
}

std::string Progress::line() const {
  const double inPhase = std::chrono::duration<double>(std::chrono::steady_clock::now() - phaseStart_).count();
  if (total_ <= 0) return fmt::format("  {} ... {}", phase_, seconds(inPhase));
  const double f = std::min(1.0, double(done_.load()) / double(total_));
  const int w = 30, k = int(f * w);
  const std::string eta = f > 0.005 ? seconds(inPhase * (1 - f) / f) : std::string("?");
  return fmt::format("  {} [{}{}] {:5.1f}%  {} elapsed, ETA {}", phase_, std::string(k, '#'), std::string(w - k, ' '),
                     100.0 * f, seconds(inPhase), eta);
}

void Progress::draw() {
  // Called with m_ held.
  if (tty_) {
    eprint("\r\033[K{}", line());
    drawn_ = true;
  }
  if (plain_ && total_ > 0) {
    const int tenths = int(10 * std::min(1.0, double(done_.load()) / double(total_)));
    if (tenths > plainTenths_ && tenths < 10) {
      plainTenths_ = tenths;
      eprint("  [{:>7}] {}\n", seconds(elapsed()), line().substr(2));
    }
  }
  std::fflush(stderr);
}

void Progress::loop() {
  std::unique_lock<std::mutex> l(m_);
  while (!cv_.wait_for(l, std::chrono::milliseconds(250), [this] { return stop_; }))
    if (!phase_.empty()) draw();
}

void Progress::clear() {
  std::lock_guard<std::mutex> l(m_);
  if (tty_ && drawn_) {
    eprint("\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
  }
}

}  // namespace oblong
