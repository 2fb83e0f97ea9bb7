#include "contact_waves.hpp"

#include <algorithm>

#include "ccfr/core/parallel.hpp"

namespace ccfr::detail {

namespace {
/// Gives `v` at least `need` elements, its first `keep` kept: within the capacity only the
/// elements past the old size are initialised; a growth past it copies the `keep` only, to a
/// capacity of at least `expect` and a quarter of headroom over `need`.
void grow_keeping(std::vector<ContactPair>& v, size_t keep, size_t need, size_t expect) {
  if (need <= v.size()) return;
  if (need > v.capacity()) {
    std::vector<ContactPair> bigger;
    bigger.reserve(std::max(expect, need + need / 4));
    bigger.assign(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(keep));
    v.swap(bigger);
  }
  v.resize(need);
}
}  // namespace

void ContactWaves::collect(Index chunks, const Fill& fill, std::vector<ContactPair>& contacts) {
  const Index wave = std::clamp<Index>(kChunksPerThread * thread_count(), 1, std::max<Index>(chunks, 1));
  if (staging_.size() < static_cast<size_t>(wave)) staging_.resize(static_cast<size_t>(wave));
  std::vector<size_t> at(static_cast<size_t>(wave) + 1);
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
    // The first wave's density, extrapolated to the pass plus an eighth, sizes the list once: a
    // list grown from empty (the first pass, a resumed run) would otherwise be copied to fresh
    // pages some 20 times over (the 50 layers: 24 M contacts, 64 waves at one thread).
    const size_t expect = first == 0 ? at[count] * static_cast<size_t>(chunks) / static_cast<size_t>(count) : 0;
    grow_keeping(contacts, used, at[count], expect + expect / 8);
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
  contacts.resize(used);  // a shrink: nothing reallocates
}

}  // namespace ccfr::detail
