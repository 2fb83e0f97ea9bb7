#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "ccfr/core/block_cursors.hpp"
#include "ccfr/core/parallel.hpp"

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
