#pragma once
/// @file timer.hpp
/// Wall-clock timers that feed the per-frame stage breakdown of stats.csv.
#include <chrono>

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
