#include "ccfr/core/parallel.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <memory>
#include <mutex>

namespace ccfr {

namespace {
std::mutex g_mutex;
std::unique_ptr<tbb::global_control> g_control;
int g_threads = 0;
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
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, std::max<Index>(1, grain)),
                    [&](const tbb::blocked_range<Index>& r) { body(r.begin(), r.end()); });
}

void parallel_chunks(Index n, Index num_chunks, const std::function<void(Index, Index, Index)>& body) {
  if (n <= 0) return;
  num_chunks = std::clamp<Index>(num_chunks, 1, n);
  auto bound = [&](Index c) { return static_cast<Index>(static_cast<long long>(n) * c / num_chunks); };
  if (num_chunks == 1) {
    body(0, 0, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<Index>(0, num_chunks, 1), [&](const tbb::blocked_range<Index>& r) {
    for (Index c = r.begin(); c != r.end(); ++c) body(c, bound(c), bound(c + 1));
  });
}

Index default_chunk_count(Index n) {
  // Fixed, not derived from the thread count: results are then identical for any thread count.
  constexpr Index kChunks = 128;
  return std::max<Index>(1, std::min<Index>(n, kChunks));
}

}  // namespace ccfr
