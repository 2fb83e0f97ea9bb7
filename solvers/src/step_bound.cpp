#include "ccfr/solvers/step_bound.hpp"

#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

StepBoundResult apply_step_bound(const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                 double r, double tolerance, Positions& out, std::span<std::uint8_t> held) {
  const Index nv = static_cast<Index>(x.size());
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

}  // namespace ccfr
