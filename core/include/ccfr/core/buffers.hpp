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

/// Gives `v` n elements equal to `value`, written in parallel chunks: a serial assign of a pass's
/// millions of entries is a serial stretch of every pass.
template <class T, class A>
void fill_parallel(std::vector<T, A>& v, Index n, const T& value) {
  resize_for_overwrite(v, static_cast<std::size_t>(n));
  parallel_for(
      n, [&](Index b, Index e) { std::fill(v.begin() + b, v.begin() + e, value); }, Index{1} << 15);
}

}  // namespace ccfr
