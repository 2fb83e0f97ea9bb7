#pragma once
/// @file parallel.hpp
/// Thread control and loops on oneTBB, without exposing TBB headers.
#include <functional>
#include <string>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// Most worker threads accepted (`--threads`, Python's `threads=`): far beyond any machine ccfr
/// runs on, yet small enough that per-thread state stays a few megabytes (2147483647 tried to
/// allocate gigabytes).
inline constexpr long long kMaxThreads = 1024;

/// Why `n` is not an admissible worker-thread count ("is too many worker threads: ..."); empty if
/// it is (0 <= n <= kMaxThreads; 0 means all cores). The CLI and Python refuse with this text.
std::string thread_count_problem(long long n);

/// Limits every parallel loop to `n` threads (n <= 0: all hardware threads). Process-wide.
void set_thread_count(int n);
/// The thread count in force.
int thread_count();

/// Calls body(begin, end) on disjoint sub-ranges covering [0, n) in parallel.
/// Use when the result does not depend on how the range is split.
void parallel_for(Index n, const std::function<void(Index begin, Index end)>& body, Index grain = 256);

/// Splits [0, n) into `num_chunks` fixed contiguous chunks and calls body(chunk, begin, end) in
/// parallel. Chunk boundaries depend only on n and num_chunks, so per-chunk buffers merged in
/// chunk order give results that are deterministic for a given chunk count.
void parallel_chunks(Index n, Index num_chunks, const std::function<void(Index chunk, Index begin, Index end)>& body);

/// Runs a() and b() in parallel.
void parallel_invoke(const std::function<void()>& a, const std::function<void()>& b);

/// Runs body() on the calling thread, counted as parallel work (parallel_seconds): for a loop that
/// runs as one block only because one thread was asked for, where more threads split it.
void run_as_parallel_work(const std::function<void()>& body);

/// Wall seconds spent so far inside outermost parallel loops (parallel_for and parallel_chunks
/// that reached TBB, parallel_invoke), summed over the threads that called them. A loop inside
/// another's body is not counted again; a loop short enough to run inline (n <= grain) is serial
/// work and not counted, unless run_as_parallel_work says more threads would split it. Over a stretch of one thread's
/// code, wall time minus this difference is the time that no extra core can shorten: Amdahl's serial part
/// (SerialStopwatch).
double parallel_seconds();

/// A fixed chunk count (at most 128, at most n): enough for load balance on a few cores and
/// independent of the thread count, so chunked results are identical for any thread count.
Index default_chunk_count(Index n);

}  // namespace ccfr
