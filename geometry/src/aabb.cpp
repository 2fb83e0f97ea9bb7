#include "ccfr/geometry/aabb.hpp"

#include <algorithm>

namespace ccfr {

bool all_apart(std::span<const AABB> a, std::span<const AABB> b, double gap, std::vector<AABB>& scratch) {
  // A box with a NaN meets everything, as apart() has it (no comparison with a NaN holds).
  auto has_nan = [](const AABB& x) { return x.lo.hasNaN() || x.hi.hasNaN(); };
  if (std::any_of(a.begin(), a.end(), has_nan) || std::any_of(b.begin(), b.end(), has_nan))
    return a.empty() || b.empty();
  AABB box_a, box_b;
  for (const AABB& x : a) box_a.expand(x);
  for (const AABB& x : b) box_b.expand(x);
  if (!box_a.valid() || !box_b.valid() || box_a.apart(box_b, gap)) return true;
  // A box within gap of another lies within gap of that one's set's box (the set's box holds it,
  // and the subtractions round monotonically): the filter drops no pair that meets.
  std::vector<AABB>& near_b = scratch;
  near_b.clear();
  double widest = 0.0;
  for (const AABB& x : b)
    if (!x.apart(box_a, gap)) {
      near_b.push_back(x);
      widest = std::max(widest, x.hi.x() - x.lo.x());
    }
  auto by_lo_x = [](const AABB& p, const AABB& q) { return p.lo.x() < q.lo.x(); };
  std::sort(near_b.begin(), near_b.end(), by_lo_x);
  for (const AABB& x : a) {
    if (near_b.empty() || x.apart(box_b, gap)) continue;
    // b boxes that can meet x start in [x.lo.x - gap - widest, x.hi.x + gap] along x; the window
    // is widened by a rounding margin, and apart() decides each pair in it.
    const double margin = 1e-9 * (std::abs(x.lo.x()) + std::abs(x.hi.x()) + widest + gap);
    AABB first = x, last = x;
    first.lo.x() = x.lo.x() - gap - widest - margin;
    last.lo.x() = x.hi.x() + gap + margin;
    const auto from = std::lower_bound(near_b.begin(), near_b.end(), first, by_lo_x);
    const auto to = std::upper_bound(from, near_b.end(), last, by_lo_x);
    for (auto it = from; it != to; ++it)
      if (!x.apart(*it, gap)) return false;
  }
  return true;
}

}  // namespace ccfr
