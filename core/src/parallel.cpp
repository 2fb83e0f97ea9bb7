#include "ccfr/core/parallel.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>

namespace ccfr {

namespace {
std::mutex g_mutex;
std::unique_ptr<tbb::global_control> g_control;
int g_threads = 0;

// Nesting depth of parallel bodies on this thread: 0 outside every parallel loop.
thread_local int t_depth = 0;
std::atomic<std::int64_t> g_parallel_ns{0};

/// Marks the scope as inside a parallel body on this thread.
struct InBody {
  InBody() { ++t_depth; }
  ~InBody() { --t_depth; }
  InBody(const InBody&) = delete;
  InBody& operator=(const InBody&) = delete;
};

/// Runs `region` and, when it is an outermost one, adds its wall time to g_parallel_ns.
template <class F>
void timed_region(F&& region) {
  if (t_depth > 0) return region();
  const auto t0 = std::chrono::steady_clock::now();
  struct Add {
    std::chrono::steady_clock::time_point t0;
    ~Add() {
      g_parallel_ns.fetch_add(
          std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count(),
          std::memory_order_relaxed);
    }
  } add{t0};
  region();
}
}  // namespace

std::string thread_count_problem(long long n) {
  if (n < 0) return "must be >= 0 (0 uses all cores)";
  if (n > kMaxThreads)
    return "is too many worker threads: at most " + std::to_string(kMaxThreads) + " (0 uses all cores)";
  return {};
}

void set_thread_count(int n) {
  std::lock_guard<std::mutex> lock(g_mutex);
  const int hw = tbb::info::default_concurrency();
  g_threads = n <= 0 ? hw : n;
  g_control.reset();
  g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<size_t>(g_threads));
}

int thread_count() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_threads > 0) return g_threads;
  return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

void parallel_for(Index n, const std::function<void(Index, Index)>& body, Index grain) {
  if (n <= 0) return;
  if (n <= grain) {
    body(0, n);
    return;
  }
  timed_region([&] {
    tbb::parallel_for(tbb::blocked_range<Index>(0, n, std::max<Index>(1, grain)),
                      [&](const tbb::blocked_range<Index>& r) {
                        const InBody in;
                        body(r.begin(), r.end());
                      });
  });
}

void parallel_chunks(Index n, Index num_chunks, const std::function<void(Index, Index, Index)>& body) {
  if (n <= 0) return;
  num_chunks = std::clamp<Index>(num_chunks, 1, n);
  auto bound = [&](Index c) { return static_cast<Index>(static_cast<long long>(n) * c / num_chunks); };
  if (num_chunks == 1) {
    body(0, 0, n);
    return;
  }
  timed_region([&] {
    tbb::parallel_for(tbb::blocked_range<Index>(0, num_chunks, 1), [&](const tbb::blocked_range<Index>& r) {
      const InBody in;
      for (Index c = r.begin(); c != r.end(); ++c) body(c, bound(c), bound(c + 1));
    });
  });
}

void parallel_invoke(const std::function<void()>& a, const std::function<void()>& b) {
  timed_region([&] {
    tbb::parallel_invoke(
        [&] {
          const InBody in;
          a();
        },
        [&] {
          const InBody in;
          b();
        });
  });
}

void run_as_parallel_work(const std::function<void()>& body) {
  timed_region([&] {
    const InBody in;
    body();
  });
}

double parallel_seconds() { return 1e-9 * static_cast<double>(g_parallel_ns.load(std::memory_order_relaxed)); }

Index default_chunk_count(Index n) {
  // Fixed, not derived from the thread count: results are then identical for any thread count.
  constexpr Index kChunks = 128;
  return std::max<Index>(1, std::min<Index>(n, kChunks));
}

}  // namespace ccfr
