#include <gtest/gtest.h>

#include <chrono>
#include <random>
#include <thread>
#include <vector>

#include "ccfr/core/block_cursors.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/core/timer.hpp"

using namespace ccfr;

// Random keys (with empty keys and a key that fills a whole block) scattered through the block
// cursors must give exactly a serial stable counting sort, at 1 and 2 threads.
TEST(BlockCursors, ScatterEqualsASerialStableCountingSort) {
  std::mt19937_64 g(5);
  const Index n = 5000, keys = 300, blocks = 32;
  std::uniform_int_distribution<Index> key(0, keys - 1);
  std::vector<Index> item_key(static_cast<size_t>(n));
  for (Index i = 0; i < n; ++i) item_key[i] = i < 200 ? 7 : (key(g) % 2 == 0 ? key(g) & ~Index{1} : key(g));
  // Serial reference.
  std::vector<Index> ref_row_start(static_cast<size_t>(keys) + 1, 0), ref(static_cast<size_t>(n));
  for (Index k : item_key) ++ref_row_start[k + 1];
  for (Index k = 0; k < keys; ++k) ref_row_start[k + 1] += ref_row_start[k];
  std::vector<Index> at(ref_row_start.begin(), ref_row_start.end() - 1);
  for (Index i = 0; i < n; ++i) ref[at[item_key[i]]++] = i;
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    std::vector<Index> cursor(static_cast<size_t>(blocks) * keys), row_start, out(static_cast<size_t>(n));
    parallel_chunks(n, blocks, [&](Index b, Index lo, Index hi) {
      Index* count = cursor.data() + static_cast<size_t>(b) * keys;
      std::fill(count, count + keys, 0);
      for (Index i = lo; i < hi; ++i) ++count[item_key[i]];
    });
    counts_to_block_cursors(keys, blocks, cursor, row_start);
    parallel_chunks(n, blocks, [&](Index b, Index lo, Index hi) {
      Index* w = cursor.data() + static_cast<size_t>(b) * keys;
      for (Index i = lo; i < hi; ++i) out[w[item_key[i]]++] = i;
    });
    EXPECT_EQ(row_start, ref_row_start) << threads << " threads";
    EXPECT_EQ(out, ref) << threads << " threads";
  }
  set_thread_count(0);
}

// Amdahl's serial part at one thread holds only what no thread count shortens: the one block of a
// one-thread run that more threads would split counts as parallel work, a pass too small to split
// anywhere counts as serial, and a loop inside run_as_parallel_work is not counted twice. Sleeps
// stand in for work; the bounds allow any scheduling delay and fail only for the wrong count.
TEST(BlockCursors, OneThreadsSingleBlockIsParallelWorkOnlyWhereMoreThreadsSplitIt) {
  const auto nap = [] { std::this_thread::sleep_for(std::chrono::milliseconds(40)); };
  set_thread_count(1);
  const Index split = 8 * kItemsPerCursorBlock, unsplit = kItemsPerCursorBlock + 1;
  ASSERT_EQ(cursor_blocks(split), 1);
  ASSERT_EQ(cursor_blocks(unsplit), 1);
  Index seen = 0;
  SerialStopwatch serial;
  for_cursor_blocks(split, cursor_blocks(split), [&](Index, Index lo, Index hi) {
    seen += hi - lo;
    nap();
  });
  EXPECT_EQ(seen, split);
  EXPECT_LT(serial.seconds(), 0.02) << "a block that 2+ threads split was counted as serial";

  serial = SerialStopwatch();
  for_cursor_blocks(unsplit, cursor_blocks(unsplit), [&](Index, Index, Index) { nap(); });
  EXPECT_GE(serial.seconds(), 0.04) << "a block that no thread count splits was counted as parallel";

  set_thread_count(2);
  ASSERT_GT(cursor_blocks(split), 1);
  const double p0 = parallel_seconds();
  Stopwatch wall;
  run_as_parallel_work([&] {
    parallel_for(
        2, [&](Index, Index) { nap(); }, 1);
  });
  const double counted = parallel_seconds() - p0;
  EXPECT_GE(counted, 0.04);
  EXPECT_LE(counted, wall.seconds() + 1e-3) << "a loop inside run_as_parallel_work was counted again";
  set_thread_count(0);
}
