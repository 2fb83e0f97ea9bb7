#pragma once
/// @file buffers.hpp
/// Buffers reused from pass to pass whose every element the caller writes next.
#include <algorithm>
#include <cstddef>
#include <vector>

#include "ccfr/core/parallel.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr {

/// Gives `v` exactly n elements for a caller that overwrites all of them: within the capacity
/// only the elements past the old size are initialised, and a growth past it drops the old
/// elements instead of copying them (with a quarter of headroom, so that a slowly growing count
/// reallocates rarely). A plain clear() + resize() would initialise all n, serially, every pass.
template <class T, class A>
void resize_for_overwrite(std::vector<T, A>& v, std::size_t n) {
  if (n > v.capacity()) {
    std::vector<T, A>().swap(v);
    v.reserve(n + n / 4);
  }
  v.resize(n);
}

/// resize_for_overwrite for a buffer whose size swings from pass to pass (a substep's first pass,
/// then its few held-back ones): a request under an eighth of the constructed size swaps `v` with
/// `spare`, which keeps the large buffer's elements constructed; a larger request takes them back.
/// Growing the large buffer again would value-initialise its elements, serially, every substep.
/// At most two buffers live, the smaller under an eighth of the larger's size when put aside.
template <class T, class A>
void resize_for_overwrite(std::vector<T, A>& v, std::size_t n, std::vector<T, A>& spare) {
  if (n * 8 < v.size()) {
    if (spare.size() < v.size()) v.swap(spare);
  } else if (spare.size() > v.size()) {
    v.swap(spare);
  }
  resize_for_overwrite(v, n);
}

/// Gives `v` n elements equal to `value`, written in parallel chunks: a serial assign of a pass's
/// millions of entries is a serial stretch of every pass.
template <class T, class A>
void fill_parallel(std::vector<T, A>& v, Index n, const T& value) {
  resize_for_overwrite(v, static_cast<std::size_t>(n));
  parallel_for(
      n, [&](Index b, Index e) { std::fill(v.begin() + b, v.begin() + e, value); }, Index{1} << 15);
}

}  // namespace ccfr
