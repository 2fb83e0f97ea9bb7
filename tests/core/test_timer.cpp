#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "ccfr/core/timer.hpp"

using namespace ccfr;

// The process CPU clock behind stats.csv's cpu_s: it must not count sleeping (a wall clock
// would), and one busy thread cannot use more CPU than the wall time it ran (plus the clock's
// granularity). Both bounds are loose: the test fails only for the wrong clock, never for speed.
TEST(CpuStopwatch, CountsWorkNotSleep) {
  CpuStopwatch cpu;
  Stopwatch wall;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_GE(wall.seconds(), 0.2);
  EXPECT_LT(cpu.seconds(), 0.1) << "a sleeping process used CPU time: is this the wall clock?";

  cpu.restart();
  wall.restart();
  std::atomic<double> sink{0.0};
  double x = 1.0;
  // Busy until the CPU clock itself has advanced 50 ms (bounded by 30 s of wall time).
  while (cpu.seconds() < 0.05 && wall.seconds() < 30.0) {
    for (int i = 0; i < 10000; ++i) x = std::sqrt(x + 1.0);
    sink = x;
  }
  const double used = cpu.seconds(), elapsed = wall.seconds();
  ASSERT_GE(used, 0.05) << "the CPU clock did not advance while this thread was busy";
  EXPECT_LE(used, elapsed + 0.02) << "one busy thread cannot use more CPU than wall time";
}

TEST(CpuStopwatch, SumsOverThreads) {
  // Two threads busy for the same CPU budget each: the process clock sees both.
  CpuStopwatch cpu;
  auto spin = [] {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    const double t0 = static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
    double x = 1.0, t = t0;
    Stopwatch wall;
    while (t - t0 < 0.05 && wall.seconds() < 30.0) {
      for (int i = 0; i < 10000; ++i) x = std::sqrt(x + 1.0);
      clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
      t = static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
    }
    volatile double keep = x;
    (void)keep;
  };
  std::thread a(spin), b(spin);
  a.join();
  b.join();
  EXPECT_GE(cpu.seconds(), 0.1 - 1e-3) << "the process clock must add the CPU time of every thread";
}
