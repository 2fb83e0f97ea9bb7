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
  /// Replaces `contacts` with the contacts of chunks 0..chunks-1 in chunk order. Its buffer may
  /// be exchanged for one this object keeps (spare_): pointers into it do not outlive the call.
  void collect(Index chunks, const Fill& fill, std::vector<ContactPair>& contacts);
  /// Records held constructed for the next large pass (spare_); 0 when none is put aside.
  size_t spare_size() const { return spare_.size(); }

  /// A small pass's result is at most this fraction of the list it filled: the list is then put
  /// aside whole (spare_) and the result copied out.
  static constexpr size_t kSpareRatio = 8;

 private:
  std::vector<std::vector<ContactPair>> staging_;  ///< one wave's chunks, reused
  /// The list of the last large pass, put aside whole by a much smaller pass after it (a substep's
  /// held-back passes after its first): its records stay constructed, so the next large pass
  /// writes into them instead of value-initialising them again, serially (the 50 layers: about
  /// 1 GB a substep). Its memory is what `contacts` would have kept as capacity.
  std::vector<ContactPair> spare_;
};

}  // namespace ccfr::detail
