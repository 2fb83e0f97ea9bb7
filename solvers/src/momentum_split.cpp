#include "ccfr/solvers/momentum_split.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "ccfr/core/parallel.hpp"

namespace ccfr {

namespace {
/// Least room a retreating side must vacate, as a share of the other side's cut, to defer it.
constexpr double kVacated = 0.1;
}  // namespace

Index split_by_motion(RegionSet& regions, std::span<const ContactPair> contacts, const Positions& anchor,
                      const Positions& x, std::span<const double> inv_mass, std::span<const double> responds,
                      double min_room, std::span<std::uint8_t> deferred) {
  if (regions.records.size() != contacts.size()) return 0;
  std::atomic<Index> held{0};
  parallel_for(
      static_cast<Index>(contacts.size()),
      [&](Index b, Index e) {
        Index local = 0;
        for (Index ci = b; ci < e; ++ci) {
          const ContactPair& c = contacts[ci];
          RegionRecord& rec = regions.records[static_cast<size_t>(ci)];
          // A turned plane (scripted vertices on a side) and mesh neighbours (their distance is the
          // material's; the response leaves them too) keep the paper's split.
          if (rec.n != c.n || c.neighbours) continue;
          const double gap = rec.d[0] + rec.d[1];
          if (!(gap >= 0.0)) continue;
          const int na = c.side_a(), nk = c.size();
          bool all_free = true, answers[2] = {responds.empty(), responds.empty()};
          double w_a = 0.0, w_b = 0.0;
          double a_a = -std::numeric_limits<double>::infinity(), a_b = a_a;
          for (int k = 0; k < nk && all_free; ++k) {
            const Index v = c.v[k];
            all_free = inv_mass[v] > 0.0;
            if (!responds.empty()) answers[k < na ? 0 : 1] |= responds[v] > 0.0;
            const double along = c.n.dot(x[v] - anchor[v]);
            if (k < na) {
              w_a += c.w[k] * inv_mass[v];
              a_a = std::max(a_a, -along);
            } else {
              w_b -= c.w[k] * inv_mass[v];
              a_b = std::max(a_b, along);
            }
          }
          // Two rigid bodies: each pose solve takes the pair as if the other were fixed, so the
          // paper's split stays (a split by their predictions would leave each a share it cannot use).
          if (!all_free || !(answers[0] || answers[1]) || !(w_a + w_b > 0.0) || !std::isfinite(a_a + a_b)) continue;
          const double s_a = w_a / (w_a + w_b);
          const double raw = a_a + s_a * (gap - a_a - a_b);
          const double d_a = std::clamp(raw, 0.0, gap);
          rec.d[0] = d_a;
          rec.d[1] = gap - d_a;
          // A side clamped at its anchor while it moves away: the other side waits for the next pass.
          const double tol = 1e-9 * gap;
          // Only where the room vacated is a fair part of the cut: a side that barely retreats
          // from an overlap the response left gives the next pass nothing to use.
          const bool hold_b =
              raw < 0.0 && a_b > rec.d[1] + tol && -a_a > std::max(min_room, kVacated * (a_b - rec.d[1]));
          const bool hold_a =
              raw > gap && a_a > rec.d[0] + tol && -a_b > std::max(min_room, kVacated * (a_a - rec.d[0]));
          if (!hold_a && !hold_b) continue;
          ++local;
          if (!deferred.empty())
            for (int k = hold_a ? 0 : na; k < (hold_a ? na : nk); ++k)
              std::atomic_ref<std::uint8_t>(deferred[static_cast<size_t>(c.v[k])]).store(1, std::memory_order_relaxed);
        }
        held += local;
      },
      2048);
  return held.load();
}

}  // namespace ccfr
