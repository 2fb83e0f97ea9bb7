#include "ccfr/solvers/step_bound.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

StepBoundResult apply_step_bound(const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                 double r_all, double tolerance, Positions& out, std::span<std::uint8_t> held,
                                 std::span<const double> reach) {
  const Index nv = static_cast<Index>(x.size());
  if (!reach.empty() && static_cast<Index>(reach.size()) != nv)
    throw Error("apply_step_bound: " + std::to_string(reach.size()) + " reaches for " + std::to_string(nv) +
                " vertices");
  if (!held.empty() && static_cast<Index>(held.size()) != nv)
    throw Error("apply_step_bound: " + std::to_string(held.size()) + " held-back marks for " + std::to_string(nv) +
                " vertices");
  if (&out != &x) out.resize(x.size());
  const Index chunks = default_chunk_count(nv);
  std::vector<Index> count(static_cast<size_t>(chunks), 0), worst(count.size(), -1);
  std::vector<double> len_max(count.size(), 0.0), intended(count.size(), 0.0), cut(count.size(), 0.0);
  parallel_chunks(nv, chunks, [&](Index c, Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      if (!held.empty()) held[i] = 0;
      const double r = reach.empty() ? r_all : reach[i];
      const Vec3 d = x[i] - anchor[i];
      const double len = d.norm();
      if (inv_mass[i] != 0.0) intended[c] += len;
      if (inv_mass[i] == 0.0 || !(len > r)) {
        if (&out != &x) out[i] = x[i];
        continue;
      }
      cut[c] += len - r;
      out[i] = anchor[i] + (r / len) * d;
      if (len > r * (1.0 + tolerance)) {
        ++count[c];
        if (!held.empty()) held[i] = 1;
        if (len > len_max[c]) len_max[c] = len, worst[c] = i;
      }
    }
  });
  StepBoundResult res;
  for (size_t c = 0; c < count.size(); ++c) {
    res.held_back += count[c];
    res.intended += intended[c];
    res.cut += cut[c];
    if (count[c] > 0 && len_max[c] > res.worst_length) res.worst_length = len_max[c], res.worst = worst[c];
  }
  return res;
}

void adaptive_vertex_reach(const Positions& intended, const Positions& anchor, std::span<const double> inv_mass,
                           std::span<const std::uint8_t> full, std::span<const std::uint8_t> held, double r,
                           double floor_fraction, double repulsion_range, std::vector<double>& reach) {
  const Index nv = static_cast<Index>(anchor.size());
  if (static_cast<Index>(intended.size()) != nv || static_cast<Index>(inv_mass.size()) != nv ||
      (!full.empty() && static_cast<Index>(full.size()) != nv) ||
      (!held.empty() && static_cast<Index>(held.size()) != nv))
    throw Error("adaptive_vertex_reach: " + std::to_string(nv) + " anchors but " + std::to_string(intended.size()) +
                " intended positions, " + std::to_string(inv_mass.size()) + " inverse masses, " +
                std::to_string(full.size()) + " and " + std::to_string(held.size()) + " marks");
  reach.resize(static_cast<size_t>(nv));
  // The floor covers the repulsion band too: a pair within ξ + δ of an immovable side is detected.
  const double floor = std::max(floor_fraction * r, repulsion_range);
  parallel_for(
      nv,
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const double step = (intended[i] - anchor[i]).norm();
          if (inv_mass[i] == 0.0)
            reach[i] = step * (1.0 + 1e-9);
          else if ((!full.empty() && full[i]) || (!held.empty() && held[i]) || !std::isfinite(step))
            reach[i] = r;
          else
            reach[i] = std::min(r, floor + 2.0 * step);
        }
      },
      4096);
}

bool reach_long_steps(const Positions& intended, const Positions& anchor, std::span<const double> inv_mass,
                      std::span<const std::uint8_t> full, double r, std::vector<double>& reach) {
  const Index nv = static_cast<Index>(anchor.size());
  if (static_cast<Index>(intended.size()) != nv || static_cast<Index>(inv_mass.size()) != nv ||
      (!full.empty() && static_cast<Index>(full.size()) != nv) ||
      (!reach.empty() && static_cast<Index>(reach.size()) != nv))
    throw Error("reach_long_steps: " + std::to_string(nv) + " anchors but " + std::to_string(intended.size()) +
                " intended positions, " + std::to_string(inv_mass.size()) + " inverse masses, " +
                std::to_string(full.size()) + " marks and " + std::to_string(reach.size()) + " reaches");
  if (reach.empty()) reach.assign(static_cast<size_t>(nv), r);
  std::atomic<bool> longer{false};
  parallel_for(
      nv,
      [&](Index b, Index e) {
        bool any = false;
        for (Index i = b; i < e; ++i) {
          if (!(inv_mass[i] > 0.0) || (!full.empty() && full[i])) continue;
          const double step = (intended[i] - anchor[i]).norm();
          // A non-finite step is left to check_finite: its reach stays as it was.
          if (!(step > r) || !std::isfinite(step)) continue;
          reach[i] = std::max(reach[i], std::min(step, kLongStepMost * r) + r);
          any = true;
        }
        if (any) longer.store(true, std::memory_order_relaxed);
      },
      4096);
  return longer.load();
}

}  // namespace ccfr
