#pragma once
/// @file timer.hpp
/// Wall-clock timers that feed the per-frame stage breakdown of stats.csv, and the process CPU
/// clock behind its `cpu_s` column.
#include <chrono>
#include <ctime>

namespace ccfr {

class Stopwatch {
 public:
  Stopwatch() : start_(clock::now()) {}
  void restart() { start_ = clock::now(); }
  double seconds() const { return std::chrono::duration<double>(clock::now() - start_).count(); }

 private:
  using clock = std::chrono::steady_clock;
  clock::time_point start_;
};

/// Adds the lifetime of the scope to `accumulator` (seconds).
class ScopedTimer {
 public:
  explicit ScopedTimer(double& accumulator) : acc_(accumulator) {}
  ~ScopedTimer() { acc_ += watch_.seconds(); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double& acc_;
  Stopwatch watch_;
};

/// CPU time consumed by the whole process (every thread) since construction or restart().
/// Against wall time it tells how much of the machine a frame used: the paper's numbers come from
/// 8 cores, ours from 2, and CPU seconds compare the work without the core count.
class CpuStopwatch {
 public:
  CpuStopwatch() : start_(now()) {}
  void restart() { start_ = now(); }
  double seconds() const { return now() - start_; }

 private:
  static double now() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  }
  double start_;
};

/// Seconds spent per stage of the paper's breakdown (Table "Performance results").
struct StageTimes {
  /// `resolution`: the contact solver's resolve alone; `check`: what the loop adds around it (the
  /// analytic-obstacle push, finite checks, the step bound and the recount of violations).
  double xpbd = 0, broad = 0, narrow = 0, resolution = 0, check = 0, audit = 0;
  StageTimes& operator+=(const StageTimes& o) {
    xpbd += o.xpbd;
    broad += o.broad;
    narrow += o.narrow;
    resolution += o.resolution;
    check += o.check;
    audit += o.audit;
    return *this;
  }
};

}  // namespace ccfr
