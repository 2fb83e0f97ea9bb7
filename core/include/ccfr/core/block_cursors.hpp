#pragma once
/// @file block_cursors.hpp
/// The middle step of a parallel, stable counting sort over fixed blocks of input (the region
/// assembly's half-spaces, the contact response's visibility groups).
#include <algorithm>
#include <functional>
#include <numeric>
#include <vector>

#include "ccfr/core/parallel.hpp"

namespace ccfr {

/// Inputs per block, and the most blocks: the blocks x keys cursors must not outweigh few inputs.
inline constexpr Index kItemsPerCursorBlock = 1024;
inline constexpr Index kMostCursorBlocks = 32;

/// Blocks for `items` inputs split into about kItemsPerCursorBlock each, between 1 and
/// kMostCursorBlocks: one on a single thread, where the blocks run in turn and each extra one only
/// adds #keys cursors to fill, sum and scatter through. The groups come out the same for any block
/// count.
inline Index cursor_blocks(Index items) {
  if (thread_count() == 1) return 1;
  return std::clamp<Index>(items / kItemsPerCursorBlock, 1, kMostCursorBlocks);
}

/// parallel_chunks over cursor_blocks(items) blocks. The one block of a one-thread run that more
/// threads would split counts as parallel work, so that Amdahl's serial part measured at one thread
/// (SerialStopwatch) holds only what no thread count shortens.
inline void for_cursor_blocks(Index items, Index blocks, const std::function<void(Index, Index, Index)>& body) {
  if (blocks == 1 && items / kItemsPerCursorBlock > 1)
    run_as_parallel_work([&] { body(0, 0, items); });
  else
    parallel_chunks(items, blocks, body);
}

/// `cursor` holds, for each of `blocks` consecutive input blocks, how many items it has per key
/// (#blocks by #keys, block-major). On return `row_start` (#keys + 1) is the CSR of the keys'
/// groups, and `cursor` holds each block's first write position per key: block b writes its items
/// of key k from row_start[k] plus the counts of blocks 0..b-1. Scattering each block in input order
/// then lists every group in input order, whatever the thread count.
inline void counts_to_block_cursors(Index keys, Index blocks, std::vector<Index>& cursor,
                                    std::vector<Index>& row_start) {
  row_start.assign(static_cast<size_t>(keys) + 1, 0);
  parallel_for(
      keys,
      [&](Index lo, Index hi) {
        for (Index k = lo; k < hi; ++k) {
          Index total = 0;
          for (Index b = 0; b < blocks; ++b) total += cursor[static_cast<size_t>(b) * keys + k];
          row_start[k + 1] = total;
        }
      },
      4096);
  std::partial_sum(row_start.begin(), row_start.end(), row_start.begin());
  parallel_for(
      keys,
      [&](Index lo, Index hi) {
        for (Index k = lo; k < hi; ++k) {
          Index at = row_start[k];
          for (Index b = 0; b < blocks; ++b) {
            Index& slot = cursor[static_cast<size_t>(b) * keys + k];
            const Index count = slot;
            slot = at;
            at += count;
          }
        }
      },
      4096);
}

}  // namespace ccfr
