#include "contact_waves.hpp"

#include <algorithm>

#include "ccfr/core/parallel.hpp"

namespace ccfr::detail {

namespace {
/// Gives `v` at least `need` elements, its first `keep` kept, growing it to a capacity of at least
/// `capacity`: within the capacity only the elements past the old size are initialised. A growth
/// that keeps nothing frees the old buffer before it allocates, so that the two are never resident
/// together; one that keeps copies the `keep` only.
void grow_keeping(std::vector<ContactPair>& v, size_t keep, size_t need, size_t capacity) {
  if (capacity > v.capacity()) {
    if (keep == 0) {
      std::vector<ContactPair>().swap(v);
      v.reserve(capacity);
    } else {
      std::vector<ContactPair> bigger;
      bigger.reserve(capacity);
      bigger.assign(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(keep));
      v.swap(bigger);
    }
  }
  if (need > v.size()) v.resize(need);
}
}  // namespace

void ContactWaves::collect(Index chunks, const Fill& fill, std::vector<ContactPair>& contacts) {
  const Index wave = std::clamp<Index>(kChunksPerThread * thread_count(), 1, std::max<Index>(chunks, 1));
  if (staging_.size() < static_cast<size_t>(wave)) staging_.resize(static_cast<size_t>(wave));
  std::vector<size_t> at(static_cast<size_t>(wave) + 1);
  // A list put aside by a small pass comes back: its records are already constructed.
  if (spare_.size() > contacts.size()) {
    contacts.swap(spare_);
    spare_.clear();  // the caller's old buffer: its capacity receives the next small pass's copy
  }
  size_t used = 0;
  for (Index first = 0; first < chunks; first += wave) {
    const Index count = std::min(wave, chunks - first);
    parallel_for(
        count,
        [&](Index b, Index e) {
          for (Index i = b; i < e; ++i) {
            std::vector<ContactPair>& out = staging_[static_cast<size_t>(i)];
            out.clear();
            fill(first + i, out);
          }
        },
        1);
    at[0] = used;
    for (Index i = 0; i < count; ++i) at[i + 1] = at[i] + staging_[static_cast<size_t>(i)].size();
    // The density so far, extrapolated to the pass plus an eighth, sizes the list: at the first
    // wave, where nothing is kept, whenever it outgrows the capacity (a quarter more at least, so
    // that a slowly growing count reallocates rarely), and later only when the list is full. A
    // growth after the first wave holds the old list and the new one at once (the 50 layers:
    // 1.4 GB more at the peak of a 60-frame run); one from empty would be copied some 20 times over.
    const size_t done = static_cast<size_t>(first + count);
    const size_t expect = at[count] * static_cast<size_t>(chunks) / done;
    const size_t need = at[count];
    const size_t headroom = expect + expect / 8;
    if (first == 0 && headroom > contacts.capacity())
      grow_keeping(contacts, 0, need, std::max(headroom, contacts.capacity() + contacts.capacity() / 4));
    else
      grow_keeping(contacts, used, need, need > contacts.capacity() ? std::max(headroom, need + need / 4) : 0);
    parallel_for(
        count,
        [&](Index b, Index e) {
          for (Index i = b; i < e; ++i) {
            const std::vector<ContactPair>& in = staging_[static_cast<size_t>(i)];
            std::copy(in.begin(), in.end(), contacts.begin() + static_cast<std::ptrdiff_t>(at[i]));
          }
        },
        1);
    used = at[count];
  }
  if (used * kSpareRatio < contacts.size()) {
    // Much smaller than the list: keep the list whole, hand out a copy (at most an eighth of the
    // list's records, where growing it back would construct all of them).
    spare_.swap(contacts);
    contacts.assign(spare_.begin(), spare_.begin() + static_cast<std::ptrdiff_t>(used));
  } else {
    contacts.resize(used);  // a shrink: nothing reallocates
  }
}

}  // namespace ccfr::detail
