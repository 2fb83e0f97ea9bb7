#include "ccfr/feasibility/region.hpp"

#include <algorithm>
#include <limits>
#include <numeric>

#include "ccfr/core/parallel.hpp"

namespace ccfr {

void RegionSet::clear(Index num_vertices) {
  row_start.assign(static_cast<size_t>(num_vertices) + 1, 0);
  records.clear();
  refs.clear();
}

std::span<const HalfSpace> RegionSet::of(Index v, std::vector<HalfSpace>& buf) const {
  const Index b = row_start[v], e = row_start[v + 1];
  buf.resize(static_cast<size_t>(e - b));
  for (Index q = b; q < e; ++q) buf[static_cast<size_t>(q - b)] = plane(q);
  return {buf.data(), buf.size()};
}

std::vector<HalfSpace> RegionSet::rows() const {
  std::vector<HalfSpace> out(refs.size());
  for (size_t q = 0; q < refs.size(); ++q) out[q] = plane_of_ref(refs[q]);
  return out;
}

bool RegionSet::falls_below(Index v, const Vec3& x_anchor, const Vec3& x, double level) const {
  // The free falls_below's arithmetic on the planes as of() would gather them.
  const Vec3 q = x - x_anchor;
  const Index b = row_start[v], e = row_start[v + 1];
  for (Index s = b; s < e; ++s) {
    const HalfSpace h = plane(s);
    if (!(h.n.dot(q) + h.d >= level)) return true;
  }
  return b == e && !(std::numeric_limits<double>::infinity() >= level);
}

void build_region_set(Index num_vertices, std::span<const std::vector<TaggedHalfSpace>> buffers, RegionSet& out) {
  out.row_start.assign(static_cast<size_t>(num_vertices) + 1, 0);
  for (const auto& buf : buffers)
    for (const auto& t : buf) ++out.row_start[t.vertex + 1];
  std::partial_sum(out.row_start.begin(), out.row_start.end(), out.row_start.begin());
  std::vector<HalfSpace> planes(static_cast<size_t>(out.row_start.back()));

  std::vector<std::uint64_t> keys(planes.size());
  std::vector<Index> cursor(out.row_start.begin(), out.row_start.end() - 1);
  for (const auto& buf : buffers)
    for (const auto& t : buf) {
      const Index slot = cursor[t.vertex]++;
      planes[slot] = t.h;
      keys[slot] = t.key;
    }

  // Sort each vertex's planes by key (small rows: insertion sort on an index permutation).
  parallel_for(num_vertices, [&](Index begin, Index end) {
    std::vector<Index> perm;
    std::vector<HalfSpace> tmp;
    std::vector<std::uint64_t> tmp_keys;
    for (Index v = begin; v < end; ++v) {
      const Index b = out.row_start[v], e = out.row_start[v + 1];
      if (e - b < 2) continue;
      perm.resize(static_cast<size_t>(e - b));
      std::iota(perm.begin(), perm.end(), b);
      std::stable_sort(perm.begin(), perm.end(), [&](Index l, Index r) { return keys[l] < keys[r]; });
      tmp.clear();
      tmp_keys.clear();
      for (Index p : perm) {
        tmp.push_back(planes[p]);
        tmp_keys.push_back(keys[p]);
      }
      std::copy(tmp.begin(), tmp.end(), planes.begin() + b);
      std::copy(tmp_keys.begin(), tmp_keys.end(), keys.begin() + b);
    }
  });
  // One record per plane, side A: the record carries the plane as given.
  out.records.resize(planes.size());
  out.refs.resize(planes.size());
  for (size_t q = 0; q < planes.size(); ++q) {
    out.records[q] = {planes[q].n, {planes[q].d, planes[q].d}};
    out.refs[q] = static_cast<std::uint32_t>(2 * q);
  }
}

}  // namespace ccfr
