#pragma once
/// @file contact_waves.hpp
/// Narrow-phase stage 3's output (private): the contacts of candidate or list chunks, found in
/// parallel, concatenated in chunk order into the pass's one list.
#include <functional>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"

namespace ccfr::detail {

/// Fills chunks a wave at a time and appends each wave to the list: only a wave's contacts are
/// staged beside the list, where per-chunk buffers of the whole pass held every contact twice
/// (the 50 layers: 2.4 GB of 96-byte records twice). The order is chunk order, whatever the
/// thread count or the wave size.
class ContactWaves {
 public:
  /// fill(chunk, out): appends chunk's contacts, in order, to the empty `out`.
  using Fill = std::function<void(Index chunk, std::vector<ContactPair>& out)>;
  /// Chunks staged at once per worker thread: the waves' barriers then idle a thread for about
  /// one chunk in this many.
  static constexpr Index kChunksPerThread = 32;
  /// Replaces `contacts` with the contacts of chunks 0..chunks-1 in chunk order.
  void collect(Index chunks, const Fill& fill, std::vector<ContactPair>& contacts);

 private:
  std::vector<std::vector<ContactPair>> staging_;  ///< one wave's chunks, reused
};

}  // namespace ccfr::detail
