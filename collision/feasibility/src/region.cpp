#include "ccfr/feasibility/region.hpp"

#include <algorithm>
#include <numeric>

#include "ccfr/core/parallel.hpp"

namespace ccfr {

void RegionSet::clear(Index num_vertices) {
  offsets.assign(static_cast<size_t>(num_vertices) + 1, 0);
  planes.clear();
}

void build_region_set(Index num_vertices, std::span<const std::vector<TaggedHalfSpace>> buffers, RegionSet& out) {
  out.offsets.assign(static_cast<size_t>(num_vertices) + 1, 0);
  for (const auto& buf : buffers)
    for (const auto& t : buf) ++out.offsets[t.vertex + 1];
  std::partial_sum(out.offsets.begin(), out.offsets.end(), out.offsets.begin());
  out.planes.resize(static_cast<size_t>(out.offsets.back()));

  std::vector<std::uint64_t> keys(out.planes.size());
  std::vector<Index> cursor(out.offsets.begin(), out.offsets.end() - 1);
  for (const auto& buf : buffers)
    for (const auto& t : buf) {
      const Index slot = cursor[t.vertex]++;
      out.planes[slot] = t.h;
      keys[slot] = t.key;
    }

  // Sort each vertex's planes by key (small rows: insertion sort on an index permutation).
  parallel_for(num_vertices, [&](Index begin, Index end) {
    std::vector<Index> perm;
    std::vector<HalfSpace> tmp;
    std::vector<std::uint64_t> tmp_keys;
    for (Index v = begin; v < end; ++v) {
      const Index b = out.offsets[v], e = out.offsets[v + 1];
      if (e - b < 2) continue;
      perm.resize(static_cast<size_t>(e - b));
      std::iota(perm.begin(), perm.end(), b);
      std::stable_sort(perm.begin(), perm.end(), [&](Index l, Index r) { return keys[l] < keys[r]; });
      tmp.clear();
      tmp_keys.clear();
      for (Index p : perm) {
        tmp.push_back(out.planes[p]);
        tmp_keys.push_back(keys[p]);
      }
      std::copy(tmp.begin(), tmp.end(), out.planes.begin() + b);
      std::copy(tmp_keys.begin(), tmp_keys.end(), keys.begin() + b);
    }
  });
}

}  // namespace ccfr
