#pragma once
/// @file timer.hpp
/// Wall-clock timers that feed the per-frame stage breakdown of stats.csv, and the process CPU
/// clock behind its `cpu_s` column.
#include <algorithm>
#include <chrono>
#include <ctime>

#include "ccfr/core/parallel.hpp"

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

/// Wall time outside outermost parallel loops since construction (seconds): what no extra core
/// shortens. Meaningful on the thread that runs the timed code while no other thread starts
/// parallel loops of its own.
class SerialStopwatch {
 public:
  SerialStopwatch() : parallel0_(parallel_seconds()) {}
  double seconds() const { return std::max(0.0, wall_.seconds() - (parallel_seconds() - parallel0_)); }

 private:
  Stopwatch wall_;
  double parallel0_;
};

/// Adds the lifetime of the scope to `accumulator` (seconds).
class ScopedTimer {
 public:
  explicit ScopedTimer(double& accumulator) : acc_(accumulator) {}
  /// Also adds the part of the scope spent outside parallel loops to `serial` (SerialStopwatch).
  ScopedTimer(double& accumulator, double& serial)
      : acc_(accumulator), serial_(&serial), parallel0_(parallel_seconds()) {}
  ~ScopedTimer() {
    const double wall = watch_.seconds();
    acc_ += wall;
    if (serial_ != nullptr) *serial_ += std::max(0.0, wall - (parallel_seconds() - parallel0_));
  }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double& acc_;
  double* serial_ = nullptr;
  double parallel0_ = 0.0;
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
  /// The part of each stage spent outside parallel loops (SerialStopwatch): the stage's Amdahl
  /// serial time. The rest of its time shrinks with the thread count.
  double xpbd_serial = 0, broad_serial = 0, narrow_serial = 0, resolution_serial = 0, check_serial = 0;
  StageTimes& operator+=(const StageTimes& o) {
    xpbd += o.xpbd;
    broad += o.broad;
    narrow += o.narrow;
    resolution += o.resolution;
    check += o.check;
    audit += o.audit;
    xpbd_serial += o.xpbd_serial;
    broad_serial += o.broad_serial;
    narrow_serial += o.narrow_serial;
    resolution_serial += o.resolution_serial;
    check_serial += o.check_serial;
    return *this;
  }
};

}  // namespace ccfr
